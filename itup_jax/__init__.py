"""itup-jax: inverse Tool-use Planning (iTuP) in JAX.

Grasps for tools are chosen by minimising the wrench that the task trajectory induces at the grasp
(wrist torque, slip, misalignment). The pipeline's stages and where they live:

  1-2 grounding (tool, target, contact and grasp region)  -> `tools` (Tool, load_tool), `task` (Omega),
                                                             `grounding` (an instruction -> task, tool, parts)
  3   trajectory synthesis xi(t)                          -> `trajectory`, `tasks/` (one module per kind)
  4   grasp candidates G                                  -> `grasp` (frame), `grasp_sampler`
  5   wrench-conditioned scoring                          -> `wrench` (physics), `costs`, `sdgnet/` (SDG-Net),
                                                             `scoring`, `verify` (a shortlist checked in MuJoCo)
  (planning: sample, score, the best reachable, verify)   -> `planning.plan_grasp`
  6   execution along xi in MuJoCo                        -> `sim/` (scene, physics, arm, native, mjx, labels)
  the whole chain from an instruction                     -> `pipeline.run` (tabletop, pickup)

Notebook API::

    import itup_jax as itup
    tool = itup.load_tool("hammer")
    task = itup.make_task("hammer", tool)
    grasps = itup.sample_grasps(tool, 1000, seed=0)
    costs = itup.wrench_costs(tool, task, grasps)      # .tau .slip .align .total, shape [N]
    labels = itup.simulate(tool, task, grasps).labels  # MuJoCo ground truth, arrays [N]

The names below are imported when first used (`import itup_jax` itself loads neither JAX nor MuJoCo),
so the command line starts fast and a notebook pays only for what it touches.
"""

import importlib

__version__ = "0.32.0"

#: Public name -> the module that defines it.
_PUBLIC = {
    **dict.fromkeys(("CostParams", "Costs", "Regime", "batched_wrench_costs", "classify_regime", "grasp_cost_trace",
                     "grasp_costs", "wrench_costs"), "itup_jax.costs"),
    "InputError": "itup_jax.errors",
    **dict.fromkeys(("Grasps", "from_graspnet", "make_grasps", "to_graspnet", "to_mujoco_site"), "itup_jax.grasp"),
    **dict.fromkeys(("SamplerConfig", "SamplingError", "sample_grasps"), "itup_jax.grasp_sampler"),
    **dict.fromkeys(("RunResult", "run"), "itup_jax.pipeline"),
    **dict.fromkeys(("GraspPlan", "plan_grasp"), "itup_jax.planning"),
    **dict.fromkeys(("Scene", "build_scene", "task_timestep"), "itup_jax.sim.scene"),
    **dict.fromkeys(("Scores", "ScoreWeights", "best_grasp", "score"), "itup_jax.scoring"),
    "SimConfig": "itup_jax.sim.config",
    "Labels": "itup_jax.sim.labels",
    "Randomization": "itup_jax.sim.physics",
    **dict.fromkeys(("SimResult", "simulate"), "itup_jax.sim.rollout"),
    **dict.fromkeys(("Task", "make_task"), "itup_jax.task"),
    **dict.fromkeys(("Tool", "ToolParams", "load_tool"), "itup_jax.tools"),
    "Trajectory": "itup_jax.trajectory",
    **dict.fromkeys(("Verified", "best_grasp_verified"), "itup_jax.verify"),
    **dict.fromkeys(("Loads", "task_loads"), "itup_jax.wrench"),
}
#: Subpackages reachable as attributes (`itup.tasks`, `itup.tools`, `itup.sim`).
_SUBMODULES = ("tasks", "tools", "sim")


def __getattr__(name: str):
    """The public names, imported on first use; `TASK_KINDS` (registered task kinds) and `TASK_TIMESTEP`
    (kind -> s), live from `itup_jax.tasks`."""
    if name in _PUBLIC:
        value = getattr(importlib.import_module(_PUBLIC[name]), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"itup_jax.{name}")
    if name == "TASK_KINDS":
        return importlib.import_module("itup_jax.tasks").names()
    if name == "TASK_TIMESTEP":
        return importlib.import_module("itup_jax.tasks").timesteps()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC) | set(_SUBMODULES) | {"TASK_KINDS", "TASK_TIMESTEP"})


__all__ = sorted([*_PUBLIC, *_SUBMODULES, "TASK_KINDS", "TASK_TIMESTEP", "__version__"])

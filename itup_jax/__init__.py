"""itup-jax: inverse Tool-use Planning (iTuP) in JAX.

Grasps for tools are chosen by minimising the wrench that the task trajectory induces at the grasp
(wrist torque, slip, misalignment). The pipeline's stages and where they live:

  1-2 grounding (tool, target, contact and grasp region)  -> `tool` (Tool, load_tool), `task` (Omega)
  3   trajectory synthesis xi(t)                          -> `trajectory`, `task.make_task`
  4   grasp candidates G                                  -> `grasp` (frame), `grasp_sampler`
  (planning: sample, score, the best reachable, verify)   -> `planning.plan_grasp`
  5   wrench-conditioned scoring                          -> `wrench` (physics), `costs`, `scoring` (SDG-Net),
                                                             `verify` (SDG-Net's shortlist checked in MuJoCo)
  6   execution along xi in MuJoCo                        -> `scene` (MjSpec composition), `ik`, `simulate`

Notebook API::

    import itup_jax as itup
    tool = itup.load_tool("hammer")
    task = itup.make_task("hammer", tool)
    grasps = itup.sample_grasps(tool, 1000, seed=0)
    costs = itup.wrench_costs(tool, task, grasps)      # .tau .slip .align .total, shape [N]
    labels = itup.simulate(tool, task, grasps).labels  # MuJoCo ground truth, arrays [N]
"""

from itup_jax import tasks
from itup_jax.costs import (
    CostParams,
    Costs,
    Regime,
    batched_wrench_costs,
    classify_regime,
    grasp_cost_trace,
    grasp_costs,
    wrench_costs,
)
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, from_graspnet, make_grasps, to_graspnet, to_mujoco_site
from itup_jax.grasp_sampler import SamplerConfig, SamplingError, sample_grasps
from itup_jax.pipeline import RunResult, run
from itup_jax.planning import GraspPlan, plan_grasp
from itup_jax.scene import Scene, build_scene, task_timestep
from itup_jax.scoring import Scores, ScoreWeights, best_grasp, score
from itup_jax.simulate import Labels, Randomization, SimConfig, SimResult, simulate
from itup_jax.task import Task, make_task
from itup_jax.tool import Tool, ToolParams, load_tool
from itup_jax.trajectory import Trajectory
from itup_jax.verify import Verified, best_grasp_verified
from itup_jax.wrench import Loads, task_loads

__version__ = "0.19.0"


def __getattr__(name: str):
    """`TASK_KINDS` (registered task kinds) and `TASK_TIMESTEP` (kind -> s), live from `itup_jax.tasks`."""
    if name == "TASK_KINDS":
        return tasks.names()
    if name == "TASK_TIMESTEP":
        return tasks.timesteps()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "CostParams", "Costs", "Grasps", "InputError", "Loads", "Regime", "SamplerConfig", "SamplingError",
    "TASK_KINDS", "Task", "Tool", "ToolParams", "Trajectory", "batched_wrench_costs", "classify_regime",
    "from_graspnet", "grasp_cost_trace", "grasp_costs", "load_tool", "make_grasps", "make_task",
    "sample_grasps", "task_loads", "to_graspnet", "to_mujoco_site", "wrench_costs", "__version__",
    "Scene", "TASK_TIMESTEP", "build_scene", "task_timestep", "Labels", "Randomization", "SimConfig", "SimResult", "simulate",
    "Scores", "ScoreWeights", "best_grasp", "score", "Verified", "best_grasp_verified", "tasks",
    "GraspPlan", "plan_grasp", "RunResult", "run",
]

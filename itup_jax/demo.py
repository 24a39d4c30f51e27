"""The main job: the planner's pick against force closure's on one tool and task, measured in MuJoCo.

    from itup_jax.demo import run_demo
    result = run_demo("hammer", out="itup-demo")     # the demo.json it writes, as a dict

The tool's reachable candidates (`evaluate.feasible_candidates`) are picked from by `itup plan`'s default
(the shipped SDG-Net's 5 best checked in MuJoCo, `evaluate.VERIFIED`) and by force closure; each pick is
rolled out `seeds` times under randomised physics (paired draws,
`evaluate.evaluate`), and once more under nominal physics with traces for the picture (`picks.png`: the
picks on the tool and the wrist torque over the motion) and one MCAP log per pick. `verdict` says which
pick carries less of the headline, the full induced peak wrist torque. `itup demo` is this function and a
printout.
"""

from __future__ import annotations

import os
import time
from typing import Any

import numpy as np

from itup_jax.errors import InputError

#: The two methods compared, the planner's default pick (`evaluate.VERIFIED`, as `itup plan` picks) first.
METHODS = ("sdgnet_verified", "force_closure")
#: How each is named in the verdict.
METHOD_NAMES = {"sdgnet_verified": "the planner", "force_closure": "force closure"}
#: Reachable candidates both methods choose from, and rollouts per pick: the defaults, and `--quick`'s.
DEFAULT_N, DEFAULT_SEEDS = 256, 5
QUICK = (32, 2)
SCHEMA = "itup.demo/2"


def verdict(measured: dict[str, dict], headline: str) -> tuple[str, float]:
    """(one sentence naming the method whose pick carries less of `headline`, with both means; the
    planner's reduction against force closure in %, > 0 when the planner's is lower). `measured`: {method:
    its `evaluate` summary}."""
    from itup_jax.evaluate import reduction

    s, f = (measured[m][headline]["mean"] for m in METHODS)
    red = reduction(s, f)
    if s == f:
        return f"The two picks carry the same full induced peak wrist torque ({s:.2f} N·m).", red
    low, high = (METHODS if s < f else METHODS[::-1])
    lo_v, hi_v = (s, f) if s < f else (f, s)
    return (f"{METHOD_NAMES[low][0].upper() + METHOD_NAMES[low][1:]}'s pick carries less full induced peak wrist "
            f"torque than {METHOD_NAMES[high]}'s: {lo_v:.2f} vs {hi_v:.2f} N·m ({abs(red):.0f}% less).", red)


def model_record(model: Any) -> dict[str, Any]:
    """Which SDG-Net checkpoint scored: {"checkpoint": "shipped" or the path given, "sha256": the file's
    SHA-256}; for a `Model` passed in memory {"checkpoint": None, "sha256": None}."""
    from itup_jax.dataset_load import sha256_file
    from itup_jax.sdgnet.config import DEFAULT_MODEL

    if model is None:
        return {"checkpoint": "shipped", "sha256": sha256_file(DEFAULT_MODEL)}
    if isinstance(model, (str, os.PathLike)):
        return {"checkpoint": os.fspath(model), "sha256": sha256_file(os.fspath(model))}
    return {"checkpoint": None, "sha256": None}


def run_demo(task_kind: str = "hammer", *, tool: Any = None, n: int = DEFAULT_N, seeds: int = DEFAULT_SEEDS,
             seed: int = 0, model: Any = None, out: str = "itup-demo", task: Any = None,
             log=print) -> dict[str, Any]:
    """Run the demo and write its files into `out` (made if missing): `demo.json` (schema itup.demo/2; its
    `model` names the checkpoint that scored and its SHA-256), `picks.png`, `sdgnet_verified.mcap`,
    `force_closure.mcap`. Returns the JSON's content.

    Args:
      task_kind: a registered task kind.  tool: a `Tool` (default: the task's built-in tool).
      n: reachable candidates both methods choose from (>= 2).  seeds: rollouts per pick (>= 1).
      seed: sampling and physics seed.  model: an SDG-Net `Model` or checkpoint path (None: shipped).
      task: a prebuilt task for `tool` (default `make_task(task_kind, tool)`).
      log: where progress lines go (None: nowhere).
    """
    from itup_jax.atomic import atomic_write_json
    from itup_jax.evaluate import HEADLINE, evaluate, feasible_candidates
    from itup_jax.grasp import Grasps
    from itup_jax.mcap_log import write_rollout_mcap
    from itup_jax.plotting import plot_picks
    from itup_jax.sim.labels import induced
    from itup_jax.sim.rollout import simulate
    from itup_jax.sim.scene import build_scene
    from itup_jax.task import DEFAULT_TOOL, contact_motion, make_task
    from itup_jax.tools import load_tool

    t_start = time.perf_counter()
    if n < 2 or seeds < 1:
        raise InputError(f"demo: n must be >= 2 and seeds >= 1, got n {n}, seeds {seeds}")
    log = log or (lambda *a, **k: None)
    tool = load_tool(DEFAULT_TOOL[task_kind]) if tool is None else tool
    task = make_task(task_kind, tool) if task is None else task
    os.makedirs(out, exist_ok=True)
    scene = build_scene(tool, task)
    log(f"itup demo: task {task_kind}, tool {tool.name} ({tool.mass:.3f} kg); sampling {n} reachable antipodal "
        "candidates ...", flush=True)
    cands, counts = feasible_candidates(tool, task, n, seed=seed)
    res = evaluate(tool, task, METHODS, seeds=seeds, seed=seed, scene=scene, candidates=cands, model=model)
    res["candidates"] = counts
    sentence, red = verdict({m: res["methods"][m]["measured"] for m in METHODS}, HEADLINE)
    # one nominal-physics rollout of each pick with traces: the PNG and the MCAP logs
    picks = {m: cands[res["methods"][m]["index"]] for m in METHODS}
    both = Grasps(*(np.stack([np.asarray(getattr(picks[m], k)) for m in METHODS])
                    for k in ("p_tool_grasp", "q_tool_grasp", "width")))
    tr = simulate(tool, task, both, scene=scene, randomize=None, traces=True)
    files = {f"mcap_{m}": write_rollout_mcap(os.path.join(out, f"{m}.mcap"), scene, task, tr, k, grasp=picks[m])
             for k, m in enumerate(METHODS)}
    # the labels' window, the motion: the settling transient is not plotted. The full induced torque is
    # what the table's headline compares; the raw norm (holding torque included) is drawn beside it
    tau = tr.traces["gripper/wrist_torque"]
    d_tau, _ = induced(scene, tr.plan, tau)
    t_motion = tr.traces["t"][tr.plan.n_settle:]
    traces = {m: (t_motion, np.linalg.norm(d_tau[k], axis=-1), np.linalg.norm(tau[k, tr.plan.n_settle:], axis=-1))
              for k, m in enumerate(METHODS)}
    files["png"] = plot_picks(tool, picks, os.path.join(out, "picks.png"), traces=traces,
                              title=f"{tool.name}, {task_kind}: the planner's pick (red) vs force closure's (blue)",
                              motion=contact_motion(task))
    result = {"schema": SCHEMA, **res, "model": model_record(model), "headline": HEADLINE,
              "torque_reduction_vs_force_closure_pct": red, "verdict": sentence, "files": files,
              "wall_s": round(time.perf_counter() - t_start, 2)}
    files["json"] = os.path.join(out, "demo.json")
    atomic_write_json(files["json"], result, indent=2)
    return result

"""What predicts that a grasp fails under a weak grip? Every candidate rolled out at the default grip and
twice at a weak one.

    python experiments/weak_grip.py --data data/val --tasks sweep,knock --tools-per-task 3 \
        --out results/weak_grip
    python experiments/weak_grip.py --quick --out results/weak_grip_quick          # knock, 1 tool, 24 grasps (tests)

The grip stress experiments find picks that hold at 100 N per pad and fail at 25 N. A scorer can avoid
them only if something it predicts ranks them, so this asks which quantity does. Per unseen tool of
--data (variants 1 .. --tools-per-task, `dataset.unit_tool`): --n reachable candidates, each rolled out
once at --strong N per pad and twice at --weak N per pad (two different physics draws, the grip fixed,
`stress.rollouts_at_grip`). Per tool:
  * the weak grip's failure rate and its repeatability: how often the two weak draws agree, and their
    Spearman rho (a failure that is a property of the grasp repeats);
  * the Spearman rho between the number of weak-grip failures (0, 1, 2) and each label measured at the
    strong grip (the full induced peak torque and its grasp-frame components, the raw and static
    torques, the induced force, the grip demand, the turn in the pads, the slip, the alignment drift),
    each output of the shipped SDG-Net (its torque, grip demand, drift, P(fail), P(fail at 25 N) where it
    has that head), and the grasp's
    position in the tool frame relative to the centre of mass (x, y, z and the distance);
  * the same pooled over the task's tools (ranks within each tool, then averaged);
  * the shipped network's drift fidelity: the rho of its predicted drift against the drift and the turn
    in the pads measured at the strong grip.
A quantity with a large |rho| and a repeatable failure is one a target could carry. Writes
weak_grip.json.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

import itup_jax as itup
from itup_jax import stress
from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import GenerateConfig, unit_tool
from itup_jax.dataset_load import read_manifest
from itup_jax.evaluate import feasible_candidates
from itup_jax.sim.scene import build_scene
from itup_jax.stats import spearman
from itup_jax.task import TASK_KINDS, make_task
from itup_jax.tools import load_tool

LABELS = ("peak_torque_induced", "peak_induced_closure", "peak_induced_approach", "peak_induced_third", "peak_torque",
          "static_torque", "peak_force_induced", "grip_demand", "slip_rotation", "slip_translation", "alignment_drift")
PREDICTED = ("tau", "grip", "align", "p_failed", "p_failed_weak")
POSITION = ("grasp_x", "grasp_y", "grasp_z", "grasp_distance")


def tool_row(tool, task, n: int, strong: float, weak: float, seed: int) -> dict:
    """One tool: the rho of every quantity against the weak-grip failure count, and the repeatability."""
    scene = build_scene(tool, task)
    cands, _ = feasible_candidates(tool, task, n, seed=seed)
    s = itup.score(tool, task, cands)
    runs = [stress.rollouts_at_grip(tool, task, cands, f, draws=1, seed=sd, scene=scene)
            for f, sd in ((strong, seed), (weak, seed), (weak, seed + 7_919))]
    ok = np.logical_and.reduce([np.asarray(L.valid) for L in runs])
    f1, f2 = (np.asarray(L.failed, float)[ok] for L in runs[1:])
    count = f1 + f2
    rel = np.asarray(cands.p_tool_grasp, float) - np.asarray(tool.params.com, float)
    quantities = {f"measured:{k}": np.asarray(getattr(runs[0], k), float)[ok] for k in LABELS}
    quantities |= {f"predicted:{k}": np.asarray(getattr(s, k), float)[ok] for k in PREDICTED if getattr(s, k) is not None}
    quantities |= {f"position:{k}": v[ok] for k, v in zip(POSITION, (*rel.T, np.linalg.norm(rel, axis=1)))}
    return {"tool": tool.name, "candidates": int(ok.sum()), "weak_failure_rate": float(count.mean() / 2),
            "strong_failure_rate": float(np.asarray(runs[0].failed, float)[ok].mean()),
            "weak_draws_agree": float(np.mean(f1 == f2)), "weak_draws_rho": spearman(f1, f2),
            "rho": {k: spearman(v, count) for k, v in quantities.items()},
            # does the network's predicted drift rank what the strong grip's rollout measured?
            "drift_fidelity": {k: spearman(quantities["predicted:align"], quantities[f"measured:{k}"])
                               for k in ("alignment_drift", "slip_rotation")}}


def pooled(rows: list) -> dict:
    """Per quantity: the mean of the per-tool rho (tools where it is defined) and the tools counted."""
    keys = sorted({k for r in rows for k in r["rho"]})
    out = {}
    for k in keys:
        v = [r["rho"][k] for r in rows if r["rho"].get(k) is not None and np.isfinite(r["rho"][k])]
        out[k] = {"mean_rho": float(np.mean(v)) if v else None, "tools": len(v)}
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="a labelled dataset whose unseen tools are measured")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--tools-per-task", type=int, default=3)
    ap.add_argument("--n", type=int, default=256, help="reachable candidates per tool")
    ap.add_argument("--strong", type=float, default=100.0, help="N per pad, the default grip")
    ap.add_argument("--weak", type=float, default=25.0, help="N per pad, the weak grip")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--quick", action="store_true", help="knock, the built-in tool, 24 candidates (tests)")
    ap.add_argument("--out", required=True, help="output folder (weak_grip.json)")
    a = ap.parse_args(argv)
    tasks = tuple(t for t in a.tasks.split(",") if t)
    bad = [t for t in tasks if t not in TASK_KINDS]
    if bad or not tasks:
        ap.error(f"--tasks must be among {', '.join(TASK_KINDS)}, got {a.tasks!r}")
    if not a.quick and not a.data:
        ap.error("--data (or --quick) is required")
    try:
        for name, f in (("--strong", a.strong), ("--weak", a.weak)):
            stress.check_grip(f, name)
        config = None if a.quick else GenerateConfig.from_json(read_manifest(a.data)["config"])
    except itup.InputError as e:
        ap.error(str(e))
    t0 = time.time()
    per_task = {}
    for kind in ("knock",) if a.quick else tasks:
        if a.quick:
            tools = [load_tool("mallet")]
        else:
            tools = [unit_tool(config, kind, v)[0] for v in range(1, a.tools_per_task + 1)]
        rows = []
        for v, tool in enumerate(tools, start=1):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a stretched tool may exceed the speed limit
                task = make_task(kind, tool)
            rows.append(tool_row(tool, task, 24 if a.quick else a.n, a.strong, a.weak, a.seed + v))
            r = rows[-1]
            top = sorted(((k, x) for k, x in r["rho"].items() if np.isfinite(x)), key=lambda kx: -abs(kx[1]))[:4]
            print(f"{kind:7s} {r['tool']:20s} weak fail {r['weak_failure_rate']:.2f} (draws agree {r['weak_draws_agree']:.2f}), "
                  f"predicted drift vs turn {r['drift_fidelity']['slip_rotation']:+.2f}; strongest: "
                  + ", ".join(f"{k} {x:+.2f}" for k, x in top), flush=True)
        per_task[kind] = {"tools": rows, "pooled": pooled(rows)}
    for kind, by in per_task.items():
        print(f"\n{kind}: mean rho over tools against the weak-grip failure count")
        for k, p in sorted(by["pooled"].items(), key=lambda kv: -abs(kv[1]["mean_rho"] or 0)):
            print(f"  {k:34s} {'-' if p['mean_rho'] is None else format(p['mean_rho'], '+.2f')}")
    out = {"schema": "itup.weak_grip/1", "data": None if a.quick else os.path.abspath(a.data),
           "strong_N": a.strong, "weak_N": a.weak, "n": 24 if a.quick else a.n, "seed": a.seed, "quick": a.quick,
           "tasks": per_task, "seconds": round(time.time() - t0, 1), "version": itup.__version__}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "weak_grip.json"), out)
    print(f"wrote {os.path.join(a.out, 'weak_grip.json')} ({out['seconds']} s)")
    return out


if __name__ == "__main__":
    main()

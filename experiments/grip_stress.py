"""Grip stress: grip failure and task success against the grip force per pad, and each pick's least
holding grip, per task and method, on the same candidates and physics draws.

    python experiments/grip_stress.py --out results/grip_stress            # 4 tasks x 3 tools
    python experiments/grip_stress.py --quick --out results/gs_quick                # the tests' smoke run
    python experiments/grip_stress.py --data data/val --methods force_closure,sdgnet@w_align=30 ...

Per task, the built-in tool and `--tools-per-task - 1` unseen stretched variants (`tools.variants.vary_tool`,
seeds 10,000 + v, as `table1.py`: the test tools); with `--data DIR`, that dataset's unseen tools instead
(variants 1 .. --tools-per-task of its manifest, `dataset.unit_tool`: e.g. the validation tools). A
method is `itup plan`'s pick ('sdgnet_verified': SDG-Net's 5 best checked in MuJoCo, 20 where the guard
fires, `planning.guarded_check`), a scorer of `scoring.score` ('sdgnet', 'sdgnet_paper', 'force_closure', 'geometric', ...) or
'sdgnet@w_NAME=V,...': the shipped SDG-Net under `ScoreWeights` with those weights changed
(`method_scorer`); methods that pick the same candidate share its rollouts. On each tool every method
picks one of the same reachable candidates (its lowest total score, or the one its check chose). Each pick is rolled out `--draws` times at every force of `--grid` (N per pad;
the grip fixed, the other priors randomised; draw d the same physics for every pick), and its least
holding grip (no grip failure and the task done in every draw) is found by bisection
(`stress.min_holding_grip`, the grid's answers reused). Forces below the 2F-85's 20 N are a labelled
robustness probe. Where rollouts fail, the pooled logistic 50 % failure point in full induced peak
torque (`stats.failure_threshold`) is printed beside the paper's ~6.9 N m.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from itup_jax import stress
from itup_jax.atomic import atomic_write_json
from itup_jax.errors import InputError
from itup_jax.evaluate import data_config, method_scorer, split_methods, stress_picks
from itup_jax.task import TASK_KINDS

PAPER_TAU50 = 6.9  # N m, the paper's empirical 50 % failure torque (arXiv:2505.01399v3, Fig. 4)
DEFAULT_GRID = (10.0, 15.0, 20.0, 25.0, 35.0, 50.0, 100.0)
DEFAULT_METHODS = ("sdgnet_verified", "sdgnet", "sdgnet_paper", "force_closure", "geometric")


def plot(summary, tasks, methods, grid, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from itup_jax.plotting import save_figure

    fig, axs = plt.subplots(1, len(tasks), figsize=(3.6 * len(tasks), 3.4), squeeze=False)
    for ax, kind in zip(axs[0], tasks):
        for m in methods:
            y = [summary[kind][m]["by_grip"][f"{g:g}"]["failed"] for g in grid]
            ax.plot(grid, [np.nan if v is None else v for v in y], marker="o", label=m)
        ax.axvspan(0, 20, color="0.9", label="probe (< 20 N)")
        ax.set_xscale("log")
        ax.set_ylim(-0.05, 1.05)
        ax.set_xlabel("grip force per pad (N)")
        ax.set_title(kind, fontsize=9)
    axs[0][0].set_ylabel("grip failure rate")
    axs[0][0].legend(fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path, dpi=100)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--tools-per-task", type=int, default=3)
    ap.add_argument("--n", type=int, default=256, help="reachable candidates per tool")
    ap.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    ap.add_argument("--grid", default=",".join(f"{g:g}" for g in DEFAULT_GRID), help="grip forces, N per pad")
    ap.add_argument("--draws", type=int, default=3, help="rollouts per pick and force (the same draws for every pick)")
    ap.add_argument("--tol", type=float, default=stress.GRIP_TOLERANCE, help="N, the bisection's bracket")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--data", default=None, help="a dataset folder: stress its unseen tools (variants 1 .. "
                    "--tools-per-task) instead of the built-in tool and table1's variants")
    ap.add_argument("--quick", action="store_true", help="hammer, 1 tool, 32 candidates, 2 forces, 1 draw")
    ap.add_argument("--out", default="results/grip_stress")
    a = ap.parse_args()
    tasks = tuple(t for t in a.tasks.split(",") if t)
    methods = split_methods(a.methods)
    grid = tuple(sorted(float(g) for g in a.grid.split(",") if g))
    if a.quick:
        tasks, tools, n, grid, draws, tol = ("hammer",), 1, 32, (15.0, 100.0), 1, 20.0
    else:
        tools, n, draws, tol = a.tools_per_task, a.n, a.draws, a.tol
    try:  # bad methods or --data fail here, before any rollout
        for m in methods:
            method_scorer(m)
        if a.data is not None:
            data_config(a.data, tasks, tools)
    except InputError as e:
        ap.error(str(e))
    os.makedirs(a.out, exist_ok=True)
    t0 = time.perf_counter()
    res = stress_picks(tasks, tools, n, methods, grid, draws, tol, seed=a.seed, data=a.data)
    out = {"schema": "itup.grip_stress/1", "config": {"tasks": tasks, "tools_per_task": tools, "n": n,
                                                       "methods": methods, "grid_N": grid, "draws": draws,
                                                       "tol_N": tol, "seed": a.seed, "quick": a.quick,
                                                       "data": a.data},
           "paper_tau50_Nm": PAPER_TAU50, "wall_s": round(time.perf_counter() - t0, 1), **res}
    atomic_write_json(os.path.join(a.out, "grip_stress.json"), out, indent=1)
    plot(res["summary"], tasks, methods, grid, os.path.join(a.out, "grip_stress.png"))
    print(f"\n{'task':7s} {'method':>14s} {'median least grip N':>20s} {'never':>6s} {'non-mono':>8s}  "
          + "  ".join(f"fail@{g:g}" for g in grid))
    for kind in tasks:
        for m in methods:
            s = res["summary"][kind][m]
            med = s["median_min_holding_grip_N"]
            print(f"{kind:7s} {m:>14s} {('>' + str(int(stress.GRIP_RANGE[1]))) if med is None else f'{med:.1f}':>20s} "
                  f"{s['never_held']:>6d} {s['non_monotone']:>8d}  " + "  ".join(
                      f"{'-' if s['by_grip'][f'{g:g}']['failed'] is None else format(s['by_grip'][f'{g:g}']['failed'], '.2f'):>7s}"
                      for g in grid))
        ft = res["summary"][kind]["failure_threshold"]
        print(f"{kind:7s} 50 % failure point (full induced peak torque): "
              + (f"{ft['tau50']:.2f} N m" if ft["tau50"] is not None else ft["note"]) + f" (paper ~{PAPER_TAU50} N m)")
    pt = res["pooled_failure_threshold"]
    print("pooled 50 % failure point: " + (f"{pt['tau50']:.2f} N m" if pt["tau50"] is not None else pt["note"])
          + f"; forces below 20 N per pad are a robustness probe; wrote {a.out}/grip_stress.json, grip_stress.png "
          f"({out['wall_s']} s)")


if __name__ == "__main__":
    main()

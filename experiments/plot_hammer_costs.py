"""Figure for the README: the built-in claw hammer, its antipodal grasp candidates coloured by the
analytic torque cost C_tau of the default hammer task, the best grasp drawn, and the grasp-frame
convention beside it.

    python experiments/plot_hammer_costs.py [--n 1000] [--seed 0] [--out docs/hammer_c_tau.png]
"""

from __future__ import annotations

import argparse

import numpy as np

import itup_jax as itup
from itup_jax.plotting import plot_grasp_candidates


def main(argv=None) -> str:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="docs/hammer_c_tau.png")
    args = ap.parse_args(argv)
    tool = itup.load_tool("hammer")
    task = itup.make_task("hammer", tool)
    grasps = itup.sample_grasps(tool, args.n, seed=args.seed)
    costs = itup.wrench_costs(tool, task, grasps)
    tau = np.asarray(costs.tau)
    best = int(np.argmin(np.asarray(costs.total)))
    path = plot_grasp_candidates(
        tool, grasps, tau, args.out, best=best,
        title=f"hammer task: C_tau of {args.n} candidates; best C in red")
    print(f"wrote {path}: C_tau {tau.min():.2f}..{tau.max():.2f} N m, best grasp #{best} "
          f"at z = {float(grasps.p_tool_grasp[best, 2]):.3f} m (head at z = 0.29 m)")
    return path


if __name__ == "__main__":
    main()

"""Which grasps to verify when the out-of-distribution guard fires: the shortlist rules compared.

    python experiments/guard_shortlist.py --out results/guard_shortlist               # calibration tools
    python experiments/guard_shortlist.py --set test --out results/guard_shortlist    # test tools, after
    python experiments/guard_shortlist.py --quick --out results/gs_quick                        # tiny (tests)

When a tool lies outside SDG-Net's training data, `itup plan` rolls a shortlist of K = 5 grasps out in
MuJoCo (nominal physics) and picks the lowest measured total. On the held-out families SDG-Net's
ranking is near chance (docs/results.md), and its 5 best of 1,000 can all lie where the network
extrapolates furthest. Shortlist rules compared on the same candidates and the same rollouts:
  * sdgnet:   the 5 best by SDG-Net's total (the rule before this experiment);
  * analytic: the 5 best by the analytic wrench cost (`analytic_wrench`: physics, no training data);
  * mixed:    the 3 best by SDG-Net and the 2 best by the analytic wrench cost not among them;
  * spread:   the candidates split into 5 equal-count bins by position along the handle (tool z), the
              best by SDG-Net in each.
Per tool of the held-out families (the families' default tool and seeds 100.. for the calibration set,
seeds 200.. for the test set: `heldout.family_tools`, as `experiments/ood_guard.py`): 1,000 candidates the arm can carry
(`sample_reachable`, seed as the planner's), each rule's shortlist rolled out once under nominal physics,
its pick the lowest measured total (`verify.measured_total`, the planner's weights) or no pick when none
of the shortlist did the task and held; each distinct pick then rolled out 3 times under random physics,
the same 3 draws for every pick of a tool. A rule's pick is "ok" when it did the task and held in all 3.

Selection rule (written before the calibration run; applied to it alone): the rule with the most ok
tools on the calibration set; a tie goes to the earlier in the order sdgnet, mixed, analytic, spread
(the least change first). The test set is run once, after the rule is chosen and built into the planner.
Writes guard_shortlist_<set>.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.heldout import family_tools

#: The rules in tie-break order (module docstring).
RULES = ("sdgnet", "mixed", "analytic", "spread")


def shortlists(net_total: np.ndarray, analytic_total: np.ndarray, z: np.ndarray, k: int) -> dict[str, list[int]]:
    """Each rule's shortlist of k candidate indices (module docstring), from the two scorers' totals [N]
    and the candidates' positions along the handle z [N] (m)."""
    from itup_jax.planning import guard_order

    net = [int(i) for i in np.argsort(net_total, kind="stable")]
    ana = [int(i) for i in np.argsort(analytic_total, kind="stable")]
    mixed = [int(i) for i in guard_order(net_total, analytic_total, k)[:k]]  # k = 5: SDG-Net's 3 + the cost's 2
    bins = np.array_split(np.argsort(z, kind="stable"), k)
    spread = [int(b[np.argmin(net_total[b])]) for b in bins if len(b)]
    return {"sdgnet": net[:k], "mixed": mixed, "analytic": ana[:k], "spread": spread}


def tool_row(tool, kind: str, n: int, k: int, draws: int, seed: int) -> dict:
    """Every rule's pick on one tool, and whether it did the task and held in `draws` random draws."""
    import itup_jax as itup
    from itup_jax import ood
    from itup_jax.grasp_sampler import sample_reachable
    from itup_jax.scoring import ScoreWeights
    from itup_jax.sim.physics import Randomization
    from itup_jax.verify import measured_total, objective_of

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        task = itup.make_task(kind, tool)
    g = sample_reachable(tool, task, n, seed=seed).grasps
    s_net = itup.score(tool, task, g)
    s_ana = itup.score(tool, task, g, model="analytic_wrench")
    guard = ood.check(tool, task, g)
    lists = shortlists(np.asarray(s_net.total, float), np.asarray(s_ana.total, float),
                       np.asarray(g.p_tool_grasp, float)[:, 2], k)
    union = sorted(set().union(*lists.values()))
    L = itup.simulate(tool, task, g[np.asarray(union)], seed=seed, randomize=None).labels
    ok_nominal = dict(zip(union, (np.asarray(L.valid) & np.asarray(L.success) & ~np.asarray(L.failed)).tolist()))
    measured = dict(zip(union, measured_total(L, ScoreWeights(), objective_of(s_net)).tolist()))
    pick = {}
    for rule, short in lists.items():
        best = min(short, key=lambda i: measured[i])
        pick[rule] = best if ok_nominal[best] else None  # the planner says "no verified success" then
    held = {}
    for i in sorted({p for p in pick.values() if p is not None}):
        R = itup.simulate(tool, task, g[np.full(draws, i)], seed=seed + 7, randomize=Randomization()).labels
        held[i] = bool(np.all(np.asarray(R.valid) & np.asarray(R.success) & ~np.asarray(R.failed)))
    return {"tool": tool.name, "task": kind, "candidates": len(g), "guard": guard.to_json(),
            "shortlists": lists, "nominal_ok": {str(i): ok_nominal[i] for i in union},
            "picks": pick, "ok": {rule: bool(pick[rule] is not None and held[pick[rule]]) for rule in lists},
            "no_pick": {rule: pick[rule] is None for rule in lists}}


def choose(rows: list[dict]) -> dict:
    """The rule by the module's selection rule."""
    counts = {rule: sum(r["ok"][rule] for r in rows) for rule in RULES}
    best = max(RULES, key=lambda rule: (counts[rule], -RULES.index(rule)))
    return {"rule": best, "ok": counts, "tools": len(rows)}


def main(argv=None) -> dict:
    from itup_jax.bench import machine_info
    from itup_jax.tools import families

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--set", choices=("calibration", "test"), default="calibration")
    ap.add_argument("--tools", type=int, default=4, help="drawn tools per family and task (default %(default)s)")
    ap.add_argument("--n", type=int, default=1000, help="candidates per tool (default %(default)s)")
    ap.add_argument("--k", type=int, default=5, help="shortlist size (default %(default)s)")
    ap.add_argument("--draws", type=int, default=3, help="random-physics rollouts of each pick (default %(default)s)")
    ap.add_argument("--families", default=",".join(families.held_out()),
                    help="comma-separated families (default: those SDG-Net was not trained on)")
    ap.add_argument("--quick", action="store_true", help="one family, one tool, 24 candidates (for the tests)")
    ap.add_argument("--out", default="results/guard_shortlist")
    args = ap.parse_args(argv)
    if args.quick:
        args.tools, args.n, args.k, args.draws, args.families = 1, 24, 5, 1, "screwdriver"
    names = [f for f in args.families.split(",") if f]
    for f in names:
        families.get(f)
    if args.tools < 1 or args.n < args.k or args.k < 5 or args.draws < 1:
        print("guard_shortlist: --tools >= 1, --k >= 5, --n >= --k and --draws >= 1 are needed", file=sys.stderr)
        raise SystemExit(2)
    os.makedirs(args.out, exist_ok=True)
    t0 = time.time()
    rows = []
    for name in names:
        for kind in families.get(name).tasks:
            for tool, s in family_tools(name, args.set, args.tools):
                row = tool_row(tool, kind, args.n, args.k, args.draws, seed=s)
                row["family"] = name
                rows.append(row)
                print(f"{args.set:11s} {tool.name:16s} {kind:6s} guard {row['guard']['score']:6.2f} ok "
                      + " ".join(f"{rule} {int(row['ok'][rule])}" for rule in RULES), flush=True)
    fired = [r for r in rows if r["guard"]["fired"]]
    doc = {"schema": "itup.guard_shortlist/1", "set": args.set, "n": args.n, "k": args.k, "draws": args.draws,
           "families": names, "tools_per_family_task": args.tools, "all": choose(rows),
           "guard_fired": choose(fired) if fired else None,
           "no_pick": {rule: sum(r["no_pick"][rule] for r in rows) for rule in RULES},
           "rows": rows, "wall_s": round(time.time() - t0, 1), "machine": machine_info()}
    atomic_write_json(os.path.join(args.out, f"guard_shortlist_{args.set}.json"), doc)
    print(json.dumps({k: doc[k] for k in ("all", "guard_fired", "no_pick", "wall_s")}, indent=1))
    return doc


if __name__ == "__main__":
    main()

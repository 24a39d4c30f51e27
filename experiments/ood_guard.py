"""SDG-Net on tool families it never saw, and the out-of-distribution guard calibrated on them.

    python experiments/ood_guard.py --out results/ood_guard       # 4 draws per family and task, the calibration families
    python experiments/ood_guard.py --calibrate-on held_out --out results/ood_guard_held_out
    python experiments/ood_guard.py --quick --out results/ood_quick                 # three families, tiny (tests)
    python experiments/ood_guard.py --model my.npz --out results/ood_my    # another checkpoint (its reference beside it)

The shipped checkpoint was trained on the four built-in families (claw hammer, hand broom, mallet,
L-stick; their part-wise and stretched variants) and the four training families of
`itup_jax.tools.families` (baton, headed stick, hook, pusher). Five families (screwdriver, spanner, pry
bar, hatchet, squeegee) are held out by construction, and four more (paddle, mace, scraper, T-hook) are
kept for calibrating the guard. Per family and task it can do, two disjoint sets
of tools are drawn (`tools.families.draw`): a calibration set (the family's default and seeds 100..) and a test
set (seeds 200..). Per tool: `--grasps` candidates the arm can carry (`sample_reachable`), each rolled
out once in native MuJoCo under the priors' nominal physics, scored by SDG-Net, and read by the guard
(`ood.check`). Reported per tool:
  * fidelity: Spearman rho between predicted and measured full induced peak wrist torque (the headline
    measure), and between predicted and measured grip demand; beside them two references for the
    torque's rho: the analytic wrench cost's peak full torque at the grasp (`costs.wrench_costs` with
    `torque_projection="full"`: physics with no learning, so it is as much at home on a new family as
    on the old ones), and a second rollout of the same candidates under one random physics draw (how
    far one rollout's ranking carries to another's: what a predictor of the nominal rollout can hope
    for in the randomised rollouts the datasets hold);
  * the learned pick (lowest predicted total) and the verified pick (the `--verify` best by predicted
    total, the lowest measured total among them, as `itup plan --verify K` picks under nominal
    physics): task success and grip failure; whether any candidate did the task and held;
  * the guard's score and groups;
  * on the test set, the planner end to end (`--plan-n` reachable candidates, its defaults: 5 grasps
    verified in MuJoCo, the guard's shortlist when it fires), its pick rolled out `--plan-draws` times
    under random physics:
    whether it did the task and held in every draw.

Calibration rule (fixed before the test set is read): the guard's threshold is the largest tool score t
such that, on the calibration tools of the calibration families, at least 90 % of the tools with
rho < 0.5 score above t, and never below the floor, the 95th percentile of the built-in families'
calibration scores (with no such tool, the floor alone): the guard is to fire on few of the network's
own families' tools, whose ranking it does not need checked, even where the calibration families hold
too few badly ranked tools to place the threshold (a network that ranks them well: one low score then
sets it, and the guard fires on the built-in tools that score above it). The calibration families are the calibration families (`--calibrate-on calibration`, the
default: no training set holds them, and the threshold is then judged on held-out families it was not
calibrated on), the held-out ones themselves (their calibration draws; `--calibrate-on held_out`), or the
training families (`--calibrate-on training`, for a checkpoint that never trained on them). The test set (the built-in and the held-out families) then reports how many of its
rho < 0.5 tools the guard catches and how often it fires on the built-in families' tools. Writes
ood_guard.json.
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
from itup_jax.fidelity import learned_and_verified_picks
from itup_jax.heldout import family_tools

#: rho below which SDG-Net's ranking counts as failed, and the share of such tools the guard must catch.
RHO_FAIL, CATCH = 0.5, 0.9


def planner_row(tool, task, n: int, seed: int, draws: int, model: str | None = None,
                guard_threshold: float | None = None) -> dict:
    """The planner end to end (`plan_grasp` with its defaults: n reachable candidates, 5 verified in
    MuJoCo, the guard's shortlist when it fires; `model` and its `guard_threshold` when given), its pick
    then rolled out `draws` times under random physics."""
    from itup_jax.planning import plan_grasp
    from itup_jax.sim.physics import Randomization
    from itup_jax.sim.rollout import simulate

    plan = plan_grasp(tool, task, n=n, seed=seed, model=model, guard_threshold=guard_threshold)
    out = {"status": plan.status, "guard_fired": bool(plan.guard is not None and plan.guard.fired),
           "verified": plan.verified is not None, "drawn": plan.sampling.get("drawn"), "ok_draws": None}
    if plan.pick is not None:
        L = simulate(tool, task, plan.grasps[np.full(draws, plan.pick)], seed=seed + 7, randomize=Randomization()).labels
        out["ok_draws"] = float(np.mean(np.asarray(L.valid) & np.asarray(L.success) & ~np.asarray(L.failed)))
    return out


def tool_row(tool, kind: str, grasps: int, verify: int, seed: int, model: str | None = None) -> dict:
    """One tool's measurements (module docstring), of `model` (None: the shipped checkpoint)."""
    import itup_jax as itup
    from itup_jax import ood
    from itup_jax.costs import CostParams, wrench_costs
    from itup_jax.grasp_sampler import sample_reachable
    from itup_jax.scoring import ScoreWeights
    from itup_jax.sim.physics import Randomization
    from itup_jax.stats import spearman
    from itup_jax.verify import measured_total, objective_of

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        task = itup.make_task(kind, tool)
    r = sample_reachable(tool, task, grasps, seed=seed)
    g = r.grasps
    s = itup.score(tool, task, g, model=model)
    guard = ood.check(tool, task, g, model=model)
    L = itup.simulate(tool, task, g, seed=seed, randomize=None).labels
    valid = np.asarray(L.valid)
    L2 = itup.simulate(tool, task, g, seed=seed + 1, randomize=Randomization()).labels
    both = valid & np.asarray(L2.valid)
    analytic_tau = np.asarray(wrench_costs(tool, task, g, CostParams(torque_projection="full")).tau, float)
    pred_tau, pred_grip, total = (np.asarray(x, float) for x in (s.tau, s.grip, s.total))
    meas_tau, meas_grip = np.asarray(L.peak_torque_induced, float), np.asarray(L.grip_demand, float)
    ok = valid & np.asarray(L.success) & ~np.asarray(L.failed)
    measured = np.asarray(measured_total(L, ScoreWeights(), objective_of(s)), float)
    learned, verified = learned_and_verified_picks(total, measured, valid, verify)
    return {
        "tool": tool.name, "task": kind, "mass_kg": round(tool.mass, 4), "candidates": len(g), "drawn": r.drawn,
        "valid": int(valid.sum()),
        "rho_induced": spearman(pred_tau[valid], meas_tau[valid]),
        "rho_grip": spearman(pred_grip[valid], meas_grip[valid]),
        "rho_induced_analytic": spearman(analytic_tau[valid], meas_tau[valid]),
        "rho_induced_random_draw": spearman(np.asarray(L2.peak_torque_induced, float)[both], meas_tau[both]),
        "guard": guard.to_json(),
        "pred_min": {"tau": float(pred_tau.min()), "grip": float(pred_grip.min())},
        "any_ok": bool(ok.any()), "ok_share": float(ok.mean()),
        "learned": {"index": learned, "success": bool(L.success[learned]), "failed": bool(L.failed[learned]),
                    "ok": bool(ok[learned])},
        "verified": {"index": verified, "success": bool(L.success[verified]), "failed": bool(L.failed[verified]),
                     "ok": bool(ok[verified])},
    }


def calibrate(rows: list[dict]) -> dict:
    """The threshold by the module's rule, from calibration rows (the rows not of a built-in family are
    the calibration families'): {"threshold", "rule" (which bound set it), "catch_t" (the largest t that
    catches CATCH of the calibration-family tools with rho < RHO_FAIL; None without such a tool),
    "floor" (the built-in rows' 95th percentile score; None without built-in rows)}."""
    held = [r for r in rows if not r["builtin"]]
    scores = np.array([r["guard"]["score"] for r in held])
    bad = np.array([r["rho_induced"] < RHO_FAIL for r in held], bool)  # NaN compares False: not a failure
    base = [r["guard"]["score"] for r in rows if r["builtin"]]
    floor = float(np.percentile(base, 95)) if base else None
    catch_t = None
    if bad.any():
        ok = [t for t in np.r_[np.sort(scores)[::-1], 0.0] if np.mean(scores[bad] > t) >= CATCH]
        catch_t = float(ok[0]) if ok else 0.0
    if catch_t is None and floor is None:
        raise ValueError("calibration needs a built-in row or a calibration-family tool with rho < "
                         f"{RHO_FAIL}; got {len(rows)} rows")
    caught = f"the largest t catching >= {CATCH:.0%} of the {int(bad.sum())} calibration-family tools with rho < {RHO_FAIL}"
    if catch_t is None:
        threshold, rule = floor, f"no calibration-family tool with rho < {RHO_FAIL}: the floor, 95th percentile of the built-ins"
    elif floor is None or catch_t >= floor:
        threshold, rule = catch_t, caught
    else:
        threshold, rule = floor, f"the floor, 95th percentile of the built-ins, above {caught} ({catch_t:.3f})"
    return {"threshold": round(threshold, 3), "rule": rule, "catch_t": None if catch_t is None else round(catch_t, 3),
            "floor": None if floor is None else round(floor, 3)}


def _median(rows: list[dict], key: str) -> float:
    """The median of `key` over `rows`, NaN (a constant ranking's rho) left out; NaN for no rows."""
    return float(np.nanmedian([r[key] for r in rows])) if rows else float("nan")


def judge(rows: list[dict], threshold: float) -> dict:
    held = [r for r in rows if not r["builtin"]]
    bad = [r for r in held if r["rho_induced"] < RHO_FAIL]
    builtin = [r for r in rows if r["builtin"]]
    fired = lambda r: r["guard"]["score"] > threshold  # noqa: E731
    solvable = [r for r in held if r["any_ok"]]
    return {
        "held_out_tools": len(held), "rho_below_0_5": len(bad),
        "caught": sum(fired(r) for r in bad),
        "fires_on_held_out": sum(fired(r) for r in held), "fires_on_builtin": sum(fired(r) for r in builtin),
        "builtin_tools": len(builtin),
        "median_rho_held_out": _median(held, "rho_induced"),
        "median_rho_builtin": _median(builtin, "rho_induced"),
        "median_rho_analytic_held_out": _median(held, "rho_induced_analytic"),
        "median_rho_analytic_builtin": _median(builtin, "rho_induced_analytic"),
        "median_rho_random_draw_held_out": _median(held, "rho_induced_random_draw"),
        "median_rho_random_draw_builtin": _median(builtin, "rho_induced_random_draw"),
        "solvable_held_out": len(solvable),
        "learned_ok_where_solvable": sum(r["learned"]["ok"] for r in solvable),
        "verified_ok_where_solvable": sum(r["verified"]["ok"] for r in solvable),
        "unsolvable_held_out": len(held) - len(solvable),
        # the planner end to end (test set): its pick did the task and held in every random draw
        "planner_ok_where_solvable": sum(bool(r.get("plan") and r["plan"]["ok_draws"] == 1.0) for r in solvable),
        "planner_runs": sum("plan" in r for r in held),
        "planner_verified": sum(bool(r.get("plan") and r["plan"]["verified"]) for r in held),
    }


def per_family(rows: list[dict]) -> list[dict]:
    out = []
    for fam in dict.fromkeys(r["family"] for r in rows):
        for kind in dict.fromkeys(r["task"] for r in rows if r["family"] == fam):
            rs = [r for r in rows if r["family"] == fam and r["task"] == kind]
            out.append({"family": fam, "task": kind, "tools": len(rs), "builtin": rs[0]["builtin"],
                        "median_rho_induced": _median(rs, "rho_induced"),
                        "median_rho_grip": _median(rs, "rho_grip"),
                        "median_rho_analytic": _median(rs, "rho_induced_analytic"),
                        "median_rho_random_draw": _median(rs, "rho_induced_random_draw"),
                        "median_guard": float(np.median([r["guard"]["score"] for r in rs])),
                        "learned_ok": float(np.mean([r["learned"]["ok"] for r in rs])),
                        "verified_ok": float(np.mean([r["verified"]["ok"] for r in rs])),
                        "any_ok": float(np.mean([r["any_ok"] for r in rs]))})
    return out


def family_sets(names: list[str], calibrate_on: str, others: tuple[str, ...]) -> dict[str, tuple[str, ...]]:
    """{family: the sets ("calibration", "test") drawn of it}: with `calibrate_on` "held_out" every family
    of `names` in both; with "training" or "calibration" the built-in families in both, the other families
    of `names` in the test set only, and the `others` families (the training or the calibration ones) in
    the calibration set only."""
    from itup_jax.tools import families

    if calibrate_on == "held_out":
        return {name: ("calibration", "test") for name in names}
    sets = {name: ("calibration", "test") if families.get(name).builtin else ("test",) for name in names}
    sets.update({name: ("calibration",) for name in others})
    return sets


def _nan_to_none(x):
    """JSON has no NaN: a Spearman rho of a constant ranking is written as null."""
    if isinstance(x, float) and not np.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _nan_to_none(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_nan_to_none(v) for v in x]
    return x


def main(argv=None) -> dict:
    import itup_jax as itup
    from itup_jax.bench import machine_info
    from itup_jax.tools import families

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tools", type=int, default=4, help="drawn tools per family, task and set (default %(default)s)")
    ap.add_argument("--grasps", type=int, default=64, help="reachable candidates per tool (default %(default)s)")
    ap.add_argument("--verify", type=int, default=5, metavar="K", help="the verified pick's shortlist (default %(default)s)")
    ap.add_argument("--families", default=",".join(families.with_role("builtin") + families.with_role("held_out")),
                    help="comma-separated families (default: the built-in and the held-out ones)")
    ap.add_argument("--calibrate-on", choices=("held_out", "training", "calibration"), default="calibration",
                    help="the calibration families: the held-out ones' calibration draws, the training "
                    "families' or the calibration families' (with either of the last two, the held-out ones "
                    "are only tested) (default %(default)s)")
    ap.add_argument("--plan-n", type=int, default=1000, help="candidates of the planner's run on each test tool "
                    "(0: no planner run; default %(default)s)")
    ap.add_argument("--plan-draws", type=int, default=3, help="random-physics rollouts of the planner's pick")
    ap.add_argument("--model", default=None, metavar="CHECKPOINT",
                    help="another SDG-Net checkpoint, its guard reference beside it (<stem>.reference.npz): "
                    "calibrated and judged instead of the shipped one; its planner runs use the threshold "
                    "calibrated here")
    ap.add_argument("--quick", action="store_true", help="two families, 1 draw each, 12 candidates (for the tests)")
    ap.add_argument("--out", default="results/ood_guard")
    args = ap.parse_args(argv)
    if args.quick:
        args.tools, args.grasps, args.verify, args.families, args.plan_n, args.plan_draws = 1, 12, 2, "mallet,screwdriver", 16, 1
    names = [f for f in args.families.split(",") if f]
    for f in names:
        families.get(f)
    if args.tools < 1 or args.grasps < 3 or args.verify < 1:
        print("ood_guard: --tools >= 1, --grasps >= 3 and --verify >= 1 are needed", file=sys.stderr)
        raise SystemExit(2)
    if args.model is not None:
        from itup_jax.ood import reference_path_of

        if not (os.path.isfile(args.model) and reference_path_of(args.model)):  # None: no reference on disk
            print(f"ood_guard: --model {args.model}: needs the checkpoint and its guard reference beside it",
                  file=sys.stderr)
            raise SystemExit(2)
    others = () if args.calibrate_on == "held_out" else families.with_role(args.calibrate_on)
    set_names = family_sets(names, args.calibrate_on, ("paddle",) if args.quick and others else others)
    os.makedirs(args.out, exist_ok=True)
    t0 = time.time()
    sets, cal = {"calibration": [], "test": []}, None
    # the calibration set first (in the families' order within each set): --model's planner runs use its threshold
    jobs = sorted(((set_name, name, kind) for name in set_names for kind in families.get(name).tasks
                   for set_name in set_names[name]), key=lambda job: job[0] != "calibration")
    for set_name, name, kind in jobs:
        if set_name == "test" and cal is None:
            cal = calibrate(sets["calibration"])
        for tool, s in family_tools(name, set_name, args.tools):
            row = tool_row(tool, kind, args.grasps, args.verify, seed=s, model=args.model)
            row.update(family=name, builtin=families.get(name).builtin)
            if set_name == "test" and args.plan_n > 0:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    task = itup.make_task(kind, tool)
                row["plan"] = planner_row(tool, task, args.plan_n, s, args.plan_draws, model=args.model,
                                          guard_threshold=cal["threshold"] if args.model else None)
            sets[set_name].append(row)
            print(f"{set_name:11s} {tool.name:16s} {kind:6s} rho {row['rho_induced']:+.2f} (analytic "
                  f"{row['rho_induced_analytic']:+.2f}, random draw {row['rho_induced_random_draw']:+.2f}) guard "
                  f"{row['guard']['score']:.2f} learned ok {row['learned']['ok']} verified ok "
                  f"{row['verified']['ok']} any ok {row['any_ok']}", flush=True)
    cal = cal or calibrate(sets["calibration"])
    from itup_jax.ood import GUARD_THRESHOLD

    doc = {"schema": "itup.ood_guard/1", "model": args.model and os.path.abspath(args.model), "grasps": args.grasps, "threshold_in_use": GUARD_THRESHOLD, "tools": args.tools, "verify": args.verify,
           "families": list(set_names), "calibrate_on": args.calibrate_on, "rho_fail": RHO_FAIL, "catch": CATCH, "calibration": cal,
           "judged": {k: judge(v, cal["threshold"]) for k, v in sets.items()},
           "judged_in_use": {k: judge(v, GUARD_THRESHOLD) for k, v in sets.items()},
           "per_family": {k: per_family(v) for k, v in sets.items()},
           "rows": sets, "wall_s": round(time.time() - t0, 1), "machine": machine_info()}
    atomic_write_json(os.path.join(args.out, "ood_guard.json"), _nan_to_none(doc))
    print(json.dumps({"calibration": cal, "judged": doc["judged"]}, indent=1))
    return doc


if __name__ == "__main__":
    main()

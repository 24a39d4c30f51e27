"""How much torque does scoring more candidates save? SDG-Net's pick among N fresh candidates, measured.

    python experiments/candidate_count.py --test data/test --n 256,1024,4096 --out results/candidates
    python experiments/candidate_count.py --quick --out results/cand_quick      # a tiny test set made here (tests)

The top-1 regret goal compares SDG-Net's pick with the best of the *same* candidates, and a tool's
best candidate is usually a lone one (`sdgnet_fidelity.py`, `best_gap`). Scoring is cheap (10,000
candidates in ~14 ms), so a planner can score many more. Per held-out tool of the test set:
  * N fresh antipodal candidates for each N of --n (sampled with a seed of their own, the arm's
    reachable ones kept: closed-form IK), scored by SDG-Net; the pick by predicted C_tau (`tau`) and the
    pick by the scorer's total (`total`, the default `ScoreWeights`, as `itup.best_grasp` picks); with
    --verify K (default 5; 0: off) also the verified pick (`verified`: `itup.best_grasp_verified`, the K
    best-scored reachable candidates rolled out under nominal physics, the lowest measured total kept,
    as `itup plan --verify K` picks);
  * each pick rolled out --draws times under randomised physics, the same draws for every pick: mean
    full induced peak wrist torque (N m; the headline, `torque`), beside it the raw peak, the projected
    part and the part about the closure axis, the grip demand (N per pad), task success and grip-failure
    rates, slip (m) and drift (rad) (`MEASURES`);
  * the reference: the test shard's own candidates (256 per tool in the shipped test set), each
    measured over the same number of draws (draw 0 and the `sdgnet_fidelity.py` redraws, cached in
    --out): the lowest mean torque among them (`best_shard`), and SDG-Net's picks among them (`shard_tau`,
    `shard_total`, `shard_verified`).
Writes candidates.json (schema `itup.candidates/2`). Summary: per pick, the geometric mean of the
torque over tools, and in how many tools it is within 5 % of (or below) `best_shard`; for each larger N,
the torque per tool against the smallest N's (`paired_vs_<N>`: `stats.paired_ratio`, with a bootstrap
interval).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

import numpy as np

import itup_jax as itup
from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import unit_tool
from itup_jax.dataset_load import load_shard
from itup_jax.grasp import Grasps
from itup_jax.grasp_sampler import sample_grasps
from itup_jax.heldout import BESIDE, MEASURES, SAMPLE_SEED, cached_redraws, held_out_dataset, measure_pick, shard_key
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sim.arm import reachable
from itup_jax.sim.scene import build_scene
from itup_jax.stats import paired_ratio
from itup_jax.verify import best_grasp_verified

GOAL = 0.05  # the top-1 regret goal (5 %)


def evaluate_tool(config, entry, a, redraw, ns, draws, model, timestep, verify) -> dict:
    """One test shard (`entry`, its arrays `a`, its further draws `redraw` {torque: [k, N]}): the shard
    candidates' mean torque over `draws` draws and SDG-Net's picks among them, then for each N of `ns` the
    picks among N fresh reachable candidates, each measured over `draws` rollouts (`_measure`)."""
    tool, task = unit_tool(config, entry["task"], entry["variant"])
    scene = build_scene(tool, task, timestep=timestep)
    ok = a["label_valid"].astype(bool)
    measured = np.vstack([np.where(ok, a["label_peak_torque_induced"], np.nan)[None], redraw["torque"][:draws - 1]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mean = np.nanmean(measured, axis=0)[ok]
    g0 = Grasps(a["grasp_p"][ok], a["grasp_q"][ok], a["grasp_width"][ok])
    s0 = itup.score(tool, task, g0, model)
    row = {"task": entry["task"], "variant": entry["variant"], "shard_candidates": int(ok.sum()),
           "best_shard": float(np.nanmin(mean)), "shard_tau": float(mean[int(np.argmin(np.asarray(s0.tau)))]),
           "shard_total": float(mean[int(np.argmin(np.asarray(s0.total)))]), "fresh": {}}
    if verify:
        row["shard_verified"] = float(mean[best_grasp_verified(tool, task, g0, scores=s0, k=verify, scene=scene).index])
    picks = []  # (N, rule, candidates, index of the pick)
    for n in ns:
        t0 = time.perf_counter()
        g = sample_grasps(tool, n, seed=SAMPLE_SEED + entry["variant"])
        g = g[np.nonzero(reachable(task, g))[0]]
        row["fresh"][str(n)] = {"reachable": int(len(g.width))}
        if not len(g.width):  # nothing the arm can carry: no pick (NaN, null in the JSON)
            none = {k: float("nan") for k in MEASURES} | {"index": None}
            row["fresh"][str(n)].update({"sample_score_s": time.perf_counter() - t0, "tau": none, "total": none,
                                         **({"verified": none} if verify else {})})
            continue
        s = itup.score(tool, task, g, model)
        row["fresh"][str(n)]["sample_score_s"] = time.perf_counter() - t0
        for rule, sc in (("tau", s.tau), ("total", s.total)):
            picks.append((str(n), rule, g, int(np.argmin(np.asarray(sc)))))
        if verify:
            picks.append((str(n), "verified", g, best_grasp_verified(tool, task, g, scores=s, k=verify, scene=scene).index))
    for n, rule, g, i in picks:
        row["fresh"][n][rule] = {**measure_pick(tool, task, scene, g, i, draws), "index": i}
    return row


def summarise(rows: list[dict], ns: list[int], rules: tuple[str, ...]) -> dict:
    """Per pick rule and N (and the shard's own picks): the geometric mean torque over the tools, and the
    share of tools whose pick is within the goal of (or below) the shard's best; a tool without a pick
    counts as not within."""
    best = np.array([r["best_shard"] for r in rows])
    geo = lambda v: float(np.exp(np.nanmean(np.log(v))))  # noqa: E731
    within = lambda v: float(np.nanmean(v <= best * (1 + GOAL)))  # noqa: E731
    out = {"tools": len(rows), "best_shard": {"geo_mean_torque": geo(best)}}
    for rule in rules:
        v = np.array([r[f"shard_{rule}"] for r in rows])
        out[f"shard_{rule}"] = {"geo_mean_torque": geo(v), "within_goal_of_best_shard": within(v)}
        for n in ns:
            c = [r["fresh"][str(n)][rule] for r in rows]
            v = np.array([x["torque"] for x in c])
            out[f"{rule}_{n}"] = {"geo_mean_torque": geo(v), "mean_torque": float(np.nanmean(v)),
                                  "within_goal_of_best_shard": within(v),
                                  **{f: float(np.nanmean([x.get(f, np.nan) for x in c]))
                                     for f in BESIDE}}
            if n != ns[0]:  # per tool against the smallest N: a geometric mean of ratios, with a bootstrap interval
                v0 = np.array([r["fresh"][str(ns[0])][rule]["torque"] for r in rows])
                out[f"{rule}_{n}"][f"paired_vs_{ns[0]}"] = paired_ratio(v, v0)
    return out


def _paired_text(p: dict | None, n0: int) -> str:
    if not p or p["ratio"] is None:
        return ""
    ci = f", 95 % {p['ci95'][0]:.2f}-{p['ci95'][1]:.2f}" if p["ci95"] else ""
    return f"; x{p['ratio']:.2f} vs {n0}{ci}, lower in {p['lower']}/{p['n']}"


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--test", default=None, help="test dataset folder (held-out tools: variants >= 1)")
    ap.add_argument("--n", default="256,1024,4096", help="comma-separated candidate counts")
    ap.add_argument("--draws", type=int, default=5, help="rollouts per pick, and draws per shard candidate")
    ap.add_argument("--verify", type=int, default=5, metavar="K",
                    help="also the verified pick among the K best-scored reachable candidates (0: off)")
    ap.add_argument("--model", default=None, help="checkpoint (default: the shipped one)")
    ap.add_argument("--quick", action="store_true", help="a tiny test set made in --out, --n 16,32, --draws 2 (for the tests)")
    ap.add_argument("--out", default="results/candidates")
    args = ap.parse_args(argv)
    if args.quick:
        args.n, args.draws, args.verify = "16,32", 2, 2
    try:
        ns = [int(x) for x in args.n.split(",")]
    except ValueError:
        ns = []
    if not ns or min(ns) < 1:
        print(f"candidate_count: --n must be positive integers separated by commas, got {args.n!r}", file=sys.stderr)
        raise SystemExit(2)
    for flag, v, lowest in (("--draws", args.draws, 1), ("--verify", args.verify, 0)):
        if v < lowest:
            print(f"candidate_count: {flag} must be >= {lowest}, got {v}", file=sys.stderr)
            raise SystemExit(2)
    rules = ("tau", "total", "verified") if args.verify else ("tau", "total")
    os.makedirs(args.out, exist_ok=True)
    quick_dir = os.path.join(args.out, "test") if args.quick else None
    args.test, manifest, config, steps = held_out_dataset(args.test, quick_dir, "--test", error=ap.error)
    # the shard candidates' further draws (cached as the fidelity experiment caches them)
    redraws = (cached_redraws(args.test, args.draws - 1, os.path.join(args.out, "redraws.npz"))
               if args.draws > 1 else {})
    model = load_model(args.model)
    rows, t0 = [], time.perf_counter()
    for e in manifest["shards"]:
        if e["variant"] == 0:
            continue
        a = load_shard(args.test, e)
        rd = redraws.get(shard_key(e), {"torque": np.zeros((0, len(a["label_valid"])))})
        rows.append(evaluate_tool(config, e, a, rd, ns, args.draws, model, steps[e["task"]], args.verify))
        r = rows[-1]
        print(f"{r['task']:7s} {r['variant']:3d} best of the shard {r['best_shard']:.3f} N m; SDG-Net's pick by C_tau: shard "
              f"{r['shard_tau']:.3f}, " + ", ".join(f"{n} {r['fresh'][str(n)]['tau']['torque']:.3f}" for n in ns), flush=True)
    summary = summarise(rows, ns, rules)
    from itup_jax.bench import machine_info

    out = {"schema": "itup.candidates/2", "test": os.path.abspath(args.test), "n": ns, "draws": args.draws,
           "verify": args.verify,
           "model": args.model or "shipped", "goal": GOAL, "wall_s": time.perf_counter() - t0, "summary": summary,
           "per_tool": rows, "machine": machine_info()}
    atomic_write_json(os.path.join(args.out, "candidates.json"), out, indent=2)
    print(f"{summary['tools']} held-out tools, {args.draws} draws per pick; geometric mean full induced peak torque (N m) / share of tools "
          f"within {100 * GOAL:.0f}% of the best shard candidate (best: {summary['best_shard']['geo_mean_torque']:.3f}):")
    for rule in rules:
        s = summary[f"shard_{rule}"]
        print(f"  by {rule:8s} shard {s['geo_mean_torque']:.3f} / {100 * s['within_goal_of_best_shard']:.0f}% | "
              + " | ".join(f"{n}: {summary[f'{rule}_{n}']['geo_mean_torque']:.3f} / "
                           f"{100 * summary[f'{rule}_{n}']['within_goal_of_best_shard']:.0f}% (task "
                           f"{100 * summary[f'{rule}_{n}']['success']:.0f}%, fails {100 * summary[f'{rule}_{n}']['failed']:.1f}%"
                           + _paired_text(summary[f"{rule}_{n}"].get(f"paired_vs_{ns[0]}"), ns[0]) + ")"
                           for n in ns))
    return out


if __name__ == "__main__":
    main()

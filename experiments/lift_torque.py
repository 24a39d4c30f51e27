"""Which grasps hold when a tool is lifted off the table: pick success against the lift torque share.

    python experiments/lift_torque.py --first-table 0 --tables 10 --out results/lift_torque   # calibration
    python experiments/lift_torque.py --quick --out results/lift_quick                                # tiny (tests)

The pick filter (`pickup.pick_candidates`) keeps a grasp when the torque about its closure axis that the
lift must hold, as a share of the pads' torsional capacity (`pickup.lift_torque`), is at most
`pickup.LIFT_TORQUE_SHARE`. This experiment measures how that share predicts the pick. Per table (seed
t, `tabletop.make_tabletop`, without clutter and with `--clutter` tools) and per task (its instruction,
grounded by the rule grounder: the task's tool and the part to hold), grasps are sampled on the grounded
tool until `--pool` pass every pick filter but the lift torque's (at most SAMPLE_ROUNDS rounds), and
`--picks` of them, evenly spread over the sorted share, are picked up in MuJoCo (`pickup.execute_pick`).
Each pick records the share with the loads of the other tools over a simulated rigid lift
(`lift_torque`, what the filter uses), with their loads at rest and with the tool's weight alone, whether the tool came up in the pads (`lifted`) and
whether it also turned less than the task labels' grip failure threshold in them (`held`:
`SimConfig.rotation_threshold`; a tool can come up turned 40 degrees).

Printed and written (lift_torque.json): the hold rate per band of each share (Clopper-Pearson 95 %
intervals) and the area under the ROC curve of each share as a predictor of a pick that did not hold
(0.5: no better than chance) and of one that did not lift. `--from JSON` summarizes an earlier run's
rows again. The threshold is chosen on tables the pipeline's ablation is not judged on.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

import itup_jax as itup
from itup_jax import grounding, pickup, tabletop
from itup_jax.atomic import atomic_write_json
from itup_jax.pipeline import INSTRUCTIONS
from itup_jax.rotations import quat_to_matrix_np
from itup_jax.sim.config import SimConfig
from itup_jax.stats import clopper_pearson

#: Bands of the lift torque share the lift rate is reported in.
BANDS = (0.0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, math.inf)
SAMPLE_ROUNDS = 4


def auc(score: np.ndarray, positive: np.ndarray) -> float:
    """Area under the ROC curve of `score` [N] for the `positive` [N] bool class (Mann-Whitney, ties
    counted half); nan when either class is empty."""
    s, pos = np.asarray(score, float), np.asarray(positive, bool)
    a, b = s[pos], s[~pos]
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    return float(((a[:, None] > b[None, :]).sum() + 0.5 * (a[:, None] == b[None, :]).sum()) / (len(a) * len(b)))


def bands(rows: list[dict], key: str) -> list[dict]:
    out = []
    for lo, hi in zip(BANDS[:-1], BANDS[1:]):
        sel = [r for r in rows if lo <= r[key] < hi]
        k, n = sum(r["held"] for r in sel), len(sel)
        ci = clopper_pearson(k, n) if n else (float("nan"), float("nan"))
        out.append({"from": lo, "to": hi if math.isfinite(hi) else None, "picks": n, "held": k,
                    "rate": k / n if n else None, "ci95": list(ci)})
    return out


def picks_on(top, task: str, pool: int, picks: int, samples: int, seed: int) -> list[dict]:
    """The calibration picks on one table for one task (module docstring)."""
    g = grounding.ground(INSTRUCTIONS[task], top, "rule")
    tool = g.grounded_tool(top)
    found = []
    for r in range(SAMPLE_ROUNDS):
        grasps = itup.sample_grasps(tool, samples, seed=seed * SAMPLE_ROUNDS + r)
        c = pickup.pick_candidates(top, g.tool_index, tool, grasps, lift_torque_share=math.inf,
                                    lift_torque_limit=math.inf)
        if c.grasps is not None:
            found.append(c)
        if sum(len(f.index) for f in found) >= pool:
            break
    if not found:
        return []
    p = np.concatenate([np.asarray(f.grasps.p_tool_grasp, float) for f in found])
    q = np.concatenate([np.asarray(f.grasps.q_tool_grasp, float) for f in found])
    w = np.concatenate([np.asarray(f.grasps.width, float) for f in found])
    q_path = np.concatenate([f.q_path for f in found])
    share = np.concatenate([f.lift_load for f in found])
    share_w = pickup.lift_torque(top, g.tool_index, tool, p, quat_to_matrix_np(q), loads=None)
    share_r = pickup.lift_torque(top, g.tool_index, tool, p, quat_to_matrix_np(q), loads="rest")
    order = np.argsort(share)
    chosen = np.unique(order[np.round(np.linspace(0, len(order) - 1, min(picks, len(order)))).astype(int)])
    loaded = len(tabletop.rest_loads(top, g.tool_index)[0]) > 0
    com = np.asarray(tool.params.com, float)
    rows = []
    for k in chosen:
        res = pickup.execute_pick(top, g.tool_index, itup.make_grasps(p[k:k + 1], q_tool_grasp=q[k:k + 1], width=w[k:k + 1]),
                                  q_path[k])
        rows.append({"task": task, "tool": tool.name, "share": float(share[k]), "share_rest": float(share_r[k]),
                     "share_weight": float(share_w[k]),
                     "loaded": loaded, "com_distance_m": float(np.linalg.norm(p[k] - com)), "lifted": res.lifted,
                     "held": bool(res.lifted and res.angle_error < SimConfig().rotation_threshold),
                     "rise_m": res.rise, "angle_error_deg": math.degrees(res.angle_error)})
    return rows


#: The shares compared: (row key, what it counts).
MEASURES = (("share", "the lift's loads"), ("share_rest", "the rest loads"), ("share_weight", "the weight alone"))


def summarize(rows: list[dict]) -> dict:
    out = {}
    measures = [(k, what) for k, what in MEASURES if rows and k in rows[0]]
    for name, sel in (("all", rows), ("loaded", [r for r in rows if r["loaded"]]),
                      ("not_loaded", [r for r in rows if not r["loaded"]])):
        if not sel:
            continue
        dropped = np.array([not r["lifted"] for r in sel])
        failed = np.array([not r["held"] for r in sel])
        o = out[name] = {"picks": len(sel), "lifted": int((~dropped).sum()), "held": int((~failed).sum())}
        for k, _ in measures:
            x = np.array([r[k] for r in sel])
            o[f"auc_{k}"], o[f"auc_{k}_lift"], o[f"bands_{k}"] = auc(x, failed), auc(x, dropped), bands(sel, k)
        print(f"\n{name}: {len(sel)} picks, {o['lifted']} lifted, {o['held']} held; AUC for a pick that did not hold "
              f"(did not lift): " + ", ".join(f"{what} {o[f'auc_{k}']:.3f} ({o[f'auc_{k}_lift']:.3f})" for k, what in measures))
        print("  band        " + "".join(f"{'held, ' + what:>30s}" for _, what in measures))

        def cell(x):
            return (f"{x['held']:4d}/{x['picks']:<4d} {100 * x['rate']:4.0f} % [{100 * x['ci95'][0]:3.0f}-"
                    f"{100 * x['ci95'][1]:3.0f}]" if x["picks"] else f"{'-':>27s}")
        for j, b in enumerate(o[f"bands_{measures[0][0]}"]):
            band = f"{b['from']:.2f}-{'inf' if b['to'] is None else format(b['to'], '.2f')}"
            print(f"  {band:10s}" + "".join(f"   {cell(o[f'bands_{k}'][j])}" for k, _ in measures))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--first-table", type=int, default=0, help="the first table's seed")
    ap.add_argument("--tables", type=int, default=10, help="tables (seeds first-table, first-table + 1, ...)")
    ap.add_argument("--clutter", type=int, nargs="+", default=[0, 4], help="clutter settings (extra tools)")
    ap.add_argument("--tasks", nargs="+", default=list(INSTRUCTIONS))
    ap.add_argument("--pool", type=int, default=64, help="pickable grasps to draw the picks from")
    ap.add_argument("--picks", type=int, default=16, help="picks per table and task")
    ap.add_argument("--samples", type=int, default=2048, help="grasps sampled per round")
    ap.add_argument("--quick", action="store_true", help="1 table, the hammer, clutter 2, 4 picks (tests)")
    ap.add_argument("--from", dest="from_json", default=None, metavar="JSON",
                    help="summarize an earlier run's lift_torque.json instead of running")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    if args.from_json:
        with open(args.from_json) as fh:
            old = json.load(fh)
        for r in old["rows"]:  # rows written before `held` was recorded
            r.setdefault("held", bool(r["lifted"] and math.radians(r["angle_error_deg"]) < SimConfig().rotation_threshold))
        out = {**old, "summary": summarize(old["rows"])}
        os.makedirs(args.out, exist_ok=True)
        atomic_write_json(os.path.join(args.out, "lift_torque.json"), out, indent=1)
        return 0
    if args.quick:
        args.tables, args.tasks, args.clutter, args.picks, args.pool, args.samples = 1, ["hammer"], [2], 4, 8, 512
    bad = [t for t in args.tasks if t not in INSTRUCTIONS]
    if bad or args.tables < 1 or args.picks < 2 or args.first_table < 0:
        ap.error(f"unknown task(s) {bad}, or --tables < 1, --picks < 2 or --first-table < 0")
    os.makedirs(args.out, exist_ok=True)
    t0 = time.perf_counter()
    rows = []
    for clutter in args.clutter:
        for t in range(args.first_table, args.first_table + args.tables):
            top = tabletop.make_tabletop(clutter=clutter, seed=t)
            for task in args.tasks:
                for r in picks_on(top, task, args.pool, args.picks, args.samples, seed=t):
                    rows.append({"clutter": clutter, "table": t, **r})
            print(f"clutter {clutter} table {t}: {len(rows)} picks, {time.perf_counter() - t0:.0f} s", flush=True)
    cells = summarize(rows)
    out = {"schema": "itup.lift_torque/1", "first_table": args.first_table, "tables": args.tables,
           "clutter": args.clutter, "tasks": args.tasks, "picks": args.picks, "pool": args.pool,
           "samples": args.samples, "lift_torque_share": pickup.LIFT_TORQUE_SHARE, "summary": cells, "rows": rows,
           "wall_s": round(time.perf_counter() - t0, 1)}
    atomic_write_json(os.path.join(args.out, "lift_torque.json"), out, indent=1)
    print(f"wrote {os.path.join(args.out, 'lift_torque.json')} ({out['wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

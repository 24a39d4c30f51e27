"""The whole chain and the paper's ablations in simulation (the paper's Tables II and III beside ours).

    python experiments/pipeline_ablation.py --trials 50 --out results/pipeline       # >= 50 per cell (tables 0-49)
    python experiments/pipeline_ablation.py --quick --out results/pipe_quick                    # tiny (tests)

Per task (one plain instruction each, INSTRUCTIONS), per table (no clutter: the four built-in tools
apart; clutter: `--clutter` procedural tools dropped among them) and per trial t, one table is laid out
with seed t (`tabletop.make_tabletop`) and every method of `pipeline.METHODS` runs on that same table
with the same seed (the same sampling and the same physics draw: paired), `pipeline.run`. A cell's
success rate comes with its exact binomial (Clopper-Pearson) 95 % interval, beside the success with the
first pick alone (a run whose first pick failed put the tool back and picked again, up to `--attempts`
picks; the same runs with one pick allowed end at that failure, so both rates come from one run,
paired); failures are broken down by
the stage the run ended at (grounding, plan, pick, grip, task), with the success among the runs that
picked the tool up and the median full induced peak wrist torque of their task rollouts (the raw peak
beside it). The paper's
numbers (real robot, 10 trials per cell) are printed beside ours. Writes pipeline_ablation.json;
`--from JSON [JSON ...] [--first-trial K]` summarizes earlier runs' rows again (K: from table seed K on),
merging runs of different tasks, e.g. two processes on a 2-core machine:

    python experiments/pipeline_ablation.py --tasks hammer sweep --out results/ablation_a &
    python experiments/pipeline_ablation.py --tasks knock reach --out results/ablation_b; wait
    python experiments/pipeline_ablation.py --from results/ablation_a/pipeline_ablation.json results/ablation_b/pipeline_ablation.json --out results/pipeline
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys
import time

import numpy as np

import itup_jax as itup
from itup_jax import tabletop
from itup_jax.atomic import atomic_write_json
from itup_jax.pipeline import INSTRUCTIONS, MAX_PICK_ATTEMPTS, METHODS, STAGES
from itup_jax.stats import clopper_pearson

#: The paper's Table II (no clutter) and III (clutter), real world, 10 trials per cell (% success).
PAPER_TABLE2 = {"hammer": {"itup": 50, "no_sdgnet": 30, "no_grounding": 0, "object_level": 10, "copa": 30},
                "sweep": {"itup": 90, "no_sdgnet": 70, "no_grounding": 10, "object_level": 60, "copa": 70},
                "knock": {"itup": 90, "no_sdgnet": 70, "no_grounding": 30, "object_level": 80, "copa": 80},
                "reach": {"itup": 80, "no_sdgnet": 70, "no_grounding": 0, "object_level": 30, "copa": 60}}
PAPER_TABLE3 = {"hammer": {"itup": 40, "copa": 20}, "sweep": {"itup": 90, "copa": 70},
                "knock": {"itup": 90, "copa": 70}, "reach": {"itup": 60, "copa": 30}}


def summarize(rows: list[dict], tasks, methods, clutters) -> dict:
    """Per (clutter, task or 'total', method): successes with the Clopper-Pearson interval, the stages
    the runs ended at, how many picked the tool up (reached the task rollout) and the success among
    those, and the median full induced and raw peak wrist torques of the task rollouts (N m). Prints the tables
    beside the paper's."""
    cells = {}
    for clutter in clutters:
        for task in list(tasks) + ["total"]:
            for m in methods:
                sel = [r for r in rows if r["clutter"] == clutter and r["method"] == m and task in (r["task"], "total")]
                if not sel:
                    continue
                k, n = sum(r["success"] for r in sel), len(sel)
                lo, hi = clopper_pearson(k, n)
                k1 = sum(r["success"] and (r.get("picks") or 1) == 1 for r in sel)
                stages = collections.Counter(r["stage"] for r in sel)
                picked = [r for r in sel if r["stage"] in ("grip", "task", "done")]
                torques = [r["peak_torque_induced"] for r in picked if r["peak_torque_induced"] is not None]
                raw = [r["peak_torque"] for r in picked if r.get("peak_torque") is not None]
                cells[f"{clutter}/{task}/{m}"] = {
                    "clutter": clutter, "task": task, "method": m, "successes": k, "trials": n, "rate": k / n,
                    "ci95": [lo, hi], "first_pick_successes": k1, "first_pick_rate": k1 / n,
                    "first_pick_ci95": list(clopper_pearson(k1, n)),
                    "repicked": sum((r.get("picks") or 1) > 1 for r in sel),
                    "stages": {s: stages.get(s, 0) for s in STAGES}, "picked": len(picked),
                    "done_given_picked": (sum(r["success"] for r in picked) / len(picked)) if picked else None,
                    "median_peak_torque_induced": float(np.median(torques)) if torques else None,
                    "median_peak_torque": float(np.median(raw)) if raw else None}
    for clutter in clutters:
        paper = PAPER_TABLE2 if clutter == 0 else PAPER_TABLE3
        name = "Table II (no clutter)" if clutter == 0 else f"Table III (clutter {clutter})"
        print(f"\n{name}: success % [95 % CI] (paper's, real robot, 10 trials)")
        print("task     " + "".join(f"{m:>26s}" for m in methods))
        for task in list(tasks) + ["total"]:
            line = f"{task:8s} "
            for m in methods:
                c = cells[f"{clutter}/{task}/{m}"]
                p = paper.get(task, {}).get(m) if task != "total" else None
                line += f"{100 * c['rate']:5.0f} [{100 * c['ci95'][0]:3.0f}-{100 * c['ci95'][1]:3.0f}]" + (
                    f" ({p:3d})" if p is not None else "      ") + "   "
            print(line)
        print("with the first pick alone (the same runs, one pick allowed):")
        for task in list(tasks) + ["total"]:
            print(f"{task:8s} " + "".join(
                f"{100 * cells[f'{clutter}/{task}/{m}']['first_pick_rate']:5.0f} [{100 * cells[f'{clutter}/{task}/{m}']['first_pick_ci95'][0]:3.0f}-"
                f"{100 * cells[f'{clutter}/{task}/{m}']['first_pick_ci95'][1]:3.0f}]" + " " * 12 for m in methods))
        for m in methods:
            c = cells[f"{clutter}/total/{m}"]
            fails = {s: v for s, v in c["stages"].items() if v and s != "done"}
            given = c["done_given_picked"]
            print(f"  {m:13s} picked {c['picked']}/{c['trials']} ({c['repicked']} picked again), done given picked "
                  f"{'-' if given is None else f'{100 * given:.0f} %'}, median full induced peak torque "
                  f"{c['median_peak_torque_induced'] or float('nan'):.2f} N m (raw "
                  f"{c['median_peak_torque'] or float('nan'):.2f} N m); ended at {fails}")
    return cells


def merge_runs(paths: list[str]) -> dict:
    """One run's document from the pipeline_ablation.json of runs of the same trials, clutter, methods and
    samples (e.g. different --tasks run in parallel): their rows and tasks together. Exits 2 when they
    differ in those settings or hold the same run twice."""
    docs = []
    for path in paths:
        with open(path) as fh:
            docs.append(json.load(fh))
    same = ("trials", "first_table", "clutter", "methods", "samples", "max_attempts")
    for path, d in zip(paths[1:], docs[1:]):
        differ = [k for k in same if d.get(k) != docs[0].get(k)]
        if differ:
            print(f"pipeline_ablation: --from {path}: {', '.join(differ)} differ from {paths[0]}'s", file=sys.stderr)
            raise SystemExit(2)
    rows = [r for d in docs for r in d["rows"]]
    keys = collections.Counter((r["clutter"], r["trial"], r["task"], r["method"]) for r in rows)
    twice = [k for k, n in keys.items() if n > 1]
    if twice:
        print(f"pipeline_ablation: --from: {len(twice)} runs appear twice (e.g. clutter, trial, task, method = "
              f"{twice[0]}); give runs of different tasks", file=sys.stderr)
        raise SystemExit(2)
    tasks = [t for t in INSTRUCTIONS if any(t in d["tasks"] for d in docs)]
    # wall_s: the longest of the merged runs (their wall time when they ran side by side)
    return {**docs[0], "tasks": tasks, "rows": rows, "wall_s": max(d.get("wall_s", 0.0) for d in docs),
            "wall_s_runs": [d.get("wall_s") for d in docs]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=50, help="tables per task and clutter setting")
    ap.add_argument("--first-table", type=int, default=0,
                    help="the first table's seed: tables K .. K + trials - 1 (default 0; a fresh set of tables "
                    "measures a change chosen on earlier ones)")
    ap.add_argument("--clutter", type=int, default=4, help="procedural tools added in the cluttered tables")
    ap.add_argument("--tasks", nargs="+", default=list(INSTRUCTIONS))
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--samples", type=int, default=2048)
    ap.add_argument("--attempts", type=int, default=MAX_PICK_ATTEMPTS,
                    help=f"picks a run tries at most (default {MAX_PICK_ATTEMPTS}; 1: a failed pick ends the run)")
    ap.add_argument("--quick", action="store_true", help="1 trial, the hammer, 2 methods, clutter 2, 256 samples (tests)")
    ap.add_argument("--from", dest="from_json", nargs="+", default=None, metavar="JSON",
                    help="summarize the rows of earlier runs' pipeline_ablation.json instead of running; several "
                    "are merged (e.g. runs of different --tasks in parallel processes)")
    ap.add_argument("--first-trial", type=int, default=0,
                    help="with --from: only trials from this seed on (e.g. tables not looked at while the "
                    "pipeline's filters were chosen)")
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    if args.from_json:
        old = merge_runs(args.from_json)
        rows = [r for r in old["rows"] if r["trial"] >= args.first_trial]
        first = old.get("first_table", 0)
        print(f"{', '.join(args.from_json)}: tables {max(args.first_trial, first)}..{first + old['trials'] - 1}")
        cells = summarize(rows, old["tasks"], old["methods"], (0, old["clutter"]))
        out = {**old, "cells": cells, "rows": rows, "first_trial": args.first_trial}
        os.makedirs(args.out, exist_ok=True)
        atomic_write_json(os.path.join(args.out, "pipeline_ablation.json"), out, indent=1)
        return 0
    if args.quick:
        args.trials, args.tasks, args.methods, args.samples, args.clutter = 1, ["hammer"], ["itup", "copa"], 256, 2
    bad = [m for m in args.methods if m not in METHODS] + [t for t in args.tasks if t not in INSTRUCTIONS]
    if bad or args.trials < 1 or args.attempts < 1:
        ap.error(f"unknown method(s) or task(s) {bad}, or --trials or --attempts < 1")
    os.makedirs(args.out, exist_ok=True)
    t0 = time.perf_counter()
    rows = []
    for clutter in (0, args.clutter):
        for t in range(args.first_table, args.first_table + args.trials):
            top = tabletop.make_tabletop(clutter=clutter, seed=t)
            for task in args.tasks:
                for m in args.methods:
                    r = itup.run(INSTRUCTIONS[task], tabletop=top, seed=t, method=m, samples=args.samples,
                                 max_attempts=args.attempts)
                    rows.append({"clutter": clutter, "trial": t, "task": task, "method": m, "stage": r.stage,
                                 "success": r.success, "message": r.message,
                                 "tool": None if r.grounding is None else r.grounding.tool_name,
                                 "task_reachable": r.counts.get("task_reachable"),
                                 "picks": r.counts.get("picks"),
                                 "actions": [a["action"] for a in r.attempts],
                                 "pick_position_error_m": None if r.pick is None else r.pick.position_error,
                                 "pick_angle_error_rad": None if r.pick is None else r.pick.angle_error,
                                 "peak_torque_induced": None if r.labels is None else r.labels["peak_torque_induced"],
                                 "peak_torque": None if r.labels is None else r.labels["peak_torque"],
                                 "guard_fired": (r.choice or {}).get("guard_fired"),
                                 "checked": None if "checked" not in (r.choice or {}) else len(r.choice["checked"]),
                                 "wall_s": round(r.wall_s, 2)})
            atomic_write_json(os.path.join(args.out, "pipeline_ablation.partial.json"), {"rows": rows})  # kept if it stops
            print(f"clutter {clutter} trial {t}: {time.perf_counter() - t0:.0f} s", flush=True)
    cells = summarize(rows, args.tasks, args.methods, (0, args.clutter))
    out = {"schema": "itup.pipeline_ablation/1", "trials": args.trials, "first_table": args.first_table,
           "clutter": args.clutter, "tasks": args.tasks,
           "methods": args.methods, "samples": args.samples, "max_attempts": args.attempts, "instructions": INSTRUCTIONS, "cells": cells,
           "paper": {"table2": PAPER_TABLE2, "table3": PAPER_TABLE3}, "rows": rows,
           "wall_s": round(time.perf_counter() - t0, 1)}
    atomic_write_json(os.path.join(args.out, "pipeline_ablation.json"), out, indent=1)
    os.remove(os.path.join(args.out, "pipeline_ablation.partial.json"))
    print(f"wrote {os.path.join(args.out, 'pipeline_ablation.json')} ({out['wall_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

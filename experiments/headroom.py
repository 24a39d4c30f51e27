"""Headroom: how much lower could any scorer's pick go than the baselines' on the full induced peak wrist
torque? The pick of a perfect predictor of one measured rollout, re-measured on fresh draws.

    python experiments/headroom.py --data data/val --out results/headroom     # 7 tools per task
    python experiments/headroom.py --quick --out results/headroom_quick                        # tiny dataset (tests)

Per tool of --data (a labelled dataset: every reachable candidate rolled out once in randomised MuJoCo):
  oracle   the candidate with the lowest measured full induced peak torque among those that did the task
           and held, in the dataset's own rollout: what a scorer that predicted that rollout exactly
           would pick;
  methods  the shipped SDG-Net (its default weights), force closure, geometric ranking (and --methods).
Every pick is then rolled out --draws times more (fresh physics draws, the same for every pick at 100 N
per pad, `stress.rollouts_at_grip`), so the oracle's own selection noise (the lowest of many noisy
values) does not flatter it: its re-measured torque is what perfect single-rollout knowledge buys.
Per task: each pick's paired ratio against force closure, geometric ranking and the per-tool better of
the two (geometric mean over tools, 90 % bootstrap interval, `stats.paired_ratio`), its task success
and grip failure in the fresh draws. If the oracle's reduction against a baseline is below a target
(the paper's 17.6 % on the hammer), no scorer of these candidates meets it. Writes headroom.json.
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
from itup_jax.dataset_load import load_dataset, read_manifest
from itup_jax.evaluate import split_methods
from itup_jax.heldout import dataset_grasps, oracle_index, quick_dataset, unit_rows, unseen_units
from itup_jax.sim.scene import build_scene
from itup_jax.stats import paired_ratio

BASELINES = ("force_closure", "geometric")
DEFAULT_METHODS = ("sdgnet",) + BASELINES
LEVEL = 0.90
GRIP = 100.0  # N per pad, the re-measurement's grip (the gripper's default)
DRAW_SEED = 1000  # fresh draws: seed DRAW_SEED + tool variant (the dataset's rollouts used others)


def tool_row(data: dict, config: GenerateConfig, task: str, variant: int, methods, draws: int) -> dict | None:
    """One tool: every pick (oracle and methods), its dataset rollout and its re-measured draws."""
    rows = unit_rows(data, task, variant)
    ok = np.asarray(data["label_success"])[rows].astype(bool) & ~np.asarray(data["label_failed"])[rows].astype(bool)
    if len(rows) < 2 or not ok.any():
        return None
    tool, tk = unit_tool(config, task, variant)
    g = dataset_grasps(data, rows)
    tau = np.asarray(data["label_peak_torque_induced"], float)[rows]
    picks = {"oracle": oracle_index(tau, ok)}
    for m in methods:
        picks[m] = int(np.argmin(np.asarray(itup.score(tool, tk, g, m, seed=variant).total, float)))
    unique = sorted(set(picks.values()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # a stretched tool may exceed the speed limit: flagged
        L = stress.rollouts_at_grip(tool, tk, g[np.array(unique)], GRIP, draws=draws, seed=DRAW_SEED + variant,
                                    scene=build_scene(tool, tk))
    valid = np.asarray(L.valid).reshape(len(unique), draws)

    def mean(x, k):
        v = np.asarray(x, float).reshape(len(unique), draws)[k][valid[k]]
        return float(v.mean()) if len(v) else None

    out = {"task": task, "variant": int(variant), "tool": tool.name, "candidates": int(len(rows)),
           "held_and_did_task": int(ok.sum()), "picks": {}}
    for name, i in picks.items():
        k = unique.index(i)
        out["picks"][name] = {"index": i, "dataset_torque": float(tau[i]), "dataset_ok": bool(ok[i]),
                              "torque": mean(L.peak_torque_induced, k), "success": mean(L.success, k),
                              "failed": mean(L.failed, k)}
    return out


def measure(path: str, methods, draws: int) -> list:
    """`tool_row` of every unseen tool (variant >= 1) of the dataset at `path`, printed as it goes."""
    data = load_dataset(path)
    config = GenerateConfig.from_json(read_manifest(path)["config"])
    per_tool = []
    for t, v in unseen_units(data):
        row = tool_row(data, config, t, v, methods, draws)
        if row is not None:
            per_tool.append(row)
            print(f"{t:7s} {row['tool']:18s} " + "  ".join(
                f"{n} {p['torque']:.2f}" if p["torque"] is not None else f"{n} -" for n, p in row["picks"].items()),
                  flush=True)
    return per_tool


def summarise(per_tool: list, names) -> dict:
    """Per task and pick: paired ratios of the re-measured torque against each baseline and the better."""
    out = {}
    for task in sorted({t["task"] for t in per_tool}):
        tt = [t for t in per_tool if t["task"] == task]
        base = {b: np.array([np.nan if t["picks"][b]["torque"] is None else t["picks"][b]["torque"] for t in tt])
                for b in BASELINES}
        base["better_baseline"] = np.fmin(*[base[b] for b in BASELINES])
        out[task] = {}
        for name in names:
            a = np.array([np.nan if t["picks"][name]["torque"] is None else t["picks"][name]["torque"] for t in tt])
            out[task][name] = {
                "tools": len(tt),
                "success": float(np.mean([t["picks"][name]["success"] or 0.0 for t in tt])),
                "failed": float(np.mean([t["picks"][name]["failed"] or 0.0 for t in tt])),
                **{f"vs_{b}": paired_ratio(a, v, level=LEVEL) for b, v in base.items()}}
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="a labelled dataset of unseen tools (variants >= 1 are used)")
    ap.add_argument("--methods", default=",".join(DEFAULT_METHODS),
                    help="scorers of itup.score to compare (the baselines are always added)")
    ap.add_argument("--draws", type=int, default=3, help="fresh rollouts per pick")
    ap.add_argument("--out", required=True, help="output folder (headroom.json)")
    ap.add_argument("--quick", action="store_true", help="a tiny dataset made here (tests)")
    a = ap.parse_args(argv)
    methods = tuple(dict.fromkeys(list(split_methods(a.methods)) + list(BASELINES)))
    if a.draws < 1:
        ap.error(f"--draws must be >= 1, got {a.draws}")
    if os.path.exists(a.out) and not os.path.isdir(a.out):
        ap.error(f"--out {a.out!r} is a file, not a folder")
    if not a.data and not a.quick:
        ap.error("--data (or --quick) is required")
    t0 = time.time()
    if a.quick:
        with quick_dataset("headroom_quick_") as tmp:
            per_tool = measure(tmp, methods, 1)
    else:
        per_tool = measure(a.data, methods, a.draws)
    names = ("oracle",) + methods
    summary = summarise(per_tool, names)
    print(f"\nre-measured full induced peak torque, geometric mean ratio over tools ({int(LEVEL * 100)} % interval)")
    for task, by in summary.items():
        for name in names:
            s = by[name]
            f = lambda r: "-" if r["ratio"] is None else (f"{r['ratio']:.3f}" + (  # noqa: E731
                f" [{r['ci'][0]:.2f}, {r['ci'][1]:.2f}]" if r["ci"] else ""))
            print(f"{task:7s} {name:14s} vs FC {f(s['vs_force_closure']):22s} vs geometric {f(s['vs_geometric']):22s} "
                  f"vs better {f(s['vs_better_baseline']):22s} success {s['success']:.2f} failed {s['failed']:.2f}")
    out = {"schema": "itup.headroom/1", "data": None if a.quick else os.path.abspath(a.data), "methods": list(methods),
           "draws": 1 if a.quick else a.draws, "grip_N": GRIP, "level": LEVEL, "per_tool": per_tool, "summary": summary,
           "seconds": round(time.time() - t0, 1), "version": itup.__version__}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "headroom.json"), out)
    print(f"wrote {os.path.join(a.out, 'headroom.json')} ({out['seconds']} s)")
    return out


if __name__ == "__main__":
    main()

"""Torque and failure in MuJoCo: does a higher peak wrist torque make a grasp fail (slip > 1 cm, turn
> 10 deg, or tool lost), at what torque does failure become as likely as not (the paper reports
~6.9 N m), and does lowering the torque of the pick lower its failure rate?

    python experiments/torque_failure.py --out results/torque_failure                 # generates its data
    python experiments/torque_failure.py --data data/train_a --table1 results/table1/table1.json \\
        --out results/torque_failure                                                  # reuse earlier runs
    python experiments/torque_failure.py --quick --out results/tf_quick                        # tests

Three results, from every valid rollout of a dataset (random antipodal grasps, randomised physics;
`itup generate`, made here in OUT/data unless --data names one):
  1. the torque-slip phase diagram: each rollout a point (peak raw wrist torque, max slip), failures marked;
  2. failure probability against peak torque: equal-count bins with Wilson intervals and a logistic
     fit whose 50 % point (with a bootstrap 95 % interval) is the empirical threshold, pooled and per task,
     for the raw and the induced (static holding torque removed) torque;
  3. per task, SDG-Net's torque suppression against each baseline beside its failure-rate reduction,
     from a Table I run (`--table1 table1.json`, or a smaller one run here).
Writes torque_failure.json and torque_failure.png into --out.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import GenerateConfig, generate
from itup_jax.dataset_load import MANIFEST, load_dataset
from itup_jax.evaluate import compare_on_tools, reduction
from itup_jax.stats import binned_rate, failure_threshold
from itup_jax.task import TASK_KINDS

PAPER_TAU50 = 6.9  # N m, the paper's empirical 50 % failure torque (arXiv:2505.01399v3)
TORQUES = ("peak_torque", "peak_torque_induced")


def thresholds(d: dict, *, bootstrap: int) -> dict:
    """Logistic 50 % torque per torque label, pooled ('all') and per task."""
    out = {}
    for lab in TORQUES:
        out[lab] = {}
        for task in ["all"] + sorted(set(d["task"])):
            m = np.ones(len(d["task"]), bool) if task == "all" else d["task"] == task
            out[lab][task] = failure_threshold(d[f"label_{lab}"][m], d["label_failed"][m], bootstrap=bootstrap)
    return out


#: The torques whose reduction `suppression` reports: the headline (the full induced peak torque) first.
SUPPRESSION_TORQUES = {"torque": "peak_torque_induced", "projected_torque": "peak_torque_projected",
                       "raw_torque": "peak_torque"}


def suppression(table1: dict) -> list[dict]:
    """Per task and baseline: SDG-Net's torque reduction (%: the full induced peak torque, the headline,
    with the raw peak and the projected part beside it) and failure-rate reduction (%, None where the
    baseline never failed)."""
    rows = []
    for task, cells in table1["table"].items():
        if "sdgnet" not in cells:
            continue
        ours = cells["sdgnet"]
        for m, c in cells.items():
            if m == "sdgnet" or not isinstance(c, dict) or "failed" not in c:
                continue
            fo, fb = ours["failed"]["mean"], c["failed"]["mean"]
            rows.append({
                "task": task, "baseline": m,
                **{f"{name}_reduction_pct": reduction(ours[label]["mean"] or np.nan, c[label]["mean"] or np.nan)
                   for name, label in SUPPRESSION_TORQUES.items()},
                "failure_sdgnet": fo, "failure_baseline": fb,
                "failure_reduction_pct": None if not fb or fo is None else 100.0 * (1.0 - fo / fb),
            })
    return rows


def _table1(path: str | None, quick: bool, tasks) -> dict:
    if path is not None:
        with open(path) as fh:
            return json.load(fh)
    if quick:
        return compare_on_tools(["hammer"], 1, 16, 1, ("sdgnet", "force_closure"), log=lambda *_: None)
    return compare_on_tools(tasks, 1, 128, 3, ("sdgnet", "force_closure", "geometric", "random"))


def plot(d: dict, thr: dict, sup: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from itup_jax.plotting import save_figure

    fig, ax = plt.subplots(1, 3, figsize=(16, 4.6))
    tasks = sorted(set(d["task"]))
    tau, slip, failed = d["label_peak_torque"], 1e3 * np.maximum(d["label_slip_translation"], 1e-5), d["label_failed"]
    for k, t in enumerate(tasks):
        m = d["task"] == t
        ax[0].scatter(tau[m & ~failed], slip[m & ~failed], s=5, color=f"C{k}", alpha=0.5, label=f"{t}")
        ax[0].scatter(tau[m & failed], slip[m & failed], s=14, color=f"C{k}", marker="x", lw=0.8)
    ax[0].axhline(10, color="k", lw=0.7, ls=":", label="slip threshold 1 cm")
    ax[0].set_yscale("log")
    ax[0].set_xlabel("peak wrist torque (N m)")
    ax[0].set_ylabel("max slip in the gripper (mm)")
    ax[0].set_title("torque-slip phase diagram (x: failed)")
    ax[0].legend(fontsize=7, markerscale=2)

    b = binned_rate(tau, failed, bins=12)
    ax[1].errorbar(b["x_mid"], b["rate"], yerr=[np.subtract(b["rate"], b["lo"]), np.subtract(b["hi"], b["rate"])],
                   fmt="o", color="k", ms=4, capsize=2, label="all tasks, binned (Wilson 95%)")
    xs = np.linspace(0, np.nanpercentile(tau, 99.5), 200)
    for k, t in enumerate(["all"] + tasks):
        f = thr["peak_torque"][t]
        if f["a"] is None:
            continue
        ax[1].plot(xs, 1 / (1 + np.exp(-(f["a"] + f["slope"] * xs))), color="k" if t == "all" else f"C{k - 1}",
                   lw=2 if t == "all" else 1, label=f"{t}: tau50 " + ("n/a" if f["tau50"] is None else f"{f['tau50']:.1f} N m"))
    if thr["peak_torque"]["all"]["tau50"] is not None:
        ax[1].axvline(thr["peak_torque"]["all"]["tau50"], color="k", lw=0.8)
    ax[1].axvline(PAPER_TAU50, color="r", ls="--", lw=1, label=f"paper ~{PAPER_TAU50} N m")
    ax[1].axhline(0.5, color="0.6", lw=0.5)
    ax[1].set_xlabel("peak wrist torque (N m)")
    ax[1].set_ylabel("P(failure)")
    ax[1].set_title("failure probability vs peak torque (logistic fits)")
    ax[1].legend(fontsize=7)

    # colour: the task (as in the other panels); marker: the baseline. Many points share a failure
    # reduction of 100 %, so a legend names them instead of labels that would overlap.
    shown = [r for r in sup if r["failure_reduction_pct"] is not None and np.isfinite(r["torque_reduction_pct"])]
    baselines = sorted({r["baseline"] for r in shown})
    markers = dict(zip(baselines, "osD^vP*X"))
    for r in shown:
        k = tasks.index(r["task"]) if r["task"] in tasks else 0
        ax[2].scatter(r["torque_reduction_pct"], r["failure_reduction_pct"], color=f"C{k}",
                      marker=markers.get(r["baseline"], "o"), s=30, alpha=0.8)
    handles = [plt.Line2D([], [], ls="", marker="o", color=f"C{k}", label=t) for k, t in enumerate(tasks)]
    handles += [plt.Line2D([], [], ls="", marker=markers[b], color="0.3", label=f"vs {b}") for b in baselines]
    ax[2].legend(handles=handles, fontsize=7, loc="lower left")
    ax[2].axhline(0, color="0.5", lw=0.6)
    ax[2].axvline(0, color="0.5", lw=0.6)
    ax[2].set_xlabel("SDG-Net torque suppression vs baseline (%)")
    ax[2].set_ylabel("failure-rate reduction (%)")
    ax[2].set_title("per task: suppression vs failure reduction")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=None, help="an `itup generate` folder (default: generate one in OUT/data)")
    ap.add_argument("--table1", default=None, help="a table1.json (default: a smaller Table I run here)")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--tools-per-task", type=int, default=3)
    ap.add_argument("--grasps", type=int, default=128)
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--bootstrap", type=int, default=200)
    ap.add_argument("--quick", action="store_true", help="hammer, 2 tools, 24 grasps, tiny Table I (tests)")
    ap.add_argument("--out", default="results/torque_failure")
    a = ap.parse_args(argv)
    tasks = tuple(t for t in a.tasks.split(",") if t)
    if a.quick:
        tasks, a.tools_per_task, a.grasps, a.bootstrap = ("hammer",), 2, 24, 20
    os.makedirs(a.out, exist_ok=True)
    t0 = time.perf_counter()
    if a.data is None:
        a.data = os.path.join(a.out, "data")
        generate(a.data, GenerateConfig(tasks=tasks, tools_per_task=a.tools_per_task, grasps=a.grasps, seed=a.seed),
                 progress=not a.quick)
    elif not os.path.exists(os.path.join(a.data, MANIFEST)):
        print(f"torque_failure: --data {a.data!r} holds no dataset manifest", file=sys.stderr)
        raise SystemExit(2)
    if a.table1 is not None and not os.path.isfile(a.table1):
        print(f"torque_failure: --table1 {a.table1!r} is not a file", file=sys.stderr)
        raise SystemExit(2)
    d = load_dataset(a.data)
    thr = thresholds(d, bootstrap=a.bootstrap)
    sup = suppression(_table1(a.table1, a.quick, list(tasks)))
    per_task = {t: {"rollouts": int((d["task"] == t).sum()), "failure_rate": float(d["label_failed"][d["task"] == t].mean()),
                    "median_peak_torque": float(np.median(d["label_peak_torque"][d["task"] == t]))}
                for t in sorted(set(d["task"]))}
    from itup_jax.bench import machine_info

    out = {"schema": "itup.torque_failure/2", "experiment": "torque_failure", "quick": a.quick, "data": a.data, "table1": a.table1 or "run here",
           "paper_tau50_Nm": PAPER_TAU50, "rollouts": int(len(d["task"])), "per_task": per_task, "thresholds": thr,
           "binned_all": binned_rate(d["label_peak_torque"], d["label_failed"], bins=12), "suppression": sup,
           "wall_s": round(time.perf_counter() - t0, 1), "machine": machine_info()}
    atomic_write_json(os.path.join(a.out, "torque_failure.json"), out, indent=1)
    plot(d, thr, sup, os.path.join(a.out, "torque_failure.png"))
    print(f"{out['rollouts']} valid rollouts")
    for lab in TORQUES:
        for t, f in thr[lab].items():
            s = "n/a (" + f["note"] + ")" if f["tau50"] is None else (
                f"{f['tau50']:.2f} N m" + (f" [95% {f['ci95'][0]:.2f}, {f['ci95'][1]:.2f}]" if f["ci95"] else ""))
            print(f"  tau50 {lab:20s} {t:7s} {s}   ({f['failures']}/{f['n']} failed)")
    print(f"  paper: ~{PAPER_TAU50} N m")
    for r in sup:
        fr = "n/a (baseline never failed)" if r["failure_reduction_pct"] is None else f"{r['failure_reduction_pct']:+.0f}%"
        print(f"  {r['task']:7s} SDG-Net vs {r['baseline']:14s} torque {r['torque_reduction_pct']:+5.0f}%  failures {fr}")
    print(f"wrote {a.out}/torque_failure.json, torque_failure.png ({out['wall_s']} s)")
    return out


if __name__ == "__main__":
    main()

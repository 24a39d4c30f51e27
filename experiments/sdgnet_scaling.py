"""Is data what limits SDG-Net? Held-out fidelity against the number of training tools per task.

    python experiments/sdgnet_scaling.py --train data/train_a data/train_b data/train_c data/train_d \\
        --test data/val --tools 6,12,24,all --seeds 3 --ensemble --out results/scaling_val
    python experiments/sdgnet_scaling.py --quick --out results/scaling_quick     # tiny datasets made here (tests)

For each size k (tools per task) and seed, SDG-Net is trained with the shipped checkpoint's recipe
(`--hidden`, `--weight-decay`, `--torque-scale`, `--epochs` override it) on the first k tools of every
task (tool ids in dataset order: the first dataset's built-in tool and variants first), and scored on
the held-out tools of --test as `sdgnet_fidelity.py` does: Spearman between the predicted torque and
the measured full induced peak wrist torque (the paper's measure, no projection; the headline), per
tool (median over tools, and per task) and pooled over every candidate of the held-out tools
(`rho_pooled`, which also counts how the tools differ); the raw peak and the projected part beside
it. With `--ensemble` the seeds of a size are also averaged into one model (`sdgnet.model.ensemble`) and
scored the same way: what ensembling buys at that size. A straight line of the median rho (mean over
seeds) against log2(k) gives the gain per doubling of the data and, where it rises, the size at which
the line would reach a Spearman of 0.9; `fit_pooled` the same for the pooled rho. That is an
extrapolation, and the curve bends: the script also fits the three largest sizes alone (the local
rate) and names any measured size past the line's crossing that is still below the goal; what bounds
any prior-blind scorer is the labels' noise (`sdgnet_fidelity.py --redraws`: about the square root of
the retest correlation). With `--tools all --epochs E` it measures fidelity against training time
instead. Writes scaling.json (`itup.scaling/2`) and scaling.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from collections.abc import Sequence

import numpy as np

from itup_jax import fidelity as fid
from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import GenerateConfig, generate
from itup_jax.dataset_load import load_datasets
from itup_jax.heldout import HEADLINE
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sdgnet.model import ensemble
from itup_jax.sdgnet.training import train


def first_tools(data: dict, k: int | None) -> np.ndarray:
    """[N] bool: the rows of the first k tools (by tool id) of every task; None: all rows."""
    keep = np.zeros(len(data["task"]), bool)
    for task in np.unique(data["task"]):
        rows = data["task"] == task
        ids = np.unique(data["tool_id"][rows])
        keep |= rows & np.isin(data["tool_id"], ids if k is None else ids[:k])
    return keep


def tools_by_task(data: dict) -> dict[str, int]:
    """{task: its number of distinct tools} in `data`."""
    return {str(t): int(len(np.unique(data["tool_id"][data["task"] == t]))) for t in np.unique(data["task"])}


def parse_sizes(tools: str, counts: Sequence[int]) -> list[tuple[int, bool]]:
    """--tools "8,16,all" -> sorted, distinct [(k, every)]: the first k tools of every task, `counts` the
    tasks' tool counts. 'all' is every tool of every task, k then the fewest (the tasks may have
    different counts); `every` says whether a size keeps every tool, so a k that already does and 'all'
    are one size, trained once. ValueError names a size that is not 1..min(counts) or 'all'."""
    available = min(counts)
    sizes = set()
    for s in tools.split(","):
        all_ = s.strip() == "all"
        try:
            k = available if all_ else int(s)
        except ValueError:
            k = 0
        if not 1 <= k <= available:
            raise ValueError(f"--tools {s!r}: need 1..{available} (tools per task in --train) or 'all'")
        sizes.add((k, all_ or k >= max(counts)))
    return sorted(sizes)


def fidelity(model, test_dir: str) -> dict:
    """The model's ranking of the held-out tools of `test_dir` (`fidelity.fidelity`): median over
    tools of the per-tool Spearman against the measured full induced peak torque (`median_rho`, the
    headline), the raw peak and the projected part beside it, the mean per task, and the rho pooled over
    every candidate of the held-out tools (`rho_pooled`, and per task `pooled_by_task`)."""
    ev = fid.fidelity(model, test_dir)
    rows = [r for r in ev["rows"] if r["held_out"]]
    rho = {m: np.array([r[f"rho_sdgnet_{m}"] for r in rows], float) for m in ("induced", "raw", "projected")}
    pooled = ev["rho_pooled_held_out"]
    return {"median_rho": float(np.nanmedian(rho["induced"])), "median_rho_raw": float(np.nanmedian(rho["raw"])),
            "median_rho_projected": float(np.nanmedian(rho["projected"])),
            "by_task": {t: float(np.nanmean([r["rho_sdgnet_induced"] for r in rows if r["task"] == t]))
                        for t in sorted({r["task"] for r in rows})},
            "rho_pooled": float(pooled["all"]), "pooled_by_task": {t: float(v) for t, v in pooled.items() if t != "all"}}


def describe(f: dict) -> str:
    """One line of `fidelity`'s figures."""
    return (f"held-out Spearman median {f['median_rho']:.3f} (raw {f['median_rho_raw']:.3f}, projected "
            f"{f['median_rho_projected']:.3f}), pooled {f['rho_pooled']:.3f}  "
            + " ".join(f"{t} {v:.2f}" for t, v in f["by_task"].items()))


def fit_log2(k: np.ndarray, rho: np.ndarray, goal: float) -> dict:
    """rho ~ a + b log2(k) by least squares over the finite rho; `tools_per_task_at_goal`: where the line
    reaches `goal` (None if it does not rise; all None with fewer than two sizes)."""
    x, rho = np.log2(np.asarray(k, float)), np.asarray(rho, float)
    ok = np.isfinite(rho)  # a size whose held-out tools gave no rank correlation does not count
    x, rho = x[ok], rho[ok]
    if len(x) < 2 or np.ptp(x) == 0:
        return {"intercept": None, "per_doubling": None, "tools_per_task_at_goal": None}
    b, a = np.polyfit(x, rho, 1)
    at = float(np.exp2(min((goal - a) / b, 1000.0))) if b > 0 else None  # capped: no inf in strict JSON
    return {"intercept": float(a), "per_doubling": float(b), "tools_per_task_at_goal": at}


def measured_past_goal(k, rho, at: float | None, goal: float) -> list[int]:
    """The measured sizes at or beyond the line's crossing `at` whose median rho is still below `goal`:
    where the straight line is contradicted by a measurement (empty if none, or no crossing)."""
    if at is None:
        return []
    return [int(ki) for ki, r in zip(k, rho) if ki >= at and np.isfinite(r) and r < goal]


def plot(out: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from itup_jax.plotting import save_figure

    sizes = out["sizes"]
    k = [s["tools_per_task"] for s in sizes]
    fig, ax = plt.subplots(figsize=(6, 4))
    for t in out["tasks"]:
        ax.plot(k, [s["by_task"][t]["mean"] for s in sizes], "o-", lw=1, ms=3, label=t)
    med = [s["median_rho"]["mean"] for s in sizes]
    err = [s["median_rho"]["std"] for s in sizes]
    ax.errorbar(k, med, yerr=err, fmt="ks-", lw=2, ms=5, capsize=3, label="median over tools")
    ax.plot(k, [s["rho_pooled"]["mean"] for s in sizes], "kD--", lw=1.5, ms=4, label="pooled over tools")
    ens = [(ki, s["ensemble"]["rho_pooled"]) for ki, s in zip(k, sizes) if "ensemble" in s]
    if ens:
        ax.plot(*zip(*ens), "r^", ms=6, label="ensemble of the seeds, pooled")
    f = out["fit"]
    if f["per_doubling"] is not None:
        xs = np.geomspace(min(k), max(k), 50)
        ax.plot(xs, f["intercept"] + f["per_doubling"] * np.log2(xs), "k:", lw=1, label="log2 fit")
    ax.axhline(fid.GOALS["spearman"], color="r", ls="--", lw=0.8, label="goal")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("training tools per task")
    ax.set_ylabel("held-out Spearman (full induced peak torque)")
    ax.set_title("SDG-Net fidelity against training data")
    ax.legend(fontsize=7)
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", nargs="+", metavar="DIR", help="training dataset folder(s), trained on as one")
    ap.add_argument("--test", help="test dataset folder (its procedural variants are the held-out tools)")
    ap.add_argument("--tools", default="8,16,32,all", help="comma-separated tools per task; 'all' for every tool")
    ap.add_argument("--seeds", type=int, default=3, help="training seeds per size (split and initialisation)")
    ap.add_argument("--hidden", default=None, help="hidden widths, e.g. 128,128,128 (default: the shipped recipe)")
    ap.add_argument("--weight-decay", type=float, default=None, help="default: the shipped recipe")
    ap.add_argument("--torque-scale", type=float, default=None, help="N m, log1p(tau / scale) target (default: the shipped recipe)")
    ap.add_argument("--epochs", type=int, default=None, help="training epochs (default: the shipped recipe); with "
                    "--tools all, fidelity against training time")
    ap.add_argument("--ensemble", action="store_true", help="also score the average of each size's seeds (sdgnet.ensemble)")
    ap.add_argument("--quick", action="store_true", help="tiny datasets made in --out (for the tests)")
    ap.add_argument("--out", default="results/scaling")
    args = ap.parse_args(argv)
    base = load_model().train_config
    if args.quick:
        os.makedirs(args.out, exist_ok=True)
        args.train = [os.path.join(args.out, "train")]
        args.test = os.path.join(args.out, "test")
        generate(args.train[0], GenerateConfig(tasks=("reach",), tools_per_task=4, grasps=24, seed=0), progress=False)
        generate(args.test, GenerateConfig(tasks=("reach",), tools_per_task=2, grasps=24, seed=1), progress=False)
        args.tools, args.seeds, args.ensemble = "2,all", 2, True
        base = dataclasses.replace(base, hidden=(16,), epochs=30, patience=10)
    try:
        hidden = tuple(int(h) for h in args.hidden.split(",") if h.strip()) if args.hidden else None
        overrides = dict(hidden=hidden, weight_decay=args.weight_decay, torque_scale=args.torque_scale, epochs=args.epochs)
        base = dataclasses.replace(base, **{k: v for k, v in overrides.items() if v is not None})
    except ValueError as exc:  # InputError is a ValueError; so is a width that is not a number
        print(f"sdgnet_scaling: bad training recipe: {exc}", file=sys.stderr)
        raise SystemExit(2)
    if not args.train or not args.test:
        print("sdgnet_scaling: --train DIR [DIR ...] and --test DIR are required (or --quick)", file=sys.stderr)
        raise SystemExit(2)
    if args.seeds < 1:
        print(f"sdgnet_scaling: --seeds must be >= 1, got {args.seeds}", file=sys.stderr)
        raise SystemExit(2)
    data, manifests = load_datasets(args.train)
    try:
        sizes = parse_sizes(args.tools, list(tools_by_task(data).values()))
    except ValueError as exc:
        print(f"sdgnet_scaling: {exc}", file=sys.stderr)
        raise SystemExit(2)
    feature_spec = manifests[0]["config"]["feature_spec"]
    results = []
    for k, every in sizes:
        keep = first_tools(data, None if every else k)  # 'all' keeps a task's tools beyond the fewest too
        sub = {key: v[keep] for key, v in data.items()}
        runs, models = [], []
        label = "all" if every else str(k)
        for seed in range(args.seeds):
            t0 = time.perf_counter()
            model = train(sub, dataclasses.replace(base, seed=seed), feature_spec=feature_spec, progress=False,
                          log=lambda *_: None)
            wall = time.perf_counter() - t0
            models.append(model)
            runs.append({"seed": seed, "train_wall_s": wall, "best_val_loss": model.spec["best_val_loss"],
                         **fidelity(model, args.test)})
            print(f"{label:>4} tools/task seed {seed}: {int(keep.sum())} rows, {wall:.1f} s, val loss "
                  f"{model.spec['best_val_loss']:.3f}, " + describe(runs[-1]), flush=True)
        tasks = list(runs[0]["by_task"])
        size = {"tools_per_task": k, "all_tools": every, "rows": int(keep.sum()), "runs": runs,
                "tools_by_task": tools_by_task(sub), "train_wall_s": {"mean": float(np.mean([r["train_wall_s"] for r in runs]))},
                "by_task": {t: {"mean": float(np.mean([r["by_task"][t] for r in runs]))} for t in tasks}}
        for key in ("median_rho", "median_rho_raw", "median_rho_projected", "rho_pooled"):
            v = np.array([r[key] for r in runs], float)
            size[key] = {"mean": float(v.mean()), "std": float(v.std()), "min": float(v.min()), "max": float(v.max())}
        if args.ensemble and len(models) >= 2:
            size["ensemble"] = {"members": len(models), **fidelity(ensemble(models), args.test)}
            print(f"{label:>4} tools/task ensemble of {len(models)}: " + describe(size["ensemble"]), flush=True)
        results.append(size)
    fit = fit_log2([r["tools_per_task"] for r in results], [r["median_rho"]["mean"] for r in results],
                   fid.GOALS["spearman"])
    grasps = manifests[0]["config"]["grasps"]
    n_tasks = len(results[0]["by_task"])
    if fit["tools_per_task_at_goal"] is not None:
        fit["rollouts_at_goal"] = fit["tools_per_task_at_goal"] * grasps * n_tasks
    # the curve bends: the line through every size can cross the goal where a size already measured
    # is below it; the line through the three largest sizes is the local rate
    ks, meds = [r["tools_per_task"] for r in results], [r["median_rho"]["mean"] for r in results]
    fit["contradicted_by"] = measured_past_goal(ks, meds, fit["tools_per_task_at_goal"], fid.GOALS["spearman"])
    pooled = [r["rho_pooled"]["mean"] for r in results]
    fit_pooled = fit_log2(ks, pooled, fid.GOALS["spearman"])
    fit_pooled["contradicted_by"] = measured_past_goal(ks, pooled, fit_pooled["tools_per_task_at_goal"], fid.GOALS["spearman"])
    if fit_pooled["tools_per_task_at_goal"] is not None:
        fit_pooled["rollouts_at_goal"] = fit_pooled["tools_per_task_at_goal"] * grasps * n_tasks
    if len(results) >= 3:
        fit["tail"] = fit_log2(ks[-3:], meds[-3:], fid.GOALS["spearman"])
        fit["tail"]["sizes"] = ks[-3:]
        if fit["tail"]["tools_per_task_at_goal"] is not None:
            fit["tail"]["rollouts_at_goal"] = fit["tail"]["tools_per_task_at_goal"] * grasps * n_tasks
    from itup_jax.bench import machine_info

    out = {"schema": "itup.scaling/2", "experiment": "sdgnet_scaling", "quick": args.quick,
           "train": [os.path.abspath(d) for d in args.train], "test": os.path.abspath(args.test),
           "train_config": {**dataclasses.asdict(base), "hidden": list(base.hidden)},
           "tasks": list(results[0]["by_task"]), "goals": fid.GOALS, "measured": HEADLINE, "sizes": results, "fit": fit, "fit_pooled": fit_pooled,
           "machine": machine_info()}
    os.makedirs(args.out, exist_ok=True)
    atomic_write_json(os.path.join(args.out, "scaling.json"), out, indent=2)
    plot(out, os.path.join(args.out, "scaling.png"))
    if fit["per_doubling"] is None:
        print("fit: one size was measured, no line" if len(results) == 1 else
              "fit: fewer than two sizes gave a held-out rank correlation; no line")
    else:
        at = fit["tools_per_task_at_goal"]
        print(f"fit: median rho = {fit['intercept']:.3f} + {fit['per_doubling']:.3f} log2(tools per task)"
              + (f"; the line reaches {fid.GOALS['spearman']} at ~{at:.0f} tools per task (~{fit['rollouts_at_goal']:.0f}"
                 " rollouts; an extrapolation)" if at is not None else "; it does not rise"))
        if fit["contradicted_by"]:
            print(f"  contradicted: measured below {fid.GOALS['spearman']} at {fit['contradicted_by']} tools per task, past that crossing")
        tail = fit.get("tail")
        if tail and tail["per_doubling"] is not None:
            at = tail["tools_per_task_at_goal"]
            print(f"  the three largest sizes {tail['sizes']}: {tail['per_doubling']:+.3f} per doubling"
                  + (f"; at that rate {fid.GOALS['spearman']} at ~{at:.0f} tools per task (~{tail['rollouts_at_goal']:.0f} rollouts)"
                     if at is not None else "; not rising"))
        if fit_pooled["per_doubling"] is not None:
            at = fit_pooled["tools_per_task_at_goal"]
            print(f"  pooled rho = {fit_pooled['intercept']:.3f} + {fit_pooled['per_doubling']:.3f} log2(tools per task)"
                  + (f"; {fid.GOALS['spearman']} at ~{at:.0f} tools per task" if at is not None else "; it does not rise"))
    return out


if __name__ == "__main__":
    main()

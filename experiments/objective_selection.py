"""Which objective should SDG-Net learn and the planner minimise? Candidate objectives judged by their picks.

    python experiments/objective_selection.py --data data/val \
        --model paper=models/paper.npz --model wrench=models/wrench.npz --out results/objective_val
    python experiments/objective_selection.py --data data/test --model ... --only CHOSEN --out ...
    python experiments/objective_selection.py --quick --out results/objective_quick     # a tiny dataset made here (tests)

Per tool of --data (a labelled dataset of tools no model was trained on), every candidate that was
rolled out (the reachable ones, one randomised MuJoCo rollout each) is scored by every method, each
method picks its lowest total, and the pick's measured labels are read from the dataset. Methods:
force closure and geometric ranking (the baselines), the analytic cost in its paper and wrench forms
(`CostParams.paper()`, `.wrench()`), and each SDG-Net checkpoint given: a paper-objective one with the
shipped weights, a wrench-objective one under every weight setting of the grid (w_tau x w_grip, the
other weights the shipped ones).

Per task and method: paired ratios over tools (geometric mean of pick / baseline pick, 90 % bootstrap
interval) against force closure, against geometric ranking and against the better of the two per tool,
of the full induced peak wrist torque (the headline), the raw peak, the induced torque's closure-axis
component and the grip demand; the task success and grip failure rates of the picks. Per SDG-Net
checkpoint, its fidelity: the Spearman rho over each tool's candidates between its predicted tau and
the measured counterpart (the full induced peak for the wrench objective, the projected one for the
paper's) and between its predicted and measured grip demand, median per task and over every tool;
with a weak-grip head and a dataset of labels 0.11.0, that head's AUC against the grasps that failed in
the grip at 25 N per pad (`p_failed_weak_auc`; NaN on a tool where none or all did). Per tool, what
any scorer could pick (`corner`): the candidates that did the task and held, and of them those within
`CORNER` (0.824x the full induced torque, 0.75x the grip demand) of the better baseline pick's labels.

The selection rule, fixed before the test tools are opened: a setting qualifies when its picks do the
task in at least 95 % of the tools of every task and fail in the grip no more often than the worse
baseline's picks on any task. Its score is the mean over tasks of log(ratio of the full induced peak
torque against the better baseline) + log(ratio of the grip demand against the better baseline): the
two acceptance measures, weighed alike. The choice is the qualifying setting with the lowest score.
Choose on the validation set (seed 6); then run the test set (seed 1) with the choice fixed (--only).
Writes objective.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

import numpy as np

import itup_jax as itup
from itup_jax.atomic import atomic_write_json
from itup_jax.costs import CostParams
from itup_jax.dataset import GenerateConfig, unit_tool
from itup_jax.dataset_load import load_dataset, read_manifest
from itup_jax.heldout import dataset_grasps, quick_dataset, unit_rows, unseen_units
from itup_jax.scoring import ScoreWeights
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sdgnet.config import WEAK_TARGET
from itup_jax.sdgnet.objective import PAPER, WRENCH
from itup_jax.sdgnet.objective import get as get_objective
from itup_jax.sdgnet.training import head_labels
from itup_jax.stats import paired_ratio, roc_auc, spearman

MEASURES = ("peak_torque_induced", "peak_torque", "peak_induced_closure", "grip_demand")
BASELINES = ("force_closure", "geometric")
LEVEL = 0.90
MIN_SUCCESS = 0.95
PAD = 64
#: the wrench objective's weight grid: (w_tau 1/(N m), w_grip N m per N)
GRID = ((1.0, 0.0), (1.0, 0.005), (1.0, 0.01), (1.0, 0.02), (1.0, 0.05), (0.0, 0.01))
#: The acceptance's corner on the hammer: a pick whose full induced peak torque is at most 1 - 0.176 (the
#: paper's reduction) and whose grip demand is at most 0.75 of the better baseline's pick's (the least
#: holding grip's target, on the label the network learns). `corner` counts the candidates in it.
CORNER = {"peak_torque_induced": 0.824, "grip_demand": 0.75}


def settings_of(models: dict, base: dict | None = None) -> dict:
    """{method name: (scorer, ScoreWeights or CostParams)} for the models given and the fixed methods;
    `base`: ScoreWeights fields every network's setting holds (`--set`), else the shipped ones."""
    base = base or {}
    out = {b: (b, None) for b in BASELINES}
    out["analytic/paper"] = ("analytic", PAPER.analytic)
    out["analytic/wrench"] = ("analytic", WRENCH.analytic)
    for name, path in models.items():
        m = load_model(path)
        if m.objective == "paper":
            out[f"sdgnet/{name}"] = (m, ScoreWeights(**base))
        else:
            for w_tau, w_grip in GRID:
                out[f"sdgnet/{name}/tau{w_tau:g}_grip{w_grip:g}"] = (
                    m, ScoreWeights(**{**base, "w_tau": w_tau, "w_grip": w_grip}))
    return out


def tool_picks(data: dict, config: GenerateConfig, task: str, variant: int, methods: dict) -> dict | None:
    """Every method's pick among one tool's rolled-out candidates, with the pick's measured labels."""
    rows = unit_rows(data, task, variant)
    if len(rows) < 2:
        return None
    tool, tk = unit_tool(config, task, variant)
    # padded (with the first candidate) to a multiple of PAD rows, so that the scorers' jits compile once
    # per size, not once per tool; the padding is never picked (only the first len(rows) count)
    pad = np.concatenate([rows, np.full(-len(rows) % PAD, rows[0])])
    g = dataset_grasps(data, pad)
    out = {"task": task, "variant": int(variant), "candidates": int(len(rows)), "picks": {}, "fidelity": {}}
    for name, (scorer, w) in methods.items():
        if isinstance(w, CostParams):
            s = itup.score(tool, tk, g, scorer, cost_params=w)
        elif w is None:
            s = itup.score(tool, tk, g, scorer)
        else:
            s = itup.score(tool, tk, g, scorer, weights=w)
        i = int(np.argmin(np.asarray(s.total)[: len(rows)]))
        model = scorer.objective if hasattr(scorer, "objective") else None
        if model is not None and name.split("/")[1] not in out["fidelity"]:
            # fidelity: Spearman of the prediction against the measured counterpart over the tool's candidates
            tau_label = get_objective(model).measured_tau
            fid = {"tau_vs_" + tau_label: spearman(np.asarray(s.tau)[: len(rows)], data[f"label_{tau_label}"][rows])}
            if s.grip is not None:
                fid["grip_vs_grip_demand"] = spearman(np.asarray(s.grip)[: len(rows)], data["label_grip_demand"][rows])
            if s.p_failed_weak is not None and WEAK_TARGET in data:  # labels 0.11.0: the weak-grip head's AUC
                lab = head_labels(data, WEAK_TARGET)[rows]  # NaN where the weak rollout is not valid
                ok = np.isfinite(lab)
                fid["p_failed_weak_auc"] = roc_auc(np.asarray(s.p_failed_weak)[: len(rows)][ok], lab[ok] > 0.5)
            out["fidelity"][name.split("/")[1]] = fid
        r = rows[i]
        out["picks"][name] = {"row": int(r), **{m: float(data[f"label_{m}"][r]) for m in MEASURES},
                              "success": bool(data["label_success"][r]), "failed": bool(data["label_failed"][r])}
    if all(b in out["picks"] for b in BASELINES):
        out["corner"] = corner_counts(data, rows, out["picks"])
    return out


def corner_counts(data: dict, rows: np.ndarray, picks: dict) -> dict:
    """How many of one tool's candidates (`rows`) did the task and held in their rollout (`held`), and of
    those how many lie within `CORNER` of the better baseline pick's label, per measure and in both at
    once: what any scorer of these candidates could pick (one draw each)."""
    held = data["label_success"][rows].astype(bool) & ~data["label_failed"][rows].astype(bool)
    below = {m: held & (data[f"label_{m}"][rows] <= f * min(picks[b][m] for b in BASELINES)) for m, f in CORNER.items()}
    return {"held": int(held.sum()), **{m: int(v.sum()) for m, v in below.items()},
            "both": int(np.logical_and.reduce(list(below.values())).sum())}


def corner_summary(per_tool: list) -> dict:
    """Per task: the tools, how many have a candidate in the corner, and the per-tool counts."""
    out = {}
    for task in sorted({t["task"] for t in per_tool if "corner" in t}):
        c = [t["corner"] for t in per_tool if t["task"] == task and "corner" in t]
        out[task] = {"tools": len(c), "tools_with_both": sum(x["both"] > 0 for x in c),
                     **{k: [x[k] for x in c] for k in ("held", *CORNER, "both")}}
    return out


def summarise(per_tool: list, methods) -> dict:
    """Per task and method: paired ratios against each baseline and the better one, success and failure."""
    out = {}
    for task in sorted({t["task"] for t in per_tool}):
        tt = [t for t in per_tool if t["task"] == task]
        out[task] = {}
        for name in methods:
            e = {"tools": len(tt), "success": float(np.mean([t["picks"][name]["success"] for t in tt])),
                 "failed": float(np.mean([t["picks"][name]["failed"] for t in tt]))}
            for m in MEASURES:
                a = np.array([t["picks"][name][m] for t in tt])
                base = {b: np.array([t["picks"][b][m] for t in tt]) for b in BASELINES}
                base["better_baseline"] = np.minimum(*base.values())
                e[m] = {"median": float(np.median(a)),
                        **{f"vs_{b}": paired_ratio(a, v, level=LEVEL) for b, v in base.items()}}
            out[task][name] = e
    return out


def fidelity_summary(per_tool: list) -> dict:
    """{model: {measure: {task: median Spearman over its tools, "all": median over every tool}}}."""
    out = {}
    for t in per_tool:
        for model, fid in t["fidelity"].items():
            for k, v in fid.items():
                out.setdefault(model, {}).setdefault(k, {}).setdefault(t["task"], []).append(v)
    return {m: {k: {**{t: float(np.nanmedian(v)) for t, v in by.items()},
                    "all": float(np.nanmedian([x for v in by.values() for x in v]))} for k, by in d.items()}
            for m, d in out.items()}


def choose(summary: dict, candidates: list) -> tuple[str | None, dict]:
    """(the chosen setting or None, {setting: score or the reason it does not qualify}) by the docstring's rule."""
    verdict = {}
    for name in candidates:
        why = []
        score = 0.0
        for task, e in summary.items():
            worst_fail = max(e[b]["failed"] for b in BASELINES)
            if e[name]["success"] < MIN_SUCCESS:
                why.append(f"{task}: success {e[name]['success']:.2f} < {MIN_SUCCESS}")
            if e[name]["failed"] > worst_fail:
                why.append(f"{task}: grip failures {e[name]['failed']:.2f} > the baselines' {worst_fail:.2f}")
            for m in ("peak_torque_induced", "grip_demand"):
                r = e[name][m]["vs_better_baseline"]["ratio"]
                score += np.log(r) / len(summary) if r else np.inf
        verdict[name] = "; ".join(why) if why else float(score)
    ok = {k: v for k, v in verdict.items() if not isinstance(v, str)}
    return (min(ok, key=ok.get) if ok else None), verdict


def report(summary: dict, methods, log=print) -> None:
    log(f"{'task':7s} {'method':38s} {'succ':>5s} {'fail':>5s}  " + "  ".join(
        f"{m[:22]:>22s}" for m in MEASURES) + "   (ratio vs the better baseline per tool, 90 % CI)")
    for task, e in summary.items():
        for name in methods:
            cells = []
            for m in MEASURES:
                p = e[name][m]["vs_better_baseline"]
                ci = p["ci"] or [np.nan, np.nan]
                cells.append(f"{p['ratio'] or np.nan:6.2f} [{ci[0]:.2f},{ci[1]:.2f}]".rjust(22))
            log(f"{task:7s} {name:38s} {e[name]['success']:5.2f} {e[name]['failed']:5.2f}  " + "  ".join(cells))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", help="labelled dataset of unseen tools")
    ap.add_argument("--model", action="append", default=[], metavar="NAME=PATH",
                    help="an SDG-Net checkpoint to compare (repeatable)")
    ap.add_argument("--only", default=None, help="score only these methods (comma-separated; the baselines always)")
    ap.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                    help="a ScoreWeights field every network's setting holds (repeatable; e.g. w_align=300), "
                    "instead of the shipped value")
    ap.add_argument("--out", required=True, help="output folder (objective.json)")
    ap.add_argument("--quick", action="store_true", help="a tiny dataset made here, the shipped model (tests)")
    a = ap.parse_args(argv)
    models = {}
    for spec in a.model:
        if "=" not in spec:
            print(f"objective_selection: --model must be NAME=PATH, got {spec!r}", file=sys.stderr)
            raise SystemExit(2)
        k, v = spec.split("=", 1)
        models[k] = v
    a.base = {}
    fields = {f.name for f in dataclasses.fields(ScoreWeights)} - {"w_tau", "w_grip"}
    for spec in a.set:
        k, sep, v = spec.partition("=")
        try:
            if not sep or k not in fields:
                raise ValueError
            a.base[k] = float(v)
        except ValueError:
            print(f"objective_selection: --set must be NAME=NUMBER with NAME among {sorted(fields)}, got {spec!r}",
                  file=sys.stderr)
            raise SystemExit(2) from None
    if os.path.exists(a.out) and not os.path.isdir(a.out):
        print(f"objective_selection: --out {a.out!r} is a file, not a folder", file=sys.stderr)
        raise SystemExit(2)
    t0 = time.time()
    if not a.data and not a.quick:
        print("objective_selection: --data (or --quick) is required", file=sys.stderr)
        raise SystemExit(2)
    if a.quick:
        models = models or {"shipped": None}
        with quick_dataset() as tmp:
            return run(a, models, tmp, t0)
    return run(a, models, a.data, t0)


def run(a, models: dict, path: str, t0: float) -> dict:
    """Everything after the arguments: score, summarise, choose and write (the dataset at `path`)."""
    a.data = path
    data = load_dataset(a.data)
    config = GenerateConfig.from_json(read_manifest(a.data)["config"])
    methods = settings_of(models, a.base)
    if a.only:
        keep = set(a.only.split(",")) | set(BASELINES)
        methods = {k: v for k, v in methods.items() if k in keep}
    per_tool = [p for t, v in unseen_units(data) if (p := tool_picks(data, config, t, v, methods)) is not None]
    summary = summarise(per_tool, list(methods))
    report(summary, list(methods))
    candidates = [k for k in methods if k.startswith("sdgnet/") or k.startswith("analytic/")]
    chosen, verdict = choose(summary, candidates)
    fidelity = fidelity_summary(per_tool)
    for model, by in fidelity.items():
        for k, v in by.items():
            print(f"fidelity {model} {k}: median over tools {v['all']:.3f} (" + ", ".join(
                f"{t} {x:.2f}" for t, x in v.items() if t != "all") + ")")
    corner = corner_summary(per_tool)
    print("\ncandidates that did the task and held, and of them those within " + " and ".join(
        f"{f}x the better baseline pick's {m}" for m, f in CORNER.items()) + ", per tool:")
    for task, c in corner.items():
        print(f"  {task:7s} held {c['held']}  torque {c['peak_torque_induced']}  grip {c['grip_demand']}  both "
              f"{c['both']}: {c['tools_with_both']} of {c['tools']} tools have one")
    print(f"\nchosen by the rule: {chosen}")
    for k, v in verdict.items():
        print(f"  {k:38s} {v if isinstance(v, str) else f'score {v:+.3f}'}")
    out = {"schema": "itup.objective/1", "data": os.path.abspath(a.data), "models": models,
           "methods": list(methods), "level": LEVEL, "rule": {"min_success": MIN_SUCCESS, "measures":
           ["peak_torque_induced", "grip_demand"], "against": "better_baseline"},
           "set": a.base, "per_tool": per_tool, "summary": summary, "fidelity": fidelity,
           "verdict": verdict, "chosen": chosen, "corner": {"bounds": CORNER, "by_task": corner},
           "seconds": time.time() - t0, "version": itup.__version__}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "objective.json"), out)
    print(f"wrote {os.path.join(a.out, 'objective.json')} ({time.time() - t0:.0f} s)")
    return out


if __name__ == "__main__":
    main()

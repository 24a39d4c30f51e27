"""SDG-Net fidelity on held-out tools: does the predicted C_tau rank grasps as MuJoCo's measured
peak wrist torque does, and how much torque does SDG-Net's pick give away to the best candidate?

    python experiments/sdgnet_fidelity.py --train data/train_a --test data/test --out results/fidelity
    python experiments/sdgnet_fidelity.py --quick --out results/fid_quick      # tiny datasets made here (tests)

Train data: `itup generate --out data/train_a --tools-per-task 6 --grasps 256 --seed 0`.
Test data:  `itup generate --out data/test --tools-per-task 4 --grasps 256 --seed 1`: its
procedural variants (variant >= 1) are tools no training shard contains (the variant seeds derive
from the run seed); variant 0 is the built-in tool, seen in training, reported apart.

Per test tool (a shard: one tool, one task, its sampled grasps; valid rollouts only):
  * Spearman rho between predicted C_tau and the measured peak torque: the headline, the full induced
    peak wrist torque (`induced`, the paper's measure, no projection), beside the raw peak and the
    projected induced torque (the paper objective's target, `projected`); the same for the analytic C_tau
    (the paper's, stored in the dataset);
  * and over the held-out tools together (`rho_pooled_held_out`: per task, and `all` over every task),
    the headline's Spearman rho over every valid candidate, which also counts how the tools differ; for
    a wrench-objective network the same for its grip demand (`rho_pooled_grip_held_out`);
  * top-1 regret = measured torque of the scorer's pick / the lowest measured torque among the
    candidates - 1; for SDG-Net, the analytic cost, and a random pick (its expectation); and two
    robust companions: the pick's percentile among the candidates' measured torques (0 = best)
    and its torque over the candidates' 10th percentile;
  * the task: whether the pick achieved the task (label `success`), for the pick by predicted C_tau
    alone (`tau`) and by the scorer's total (`total`: the three costs and, for a model with a
    success head, w_task x its predicted probability of missing the task, and with a failure head
    w_fail x its predicted probability of failing in the grip, as `itup.best_grasp` picks); the
    task regret = the pick's torque / the lowest torque among the candidates that achieved the task
    - 1 (NaN where the pick itself failed, so read it beside the pick's success rate); and the AUC of
    the predicted success probability, pooled per task over the held-out tools;
  * the planner's objective: the measured total (`verify.measured_total` of the labels: torque, slip,
    drift, and the task and grip penalties with the scorer's weights), its Spearman rho with the
    predicted total, and the pick by the total's regret on it (`total_regret_*`). The lowest-torque
    candidate usually fails the task (on the knock and the reach almost always), so the torque regret
    above is measured against a grasp no planner should pick;
  * how hard the regret goal is on the tool (`best_gap_stats`): the second-best candidate's torque over
    the best's - 1, and how many candidates lie within the goal (5 %) of the best.
With `--verify K`, both verified picks (by C_tau alone, and by the total as `itup plan --verify K`
picks) are judged in the same terms, and the one by C_tau also against the task. With
`--verify-draws R` each of the K grasps is rolled out under R draws of the priors and the pick has
the lowest mean measured total (`itup plan --verify K --verify-draws R`); `--torque-first` makes the
total torque alone with the task and grip penalties (`ScoreWeights.torque_first`, `itup plan
--torque-first`).
Also the wall time of training (`--train-model` retrains on --train and times it; otherwise the
model given by --model, default the shipped checkpoint). Writes fidelity.json and fidelity.png.
The redraws (`--redraws K`) are deterministic (seeded by the shard); they are kept in --out as
redraws.npz, keyed by the test manifest and K, and reused by a later run on the same test set.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import GenerateConfig, generate
from itup_jax.dataset_load import MANIFEST
from itup_jax.fidelity import GOALS, fidelity
from itup_jax.scoring import ScoreWeights
from itup_jax.sdgnet.checkpoint import load_model, save_model
from itup_jax.sdgnet.config import TrainConfig
from itup_jax.sdgnet.training import train


def _nan_stat(f, v: np.ndarray) -> float:
    return float(f(v)) if np.isfinite(v).any() else float("nan")


def summarise(rows: list[dict]) -> dict:
    out = {}
    for subset, keep in (("held_out", True), ("seen", False)):
        sel = [r for r in rows if r["held_out"] == keep]
        if not sel:
            continue
        s = {"tools": len(sel)}
        keys = [k for k in dict.fromkeys(k for r in sel for k in r)
                if k.startswith(("rho_", "regret_", "percentile_", "over_p10_", "retest_", "success_", "task_regret_", "total_regret_",
                                 "failed_", "torque_draws_", "verify_", "best_gap_", "within_goal_", "task_within_",
                                 "pick_"))]
        for k in keys:
            v = np.array([r.get(k, np.nan) for r in sel], float)
            s[k] = {"median": _nan_stat(np.nanmedian, v), "mean": _nan_stat(np.nanmean, v)}
        by_task = {}
        for t in sorted({r["task"] for r in sel}):
            tr = [r for r in sel if r["task"] == t]
            by_task[t] = {k: _nan_stat(np.nanmean, np.array([r.get(k, np.nan) for r in tr], float)) for k in
                          ("rho_sdgnet_induced", "rho_analytic_induced", "regret_sdgnet_induced",
                           "regret_analytic_induced", "regret_random_induced", "percentile_sdgnet_induced",
                           "percentile_analytic_induced", "retest_rho", "retest_ceiling_rho", "rho_sdgnet_mean", "rho_analytic_mean",
                           "regret_sdgnet_mean", "percentile_sdgnet_mean", "regret_retest_induced",
                           "percentile_retest_induced", "regret_sdgnet_same_rows_induced", "success_rate_candidates",
                           "success_tau", "success_total", "success_draws_tau", "success_draws_total",
                           "failed_draws_tau", "failed_draws_total", "torque_draws_tau", "torque_draws_total",
                           "task_regret_retest", "success_retest",
                           "task_regret_tau", "task_regret_total", "success_auc", "regret_verified_induced",
                           "percentile_verified_induced", "success_verified_total", "task_regret_verified_total",
                           "success_verified_tau", "task_regret_verified_tau", "regret_verified_total_induced",
                           "total_regret_total", "total_regret_verified_total", "rho_total_measured",
                           "success_draws_verified_total", "failed_draws_verified_total", "torque_draws_verified_total",
                           "verify_s", "best_gap_induced", "within_goal_induced", "best_gap_mean",
                           "within_goal_mean", "task_within_goal_total", "task_within_goal_verified_total",
                           "pick_slip_mm_total", "pick_drift_total", "pick_slip_mm_verified_total",
                           "pick_drift_verified_total") if any(k in r for r in tr)}
            for k in ("regret_sdgnet_induced", "regret_analytic_induced", "regret_random_induced",
                      "task_regret_total", "task_regret_retest", "regret_verified_induced", "task_regret_verified_total",
                      "regret_verified_total_induced", "total_regret_total", "total_regret_verified_total"):
                by_task[t][f"{k}_median"] = _nan_stat(np.nanmedian, np.array([r.get(k, np.nan) for r in tr], float))
        s["by_task"] = by_task
        out[subset] = s
    return out


def plot(rows: list[dict], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from itup_jax.plotting import save_figure

    held = [r for r in rows if r["held_out"]] or rows
    tasks = sorted({r["task"] for r in held})
    fig, ax = plt.subplots(1, 3, figsize=(15, 3.8))
    x = np.arange(len(tasks))
    for j, (scorer, c) in enumerate((("sdgnet", "C0"), ("analytic", "C1"))):
        v = [np.nanmean([r[f"rho_{scorer}_induced"] for r in held if r["task"] == t]) for t in tasks]
        ax[0].bar(x + 0.38 * (j - 0.5), v, 0.38, label=scorer, color=c)
    ax[0].axhline(GOALS["spearman"], color="k", ls="--", lw=0.8, label="goal")
    ax[0].set_xticks(x, tasks)
    ax[0].set_ylabel("Spearman rho (per tool, mean)")
    ax[0].set_title("predicted C_tau vs measured torque")
    ax[0].legend(fontsize=8)
    scorers = [("sdgnet", "C0", "sdgnet")]
    if any("regret_verified_induced" in r for r in held):
        scorers.append(("verified", "C2", "sdgnet C_tau + verify"))
    if any("regret_verified_total_induced" in r for r in held):
        scorers.append(("verified_total", "C3", "sdgnet total + verify"))
    scorers += [("analytic", "C1", "analytic"), ("random", "C7", "random")]
    wd = 0.8 / len(scorers)
    for j, (scorer, c, label) in enumerate(scorers):
        v = [100 * np.nanmean([r[f"regret_{scorer}_induced"] for r in held if r["task"] == t]) for t in tasks]
        ax[1].bar(x + wd * (j - (len(scorers) - 1) / 2), v, wd, label=label, color=c)
    ax[1].axhline(100 * GOALS["regret"], color="k", ls="--", lw=0.8, label="goal")
    ax[1].set_xticks(x, tasks)
    ax[1].set_yscale("symlog", linthresh=10)  # the analytic and random regrets reach 1e4 %
    ax[1].set_ylabel("top-1 regret (%, mean over tools)")
    ax[1].set_title("measured torque of the pick over the best")
    ax[1].set_ylim(0, 1e6)
    ax[1].legend(fontsize=8, loc="upper center", ncol=2)
    draws = any("success_draws_total" in r for r in held)
    picks = [("tau", "C7", "pick by predicted C_tau"), ("total", "C0", "pick by the scorer's total")]
    if any("success_verified_tau" in r for r in held):  # judged on draw 0 only
        picks.append(("verified_tau", "C2", "C_tau + verify (draw 0)"))
    wp = 0.8 / len(picks)
    for j, (pick, c, label) in enumerate(picks):
        key = f"success_draws_{pick}" if draws and pick != "verified_tau" else f"success_{pick}"
        v = [100 * np.nanmean([r.get(key, np.nan) for r in held if r["task"] == t]) for t in tasks]
        ax[2].bar(x + wp * (j - (len(picks) - 1) / 2), v, wp, color=c, label=label)
    ax[2].set_xticks(x, tasks)
    ax[2].set_ylim(0, 130)
    ax[2].set_ylabel("pick achieves the task (% of rollouts)")
    ax[2].set_title("the task: " + ("all physics draws" if draws else "draw 0"))
    ax[2].legend(fontsize=8, loc="upper center", ncol=2)
    fig.suptitle("SDG-Net fidelity on held-out tools (MuJoCo, randomised physics)")
    fig.tight_layout()
    save_figure(fig, path, dpi=110)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", default=None, nargs="+", metavar="DIR",
                    help="training dataset folder(s) (for --train-model; several are trained on as one)")
    ap.add_argument("--test", default=None, help="test dataset folder (held-out tools)")
    ap.add_argument("--model", default=None, help="checkpoint to evaluate (default: the shipped one)")
    ap.add_argument("--train-model", action="store_true",
                    help="retrain --model's recipe (default: the shipped one's) on --train, time it, evaluate that")
    ap.add_argument("--redraws", type=int, default=0, help="roll every test grasp out K more times under new "
                    "physics draws: retest ceiling and the mean-over-draws target")
    ap.add_argument("--w-task", type=float, default=ScoreWeights().w_task,
                    help="weight of the predicted probability of missing the task in the pick by total (default: the scorer's)")
    ap.add_argument("--w-fail", type=float, default=ScoreWeights().w_fail,
                    help="weight of the predicted probability of failing in the grip (default: the scorer's)")
    ap.add_argument("--w-align", type=float, default=ScoreWeights().w_align,
                    help="weight of the predicted alignment drift, 1/rad (default: the scorer's)")
    ap.add_argument("--verify", type=int, default=0, metavar="K",
                    help="also judge the verified pick: SDG-Net's K best of each tool rolled out once more, the best "
                    "measured taken (itup.best_grasp_verified)")
    ap.add_argument("--verify-physics", choices=("nominal", "random"), default=None,
                    help="the check rollouts' physics: the priors' nominal values (the default for one draw) or "
                    "fresh draws (the default with --verify-draws > 1)")
    ap.add_argument("--verify-draws", type=int, default=1, metavar="R",
                    help="roll each of the K grasps out R times (random physics); the pick has the lowest mean")
    ap.add_argument("--torque-first", action="store_true",
                    help="the total weighs torque alone, with the task and grip penalties (ScoreWeights.torque_first)")
    ap.add_argument("--quick", action="store_true", help="tiny datasets made in --out, 1 redraw, --verify 2 (for the tests)")
    ap.add_argument("--out", default="results/fidelity")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    if args.quick:
        args.train = [os.path.join(args.out, "train")]
        args.test = os.path.join(args.out, "test")
        generate(args.train[0], GenerateConfig(tasks=("hammer",), tools_per_task=3, grasps=12, seed=0), progress=False)
        generate(args.test, GenerateConfig(tasks=("hammer",), tools_per_task=2, grasps=12, seed=1), progress=False)
        args.train_model, args.redraws, args.verify = True, 1, 2
    for flag, v, lowest in (("--redraws", args.redraws, 0), ("--verify", args.verify, 0),
                            ("--verify-draws", args.verify_draws, 1)):
        if v < lowest:
            print(f"sdgnet_fidelity: {flag} must be >= {lowest}, got {v}", file=sys.stderr)
            raise SystemExit(2)
    args.verify_physics = args.verify_physics or ("random" if args.verify_draws > 1 else "nominal")
    if args.verify_draws > 1 and args.verify_physics == "nominal":
        print("sdgnet_fidelity: --verify-draws > 1 needs --verify-physics random (nominal physics rolls out the "
              "same every time)", file=sys.stderr)
        raise SystemExit(2)
    if not args.test or not os.path.exists(os.path.join(args.test, MANIFEST)):
        print(f"sdgnet_fidelity: --test {args.test!r} holds no dataset manifest", file=sys.stderr)
        raise SystemExit(2)
    train_s = None
    if args.train_model:
        from itup_jax.dataset_load import load_datasets

        if not args.train:
            print("sdgnet_fidelity: --train-model needs --train DIR [DIR ...]", file=sys.stderr)
            raise SystemExit(2)
        data, manifests = load_datasets(args.train)
        spec = manifests[0]["config"]["feature_spec"]
        # the recipe of --model (default: the shipped checkpoint's), so the wall time is its time to train
        cfg = TrainConfig(epochs=20, patience=5) if args.quick else load_model(args.model).train_config
        t0 = time.perf_counter()
        model = train(data, cfg, feature_spec=spec, progress=False, log=lambda *_: None)
        train_s = time.perf_counter() - t0
        save_model(os.path.join(args.out, "model.npz"), model)
    else:
        model = load_model(args.model)
    weights = (ScoreWeights.torque_first(w_task=args.w_task, w_fail=args.w_fail) if args.torque_first
               else ScoreWeights(w_task=args.w_task, w_fail=args.w_fail, w_align=args.w_align))
    res = fidelity(model, args.test, redraws=args.redraws, cache=os.path.join(args.out, "redraws.npz"), weights=weights,
                   verify=args.verify, verify_physics=args.verify_physics, verify_draws=args.verify_draws)
    summary = summarise(res["rows"])
    out = {"schema": "itup.fidelity/2", "experiment": "sdgnet_fidelity", "quick": args.quick, "model": args.model or "shipped default",
           "retrained": bool(args.train_model), "train_wall_s": train_s, "redraws": args.redraws,
           "verify": args.verify, "verify_physics": args.verify_physics if args.verify else None,
           "verify_draws": args.verify_draws if args.verify else None, "goals": GOALS,
           "success_head": model.has_success_head, "class_heads": model.class_heads, "objective": model.objective,
           "weights": dataclasses.asdict(weights), "summary": summary,
           "success_auc_held_out": res["success_auc_held_out"], "failure_auc_held_out": res["failure_auc_held_out"],
           "weak_failure_auc_held_out": res["weak_failure_auc_held_out"],
           "rho_pooled_held_out": res["rho_pooled_held_out"],
           "rho_pooled_grip_held_out": res["rho_pooled_grip_held_out"],
           "per_tool": res["rows"], "test_config": res["test_config"]}
    from itup_jax.bench import machine_info

    out["machine"] = machine_info()
    atomic_write_json(os.path.join(args.out, "fidelity.json"), out, indent=2)
    plot(res["rows"], os.path.join(args.out, "fidelity.png"))
    h = summary.get("held_out") or summary.get("seen")
    pooled = res["rho_pooled_held_out"]
    if pooled:
        print("Spearman (SDG-Net, full induced torque) pooled over the held-out tools: "
              + ", ".join(f"{t} {v:.2f}" for t, v in pooled.items()))
    if res["rho_pooled_grip_held_out"]:
        print("Spearman (SDG-Net, grip demand) pooled over the held-out tools: "
              + ", ".join(f"{t} {v:.2f}" for t, v in res["rho_pooled_grip_held_out"].items()))
    print(f"held-out tools: {h['tools']}; Spearman (SDG-Net, full induced torque) median "
          f"{h['rho_sdgnet_induced']['median']:.2f}, raw {h['rho_sdgnet_raw']['median']:.2f}; analytic "
          f"{h['rho_analytic_induced']['median']:.2f}; top-1 regret, median / mean over tools: "
          + " ".join(f"{name} {100 * h[f'regret_{key}_induced']['median']:.0f}% / {100 * h[f'regret_{key}_induced']['mean']:.0f}%"
                     for name, key in (("SDG-Net", "sdgnet"), ("analytic", "analytic"), ("random", "random")))
          + (f"; training {train_s:.1f} s" if train_s is not None else ""))
    print("  per task, means over its tools (the regret: median / mean):")
    for t, v in h["by_task"].items():
        reg = lambda key: f"{100 * v[f'regret_{key}_induced_median']:.0f}% / {100 * v[f'regret_{key}_induced']:.0f}%"  # noqa: E731
        print(f"  {t:7s} rho sdgnet {v['rho_sdgnet_induced']:+.2f} analytic {v['rho_analytic_induced']:+.2f} | regret "
              f"sdgnet {reg('sdgnet')} analytic {reg('analytic')} random {reg('random')} | pick percentile sdgnet "
              f"{100 * v['percentile_sdgnet_induced']:.0f} analytic {100 * v['percentile_analytic_induced']:.0f}")
    draws = "success_draws_total" in h
    print(f"the task ({'draws 0-' + str(args.redraws) if draws else 'draw 0'}): the pick achieves it by predicted C_tau "
          f"{100 * h['success_draws_tau' if draws else 'success_tau']['mean']:.0f}% / by the total "
          f"{100 * h['success_draws_total' if draws else 'success_total']['mean']:.0f}% of tools (candidates "
          f"{100 * h['success_rate_candidates']['mean']:.0f}%); task regret (vs the best candidate that did it, draw 0, "
          f"picks that did it) by the total median {100 * h['task_regret_total']['median']:.0f}%; regret of the measured "
          f"total (torque, slip, drift, task and grip penalties; Spearman of the predicted total with it, median "
          f"{h['rho_total_measured']['median']:.2f}) by the total median "
          f"{100 * h['total_regret_total']['median']:.0f}%, within 5% in "
          f"{100 * np.mean([r['total_regret_total'] <= GOALS['regret'] for r in res['rows'] if r['held_out']]):.0f}% of tools"
          + (f"; success head AUC {', '.join(f'{t} {v:.2f}' for t, v in res['success_auc_held_out'].items())}"
             if res["success_auc_held_out"] else "; no success head")
          + (f"; failure head AUC {', '.join(f'{t} {v:.2f}' for t, v in res['failure_auc_held_out'].items())}"
             if res["failure_auc_held_out"] else "")
          + (f"; weak-grip failure head AUC {', '.join(f'{t} {v:.2f}' for t, v in res['weak_failure_auc_held_out'].items())}"
             if res["weak_failure_auc_held_out"] else ""))
    if draws:
        print(f"the pick by the total fails in the grip in {100 * h['failed_draws_total']['mean']:.1f}% of the rollouts "
              f"(by predicted C_tau {100 * h['failed_draws_tau']['mean']:.1f}%)")
    for t, v in h["by_task"].items():
        print(f"  {t:7s} pick success tau {100 * v['success_draws_tau' if draws else 'success_tau']:.0f}% total "
              f"{100 * v['success_draws_total' if draws else 'success_total']:.0f}% | task regret total median "
              f"{100 * v['task_regret_total_median']:.0f}% (tau mean {100 * v['task_regret_tau']:.0f}%) | measured-total "
              f"regret median {100 * v['total_regret_total_median']:.0f}% (rho of the total {v['rho_total_measured']:+.2f})")
    if args.redraws:
        print(f"with {args.redraws} more physics draws per grasp: retest rho (draw 0 vs draw 1) median "
              f"{h['retest_rho']['median']:.2f} (a perfect prior-blind scorer's rho against one draw: ~sqrt of it, "
              f"median {h['retest_ceiling_rho']['median']:.2f}); against the mean over {args.redraws + 1} draws: Spearman SDG-Net "
              f"{h['rho_sdgnet_mean']['median']:.2f} analytic {h['rho_analytic_mean']['median']:.2f}; regret SDG-Net "
              f"{100 * h['regret_sdgnet_mean']['mean']:.0f}% (median {100 * h['regret_sdgnet_mean']['median']:.0f}%), "
              f"pick percentile {100 * h['percentile_sdgnet_mean']['mean']:.0f}")
        print(f"regret goal, on one draw: picking by the mean of {args.redraws} further simulated draws of every candidate "
              f"gives median {100 * h['regret_retest_induced']['median']:.0f}% (pick percentile "
              f"{100 * h['percentile_retest_induced']['median']:.0f}), SDG-Net on the same rows "
              f"{100 * h['regret_sdgnet_same_rows_induced']['median']:.0f}%")
        print(f"how hard the regret goal is: a tool's best candidate lies a median "
              f"{100 * h['best_gap_induced']['median']:.0f}% below its second on draw 0 "
              f"({100 * h['best_gap_mean']['median']:.0f}% on the mean of {args.redraws + 1} draws), and a median of "
              f"{h['within_goal_induced']['median']:.0f} candidate(s) per tool lie within {100 * GOALS['regret']:.0f}% "
              f"of the best ({h['within_goal_mean']['median']:.0f} on the mean): SDG-Net's pick meets the goal in "
              f"{100 * np.mean([r['regret_sdgnet_induced'] <= GOALS['regret'] for r in res['rows'] if r['held_out']]):.0f}% "
              f"of tools on draw 0")
        for t, v in h["by_task"].items():
            print(f"  {t:7s} retest {v['retest_rho']:+.2f} (ceiling {v['retest_ceiling_rho']:+.2f}) | vs mean: rho sdgnet {v['rho_sdgnet_mean']:+.2f} analytic "
                  f"{v['rho_analytic_mean']:+.2f} regret sdgnet {100 * v['regret_sdgnet_mean']:.0f}% percentile "
                  f"{100 * v['percentile_sdgnet_mean']:.0f}")
    if args.verify:
        times = "once more" if args.verify_draws == 1 else f"{args.verify_draws} times each, the mean taken"
        print(f"verified pick (SDG-Net's {args.verify} best per tool rolled out {times}, {args.verify_physics} physics, "
              f"{h['verify_s']['mean']:.2f} s per tool for both checks): top-1 regret median "
              f"{100 * h['regret_verified_induced']['median']:.0f}% (SDG-Net alone "
              f"{100 * h['regret_sdgnet_induced']['median']:.0f}%), mean {100 * h['regret_verified_induced']['mean']:.0f}%, "
              f"within the goal in {100 * np.mean([r['regret_verified_induced'] <= GOALS['regret'] for r in res['rows'] if r['held_out']]):.0f}% "
              f"of tools, the task done by it in {100 * h['success_verified_tau']['mean']:.0f}% (draw 0); by the total: task achieved "
              f"{100 * h['success_verified_total']['mean']:.0f}% (draw 0), top-1 regret median "
              f"{100 * h['regret_verified_total_induced']['median']:.0f}%, task regret median "
              f"{100 * h['task_regret_verified_total']['median']:.0f}% (within 5% in "
              f"{100 * h['task_within_goal_verified_total']['mean']:.0f}% "
              f"of tools; the pick slips {h['pick_slip_mm_verified_total']['median']:.1f} mm and drifts "
              f"{h['pick_drift_verified_total']['median']:.3f} rad, medians, draw 0), measured-total regret median "
              f"{100 * h['total_regret_verified_total']['median']:.0f}% (within 5% in "
              f"{100 * np.mean([r['total_regret_verified_total'] <= GOALS['regret'] for r in res['rows'] if r['held_out']]):.0f}% of tools)"
              + (f"; over draws 0-{args.redraws}: success {100 * h['success_draws_verified_total']['mean']:.0f}%, "
                 f"fails in the grip {100 * h['failed_draws_verified_total']['mean']:.1f}%, torque "
                 f"{h['torque_draws_verified_total']['mean']:.3f} N m (unverified {h['torque_draws_total']['mean']:.3f})"
                 if draws else ""))
        for t, v in h["by_task"].items():
            print(f"  {t:7s} regret verified {100 * v['regret_verified_induced_median']:.0f}% (median; mean "
                  f"{100 * v['regret_verified_induced']:.0f}%), does the task {100 * v['success_verified_tau']:.0f}% | by the "
                  f"total: regret median {100 * v['regret_verified_total_induced_median']:.0f}%, task regret median "
                  f"{100 * v['task_regret_verified_total_median']:.0f}%, measured-total regret median "
                  f"{100 * v['total_regret_verified_total_median']:.0f}%, success {100 * v['success_verified_total']:.0f}%")
    return out


if __name__ == "__main__":
    main()

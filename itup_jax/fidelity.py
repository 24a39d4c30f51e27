"""How well a scorer ranks and picks on held-out tools: rank correlations, regrets and task outcomes of
its picks among a tool's rolled-out candidates, against the measured labels.

    res = fidelity(load_model(), "data/test", redraws=2)   # per tool and pooled; docs/results.md, "Fidelity"
    pick_stats(y, score)                                    # one pick's regret among candidates measured y

The headline is the full induced peak wrist torque (`heldout.HEADLINE`); the raw and projected torques are
judged beside it (`MEASURED`). Redraws (`heldout.cached_redraws`) give each label's retest correlation,
the ceiling a scorer that cannot see the physics draw can reach. `experiments/sdgnet_fidelity.py` and
`experiments/sdgnet_scaling.py` are this module and a report.
"""

from __future__ import annotations

import json
import os
import time
import types

import numpy as np

from itup_jax.dataset import GenerateConfig, unit_tool
from itup_jax.dataset_load import MANIFEST, dataset_timesteps, load_shard
from itup_jax.grasp import Grasps
from itup_jax.heldout import HEADLINE, cached_redraws, shard_key
from itup_jax.scoring import Scores, ScoreWeights, sdgnet_total
from itup_jax.sdgnet.config import CLASS_NAMES, CLASS_TARGETS
from itup_jax.sdgnet.model import predict_costs
from itup_jax.sdgnet.training import head_labels
from itup_jax.sim.physics import Randomization
from itup_jax.sim.scene import build_scene
from itup_jax.stats import roc_auc, spearman
from itup_jax.verify import best_grasp_verified, measured_total

#: The measured torques each scorer is judged against (dataset columns); the first is the headline.
MEASURED = {"induced": HEADLINE, "raw": "label_peak_torque", "projected": "label_peak_torque_projected"}
#: The goals a scorer is held to: per-tool Spearman, top-1 regret, training time (min).
GOALS = {"spearman": 0.9, "regret": 0.05, "train_minutes": 5.0}


def learned_and_verified_picks(total: np.ndarray, measured: np.ndarray, valid: np.ndarray, verify: int) -> tuple[int, int]:
    """(the learned pick: the lowest predicted total; the verified pick: among the `verify` best by
    predicted total with a valid rollout, the lowest measured total, as `itup plan --verify K` picks under
    nominal physics, or the learned pick when none is valid), from every candidate's rollout."""
    order = np.argsort(total, kind="stable")
    short = [int(i) for i in order if valid[i]][:verify]
    return int(order[0]), (short[int(np.argmin(measured[short]))] if short else int(order[0]))


def pick_stats(y: np.ndarray, score: np.ndarray) -> dict:
    """The scorer's pick (lowest score) among candidates with measured torques y [N]: its regret (its
    torque over the lowest - 1), its percentile among the candidates (share with lower torque, 0 = the
    best) and its torque over the candidates' 10th percentile - 1 (the minimum of ~100-250 rollouts
    under randomised physics is partly luck of the physics draw)."""
    y_pick = float(y[int(np.argmin(score))])
    return {"regret": y_pick / float(y.min()) - 1, "percentile": float((y < y_pick).mean()),
            "over_p10": y_pick / float(np.percentile(y, 10)) - 1}


def best_gap_stats(y: np.ndarray, goal: float = GOALS["regret"]) -> dict:
    """How hard the top-1 regret goal is on one tool, from its candidates' measured torques y [N]: the
    second-lowest torque over the lowest - 1 (`best_gap`; any pick but the best has at least this regret)
    and the number of candidates within `goal` of the lowest (`within_goal`, the best itself included:
    1 means a pick meets the goal only by being the best candidate)."""
    y = np.sort(np.asarray(y, float))
    return {"best_gap": float(y[1] / y[0] - 1) if len(y) > 1 else float("nan"),
            "within_goal": int((y <= y[0] * (1 + goal)).sum())}


def task_pick_stats(y: np.ndarray, success: np.ndarray, score: np.ndarray) -> dict:
    """The pick (lowest score) against the task: whether it succeeded (1/0) and its task regret, its
    torque over the lowest torque among the candidates that succeeded - 1 (NaN when the pick failed or
    no candidate succeeded)."""
    i = int(np.argmin(score))
    ok = success.astype(bool)
    regret = float(y[i] / y[ok].min() - 1) if ok[i] else float("nan")
    return {"success": float(ok[i]), "task_regret": regret}


def one_hot(n: int, i: int) -> np.ndarray:
    """[n] a score whose lowest entry is i (to judge a pick made elsewhere with `pick_stats`)."""
    z = np.ones(n)
    z[i] = 0.0
    return z


def stacked_draws(ok: np.ndarray, first: np.ndarray, extra: np.ndarray) -> np.ndarray:
    """[k + 1, N]: draw 0 (the shard's label, NaN where not valid) over the k redraws."""
    return np.vstack([np.where(ok, first.astype(float), np.nan)[None], extra])


def verified_picks(config: GenerateConfig, entry: dict, a: dict, ok: np.ndarray, pred_tau: np.ndarray,
                   pred_total: np.ndarray, k: int, physics: str, timestep: float,
                   weights: ScoreWeights, draws: int = 1) -> dict[str, int | float]:
    """SDG-Net's shortlist of the k best of a shard's valid grasps, each rolled out `draws` more times and
    the best measured (mean over the draws) taken (`best_grasp_verified`): by predicted C_tau then
    measured full induced torque (`tau`), and by the scorer's total then the measured total (`total`,
    `weights`). The check rollouts run under nominal physics (`physics` = 'nominal') or fresh draws
    (`random`: from the shard's seed + 2; the redraws use + 1), never under draw 0, which judges the
    pick. Returns {pick_tau, pick_total (indices into the valid rows), verify_s (wall time of both
    checks)}."""
    tool, task = unit_tool(config, entry["task"], entry["variant"])
    scene = build_scene(tool, task, timestep=timestep)
    g = Grasps(a["grasp_p"][ok], a["grasp_q"][ok], a["grasp_width"][ok])
    seed = json.loads(bytes(a["meta_json"]))["seed"] + 2
    randomize = None if physics == "nominal" else Randomization()
    only_tau = ScoreWeights(w_tau=1.0, w_slip=0.0, w_align=0.0, w_task=0.0, w_fail=0.0)
    out: dict[str, int | float] = {}
    t0 = time.perf_counter()
    for name, total, w in (("tau", pred_tau, only_tau), ("total", pred_total, weights)):
        z = np.zeros(len(total))
        v = best_grasp_verified(tool, task, g, k=k, draws=draws, seed=seed, randomize=randomize, weights=w, scene=scene,
                                scores=Scores(tau=z, slip=z, align=z, total=np.asarray(total, float), scorer="sdgnet"))
        out[f"pick_{name}"] = v.index
    out["verify_s"] = time.perf_counter() - t0
    return out


def pooled_rho(pairs: dict[str, tuple[list, list]]) -> dict[str, float]:
    """{task: Spearman rho over every (prediction, measurement) pair of its tools together, and 'all' over
    every task's}; `pairs`: {task: ([predictions per tool], [measurements per tool])}."""
    out = {t: spearman(np.concatenate(p), np.concatenate(y)) for t, (p, y) in sorted(pairs.items())}
    if pairs:
        out["all"] = spearman(*(np.concatenate([np.concatenate(v[i]) for v in pairs.values()]) for i in (0, 1)))
    return out


def fidelity(model, test_dir: str, redraws: int = 0, *, cache: str | None = None,
             weights: ScoreWeights = ScoreWeights(), verify: int = 0, verify_physics: str = "nominal",
             verify_draws: int = 1) -> dict:
    """Per shard of a held-out dataset: rank correlations and regrets of SDG-Net and the analytic cost against the measured
    torques. With `redraws` k >= 1 every grasp is rolled out k more times under new physics draws, which
    adds the retest correlation between two draws (`retest_rho` = r) and the target `mean` (the mean over
    the k + 1 draws, an estimate of the expected torque under the priors, which is what a prior-blind
    scorer predicts). If a draw's label is the expected torque plus independent noise, r is the share of
    the labels' variance that the grasp explains, and a perfect prior-blind scorer correlates with one
    draw's label at sqrt(r) (`retest_ceiling_rho`, for ranks an approximation): the ceiling against
    single-draw labels is sqrt(r), not r. Likewise `regret_retest_induced`: the regret on draw 0 of
    the candidate with the lowest mean over draws 1..k, i.e. of a scorer that simulated every candidate
    k more times (a perfect scorer of the expected torque is its limit as k grows), with
    `regret_sdgnet_same_rows_induced` SDG-Net's on the same rows (valid in every draw). The task
    fields (`task_pick_stats`) judge the pick by `tau` and by `total` (weighted by `weights`) on draw 0;
    with redraws, `success_draws_*` is the pick's success rate over all k + 1 draws. With `verify` K >= 1,
    the same for the verified picks (`verified_picks`: SDG-Net's K best rolled out `verify_draws` more
    times under `verify_physics`): `regret_verified_induced`, `percentile_verified_induced` and `*_verified_tau` (the
    pick by torque alone, and whether it did the task), `*_verified_total` and
    `regret_verified_total_induced` (the pick by the total, against the best candidate whatever it did).
    `total_regret_total` / `total_regret_verified_total`: the regret of the pick by the total (unverified /
    verified) in the objective the total predicts, the measured total (`verify.measured_total`, draw 0),
    over the lowest measured total among the candidates."""
    with open(os.path.join(test_dir, MANIFEST)) as fh:
        manifest = json.load(fh)
    extra_all = cached_redraws(test_dir, redraws, cache) if redraws else {}
    config = GenerateConfig.from_json(manifest["config"])
    steps = dataset_timesteps(manifest)
    rows, pooled, pooled_tau, pooled_grip = [], {}, {}, {}
    for entry in manifest["shards"]:
        a = load_shard(test_dir, entry)
        ok = a["label_valid"].astype(bool)
        if ok.sum() < 3:
            continue
        predicted = {k: np.asarray(v, float) for k, v in predict_costs(model, a["features"], entry["task"]).items()}
        pred_all = predicted["tau"]
        p_success = predicted.get("p_success")
        net = model.for_task(entry["task"])
        probs = np.stack([predicted[n] for n in net.head_names], 1) if net.head_names else None
        cols = [predicted[c] if c in predicted else np.zeros_like(predicted["tau"]) for c in ("tau", "slip", "align", "grip")]
        total_all = np.asarray(sdgnet_total(np.stack(cols, 1), probs,
                                            np.asarray(weights.costs()), np.asarray(weights.heads(net.class_heads))))
        targets = {name: (ok, a[key]) for name, key in MEASURED.items()}
        row = {"task": entry["task"], "variant": entry["variant"], "held_out": entry["variant"] > 0, "n": int(ok.sum())}
        y_ok, s_ok = a[HEADLINE][ok], a["label_success"][ok].astype(bool)
        # the measured total (`verify.measured_total`, the objective the scorer's total predicts: torque,
        # slip, drift, and the task and grip penalties) of every valid row, draw 0
        m_ok = measured_total(types.SimpleNamespace(valid=ok[ok], **{f: a[f"label_{f}"][ok] for f in (
            "peak_torque_projected", "peak_torque_induced", "grip_demand", "slip_translation", "alignment_drift",
            "success", "failed")}), weights, objective=model.objective)
        row["success_rate_candidates"] = float(s_ok.mean())
        for name, sc in (("tau", pred_all[ok]), ("total", total_all[ok])):
            for stat, v in task_pick_stats(y_ok, s_ok, sc).items():
                row[f"{stat}_{name}"] = v
        slip_ok, drift_ok = a["label_slip_translation"][ok], a["label_alignment_drift"][ok]
        i_total = int(np.argmin(total_all[ok]))
        row["pick_slip_mm_total"], row["pick_drift_total"] = 1e3 * float(slip_ok[i_total]), float(drift_ok[i_total])
        row["task_within_goal_total"] = float(row["task_regret_total"] <= GOALS["regret"])  # NaN (missed) counts as not
        row["total_regret_total"] = pick_stats(m_ok, total_all[ok])["regret"]
        row["rho_total_measured"] = spearman(total_all[ok], m_ok)  # the planner's objective, predicted vs measured
        if p_success is not None:
            row["success_auc"] = roc_auc(p_success[ok], s_ok)
        vp = (verified_picks(config, entry, a, ok, pred_all[ok], total_all[ok], verify, verify_physics,
                             steps[entry["task"]], weights, verify_draws) if verify else None)
        if vp is not None:
            row["verify_s"] = vp["verify_s"]
            for stat, v in pick_stats(y_ok, one_hot(len(y_ok), vp["pick_tau"])).items():
                row[f"{stat}_verified_induced"] = v
            for stat, v in task_pick_stats(y_ok, s_ok, one_hot(len(y_ok), vp["pick_tau"])).items():
                row[f"{stat}_verified_tau"] = v  # does the verified pick by torque alone do the task?
            pick_total = one_hot(len(y_ok), vp["pick_total"])
            for stat, v in task_pick_stats(y_ok, s_ok, pick_total).items():
                row[f"{stat}_verified_total"] = v
            # the verified pick by the total against the best candidate, whether or not that did the task
            row["regret_verified_total_induced"] = pick_stats(y_ok, pick_total)["regret"]
            row["task_within_goal_verified_total"] = float(row["task_regret_verified_total"] <= GOALS["regret"])
            row["pick_slip_mm_verified_total"] = 1e3 * float(slip_ok[vp["pick_total"]])
            row["pick_drift_verified_total"] = float(drift_ok[vp["pick_total"]])
            row["total_regret_verified_total"] = pick_stats(m_ok, pick_total)["regret"]
        for name, label in zip(CLASS_NAMES, CLASS_TARGETS):
            if name in predicted and row["held_out"] and label in a:  # pooled per task over the held-out tools
                pt = pooled.setdefault(name, {}).setdefault(entry["task"], ([], []))
                lab = head_labels(a, label)[ok]  # NaN: not measured (a weak-grip rollout that is not valid)
                pt[0].append(predicted[name][ok][np.isfinite(lab)])
                pt[1].append(lab[np.isfinite(lab)] > 0.5)
        if redraws:
            extra = extra_all[shard_key(entry)]
            succ = stacked_draws(ok, a["label_success"], extra["success"])
            failed = stacked_draws(ok, a["label_failed"], extra["failed"])
            draws = stacked_draws(ok, a[HEADLINE], extra["torque"])
            picks = {name: int(np.argmin(np.where(ok, sc, np.inf))) for name, sc in (("tau", pred_all), ("total", total_all))}
            if vp is not None:
                picks["verified_total"] = int(np.nonzero(ok)[0][vp["pick_total"]])
            for name, i in picks.items():
                row[f"success_draws_{name}"] = float(np.nanmean(succ[:, i]))
                row[f"failed_draws_{name}"] = float(np.nanmean(failed[:, i]))
                row[f"torque_draws_{name}"] = float(np.nanmean(draws[:, i]))
            both = np.isfinite(draws).all(axis=0)
            row["retest_rho"] = spearman(draws[0][both], draws[1][both]) if both.sum() >= 3 else float("nan")
            row["retest_ceiling_rho"] = float(np.sqrt(row["retest_rho"])) if row["retest_rho"] > 0 else float("nan")
            row["n_mean"] = int(both.sum())
            if both.sum() >= 3:
                targets["mean"] = (both, draws.mean(axis=0))
                # what the regret goal asks of a scorer that has *simulated* every candidate k more times:
                # pick by the mean of draws 1..k, measured on draw 0 like SDG-Net's pick (same rows)
                retest = pick_stats(draws[0][both], draws[1:, both].mean(axis=0))
                row["regret_retest_induced"] = retest["regret"]
                row["percentile_retest_induced"] = retest["percentile"]
                row["regret_sdgnet_same_rows_induced"] = pick_stats(draws[0][both], pred_all[both])["regret"]
                # the same simulating scorer under the task: lowest mean torque among the candidates that did
                # the task in every one of draws 1..k, judged on draw 0 by `task_pick_stats`
                always = (succ[1:, both] == 1).all(axis=0)
                if always.any():
                    oracle = np.where(always, draws[1:, both].mean(axis=0), np.inf)
                    ts = task_pick_stats(draws[0][both], succ[0][both] == 1, oracle)
                    row["task_regret_retest"], row["success_retest"] = ts["task_regret"], ts["success"]
        if row["held_out"]:  # the headline ranking pooled over the held-out tools of a task
            pt = pooled_tau.setdefault(entry["task"], ([], []))
            pt[0].append(pred_all[ok])
            pt[1].append(a[HEADLINE][ok])
            if "grip" in predicted and "label_grip_demand" in a:  # a wrench-objective network's grip demand
                pg = pooled_grip.setdefault(entry["task"], ([], []))
                pg[0].append(predicted["grip"][ok])
                pg[1].append(a["label_grip_demand"][ok])
        for name, (mask, y_all) in targets.items():
            y, pred, ana = y_all[mask], pred_all[mask], a["analytic_tau"][mask]
            row[f"rho_sdgnet_{name}"] = spearman(pred, y)
            row[f"rho_analytic_{name}"] = spearman(ana, y)
            for scorer, score in (("sdgnet", pred), ("analytic", ana)):
                for stat, v in pick_stats(y, score).items():
                    row[f"{stat}_{scorer}_{name}"] = v
            row[f"regret_random_{name}"] = float(y.mean() / y.min() - 1)
            for stat, v in best_gap_stats(y).items():
                row[f"{stat}_{name}"] = v
        rows.append(row)
    auc = {name: {t: roc_auc(np.concatenate(p), np.concatenate(sv)) for t, (p, sv) in sorted(by_task.items())}
           for name, by_task in pooled.items()}
    return {"rows": rows, "test_config": manifest["config"], "rho_pooled_held_out": pooled_rho(pooled_tau),
            "rho_pooled_grip_held_out": pooled_rho(pooled_grip),
            "success_auc_held_out": auc.get("p_success", {}),
            "failure_auc_held_out": auc.get("p_failed", {}), "weak_failure_auc_held_out": auc.get("p_failed_weak", {})}

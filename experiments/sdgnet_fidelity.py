"""SDG-Net fidelity on held-out tools: does the predicted C_tau rank grasps as MuJoCo's measured
peak wrist torque does, and how much torque does SDG-Net's pick give away to the best candidate?

    python experiments/sdgnet_fidelity.py --train /tmp/sdg_train --test /tmp/sdg_test --out results/fidelity
    python experiments/sdgnet_fidelity.py --quick --out /tmp/fid      # tiny datasets made here (tests)

Train data: `itup generate --out /tmp/sdg_train --tools-per-task 6 --grasps 256 --seed 0`.
Test data:  `itup generate --out /tmp/sdg_test --tools-per-task 4 --grasps 256 --seed 1`: its
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
import hashlib
import io
import json
import os
import sys
import time
import types
import zipfile

import numpy as np

from itup_jax.atomic import atomic_write, atomic_write_json
from itup_jax.dataset import MANIFEST, GenerateConfig, dataset_timesteps, generate, load_shard, unit_tool
from itup_jax.grasp import Grasps
from itup_jax.scene import build_scene
from itup_jax.scoring import Scores, ScoreWeights, sdgnet_total
from itup_jax.sdgnet import (
    CLASS_NAMES,
    CLASS_TARGETS,
    TrainConfig,
    head_labels,
    load_model,
    predict_costs,
    save_model,
    train,
)
from itup_jax.simulate import Randomization, simulate
from itup_jax.stats import roc_auc, spearman
from itup_jax.verify import best_grasp_verified, measured_total

#: The measured torques each scorer is judged against; the first is the headline (the paper's "peak induced
#: wrist torque", the full vector with the static holding torque removed, no projection).
MEASURED = {"induced": "label_peak_torque_induced", "raw": "label_peak_torque",
            "projected": "label_peak_torque_projected"}
HEADLINE = MEASURED["induced"]
GOALS = {"spearman": 0.9, "regret": 0.05, "train_minutes": 5.0}
REDRAWN = ("torque", "success", "failed")  # the labels `redraw_labels` keeps


def redraw_labels(config: GenerateConfig, entry: dict, a: dict, k: int, timestep: float) -> dict[str, np.ndarray]:
    """{torque, success, failed}: each [k, N], the measured full induced peak torque (N m), task success (1/0)
    and grasp failure (1/0: slip or rotation over the thresholds, or the tool lost) of a shard's N
    grasps under k further physics draws (NaN where a rollout is not valid): the same grasps, tool and
    task, one simulate call, a new seed, at `timestep` s (the dataset's step for the task,
    `dataset_timesteps`)."""
    tool, task = unit_tool(config, entry["task"], entry["variant"])
    n = len(a["grasp_width"])
    reps = Grasps(*(np.tile(a[f], (k,) + (1,) * (a[f].ndim - 1)) for f in ("grasp_p", "grasp_q", "grasp_width")))
    seed = json.loads(bytes(a["meta_json"]))["seed"] + 1
    L = simulate(tool, task, reps, seed=seed, backend=config.backend,
                 scene=build_scene(tool, task, timestep=timestep)).labels
    return {"torque": np.where(L.valid, L.peak_torque_induced, np.nan).reshape(k, n),
            "success": np.where(L.valid, L.success.astype(float), np.nan).reshape(k, n),
            "failed": np.where(L.valid, L.failed.astype(float), np.nan).reshape(k, n)}


def _shard_key(entry: dict) -> str:
    return f"{entry['task']}_{entry['variant']}"


def cached_redraws(test_dir: str, k: int, cache: str | None) -> dict[str, dict[str, np.ndarray]]:
    """{shard key: redraw_labels(...)} for every shard of the test set, read from `cache` (an npz) when
    it was made from this very manifest with this k and the same redrawn labels (`REDRAWN`, the torque
    being `HEADLINE`), else simulated and written there atomically."""
    with open(os.path.join(test_dir, MANIFEST), "rb") as fh:
        raw = fh.read()
    key = f"{hashlib.sha256(raw).hexdigest()}:{k}:{','.join(REDRAWN)}:{HEADLINE}"
    if cache and os.path.exists(cache):
        try:
            with np.load(cache, allow_pickle=False) as z:
                if str(z["key"]) == key:
                    return {n[: -len("/torque")]: {f: z[n[: -len("torque")] + f] for f in REDRAWN}
                            for n in z.files if n.endswith("/torque")}
        except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:  # unreadable: simulate again
            print(f"sdgnet_fidelity: ignoring the redraw cache {cache!r} ({exc})", file=sys.stderr)
    manifest = json.loads(raw)
    config = GenerateConfig.from_json(manifest["config"])
    steps = dataset_timesteps(manifest)
    out = {_shard_key(e): redraw_labels(config, e, load_shard(test_dir, e), k, steps[e["task"]])
           for e in manifest["shards"]}
    if cache:
        buf = io.BytesIO()
        np.savez(buf, key=np.array(key), **{f"{n}/{f}": v for n, d in out.items() for f, v in d.items()})
        atomic_write(cache, buf.getvalue())
    return out


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


def _one_hot(n: int, i: int) -> np.ndarray:
    """[n] a score whose lowest entry is i (to judge a pick made elsewhere with `pick_stats`)."""
    z = np.ones(n)
    z[i] = 0.0
    return z


def _draws(ok: np.ndarray, first: np.ndarray, extra: np.ndarray) -> np.ndarray:
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


def _pooled_rho(pairs: dict[str, tuple[list, list]]) -> dict[str, float]:
    """{task: Spearman rho over every (prediction, measurement) pair of its tools together, and 'all' over
    every task's}; `pairs`: {task: ([predictions per tool], [measurements per tool])}."""
    out = {t: spearman(np.concatenate(p), np.concatenate(y)) for t, (p, y) in sorted(pairs.items())}
    if pairs:
        out["all"] = spearman(*(np.concatenate([np.concatenate(v[i]) for v in pairs.values()]) for i in (0, 1)))
    return out


def evaluate(model, test_dir: str, redraws: int = 0, *, cache: str | None = None,
             weights: ScoreWeights = ScoreWeights(), verify: int = 0, verify_physics: str = "nominal",
             verify_draws: int = 1) -> dict:
    """Per test shard: rank correlations and regrets of SDG-Net and the analytic cost against the measured
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
            for stat, v in pick_stats(y_ok, _one_hot(len(y_ok), vp["pick_tau"])).items():
                row[f"{stat}_verified_induced"] = v
            for stat, v in task_pick_stats(y_ok, s_ok, _one_hot(len(y_ok), vp["pick_tau"])).items():
                row[f"{stat}_verified_tau"] = v  # does the verified pick by torque alone do the task?
            pick_total = _one_hot(len(y_ok), vp["pick_total"])
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
            extra = extra_all[_shard_key(entry)]
            succ = _draws(ok, a["label_success"], extra["success"])
            failed = _draws(ok, a["label_failed"], extra["failed"])
            draws = _draws(ok, a[HEADLINE], extra["torque"])
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
    return {"rows": rows, "test_config": manifest["config"], "rho_pooled_held_out": _pooled_rho(pooled_tau),
            "rho_pooled_grip_held_out": _pooled_rho(pooled_grip),
            "success_auc_held_out": auc.get("p_success", {}),
            "failure_auc_held_out": auc.get("p_failed", {}), "weak_failure_auc_held_out": auc.get("p_failed_weak", {})}


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
        from itup_jax.dataset import load_datasets

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
    res = evaluate(model, args.test, redraws=args.redraws, cache=os.path.join(args.out, "redraws.npz"), weights=weights,
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

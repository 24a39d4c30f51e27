"""Checkpoints judged on drawn tools of the tool families: the candidates of each evaluation tool rolled
out once, and every checkpoint's ranking, guard and picks on the same rollouts.

    evals = family_rollouts("spanner", ("hammer",), tools=4, grasps=64)    # seeds heldout.TEST_SEED, ...
    row = judge(sdgnet.DEFAULT_MODEL, evals[0], verify=5)                  # one checkpoint on one tool
    summary = summarise([row, ...])                                        # medians and rates over tools

The evaluation draws are the out-of-distribution guard's test draws (`heldout.TEST_SEED` on), which no
dataset of docs/results.md holds; each tool's candidates are ones the arm can carry
(`grasp_sampler.sample_reachable`), rolled out in native MuJoCo under nominal physics. Judged against
the measured full induced peak wrist torque and grip demand; the learned pick is the lowest predicted
total, the verified pick the lowest measured total among the `verify` best by predicted total (as
`itup plan --verify K`). `experiments/leave_family_out.py` and `experiments/training_families.py` are
this module and a report.
"""

from __future__ import annotations

import warnings

import numpy as np

from itup_jax.fidelity import learned_and_verified_picks
from itup_jax.heldout import TEST_SEED

#: Seeds of the evaluation draws (the out-of-distribution guard's test draws).
EVAL_SEED = TEST_SEED


def family_rollouts(name: str, kinds, tools: int, grasps: int) -> list[dict]:
    """The evaluation tools of family `name` for each task kind in `kinds`: `tools` draws (seeds EVAL_SEED,
    EVAL_SEED + 1, ...), each with `grasps` reachable candidates and their nominal-physics labels;
    [{family, tool, task, grasps, labels}]."""
    import itup_jax as itup
    from itup_jax.grasp_sampler import sample_reachable
    from itup_jax.tools import families

    out = []
    for kind in kinds:
        for s in range(EVAL_SEED, EVAL_SEED + tools):
            tool = families.draw(name, s)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                task = itup.make_task(kind, tool)
            g = sample_reachable(tool, task, grasps, seed=s).grasps
            out.append({"family": name, "tool": tool, "task": task, "grasps": g,
                        "labels": itup.simulate(tool, task, g, seed=s, randomize=None).labels})
    return out


def judge(model_path: str, ev: dict, verify: int) -> dict:
    """Checkpoint `model_path` (its guard reference beside it, `ood.reference_path`) on one evaluation
    tool of `family_rollouts`: Spearman of its torque and grip predictions against the measured full
    induced peak torque and grip demand (valid rollouts), the guard's score, and whether its learned and
    verified picks did the task and held."""
    import itup_jax as itup
    from itup_jax import ood
    from itup_jax.scoring import ScoreWeights
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.stats import spearman
    from itup_jax.verify import measured_total, objective_of

    model = load_model(model_path)
    tool, task, g, L = ev["tool"], ev["task"], ev["grasps"], ev["labels"]
    s = itup.score(tool, task, g, model=model)
    guard = ood.check(tool, task, g, model=model_path)
    valid = np.asarray(L.valid)
    ok = valid & np.asarray(L.success) & ~np.asarray(L.failed)
    total = np.asarray(s.total, float)
    measured = np.asarray(measured_total(L, ScoreWeights(), objective_of(s)), float)
    learned, verified = learned_and_verified_picks(total, measured, valid, verify)
    rho = spearman(np.asarray(s.tau, float)[valid], np.asarray(L.peak_torque_induced, float)[valid])
    rho_grip = spearman(np.asarray(s.grip, float)[valid], np.asarray(L.grip_demand, float)[valid])
    return {"tool": tool.name, "task": task.kind, "rho_induced": None if np.isnan(rho) else rho,
            "rho_grip": None if np.isnan(rho_grip) else rho_grip,
            "guard": None if guard is None else guard.score, "fired": bool(guard is not None and guard.fired),
            "learned_ok": bool(ok[learned]), "verified_ok": bool(ok[verified]), "any_ok": bool(ok.any()),
            "learned_success": bool(L.success[learned]), "learned_failed": bool(L.failed[learned]),
            "verified_success": bool(L.success[verified]), "verified_failed": bool(L.failed[verified])}


def summarise(rows: list[dict]) -> dict:
    """Over `judge` rows: the median Spearman (torque, grip), how often the guard fired, and the rates of
    the learned and verified picks' outcomes."""
    rho = [r["rho_induced"] for r in rows if r["rho_induced"] is not None]
    grip = [r["rho_grip"] for r in rows if r["rho_grip"] is not None]
    return {"tools": len(rows), "median_rho_induced": float(np.median(rho)) if rho else None,
            "median_rho_grip": float(np.median(grip)) if grip else None,
            "guard_fired": float(np.mean([r["fired"] for r in rows])),
            **{k: float(np.mean([r[k] for r in rows])) for k in
               ("learned_ok", "learned_success", "learned_failed", "verified_ok", "verified_success", "verified_failed")},
            "any_ok": float(np.mean([r["any_ok"] for r in rows]))}

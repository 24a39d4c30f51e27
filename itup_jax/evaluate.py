"""Evaluation against MuJoCo ground truth: every method picks a grasp from the same candidates, and the
picks are rolled out with the same trajectories, contacts and randomised physics.

    res = evaluate(tool, task, methods=("sdgnet", "force_closure", "geometric", "random"), n=256, seeds=5)
    res["methods"]["sdgnet"]["measured"]["peak_torque_induced"]["mean"]   # the headline (HEADLINE)

Candidates are antipodal samples whose task trajectory the arm can reach (closed-form IK,
`simulate.reachable`): an unreachable grasp is flagged and dropped here before any method sees the set, so no
method is credited or blamed for reachability. Each pick is rolled out `seeds` times; rollout k of
every method uses the same physics draw (`simulate(seed=...)` samples physics per row, and row k is
the same draw for every method). `sdgnet_verified` is SDG-Net's shortlist checked in MuJoCo
(`VERIFIED`), and `sdgnet_verified_torque` the torque-first verified pick (`VERIFIED_TORQUE`: a longer
shortlist by the torque-first total, `ScoreWeights.torque_first`, each grasp under three draws of the
priors); their times (`score_s`) include those check rollouts, which never share a physics draw with
the evaluation's rollouts.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from itup_jax import robot
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps
from itup_jax.grasp_sampler import sample_grasps
from itup_jax.scene import Scene, build_scene
from itup_jax.scoring import SCORERS, ScoreWeights, score
from itup_jax.simulate import Randomization, SimConfig, reachable, simulate
from itup_jax.task import Task
from itup_jax.tool import Tool
from itup_jax.verify import best_grasp_verified

#: Labels summarised per method: mean and std over seeds.
MEASURED = ("peak_torque_induced", "peak_torque", "peak_induced_closure", "peak_induced_approach",
            "peak_induced_third", "peak_torque_projected", "grip_demand", "slip_translation", "slip_rotation",
            "alignment_drift", "failed", "success")
#: The headline of a comparison of picks: the full peak induced wrist torque (all three axes, the static
#: holding torque removed), the paper's measure. The projected torque is the C_tau component a scorer
#: trained on it can lower by turning the jaw, so it is reported beside it, never ranked on.
HEADLINE = "peak_torque_induced"
#: SDG-Net's VERIFY_K best rolled out once more under nominal physics, the best measured kept
#: (`verify.best_grasp_verified`); its check rollouts are not among the evaluation's draws.
VERIFIED = "sdgnet_verified"
VERIFY_K = 5
#: The torque-first verified pick: SDG-Net's VERIFY_TORQUE_K best by the torque-first total
#: (`ScoreWeights.torque_first`: torque, and the task and grip penalties), each rolled out under
#: VERIFY_TORQUE_DRAWS draws of the priors, the lowest mean measured total kept (`itup plan --verify 10
#: --verify-draws 3 --torque-first`; chosen on the validation set, docs/results.md).
VERIFIED_TORQUE = "sdgnet_verified_torque"
VERIFY_TORQUE_K = 10
VERIFY_TORQUE_DRAWS = 3
#: Every method `evaluate` takes: the scorers and the verified picks.
METHODS = SCORERS + (VERIFIED, VERIFIED_TORQUE)
DEFAULT_METHODS = ("sdgnet", "sdgnet_paper", VERIFIED, VERIFIED_TORQUE, "analytic", "analytic_wrench", "static",
                   "force_closure", "geometric", "random")


def feasible_candidates(tool: Tool, task: Task, n: int, *, seed: int = 0,
                        oversample: int = 4) -> tuple[Grasps, dict]:
    """Up to n sampled grasps whose trajectory the arm can follow (`simulate.reachable`); also {'sampled',
    'feasible', 'used'} counts."""
    g = sample_grasps(tool, oversample * n, seed=seed)
    ok = np.nonzero(reachable(task, g))[0]
    if len(ok) == 0:
        raise InputError(f"evaluate: none of {len(g)} sampled grasps of {tool.name!r} can follow the "
                         f"{task.kind} trajectory (all IK-infeasible)")
    return g[ok[:n]], {"sampled": int(len(g)), "feasible": int(len(ok)), "used": int(min(n, len(ok)))}


def _summary(v: np.ndarray) -> dict[str, float]:
    v = np.asarray(v, float)
    return {"mean": float(np.nanmean(v)), "std": float(np.nanstd(v)), "n": int(np.isfinite(v).sum())}


def evaluate(tool: Tool, task: Task, methods: Sequence[str] = DEFAULT_METHODS, *, n: int = 256, seeds: int = 5,
             seed: int = 0, scene: Scene | None = None, candidates: Grasps | None = None,
             randomize: Randomization | None = Randomization(), model: Any = None,
             grip_force: float | None = None) -> dict[str, Any]:
    """Each method's pick among the same candidates and its MuJoCo-measured labels over `seeds` rollouts.

    grip_force: N per pad of the evaluation's rollouts, fixed (not randomised); None: the default
    (`SimConfig.grip_force`, randomised with the other priors). Below the gripper's 20 N the rollouts
    are a robustness probe (`stress.probe_scene`) and the result's "grip_probe" says so. The picks
    themselves (and the verified picks' check rollouts) do not depend on it.

    Returns {"candidates": counts, "methods": {name: {"index", "grasp", "score", "p_success", "p_failed", "score_s",
    "measured": {label: {mean, std, n}}, "rollouts": {label: [seeds]}}}}; `sdgnet_verified` and
    `sdgnet_verified_torque` also have "verified": {k, draws, weights, physics, tried (the candidates
    rolled out to check), chosen_by, unreachable (how many candidates were skipped as unreachable: 0
    unless `candidates` given here holds unreachable ones), succeeded (the pick did the task and held in
    every check rollout; False: no verified grasp did, and the pick is only the least bad)}. The torque-first pick's check rollouts draw
    their physics from seed + 1 (with `randomize`, or the default spreads when it is None), the
    evaluation's rollouts from seed.
    """
    unknown = [m for m in methods if m not in METHODS]
    if unknown or not methods:
        raise InputError(f"evaluate: methods must be among {METHODS}, got {list(methods)}")
    if seeds < 1 or n < 1:
        raise InputError(f"evaluate: need seeds >= 1 and n >= 1, got seeds={seeds}, n={n}")
    scene = scene or build_scene(tool, task)
    sim_scene, config, sim_randomize = scene, SimConfig(), randomize
    if grip_force is not None:
        from itup_jax import stress

        g = stress.check_grip(grip_force, "evaluate")
        config = SimConfig(grip_force=g)
        sim_scene, sim_randomize = stress.fixed_grip(scene, randomize, g)
    if candidates is None:
        candidates, counts = feasible_candidates(tool, task, n, seed=seed)
    else:
        counts = {"given": len(candidates)}
    out: dict[str, Any] = {"task": task.kind, "tool": tool.name, "seeds": seeds, "seed": seed,
                           "candidates": counts, "grip_force": config.grip_force, "grip_fixed": grip_force is not None,
                           "grip_probe": grip_force is not None and config.grip_force < robot.GRIPPER_MIN_GRIP_FORCE,
                           "methods": {}}
    for name in methods:
        t0 = time.perf_counter()
        sdg = name in ("sdgnet", VERIFIED, VERIFIED_TORQUE)
        weights = ScoreWeights.torque_first() if name == VERIFIED_TORQUE else ScoreWeights()
        s = score(tool, task, candidates, model=(model if sdg and model is not None else "sdgnet" if sdg else name),
                  seed=seed, weights=weights)
        verified = None
        if name == VERIFIED:
            v = best_grasp_verified(tool, task, candidates, k=VERIFY_K, seed=seed, scores=s, scene=scene)
            verified = {"k": VERIFY_K, "draws": 1, "weights": "default", "physics": "nominal"}
        elif name == VERIFIED_TORQUE:
            v = best_grasp_verified(tool, task, candidates, k=VERIFY_TORQUE_K, draws=VERIFY_TORQUE_DRAWS, seed=seed + 1,
                                    randomize=randomize or Randomization(), weights=weights, scores=s, scene=scene)
            verified = {"k": VERIFY_TORQUE_K, "draws": VERIFY_TORQUE_DRAWS, "weights": "torque_first", "physics": "random"}
        if verified is not None:
            i = v.index
            verified.update(tried=[int(j) for j in v.shortlist], chosen_by=v.chosen_by, unreachable=len(v.unreachable),
                            succeeded=v.succeeded)
        else:
            i = int(np.argmin(np.asarray(s.total, float)))
        dt = time.perf_counter() - t0
        total = np.asarray(s.total, float)
        g = candidates[i]
        reps = Grasps(*(np.repeat(np.asarray(a)[None], seeds, axis=0) for a in
                        (g.p_tool_grasp, g.q_tool_grasp, g.width)))
        res = simulate(tool, task, reps, scene=sim_scene, seed=seed, randomize=sim_randomize, config=config)
        L = res.labels
        rollouts = {f: np.where(L.valid, getattr(L, f).astype(float), np.nan) for f in MEASURED}
        out["methods"][name] = {
            "index": i,
            "grasp": {"p_tool_grasp_m": np.asarray(g.p_tool_grasp, float).round(6).tolist(),
                      "q_tool_grasp_wxyz": np.asarray(g.q_tool_grasp, float).round(6).tolist(),
                      "width_m": round(float(g.width), 6)},
            "score": float(total[i]),
            # SDG-Net's predicted probability that the pick achieves the task (None: the scorer does not predict it)
            "p_success": None if s.p_success is None else float(np.asarray(s.p_success)[i]),
            "p_failed": None if s.p_failed is None else float(np.asarray(s.p_failed)[i]),
            "p_failed_weak": None if s.p_failed_weak is None else float(np.asarray(s.p_failed_weak)[i]),
            "score_s": round(dt, 4),
            "valid_rollouts": int(L.valid.sum()),
            "measured": {f: _summary(v) for f, v in rollouts.items()},
            "rollouts": {f: [None if not np.isfinite(x) else float(x) for x in v] for f, v in rollouts.items()},
        }
        if verified is not None:
            out["methods"][name]["verified"] = verified
    return out


def reduction(ours: float, theirs: float) -> float:
    """Percentage by which `ours` is lower than `theirs` (positive: ours is lower)."""
    return float("nan") if not np.isfinite(theirs) or theirs == 0 else 100.0 * (1.0 - ours / theirs)




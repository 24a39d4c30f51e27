"""Evaluation against MuJoCo ground truth: every method picks a grasp from the same candidates, and the
picks are rolled out with the same trajectories, contacts and randomised physics; `stress_picks` also
stresses each pick at weaker grips (its least holding grip).

    res = evaluate(tool, task, methods=("sdgnet", "force_closure", "geometric", "random"), n=256, seeds=5)
    res["methods"]["sdgnet"]["measured"]["peak_torque_induced"]["mean"]   # the headline (HEADLINE)

Candidates are antipodal samples whose task trajectory the arm can reach (closed-form IK,
`sim.arm.reachable`): an unreachable grasp is flagged and dropped here before any method sees the set, so no
method is credited or blamed for reachability. Each pick is rolled out `seeds` times; rollout k of
every method uses the same physics draw (`simulate(seed=...)` samples physics per row, and row k is
the same draw for every method). `sdgnet_verified` is `itup plan`'s default pick, SDG-Net's shortlist
checked in MuJoCo (`VERIFIED`), and `sdgnet_verified_torque` the torque-first verified pick (`VERIFIED_TORQUE`: a longer
shortlist by the torque-first total, `ScoreWeights.torque_first`, each grasp under three draws of the
priors); their times (`score_s`) include those check rollouts, which never share a physics draw with
the evaluation's rollouts.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from itup_jax import robot, stress
from itup_jax.dataset import GenerateConfig, unit_tool
from itup_jax.dataset_load import read_manifest
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps
from itup_jax.grasp_sampler import MAX_CANDIDATES, sample_grasps
from itup_jax.planning import DEFAULT_VERIFY, guarded_check
from itup_jax.scoring import SCORERS, ScoreWeights, score
from itup_jax.sim.arm import reachable
from itup_jax.sim.config import SimConfig
from itup_jax.sim.physics import Randomization
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import Scene, build_scene
from itup_jax.stats import failure_threshold, paired_ratio
from itup_jax.task import DEFAULT_TOOL, Task, make_task
from itup_jax.tools import Tool, load_tool
from itup_jax.tools.variants import vary_tool
from itup_jax.verify import best_grasp_verified

#: Labels summarised per method: mean and std over seeds.
MEASURED = ("peak_torque_induced", "peak_torque", "peak_induced_closure", "peak_induced_approach",
            "peak_induced_third", "peak_torque_projected", "grip_demand", "slip_translation", "slip_rotation",
            "alignment_drift", "failed", "success")
#: The headline of a comparison of picks: the full peak induced wrist torque (all three axes, the static
#: holding torque removed), the paper's measure. The projected torque is the C_tau component a scorer
#: trained on it can lower by turning the jaw, so it is reported beside it, never ranked on.
HEADLINE = "peak_torque_induced"
#: `itup plan`'s default pick (`planning.guarded_check`): SDG-Net's VERIFY_K best rolled out once more
#: under nominal physics and again at the weak grip (`robot.WEAK_GRIP`), the best measured kept; when the
#: out-of-distribution guard fires, `planning.GUARD_VERIFY_K` of a shortlist that mixes in the analytic
#: wrench cost's best. Its check rollouts are not among the evaluation's draws.
VERIFIED = "sdgnet_verified"
VERIFY_K = DEFAULT_VERIFY
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
    """Up to n sampled grasps whose trajectory the arm can follow (`sim.arm.reachable`); also {'sampled',
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

    methods: names of `METHODS`, or a network under weights of its own, 'sdgnet@w_align=100,w_grip=0.05'
      (`method_scorer`; 'sdgnet' is `model` when given).
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
    weighted = check_methods(methods, "evaluate: methods")  # a bad one is named before any work
    if seeds < 1 or n < 1:
        raise InputError(f"evaluate: need seeds >= 1 and n >= 1, got seeds={seeds}, n={n}")
    if n > MAX_CANDIDATES:
        raise InputError(f"evaluate: n must be at most {MAX_CANDIDATES:,} candidates, got {n:,}")
    scene = scene or build_scene(tool, task)
    sim_scene, config, sim_randomize = scene, SimConfig(), randomize
    if grip_force is not None:
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
        if name in weighted:  # a network under weights of its own: its pick by that total
            base, weights = weighted[name]
            scorer = model if base == "sdgnet" and model is not None else base
        else:
            sdg = name in ("sdgnet", VERIFIED, VERIFIED_TORQUE)
            weights = ScoreWeights.torque_first() if name == VERIFIED_TORQUE else ScoreWeights()
            scorer = model if sdg and model is not None else "sdgnet" if sdg else name
        s = score(tool, task, candidates, model=scorer, seed=seed, weights=weights)
        verified = None
        if name == VERIFIED:
            v, reading, rule = guarded_check(tool, task, candidates, s, model=model, k=VERIFY_K, seed=seed, scene=scene)
            verified = {"k": VERIFY_K, "draws": 1, "weights": "default", "physics": "nominal",
                        "weak_grip": v.weak_grip, "guard_fired": bool(reading.fired), "shortlist_rule": rule}
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


# ---------------------------------------------------------------------------------------------------
# Methods' picks under grip stress (the experiments' grip stress and weight choice)
# ---------------------------------------------------------------------------------------------------
def split_methods(text: str) -> tuple[str, ...]:
    """'sdgnet@w_align=0,w_grip=0,force_closure' -> ('sdgnet@w_align=0,w_grip=0', 'force_closure'): a
    comma-separated list of methods (`method_scorer`), where a NAME=VALUE item continues the weights of
    the method before it. InputError for a NAME=VALUE item with no method before it."""
    out: list[str] = []
    for part in (p.strip() for p in text.split(",")):
        if not part:
            continue
        if "=" in part and "@" not in part:
            if not out or "@" not in out[-1]:
                raise InputError(f"methods {text!r}: {part!r} is a weight with no 'method@' before it "
                                 "(e.g. sdgnet@w_align=0,w_grip=0)")
            out[-1] += "," + part
        else:
            out.append(part)
    return tuple(out)


def check_methods(methods: Sequence[str], flag: str = "methods") -> dict[str, tuple[str, ScoreWeights]]:
    """{name: (network, weights)} of the methods that carry weights of their own (`method_scorer`), after
    checking that every method is a name of `METHODS` or such a network. InputError naming `flag` and the
    bad entry."""
    try:
        weighted = {m: method_scorer(m) for m in methods if "@" in m}
    except InputError as e:
        raise InputError(f"{flag}: {e}") from None
    bad = [m for m in methods if m not in METHODS and m not in weighted]
    if bad or not methods:
        raise InputError(f"{flag}: unknown {bad or 'empty list'}; choose from {','.join(METHODS)}, "
                         "or sdgnet@NAME=VALUE,... (the network under other weights)")
    return weighted


def parse_methods(text: str, flag: str = "methods") -> tuple[str, ...]:
    """The methods of a comma-separated list (`split_methods`), checked (`check_methods`)."""
    try:
        methods = split_methods(text)
    except InputError as e:
        raise InputError(f"{flag}: {e}") from None
    check_methods(methods, flag)
    return methods


def method_scorer(method: str) -> tuple[str, ScoreWeights]:
    """'sdgnet@w_align=30,w_grip=0.05' -> ('sdgnet', ScoreWeights with those fields) (a checkpoint path
    'm.npz@w_weak=3' in place of 'sdgnet' scores with that network); a plain name or path ->
    (name, the default weights). InputError naming the method for an unknown or malformed weight."""
    if "@" not in method:
        return method, ScoreWeights()
    model, spec = method.split("@", 1)
    if model not in ("sdgnet", "sdgnet_paper") and not model.endswith(".npz"):
        raise InputError(f"method {method!r}: weights apply to 'sdgnet', 'sdgnet_paper' or a checkpoint (.npz), "
                         f"not {model!r}")
    known = {f.name for f in dataclasses.fields(ScoreWeights)}
    kw = {}
    for part in spec.split(","):
        k, eq, v = part.partition("=")
        if not eq or k not in known:
            raise InputError(f"method {method!r}: expected NAME=VALUE with NAME one of {', '.join(sorted(known))}, "
                             f"got {part!r}")
        try:
            kw[k] = float(v)
        except ValueError:
            raise InputError(f"method {method!r}: {k} must be a number, got {v!r}") from None
    return model, ScoreWeights(**kw)


def data_config(data: str, tasks, tools_per_task: int) -> GenerateConfig:
    """The GenerateConfig of the dataset in `data`, checked to hold `tools_per_task` unseen tools of every
    task in `tasks` (InputError naming what is missing); builds no tool."""
    config = GenerateConfig.from_json(read_manifest(data)["config"])
    missing = [k for k in tasks if k not in config.tasks]
    if missing:
        raise InputError(f"--data {data}: the dataset has no {', '.join(map(repr, missing))} tools "
                         f"(its tasks: {', '.join(config.tasks)})")
    if tools_per_task > config.tools_per_task - 1:
        raise InputError(f"--data {data}: it has {config.tools_per_task - 1} unseen tools per task, "
                         f"asked for {tools_per_task}")
    return config


def stress_tools(kind: str, tools_per_task: int, data: str | None = None) -> list[tuple[int, object]]:
    """[(v, Tool)]: the built-in tool and table1's unseen variants (seeds 10,000 + v), or with `data`
    the dataset's variants 1 .. tools_per_task (its unseen tools, `data_config`)."""
    if data is None:
        base = load_tool(DEFAULT_TOOL[kind])
        return [(v, base if v == 0 else vary_tool(base, 10_000 + v)) for v in range(tools_per_task)]
    config = data_config(data, (kind,), tools_per_task)
    return [(v, unit_tool(config, kind, v)[0]) for v in range(1, tools_per_task + 1)]


def stress_picks(tasks, tools_per_task, n, methods, grid, draws, tol, seed=0, log=print, data=None) -> dict:
    """Each method's pick on each tool, stressed: per task the built-in tool and `tools_per_task - 1` unseen
    stretched variants (`stress_tools`), each method (`method_scorer`) picking the lowest total score among
    the same `n` reachable candidates (VERIFIED: `itup plan`'s pick, `planning.guarded_check`) (methods that pick the same candidate share its rollouts); each pick
    rolled out `draws` times at every force of `grid` (N per pad; the grip fixed, the other priors
    randomised; draw d the same physics for every pick) and its least holding grip found by bisection to
    `tol` N (`stress.pick_min_holding_grip`, the grid's answers reused). Returns {"rows": one per (task, tool,
    method), "summary": per task and method (median least holding grip, failure and success by grip, the
    logistic 50 % failure torque `stats.failure_threshold`), "pooled_failure_threshold"}.
    `experiments/grip_stress.py` and `experiments/weight_by_stress.py` are this and a report."""
    scorers = {m: method_scorer(m) for m in methods}  # bad method names fail before any rollout
    rows = []  # one per (task, tool, method)
    rollouts = {k: {"torque": [], "failed": []} for k in tasks}
    for kind in tasks:
        for v, tool in stress_tools(kind, tools_per_task, data):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a stretched tool may exceed the speed limit
                task = make_task(kind, tool)
            scene = build_scene(tool, task)
            t0 = time.perf_counter()
            cands, _ = feasible_candidates(tool, task, n, seed=seed + v)
            done: dict[int, dict] = {}  # candidate index -> its stress row (methods that pick it share it)
            for m in methods:
                model, weights = scorers[m]
                if m == VERIFIED:  # `itup plan`'s pick: SDG-Net's shortlist checked in MuJoCo
                    s = score(tool, task, cands, weights=weights, seed=seed + v)
                    i = int(guarded_check(tool, task, cands, s, k=VERIFY_K, seed=seed + v, scene=scene)[0].index)
                else:
                    i = int(np.argmin(np.asarray(score(tool, task, cands, model=model, weights=weights,
                                                       seed=seed + v).total, float)))
                if i in done:
                    rows.append({**done[i], "method": m})
                    continue
                pick = cands[i:i + 1]
                cache: dict[float, bool] = {}
                at = {}
                for g in grid:
                    L = stress.rollouts_at_grip(tool, task, pick, g, draws=draws, seed=seed + v, scene=scene)
                    cache[float(g)] = bool(stress.holds(L, draws)[0])
                    ok = np.asarray(L.valid)
                    at[float(g)] = {"failed": float(np.mean(L.failed[ok])) if ok.any() else None,
                                    "success": float(np.mean(L.success[ok])) if ok.any() else None,
                                    "holds": cache[float(g)], "probe": stress.is_probe(g),
                                    "peak_torque_induced": float(np.mean(L.peak_torque_induced[ok])) if ok.any() else None}
                    rollouts[kind]["torque"] += np.asarray(L.peak_torque_induced)[ok].tolist()
                    rollouts[kind]["failed"] += np.asarray(L.failed)[ok].tolist()

                mg = stress.pick_min_holding_grip(tool, task, pick, draws=draws, seed=seed + v, scene=scene, tol=tol,
                                                  grid=grid, known=cache)  # the grid's answers reused
                done[i] = {"task": kind, "tool": tool.name, "unseen": v > 0, "method": m, "index": i,
                           "min_holding_grip_N": mg.force, "monotone": mg.monotone, "probe": mg.probe,
                           "tried": {f"{f:g}": ok for f, ok in sorted(mg.tried.items())}, "at_grip": at}
                rows.append(done[i])
            log(f"{kind:7s} {tool.name:12s} {time.perf_counter() - t0:5.1f} s  " + "  ".join(
                f"{r['method']} {r['min_holding_grip_N'] if r['min_holding_grip_N'] is None else round(r['min_holding_grip_N'], 1)} N"
                for r in rows if r["task"] == kind and r["tool"] == tool.name))
    summary = {}
    for kind in tasks:
        summary[kind] = {}
        for m in methods:
            mine = [r for r in rows if r["task"] == kind and r["method"] == m]
            forces = [np.inf if r["min_holding_grip_N"] is None else r["min_holding_grip_N"] for r in mine]
            med = float(np.median(forces)) if forces else None
            summary[kind][m] = {
                "median_min_holding_grip_N": None if med is None or not np.isfinite(med) else med,
                "never_held": int(sum(r["min_holding_grip_N"] is None for r in mine)),
                "non_monotone": int(sum(not r["monotone"] for r in mine)), "tools": len(mine),
                "by_grip": {f"{g:g}": {k: _mean_of_given([r["at_grip"][float(g)][k] for r in mine]) for k in ("failed", "success")}
                            for g in grid},
            }
        summary[kind]["failure_threshold"] = failure_threshold(rollouts[kind]["torque"], rollouts[kind]["failed"])
    pooled = failure_threshold(sum((rollouts[k]["torque"] for k in tasks), []), sum((rollouts[k]["failed"] for k in tasks), []))
    return {"rows": rows, "summary": summary, "pooled_failure_threshold": pooled}


def _mean_of_given(values):
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


#: The headline first (the full induced peak wrist torque, the paper's measure), then the raw peak, the
#: induced torque's grasp-frame components at its peak, the projected torque (the C_tau component), the
#: grip demand (N per pad).
COLUMNS = ("peak_torque_induced", "peak_torque", "peak_induced_closure", "peak_induced_approach", "peak_induced_third",
           "peak_torque_projected", "grip_demand", "slip_translation", "slip_rotation", "alignment_drift", "failed",
           "success")


#: The paired comparisons: the headline, the raw peak, the closure-axis component, the grip demand.
PAIRED_MEASURES = ("peak_torque_induced", "peak_torque", "peak_induced_closure", "grip_demand")


def compare_on_tools(tasks, tools_per_task: int, n: int, seeds: int, methods, seed: int = 0, log=print, model=None,
                     timestep: float | None = None) -> dict:
    """Table I's measurement: per task the built-in tool and `tools_per_task - 1` unseen stretched variants
    (`tools.variants.vary_tool`, seeds 10,000 + v, none of which a training shard used), each `evaluate`d
    (every method's pick among the same `n` reachable candidates, `seeds` paired draws). Returns {"table":
    per task and method the mean and std over tools and draws of `COLUMNS` and SDG-Net's reductions against
    every other method, "paired": `paired_reductions` of SDG-Net, "paired_paper_objective": those of its
    paper-objective checkpoint, "paired_planner": those of `itup plan`'s default pick (VERIFIED), "per_tool":
    each tool's `evaluate` result}. `experiments/table1.py` is this
    and its tables and plots."""
    per_tool = []
    for kind in tasks:
        base = load_tool(DEFAULT_TOOL[kind])
        for v in range(tools_per_task):
            tool = base if v == 0 else vary_tool(base, 10_000 + v)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)  # a stretched tool may exceed the speed limit: flagged
                task = make_task(kind, tool)
            t0 = time.perf_counter()
            res = evaluate(tool, task, methods, n=n, seeds=seeds, seed=seed + v, model=model,
                           scene=build_scene(tool, task, timestep=timestep))
            log(f"{kind:7s} {tool.name:12s} {time.perf_counter() - t0:5.1f} s  " + "  ".join(
                f"{m} {res['methods'][m]['measured']['peak_torque_induced']['mean']:.2f}" for m in methods))
            per_tool.append(res)
    table = {}
    for kind in tasks:
        rows = [r for r in per_tool if r["task"] == kind]
        table[kind] = {}
        for m in methods:
            cell = {}
            for c in COLUMNS:
                v = np.concatenate([np.asarray(r["methods"][m]["rollouts"][c], dtype=float) for r in rows])
                cell[c] = {"mean": float(np.nanmean(v)) if np.isfinite(v).any() else None,
                           "std": float(np.nanstd(v)) if np.isfinite(v).any() else None, "n": int(np.isfinite(v).sum())}
            table[kind][m] = cell
        if "sdgnet" in methods:
            ours = table[kind]["sdgnet"]
            # against the other methods, not SDG-Net's own verified pick (it is SDG-Net too)
            others = [m for m in methods if not m.startswith("sdgnet")]
            table[kind]["sdgnet_torque_reduction_pct"] = {
                m: reduction(ours["peak_torque_projected"]["mean"] or np.nan,
                             table[kind][m]["peak_torque_projected"]["mean"] or np.nan)
                for m in others}
            table[kind]["sdgnet_induced_torque_reduction_pct"] = {
                m: reduction(ours["peak_torque_induced"]["mean"] or np.nan,
                             table[kind][m]["peak_torque_induced"]["mean"] or np.nan)
                for m in others}
            table[kind]["sdgnet_raw_torque_reduction_pct"] = {
                m: reduction(ours["peak_torque"]["mean"] or np.nan, table[kind][m]["peak_torque"]["mean"] or np.nan)
                for m in others}
            table[kind]["sdgnet_failure_rate_ratio"] = {
                m: (None if not table[kind][m]["failed"]["mean"] else ours["failed"]["mean"] / table[kind][m]["failed"]["mean"])
                for m in others}
    return {"table": table, "paired": paired_reductions(per_tool, tasks, methods),
            "paired_paper_objective": paired_reductions(per_tool, tasks, methods, ours="sdgnet_paper"),
            "paired_planner": paired_reductions(per_tool, tasks, methods, ours=VERIFIED), "per_tool": per_tool}


#: The interval of the paired reductions: 90 % over tools.
PAIRED_LEVEL = 0.90


def paired_reductions(per_tool: list, tasks, methods, measures=PAIRED_MEASURES, ours: str = "sdgnet") -> dict:
    """Per task, measure and baseline: the reduction of `ours` (SDG-Net, its paper-objective
    checkpoint "sdgnet_paper", or `itup plan`'s default pick VERIFIED) against the baseline, paired tool by tool (each
    tool's mean over its draws; the same candidates and draws for both), as 100 (1 - geometric-mean ratio)
    with a PAIRED_LEVEL bootstrap interval over tools (`stats.paired_ratio`), on the unseen variants alone
    and on every tool."""
    out = {}
    if ours not in methods:
        return out
    for kind in tasks:
        rows = [r for r in per_tool if r["task"] == kind]
        out[kind] = {}
        for meas in measures:
            out[kind][meas] = {}
            for m in [m for m in methods if not m.startswith("sdgnet")]:
                entry = {}
                for subset, keep in (("unseen", lambda i: i > 0), ("all", lambda i: True)):
                    sel = [r for i, r in enumerate(rows) if keep(i)]
                    a = [r["methods"][ours]["measured"][meas]["mean"] for r in sel]
                    b = [r["methods"][m]["measured"][meas]["mean"] for r in sel]
                    pr = paired_ratio(np.array(a, float), np.array(b, float), level=PAIRED_LEVEL)
                    pct = lambda x: None if x is None else 100.0 * (1.0 - x)  # noqa: E731
                    entry[subset] = {"reduction_pct": pct(pr["ratio"]), "n_tools": pr["n"],
                                     "interval_pct": None if pr["ci"] is None else [pct(pr["ci"][1]), pct(pr["ci"][0])],
                                     "tools_lower": pr["lower"], "tools_higher": pr["higher"]}
                out[kind][meas][m] = entry
    return out


def table(res: dict) -> str:
    """Per method, mean ± std over its rollouts: the full induced peak wrist torque (the headline), the raw
    peak, the induced torque's grasp-frame components at its peak (about the jaw's closure axis, the
    approach axis, the third axis), the projected torque (the C_tau component), slip, turn in the pads,
    alignment drift, grip failure and task success; `res` is `evaluate`'s result. `itup evaluate` and
    `itup demo` print it."""
    lines = [f"{'method':>22} {'tau_ind N·m':>12} {'tau_raw N·m':>12} {'closure':>8} {'approach':>8} {'third':>8} "
             f"{'tau_proj':>9} {'grip N':>7} {'slip mm':>10} {'turn deg':>9} {'drift deg':>9} {'fail':>5} {'task':>5}  "
             "grasp (tool frame, m)"]
    for name, r in res["methods"].items():
        m = r["measured"]

        def ms(k, scale=1.0, w=5, p=2):
            return f"{scale * m[k]['mean']:{w}.{p}f}±{scale * m[k]['std']:<{w}.{p}f}"

        def mean(k, scale=1.0, w=8, p=2):
            return f"{scale * m[k]['mean']:>{w}.{p}f}"
        lines.append(f"{name:>22} {ms('peak_torque_induced', w=5)} {ms('peak_torque', w=5)} "
                     f"{mean('peak_induced_closure')} {mean('peak_induced_approach')} {mean('peak_induced_third')} "
                     f"{mean('peak_torque_projected', w=9)} {mean('grip_demand', w=7, p=0)} "
                     f"{ms('slip_translation', 1e3, 4, 1)} {mean('slip_rotation', 180 / np.pi, 9, 1)} "
                     f"{mean('alignment_drift', 180 / np.pi, 9, 1)} {m['failed']['mean']:>5.2f} "
                     f"{m['success']['mean']:>5.2f}  {r['grasp']['p_tool_grasp_m']}")
    lines.append("tau_ind: full peak induced wrist torque (static holding torque removed, all axes; the headline); "
                 "closure/approach/third: its grasp-frame components at that peak (N·m); tau_proj: the part off the "
                 "closure axis, the paper's C_tau component (N·m); grip: the normal force per pad the induced wrench "
                 "needs (N); turn: the tool's turn in the pads")
    return "\n".join(lines)

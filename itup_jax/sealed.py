"""The sealed evaluation's protocol (docs/results.md, "The sealed evaluation"): how its test tools are
drawn, what is measured on each, and how a run is summarised. `experiments/sealed_eval.py` runs it once
per round; `experiments/sealed_reopen.py` re-plans, re-measures or re-ranks a finished run's tools.

    tools = sealed_tools(checkpoint + round_salt(6), "knock")    # [{i, seed, kind, family, tool}] x 16
    row = evaluate_tool(tools[0], "knock", n=256, draws=5, weak=True, with_fidelity=True)
    summary = summarise(rows)                                     # per task: reductions, grip, fidelity

Test tool i of task k is drawn from the first 8 bytes, big-endian, of SHA-256(checkpoint bytes || salt ||
k || i) (`sealed_seed`): no one chooses it, and a new checkpoint or round (`round_salt`) draws new ones.
Half are part-wise variants of the task's built-in tool, half draws of its other families. Per tool the
picks of every method (`METHODS`: `itup plan`'s default and the analytic and baseline rankings) are rolled
out under the same randomised physics draws (seed `PICK_SEED`), at 25 N per pad (`GRIP_SEED`), and every
candidate once more for the fidelity (`FIDELITY_SEED`) and, from round 6, `REDRAWS` more times (seeds
`RETEST_SEED` + r) for the ceiling one rollout's noise sets on it. The headline is the full induced peak wrist torque
(`evaluate.MEASURED`'s first), paired per tool against force closure, geometric ranking and the better of
the two. Nothing here is jit-compiled itself: the rollouts are MuJoCo's, the scorers jit at their own
outer calls.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import warnings

import numpy as np

from itup_jax.costs import wrench_costs
from itup_jax.dataset import WEAK_GRIP
from itup_jax.errors import InputError
from itup_jax.evaluate import MEASURED
from itup_jax.grasp_sampler import sample_reachable
from itup_jax.planning import DEFAULT_VERIFY, GUARD_VERIFY_K, default_pick
from itup_jax.scoring import score
from itup_jax.sdgnet.objective import OBJECTIVES
from itup_jax.sim.physics import Randomization
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import build_scene
from itup_jax.stats import paired_ratio, spearman
from itup_jax.stress import rollouts_at_grip
from itup_jax.task import DEFAULT_TOOL, make_task
from itup_jax.tools import families
from itup_jax.tools.variants import part_variant
from itup_jax.verify import weak_failures as _weak_failed

TASKS = ("hammer", "sweep", "knock", "reach")
PLANNER = "planner"
METHODS = (PLANNER, "analytic", "analytic_wrench", "force_closure", "geometric")
BASELINES = ("force_closure", "geometric")
#: The paper's margins over its baselines (arXiv:2505.01399v3, Table I), % per task.
PAPER = {"gqcnn": {"hammer": 17.6, "sweep": 17.5, "knock": 11.6, "reach": 20.8},
         "graspnet": {"hammer": 10.2, "sweep": 14.3, "knock": 10.4, "reach": 13.5}}
#: Appended to the checkpoint's bytes for --quick's tools: never the sealed ones.
QUICK_SALT = b"/quick"
#: The round of the sealed evaluation this code runs: round 1 (0.25.0) drew its tools from the
#: checkpoint's bytes alone; round r > 1 appends `round_salt(r)`, so that an unchanged checkpoint draws
#: tools no one has seen. Rounds 1 to 6 have run; round 7 draws once new sealed-test families exist.
ROUND = 7
#: Seeds of the rollouts: the pick draws, the weak-grip draws, the fidelity draw.
PICK_SEED, GRIP_SEED, FIDELITY_SEED = 11, 12, 13
#: sealed_reopen.py --headroom R: draw r of every candidate uses seed HEADROOM_SEED + r.
HEADROOM_SEED = 100
#: `fidelity(..., redraws=R)`: redraw r of the fidelity draw uses seed RETEST_SEED + r.
RETEST_SEED = 200
#: The fidelity draw's redraws in a sealed round from round 6 (rounds 1 to 5 had none; their tools were
#: redrawn after, `experiments/sealed_reopen.py --fidelity-of --redraws`): every scorer is also ranked
#: against the mean of 1 + REDRAWS draws, beside the retest ceiling of one draw.
REDRAWS = 2
#: The fidelity goals for SDG-Net's median per-tool Spearman per task (docs/results.md, "The fidelity
#: goals and the noise of one rollout"): on the built-in families' variants and on the other families' tools.
FIDELITY_GOAL = {"builtin": 0.85, "other": 0.7}
#: Grasps the planners up to itup-jax 0.28.0 verified where the guard fired (max(verify, 5); their runs
#: record no `guard_verify`), for sealed_reopen.py to replay them
EARLIER_GUARD_VERIFY = 5


def sealed_seed(checkpoint: bytes, task: str, i: int) -> int:
    """The seed of test tool `i` of `task`: the first 8 bytes, big-endian, of SHA-256(checkpoint || task || i)."""
    h = hashlib.sha256(checkpoint + task.encode() + str(int(i)).encode()).digest()
    return int.from_bytes(h[:8], "big")


def round_salt(r: int) -> bytes:
    """What round r appends to the checkpoint's bytes before the seeds are drawn: nothing for round 1,
    b"/round<r>" after it."""
    if int(r) < 1:
        raise ValueError(f"round must be >= 1, got {r}")
    return b"" if int(r) == 1 else f"/round{int(r)}".encode()


def other_families(task: str) -> list[str]:
    """The families no training set holds that do `task`: the held-out ones, then the sealed-test ones of
    this round (`families.sealed()`, never rolled out before this evaluation; the earlier rounds' are
    `families.validation()` and drawn no more), in `families.names()` order."""
    return [n for n in families.held_out() + families.sealed() if task in families.get(n).tasks]


def sealed_tools(checkpoint: bytes, task: str, per_task: int = 16) -> list[dict]:
    """[{i, seed, kind, family, tool}] of a task: the first half part-wise variants of its built-in tool,
    the rest draws of its other families in turn."""
    half, fams, out = per_task // 2, other_families(task), []
    for i in range(per_task):
        entry = {"i": i, "seed": sealed_seed(checkpoint, task, i)}
        if i < half or not fams:
            entry.update(kind="builtin", family=DEFAULT_TOOL[task])
        else:
            entry.update(kind="other", family=fams[(i - half) % len(fams)])
        out.append({**entry, "tool": rebuild_tool(entry)})
    return out


def planner_pick(tool, task, grasps, scene, verify: int = DEFAULT_VERIFY, weak_grip: float | None = WEAK_GRIP,
                 guard_verify: int = GUARD_VERIFY_K, model: str | None = None,
                 guard_threshold: float | None = None) -> tuple[int | None, dict]:
    """`itup plan`'s default pick among `grasps` (`planning.default_pick`): SDG-Net's scores, the guard,
    `verify` grasps rolled out under nominal physics (max(verify, guard_verify) of the guard's shortlist
    where it fired), each again at
    `weak_grip` N per pad, the lowest measured total kept; None when none of them did the task and held
    (`itup plan` then recommends no grasp). verify 0 and weak_grip None: the planner of 0.25.0 (verified
    only when the guard fired, at the default grip alone). `model` and `guard_threshold`: another
    checkpoint and its guard's threshold (None: the shipped ones)."""
    index, info = default_pick(tool, task, grasps, scene=scene, verify=verify, weak_grip=weak_grip,
                               guard_verify=guard_verify, model=model, guard_threshold=guard_threshold)
    info.pop("shortlist", None)
    return index, info


def measure(tool, task, scene, g, i: int, draws: int) -> dict:
    """The means over `draws` randomised rollouts of grasp i (`evaluate.MEASURED`; NaN where none is valid)."""
    reps = g[np.full(draws, i)]
    L = simulate(tool, task, reps, scene=scene, seed=PICK_SEED, randomize=Randomization()).labels
    ok = np.asarray(L.valid)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        out = {f: float(np.nanmean(np.where(ok, np.asarray(getattr(L, f), float), np.nan))) for f in MEASURED}
    out["valid"] = int(ok.sum())
    return out


def weak_failures(tool, task, scene, g, i: int, draws: int) -> dict:
    """Grasp i's rollouts at WEAK_GRIP N per pad: {"rollouts", "failed"} (an invalid rollout counts as failed)."""
    bad = _weak_failed(rollouts_at_grip(tool, task, g[i:i + 1], WEAK_GRIP, draws=draws, seed=GRIP_SEED,
                                                scene=scene))
    return {"rollouts": int(len(bad)), "failed": int(bad.sum())}


def fidelity(tool, task, scene, g, checkpoints: dict | None = None, redraws: int = 0) -> dict:
    """Spearman over the candidates of each model's predicted torque with the measured full induced peak
    (the fidelity draw): SDG-Net, the analytic forms and the `checkpoints` {label: path} beside them.
    With `redraws` R >= 1 every candidate is rolled out R more times (seeds RETEST_SEED + r), which adds
    `retest`, the Spearman of the fidelity draw with the first redraw over the candidates valid in both;
    `ceiling`, its square root, about what a scorer of the expected torque, blind to the physics draw, can
    reach against one draw (`itup_jax.fidelity`); and `rho_mean`, each model against the mean of the
    R + 1 draws over the candidates valid in all."""
    L = simulate(tool, task, g, scene=scene, seed=FIDELITY_SEED, randomize=Randomization()).labels
    ok = np.asarray(L.valid)
    y = np.asarray(L.peak_torque_induced, float)[ok]
    preds = {"sdgnet": score(tool, task, g).tau,
             "analytic": wrench_costs(tool, task, g, OBJECTIVES["paper"].analytic).tau,
             "analytic_wrench": wrench_costs(tool, task, g, OBJECTIVES["wrench"].analytic).tau}
    preds |= {label: score(tool, task, g, model=p).tau for label, p in (checkpoints or {}).items()}
    preds = {m: np.asarray(p, float) for m, p in preds.items()}

    def rho(a, b):
        v = spearman(a, b)
        return None if not np.isfinite(v) else float(v)

    out = {"valid": int(ok.sum()), **{m: rho(p[ok], y) for m, p in preds.items()}}
    if redraws:
        draws = [np.where(ok, np.asarray(L.peak_torque_induced, float), np.nan)]
        for r in range(1, redraws + 1):
            Lr = simulate(tool, task, g, scene=scene, seed=RETEST_SEED + r, randomize=Randomization()).labels
            draws.append(np.where(np.asarray(Lr.valid), np.asarray(Lr.peak_torque_induced, float), np.nan))
        d = np.stack(draws)
        both, every = np.isfinite(d[:2]).all(0), np.isfinite(d).all(0)
        out["retest"] = rho(d[0, both], d[1, both])
        out["ceiling"] = float(np.sqrt(out["retest"])) if out["retest"] is not None and out["retest"] > 0 else None
        out["valid_all"] = int(every.sum())
        out["rho_mean"] = {m: rho(p[every], d[:, every].mean(0)) for m, p in preds.items()}
    return out


def evaluate_tool(entry: dict, task_kind: str, n: int, draws: int, weak: bool, with_fidelity: bool,
                  redraws: int = 0) -> dict:
    """One test tool's row of sealed.json: its `n` reachable candidates, every method's pick (`METHODS`)
    measured over `draws` randomised rollouts (`measure`), with `weak` also at 25 N per pad
    (`weak_failures`), and with `with_fidelity` each scorer's Spearman over the candidates (`fidelity`,
    with `redraws` more draws of every candidate for the retest ceiling and the draws' mean).
    A tool the task refuses, or with no reachable candidate, is kept with no picks: a loss for every method."""
    tool = entry["tool"]
    row = {k: entry[k] for k in ("i", "seed", "kind", "family")} | {"task": task_kind, "tool": tool.name}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # a drawn tool may swing a little over the speed limit
            task = make_task(task_kind, tool)
    except InputError as e:  # no task for this tool: kept, as a tool no method can pick for (a loss for all)
        return row | {"candidates": 0, "picks": {}, "task_refused": str(e)}
    found = sample_reachable(tool, task, n, seed=0)
    g = found.grasps
    row["candidates"] = int(len(g))
    if not len(g):
        row["picks"] = {}
        return row
    scene = build_scene(tool, task)
    index, info = {}, {}
    index[PLANNER], info = planner_pick(tool, task, g, scene)
    for m in METHODS[1:]:
        index[m] = int(np.argmin(np.asarray(score(tool, task, g, m).total, float)))
    picked = sorted({i for i in index.values() if i is not None})
    measured = {i: measure(tool, task, scene, g, i, draws) for i in picked}
    grip = {i: weak_failures(tool, task, scene, g, i, draws) for i in picked} if weak else {}
    # no pick (the planner's verified shortlist all failed): a loss, measured as nothing
    measured[None] = {f: float("nan") for f in MEASURED} | {"valid": 0}
    grip[None] = {"rollouts": draws, "failed": draws}
    row["planner"] = info
    row["picks"] = {m: {"index": i, **measured[i], **({"weak": grip[i]} if weak else {})} for m, i in index.items()}
    if with_fidelity:
        row["fidelity"] = fidelity(tool, task, scene, g, redraws=redraws)
    return row


def rebuild_tool(row: dict):
    """The tool of a test tool's entry (a sealed.json row), from its kind, family and seed: a part-wise
    variant of a built-in tool, or a draw of another family."""
    if row["kind"] == "builtin":
        return part_variant(row["family"], int(row["seed"]))
    return families.draw(row["family"], int(row["seed"]))


def rebuild_row(row: dict, n: int, what: str = "reopen") -> tuple:
    """A finished run's tool as the run had it: (tool, task, the same n candidates, scene); RuntimeError
    when the rebuilt tool's name or candidate count is not the run's."""
    tool = rebuild_tool(row)
    if tool.name != row["tool"]:
        raise RuntimeError(f"{what}: rebuilt {tool.name!r}, the run has {row['tool']!r}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        task = make_task(row["task"], tool)
    g = sample_reachable(tool, task, n, seed=0).grasps
    if len(g) != row["candidates"]:
        raise RuntimeError(f"{what}: {tool.name} {row['task']}: {len(g)} candidates, the run had {row['candidates']}")
    return tool, task, g, build_scene(tool, task)


def round2(x: float | None) -> float | None:
    """`x` rounded to 2 decimals for a printout; None stays None."""
    return x if x is None else round(x, 2)


def median_or_none(values) -> float | None:
    """The median of the values that are not None; None when none is."""
    v = [x for x in values if x is not None]
    return float(np.median(v)) if v else None


def by_task_and_kind(rows: list[dict]) -> dict:
    """{task: {"builtin" | "other": its rows}}, in TASKS order, kinds without rows left out."""
    return {k: {kind: rs for kind in ("builtin", "other") for rs in [[r for r in rows if r["task"] == k and r["kind"] == kind]]
                if rs} for k in TASKS if any(r["task"] == k for r in rows)}


#: The keys of a `fidelity` result that are not a scorer's Spearman.
FIDELITY_FIELDS = ("valid", "retest", "ceiling", "valid_all", "rho_mean")


def fidelity_row(row: dict, f: dict) -> dict:
    """A tool's `fidelity` result `f` as a row of fidelity_of.json: {task, tool, kind, family} of sealed.json's
    `row`, rho: {scorer: Spearman}, valid and, where it redrew, retest, ceiling, valid_all and rho_mean."""
    return ({k: row[k] for k in ("task", "tool", "kind", "family")}
            | {"rho": {m: v for m, v in f.items() if m not in FIDELITY_FIELDS}}
            | {k: f[k] for k in FIDELITY_FIELDS if k in f})


def fidelity_rows(rows: list[dict]) -> list[dict]:
    """sealed.json's rows with a fidelity, as fidelity_of.json's rows (`fidelity_row`)."""
    return [fidelity_row(r, r["fidelity"]) for r in rows if r.get("fidelity")]


def retest_summary(rows: list[dict]) -> dict:
    """Per task and kind, over fidelity_of.json's rows with redraws: the median retest, ceiling and each
    scorer's Spearman against the draws' mean; the fidelity goal (`FIDELITY_GOAL`), how many tools' own
    ceiling lies below it, and per scorer the median share of its tool's ceiling it reaches (rho / ceiling)."""
    out = {}
    for k, g in by_task_and_kind(rows).items():
        out[k] = {}
        for kind, rs in g.items():
            scorers = list(rs[0]["rho"])
            goal = FIDELITY_GOAL[kind]
            out[k][kind] = {"tools": len(rs), "retest": median_or_none([r["retest"] for r in rs]),
                            "ceiling": median_or_none([r["ceiling"] for r in rs]), "goal": goal,
                            "ceiling_below_goal": sum(r["ceiling"] is not None and r["ceiling"] < goal for r in rs),
                            "rho_mean": {m: median_or_none([r["rho_mean"][m] for r in rs]) for m in scorers},
                            "share_of_ceiling": {m: median_or_none([r["rho"][m] / r["ceiling"] for r in rs if r["rho"][m] is not None
                                                             and r["ceiling"]]) for m in scorers}}
    return out


def fidelity_summary(rows: list[dict], scorers: list[str]) -> dict:
    """{task: {kind: {scorer: median per-tool Spearman}}} over fidelity_of.json's rows (`rho` per scorer)."""
    return {k: {kind: {m: median_or_none([r["rho"][m] for r in rs]) for m in scorers} for kind, rs in g.items()}
            for k, g in by_task_and_kind(rows).items()}


def print_summary(summary: dict, before: dict | None = None) -> None:
    """A run's `summarise` per task on stdout; with `before` (another run's), the two side by side."""
    for k, s in summary.items():
        v = {b: s[f"vs_{b}"] for b in ("force_closure", "geometric", "better")}
        txt = "  ".join(f"vs {b} median {x['median_pct']:+.0f}% {x['interval_pct'] or ''} ({x['tools_lower']}/{s['tools']} lower)"
                        for b, x in v.items() if x["median_pct"] is not None)
        print(f"{k:7s} {txt}; paper +{PAPER['gqcnn'][k]}% / +{PAPER['graspnet'][k]}%")
        if before and k in before:
            print(f"        before: vs better median {before[k]['vs_better']['median_pct']:+.1f}%  now "
                  f"{s['vs_better']['median_pct']:+.1f}%; other families below FC {before[k]['other_family_below_fc']['lower']}"
                  f" -> {s['other_family_below_fc']['lower']}; no pick {before[k]['planner_no_pick']} -> {s['planner_no_pick']}")
        if "weak_grip" in s:
            print("        25 N failures: " + "  ".join(f"{m} {w['failed']}/{w['rollouts']}" for m, w in s["weak_grip"].items())
                  + (f"  (planner before: {before[k]['weak_grip'][PLANNER]['failed']})" if before and k in before else ""))
        if "fidelity_median" in s:
            print("        fidelity (median Spearman): " + "  ".join(f"{m} {round2(x)}"
                                                                    for m, x in s["fidelity_median"].items()))
        for kind, f in s.get("fidelity_retest", {}).items():
            print(f"        {kind}: retest {round2(f['retest'])} ceiling {round2(f['ceiling'])} (goal {f['goal']}); against "
                  "the draws' mean " + "  ".join(f"{m} {round2(x)}" for m, x in f["rho_mean"].items()))


def bootstrap_median(x: np.ndarray, level: float = 0.9, n: int = 2000, seed: int = 0) -> list[float] | None:
    """The `level` percentile interval of the median of `x` over `n` bootstrap resamples (seed `seed`);
    None below 3 values."""
    if len(x) < 3:
        return None
    m = np.median(np.random.default_rng(seed).choice(x, (n, len(x))), axis=1)
    return [float(np.percentile(m, 50 * (1 - level))), float(np.percentile(m, 100 - 50 * (1 - level)))]


def summarise(rows: list[dict]) -> dict:
    """Per task over sealed.json's rows: the planner's reduction of the full induced torque against force
    closure, geometric ranking and the better of the two per tool (the median of 100 (1 - ratio) with its
    90 % bootstrap interval, the paired geometric mean, the tools lower; no pick is a loss), the other-family
    tools below force closure, the 25 N grip failures per method and the better baseline's, the median
    fidelity (all tools, and the other families' alone) and, where the run redrew, per kind the retest,
    the ceiling and each scorer against the draws' mean (`fidelity_retest`, `retest_summary`)."""
    out = {}
    for k in TASKS:
        rs = [r for r in rows if r["task"] == k]
        if not rs:
            continue

        def torque(r, m):
            return r["picks"][m]["peak_torque_induced"] if r["picks"] else np.nan

        ours = np.array([torque(r, PLANNER) for r in rs])
        base = {b: np.array([torque(r, b) for r in rs]) for b in BASELINES}
        better = np.fmin(base["force_closure"], base["geometric"])
        s = {"tools": len(rs), "no_candidates": sum(not r["picks"] for r in rs),
             "guard_fired": sum(bool(r.get("planner", {}).get("guard_fired")) for r in rs),
             "planner_no_pick": sum(r.get("planner", {}).get("verified_succeeded") is False for r in rs),
             "mean_torque": {m: float(np.nanmean([torque(r, m) for r in rs])) for m in METHODS}}
        for name, ref in (("force_closure", base["force_closure"]), ("geometric", base["geometric"]),
                          ("better", better)):
            with np.errstate(invalid="ignore", divide="ignore"):
                red = 100.0 * (1.0 - ours / ref)
            red = np.where(np.isnan(ours) & np.isfinite(ref), -np.inf, red)  # no pick: a loss
            fin = red[~np.isnan(red)]
            s[f"vs_{name}"] = {"median_pct": float(np.median(fin)) if len(fin) else None,
                               "interval_pct": bootstrap_median(np.clip(fin, -1e3, None)),
                               "paired": paired_ratio(ours, ref, level=0.9), "tools_lower": int(np.sum(fin > 0))}
        other = [r for r in rs if r["kind"] == "other"]
        s["other_family_below_fc"] = {"tools": len(other), "lower": int(sum(
            torque(r, PLANNER) < torque(r, "force_closure") for r in other if r["picks"]))}
        weak = [r for r in rs if r["picks"] and "weak" in r["picks"][PLANNER]]
        if weak:
            s["weak_grip"] = {m: {"rollouts": sum(r["picks"][m]["weak"]["rollouts"] for r in weak),
                                  "failed": sum(r["picks"][m]["weak"]["failed"] for r in weak)} for m in METHODS}
            bb = [r["picks"]["geometric" if torque(r, "geometric") < torque(r, "force_closure") else "force_closure"]
                  for r in weak]
            s["weak_grip"]["better_baseline"] = {"rollouts": sum(p["weak"]["rollouts"] for p in bb),
                                                 "failed": sum(p["weak"]["failed"] for p in bb)}
        fid = [r["fidelity"] for r in rs if r.get("fidelity")]
        if fid:
            models = ("sdgnet", "analytic", "analytic_wrench")
            s["fidelity_median"] = {m: median_or_none([f[m] for f in fid]) for m in models}
            s["fidelity_median_other_families"] = {m: median_or_none([r["fidelity"][m] for r in rs if r.get("fidelity")
                                                               and r["kind"] == "other"]) for m in models}
            redrawn = [f for f in fidelity_rows(rs) if "retest" in f]
            if redrawn:
                s["fidelity_retest"] = retest_summary(redrawn)[k]
        out[k] = s
    return out


def code_commit(path: str) -> str | None:
    """The commit of the git work tree that holds `path` and whether it had changes ('<sha>+dirty');
    None outside git. The experiments pass their own folder: the code that runs them."""
    root = path if os.path.isdir(path) else os.path.dirname(os.path.abspath(path))
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root, capture_output=True,
                               text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return sha + ("+dirty" if dirty else "")


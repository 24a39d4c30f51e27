"""The sealed evaluation: the protocol of docs/results.md ("The sealed evaluation"), run once per checkpoint.

    python experiments/sealed_eval.py --out results/sealed                   # the protocol (once)
    python experiments/sealed_eval.py --quick --out results/sealed_quick     # 1 tool per task, small (tests)
    python experiments/sealed_eval.py --reopen results/sealed/sealed.json --out results/reopened   # see below

The test tools are drawn from the checkpoint itself, so no one chooses them and a new checkpoint gets
new ones: for task k and tool i (0-15) the seed is the first 8 bytes, big-endian, of
SHA-256(checkpoint bytes || salt || k || i), with k the task's name and i in decimal, both UTF-8
(`sealed_seed`), and the salt empty in round 1 and "/round<r>" in round r (`round_salt`, `ROUND`): a
later round of an unchanged checkpoint draws new tools.
Tools 0-7 are part-wise variants of the task's built-in tool (`tools.variants.part_variant`), tools 8-15
draws of the task's other families (`tools.families`: the held-out families and the round's sealed-test
families that do the task), one after the other in the families' order (--quick appends "/quick" to
the salted bytes: never a sealed tool). Per tool:
  * 256 candidates the arm can carry (`sample_reachable`, seed 0; a tool with none is a loss for
    every method);
  * the picks: `itup plan`'s default (`planning.default_pick`: SDG-Net under the shipped weights, its
    DEFAULT_VERIFY best rolled out under nominal physics and again at 25 N per pad, the lowest measured
    total kept; when the out-of-distribution guard fires, GUARD_VERIFY_K grasps and a shortlist that
    mixes in the analytic wrench cost's best, `planning.guard_order`), the analytic cost in the paper's
    and the wrench form, force closure, geometric ranking;
  * every distinct pick rolled out under the same 5 randomised physics draws (the headline: the mean
    full induced peak wrist torque; the raw peak and the induced torque's grasp-frame components
    beside it), and, on tools i % 8 < 5 (10 per task), 5 more at 25 N per pad;
  * every candidate rolled out once under one randomised draw: the Spearman correlation over the
    candidates of SDG-Net's and each analytic form's predicted torque with the measured full induced
    peak torque (the fidelity).
Reported per task: the planner's reduction of the full induced torque against force closure, geometric
ranking and the better of the two on each tool (100 (1 - ratio) per tool: the median over the 16 tools
with a 90 % bootstrap interval, and beside it the paired geometric mean), the share of other-family
tools on which it is below force closure's; grip failures at 25 N (50 rollouts per method and task)
against the better baseline's; the median fidelity per task (pooled only beside it). The paper's
margins: 17.6 / 17.5 / 11.6 / 20.8 % over GQ-CNN, 10.2 / 14.3 / 10.4 / 13.5 % over GraspNet (hammer /
sweep / knock / reach). Writes sealed.json (schema `itup.sealed/1`).

--reopen SEALED_JSON: a finished run's tools, validation tools from then on, with the planner of this
code: every tool that either planner verifies is planned again (its tool rebuilt from the recorded
family and seed, the same 256 candidates), first as the run's planner did (its `config.verify` and
`config.verify_weak_grip`; none recorded: verified only where the guard fired, at the default grip
alone), checked to give the recorded pick, then as `itup plan` does now (or with --planner-verify K,
0: verified only where the guard fires, and --planner-weak-grip N, 0: at the default grip alone); a
pick that changed is measured on the run's draws (the same seeds), every other pick is the run's.
--model CHECKPOINT (and --guard-threshold T, its guard's own) re-plans with another network.
Writes sealed.json of the same schema, with `reopened` naming the run and the planner, and
prints the summary beside the run's. With --headroom R (and --tasks), the tools of those tasks are also
asked what a perfect predictor would pick: every candidate rolled out R more times (their own draws),
the *oracle* the candidate with the lowest mean full induced peak torque among those that did the task
and held in all R, measured on the run's draws like every pick (so its luck in the R draws does not
flatter it); per tool its torque and the rank among the R-draw means of the planner's and the
baselines' picks; per task its reduction against the better baseline (`reopened.headroom.summary`).
With --fidelity-of [LABEL=]CHECKPOINT ..., nothing is planned: every tool's fidelity draw is rolled out
again (the same candidates and seed) and ranked by those checkpoints (none: only) beside the shipped one
and the analytic forms, per task the median Spearman on the built-in and the other families' tools
(fidelity_of.json). With --redraws R every candidate is rolled out R more times: per tool the retest
correlation of two draws, the ceiling it sets for a scorer blind to the physics draw, and each scorer
against the draws' mean; per task and kind against the fidelity goals (`FIDELITY_GOAL`, `retest_summary`).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import time
import warnings

import numpy as np

import itup_jax as itup
from itup_jax import verify
from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import WEAK_GRIP
from itup_jax.errors import InputError
from itup_jax.evaluate import MEASURED
from itup_jax.grasp_sampler import sample_reachable
from itup_jax.heldout import oracle_index
from itup_jax.ood import reference_path, reference_path_of
from itup_jax.planning import DEFAULT_VERIFY, GUARD_VERIFY_K, default_pick
from itup_jax.scoring import ScoreWeights
from itup_jax.sdgnet.config import DEFAULT_MODEL
from itup_jax.sdgnet.objective import OBJECTIVES
from itup_jax.sim.physics import Randomization
from itup_jax.sim.scene import build_scene
from itup_jax.stats import paired_ratio, spearman
from itup_jax.stress import rollouts_at_grip
from itup_jax.task import DEFAULT_TOOL, make_task
from itup_jax.tools import families
from itup_jax.tools.variants import part_variant

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
#: tools no one has seen. Rounds 1 to 4 have run; round 5 draws once new sealed-test families exist.
ROUND = 6
#: Seeds of the rollouts: the pick draws, the weak-grip draws, the fidelity draw.
PICK_SEED, GRIP_SEED, FIDELITY_SEED = 11, 12, 13
#: --reopen --headroom R: draw r of every candidate uses seed HEADROOM_SEED + r.
HEADROOM_SEED = 100
#: --fidelity-of --redraws R: redraw r of the fidelity draw uses seed RETEST_SEED + r.
RETEST_SEED = 200
#: The fidelity goals for SDG-Net's median per-tool Spearman per task (docs/results.md, "The fidelity
#: goals and the noise of one rollout"): on the built-in families' variants and on the other families' tools.
FIDELITY_GOAL = {"builtin": 0.85, "other": 0.7}
#: Grasps the planners up to itup-jax 0.28.0 verified where the guard fired (max(verify, 5); their runs
#: record no `guard_verify`), for --reopen to replay them
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
    L = itup.simulate(tool, task, reps, scene=scene, seed=PICK_SEED, randomize=Randomization()).labels
    ok = np.asarray(L.valid)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        out = {f: float(np.nanmean(np.where(ok, np.asarray(getattr(L, f), float), np.nan))) for f in MEASURED}
    out["valid"] = int(ok.sum())
    return out


def weak_failures(tool, task, scene, g, i: int, draws: int) -> dict:
    """Grasp i's rollouts at WEAK_GRIP N per pad: {"rollouts", "failed"} (an invalid rollout counts as failed)."""
    bad = verify.weak_failures(rollouts_at_grip(tool, task, g[i:i + 1], WEAK_GRIP, draws=draws, seed=GRIP_SEED,
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
    L = itup.simulate(tool, task, g, scene=scene, seed=FIDELITY_SEED, randomize=Randomization()).labels
    ok = np.asarray(L.valid)
    y = np.asarray(L.peak_torque_induced, float)[ok]
    preds = {"sdgnet": itup.score(tool, task, g).tau,
             "analytic": itup.wrench_costs(tool, task, g, OBJECTIVES["paper"].analytic).tau,
             "analytic_wrench": itup.wrench_costs(tool, task, g, OBJECTIVES["wrench"].analytic).tau}
    preds |= {label: itup.score(tool, task, g, model=p).tau for label, p in (checkpoints or {}).items()}
    preds = {m: np.asarray(p, float) for m, p in preds.items()}

    def rho(a, b):
        v = spearman(a, b)
        return None if not np.isfinite(v) else float(v)

    out = {"valid": int(ok.sum()), **{m: rho(p[ok], y) for m, p in preds.items()}}
    if redraws:
        draws = [np.where(ok, np.asarray(L.peak_torque_induced, float), np.nan)]
        for r in range(1, redraws + 1):
            Lr = itup.simulate(tool, task, g, scene=scene, seed=RETEST_SEED + r, randomize=Randomization()).labels
            draws.append(np.where(np.asarray(Lr.valid), np.asarray(Lr.peak_torque_induced, float), np.nan))
        d = np.stack(draws)
        both, every = np.isfinite(d[:2]).all(0), np.isfinite(d).all(0)
        out["retest"] = rho(d[0, both], d[1, both])
        out["ceiling"] = float(np.sqrt(out["retest"])) if out["retest"] is not None and out["retest"] > 0 else None
        out["valid_all"] = int(every.sum())
        out["rho_mean"] = {m: rho(p[every], d[:, every].mean(0)) for m, p in preds.items()}
    return out


def evaluate_tool(entry: dict, task_kind: str, n: int, draws: int, weak: bool, with_fidelity: bool) -> dict:
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
        index[m] = int(np.argmin(np.asarray(itup.score(tool, task, g, m).total, float)))
    picked = sorted({i for i in index.values() if i is not None})
    measured = {i: measure(tool, task, scene, g, i, draws) for i in picked}
    grip = {i: weak_failures(tool, task, scene, g, i, draws) for i in picked} if weak else {}
    # no pick (the planner's verified shortlist all failed): a loss, measured as nothing
    measured[None] = {f: float("nan") for f in MEASURED} | {"valid": 0}
    grip[None] = {"rollouts": draws, "failed": draws}
    row["planner"] = info
    row["picks"] = {m: {"index": i, **measured[i], **({"weak": grip[i]} if weak else {})} for m, i in index.items()}
    if with_fidelity:
        row["fidelity"] = fidelity(tool, task, scene, g)
    return row


def rebuild_tool(row: dict):
    """The tool of a test tool's entry (a sealed.json row), from its kind, family and seed: a part-wise
    variant of a built-in tool, or a draw of another family."""
    if row["kind"] == "builtin":
        return part_variant(row["family"], int(row["seed"]))
    return families.draw(row["family"], int(row["seed"]))


def rebuild_row(row: dict, n: int, what: str = "--reopen") -> tuple:
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


def replan_row(row: dict, n: int, draws: int, was_verify: int, was_weak_grip: float | None, was_guard_verify: int,
               verify: int = DEFAULT_VERIFY, weak_grip: float | None = WEAK_GRIP, guard_verify: int = GUARD_VERIFY_K,
               model: str | None = None, guard_threshold: float | None = None) -> dict:
    """A guard-fired row of a finished run with the planner of this code (module docstring, --reopen), with
    `model` and `guard_threshold` when given (the run's own planner is replayed with the shipped ones)."""
    tool, task, g, scene = rebuild_row(row, n)
    old, _ = planner_pick(tool, task, g, scene, verify=was_verify, weak_grip=was_weak_grip, guard_verify=was_guard_verify)
    if old != row["picks"][PLANNER]["index"]:
        raise RuntimeError(f"--reopen: {tool.name} {row['task']}: the run's planner picked "
                           f"{row['picks'][PLANNER]['index']}, re-planned {old}")
    new, info = planner_pick(tool, task, g, scene, verify=verify, weak_grip=weak_grip, guard_verify=guard_verify,
                             model=model, guard_threshold=guard_threshold)
    out = {**row, "planner": info, "picks": dict(row["picks"]), "replaced": None}
    if new != old:
        weak = "weak" in row["picks"][PLANNER]
        if new is None:
            m = {f: float("nan") for f in MEASURED} | {"valid": 0}
            w = {"rollouts": draws, "failed": draws}
        else:
            m = measure(tool, task, scene, g, new, draws)
            w = weak_failures(tool, task, scene, g, new, draws) if weak else None
        out["picks"][PLANNER] = {"index": new, **m, **({"weak": w} if weak else {})}
        out["replaced"] = row["picks"][PLANNER]
    return out


def headroom_row(row: dict, n: int, draws: int, repeats: int) -> dict:
    """--headroom: the oracle pick of a finished run's tool (module docstring)."""
    tool, task, g, scene = rebuild_row(row, n, "--headroom")
    tau, ok = np.zeros(len(g)), np.ones(len(g), bool)
    for r in range(repeats):
        L = itup.simulate(tool, task, g, scene=scene, seed=HEADROOM_SEED + r, randomize=Randomization()).labels
        ok &= np.asarray(L.valid) & np.asarray(L.success) & ~np.asarray(L.failed)
        tau += np.where(np.asarray(L.valid), np.asarray(L.peak_torque_induced, float), np.inf) / repeats
    if not ok.any():
        return {"oracle": None, "held": 0}
    i = oracle_index(tau, ok)
    order = np.argsort(np.where(np.isfinite(tau), tau, np.inf), kind="stable")
    rank = {m: (None if p.get("index") is None else int(np.nonzero(order == p["index"])[0][0]) + 1)
            for m, p in row["picks"].items()}
    return {"oracle": {"index": i, **measure(tool, task, scene, g, i, draws)}, "held": int(ok.sum()),
            "rank_of_picks": rank, "candidates": int(len(g))}


def _oracle_summary(rows: list[dict]) -> dict:
    """Per task: the oracle's reduction against the better baseline per tool, as `summarise` gives the planner's."""
    out = {}
    for k in TASKS:
        rs = [r for r in rows if r["task"] == k and r.get("headroom") and r["headroom"]["oracle"]]
        if not rs:
            continue
        o = np.array([r["headroom"]["oracle"]["peak_torque_induced"] for r in rs])
        p = np.array([r["picks"][PLANNER]["peak_torque_induced"] for r in rs])
        b = np.array([min(r["picks"][m]["peak_torque_induced"] for m in BASELINES) for r in rs])
        red, red_p = 100.0 * (1.0 - o / b), 100.0 * (1.0 - p / b)
        out[k] = {"tools": len(rs), "oracle_vs_better_median_pct": float(np.median(red)),
                  "interval_pct": _bootstrap_median(red), "planner_vs_better_median_pct": float(np.median(red_p)),
                  "by_kind": {kind: {"tools": int(np.sum(sel)), "oracle": float(np.median(red[sel])),
                                     "planner": float(np.median(red_p[sel]))}
                              for kind in ("builtin", "other")
                              for sel in [np.array([r["kind"] == kind for r in rs])] if sel.any()}}
    return out


def reopen(path: str, out_dir: str, headroom: int = 0, headroom_tasks: tuple = (), verify: int = DEFAULT_VERIFY,
           weak_grip: float | None = WEAK_GRIP, guard_verify: int = GUARD_VERIFY_K, model: str | None = None,
           guard_threshold: float | None = None) -> dict:
    """--reopen: the run at `path` with the planner of this code (module docstring)."""
    import json

    with open(path) as fh:
        run = json.load(fh)
    if run.get("schema") != "itup.sealed/1":
        raise SystemExit(f"--reopen: {path} is not a sealed run (schema itup.sealed/1)")
    cfg = run["config"]
    t0, rows = time.perf_counter(), []
    for row in run["per_tool"]:
        # the run's planner: verify and weak grip as recorded (none recorded: 0.25.0's, verified only where
        # the guard fired, at the default grip alone); a tool it did not verify is re-planned only when
        # the planner of this code verifies every tool
        was = (cfg.get("verify", 0), cfg.get("verify_weak_grip"), cfg.get("guard_verify", EARLIER_GUARD_VERIFY))
        if row["picks"] and (verify > 0 or was[0] > 0 or row.get("planner", {}).get("guard_fired")):
            t = time.perf_counter()
            rows.append(replan_row(row, cfg["n"], cfg["draws"], *was, verify=verify, weak_grip=weak_grip,
                                   guard_verify=guard_verify, model=model, guard_threshold=guard_threshold))
            r = rows[-1]
            was, now = r["replaced"] or r["picks"][PLANNER], r["picks"][PLANNER]
            print(f"{r['task']:7s} {r['tool']:28s} planner {was['index']} -> {now['index']}  torque "
                  f"{was['peak_torque_induced']:.2f} -> {now['peak_torque_induced']:.2f}  weak "
                  f"{was.get('weak', {}).get('failed', '-')} -> {now.get('weak', {}).get('failed', '-')}  "
                  f"({time.perf_counter() - t:.0f} s)", flush=True)
        else:
            rows.append({**row, "replaced": None})
        if headroom and row["picks"] and row["task"] in headroom_tasks:
            t = time.perf_counter()
            rows[-1]["headroom"] = h = headroom_row(rows[-1], cfg["n"], cfg["draws"], headroom)
            o = h["oracle"]
            print(f"{row['task']:7s} {row['tool']:28s} oracle {o and o['index']} {o and round(o['peak_torque_induced'], 2)}"
                  f"  planner {rows[-1]['picks'][PLANNER]['peak_torque_induced']:.2f}  fc "
                  f"{row['picks']['force_closure']['peak_torque_induced']:.2f}  geo "
                  f"{row['picks']['geometric']['peak_torque_induced']:.2f}  held {h['held']}  ranks "
                  f"{h.get('rank_of_picks')}  ({time.perf_counter() - t:.0f} s)", flush=True)
    from itup_jax.bench import machine_info

    res = {**run, "version": itup.__version__, "commit": _commit(), "summary": summarise(rows), "per_tool": rows,
           "wall_s": time.perf_counter() - t0, "machine": machine_info(),
           "reopened": {"from": os.path.abspath(path), "commit": run["commit"], "version": run["version"],
                        "verify": verify, "weak_grip": weak_grip, "guard_verify": guard_verify,
                        "model": model and os.path.abspath(model), "guard_threshold": guard_threshold,
                        "replaced": sum(r["replaced"] is not None for r in rows),
                        "headroom": {"repeats": headroom, "tasks": list(headroom_tasks),
                                     "summary": _oracle_summary(rows)} if headroom else None}}
    os.makedirs(out_dir, exist_ok=True)
    atomic_write_json(os.path.join(out_dir, "sealed.json"), res, indent=1)
    _print_summary(res["summary"], run["summary"])
    if headroom:
        for k, h in res["reopened"]["headroom"]["summary"].items():
            print(f"{k:7s} oracle vs better median {h['oracle_vs_better_median_pct']:+.0f}% {h['interval_pct']}; planner "
                  f"{h['planner_vs_better_median_pct']:+.0f}%; by kind {h['by_kind']}")
    return res


def fidelity_of(path: str, out_dir: str, models: list[str], redraws: int = 0) -> dict:
    """--fidelity-of: a finished run's fidelity draw of every tool rolled out again (the same candidates and
    seed) and ranked by each checkpoint in `models` ("label=path" or a path) beside the run's SDG-Net and
    the analytic forms; per task the median Spearman on the built-in and the other families' tools. With
    `redraws` R >= 1, the R more draws of `fidelity`: per task and kind the median retest, ceiling and
    Spearman against the draws' mean (`retest`). Writes fidelity_of.json."""
    import json

    from itup_jax.bench import machine_info

    with open(path) as fh:
        run = json.load(fh)
    if run.get("schema") != "itup.sealed/1":
        raise SystemExit(f"--fidelity-of: {path} is not a sealed run (schema itup.sealed/1)")
    named = dict(m.split("=", 1) if "=" in m else (os.path.splitext(os.path.basename(m))[0], m) for m in models)
    missing = [p for p in named.values() if not os.path.isfile(p)]
    if missing:
        raise SystemExit(f"--fidelity-of: no checkpoint at {', '.join(missing)}")
    t0, rows, scorers = time.perf_counter(), [], ["sdgnet", "analytic", "analytic_wrench", *named]
    for row in run["per_tool"]:
        if not row.get("fidelity"):
            continue
        tool, task, g, scene = rebuild_row(row, run["config"]["n"], "--fidelity-of")
        f = fidelity(tool, task, scene, g, checkpoints=named, redraws=redraws)
        rows.append({k: row[k] for k in ("task", "tool", "kind", "family")}
                    | {"valid": f["valid"], "run_sdgnet": row["fidelity"]["sdgnet"], "rho": {m: f[m] for m in scorers}}
                    | {k: f[k] for k in ("retest", "ceiling", "valid_all", "rho_mean") if k in f})
        print(f"{row['task']:7s} {row['tool']:34s} " + "  ".join(f"{m} {_r2(v)}" for m, v in rows[-1]["rho"].items())
              + (f"  retest {_r2(f['retest'])}" if redraws else ""), flush=True)

    summary = {k: {kind: {m: _median([r["rho"][m] for r in rs]) for m in scorers} for kind, rs in g.items()}
               for k, g in _by_task_and_kind(rows).items()}
    res = {"schema": "itup.sealed_fidelity_of/1", "from": os.path.abspath(path), "models": named, "summary": summary,
           "per_tool": rows, "version": itup.__version__, "commit": _commit(), "wall_s": time.perf_counter() - t0,
           "machine": machine_info()}
    if redraws:
        res["redraws"], res["retest"] = redraws, retest_summary(rows)
    os.makedirs(out_dir, exist_ok=True)
    atomic_write_json(os.path.join(out_dir, "fidelity_of.json"), res, indent=1)
    for k, s in summary.items():
        for kind, d in s.items():
            line = f"{k:7s} {kind:7s} " + " ".join(f"{m} {_r2(v)}" for m, v in d.items())
            if redraws:
                t = res["retest"][k][kind]
                line += (f"  | retest {_r2(t['retest'])} ceiling {_r2(t['ceiling'])}  vs the mean: "
                         + " ".join(f"{m} {_r2(v)}" for m, v in t["rho_mean"].items()))
            print(line)
    return res


def _r2(x):
    return x if x is None else round(x, 2)


def _median(values) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.median(v)) if v else None


def _by_task_and_kind(rows: list[dict]) -> dict:
    """{task: {"builtin" | "other": its rows}}, in TASKS order, kinds without rows left out."""
    return {k: {kind: rs for kind in ("builtin", "other") for rs in [[r for r in rows if r["task"] == k and r["kind"] == kind]]
                if rs} for k in TASKS if any(r["task"] == k for r in rows)}


def retest_summary(rows: list[dict]) -> dict:
    """Per task and kind, over fidelity_of.json's rows with redraws: the median retest, ceiling and each
    scorer's Spearman against the draws' mean; the fidelity goal (`FIDELITY_GOAL`), how many tools' own
    ceiling lies below it, and per scorer the median share of its tool's ceiling it reaches (rho / ceiling)."""
    out = {}
    for k, g in _by_task_and_kind(rows).items():
        out[k] = {}
        for kind, rs in g.items():
            scorers = list(rs[0]["rho"])
            goal = FIDELITY_GOAL[kind]
            out[k][kind] = {"tools": len(rs), "retest": _median([r["retest"] for r in rs]),
                            "ceiling": _median([r["ceiling"] for r in rs]), "goal": goal,
                            "ceiling_below_goal": sum(r["ceiling"] is not None and r["ceiling"] < goal for r in rs),
                            "rho_mean": {m: _median([r["rho_mean"][m] for r in rs]) for m in scorers},
                            "share_of_ceiling": {m: _median([r["rho"][m] / r["ceiling"] for r in rs if r["rho"][m] is not None
                                                             and r["ceiling"]]) for m in scorers}}
    return out


def _print_summary(summary: dict, before: dict | None = None) -> None:
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
            print("        fidelity (median Spearman): " + "  ".join(f"{m} {x if x is None else round(x, 2)}"
                                                                    for m, x in s["fidelity_median"].items()))


def _bootstrap_median(x: np.ndarray, level: float = 0.9, n: int = 2000, seed: int = 0) -> list[float] | None:
    if len(x) < 3:
        return None
    m = np.median(np.random.default_rng(seed).choice(x, (n, len(x))), axis=1)
    return [float(np.percentile(m, 50 * (1 - level))), float(np.percentile(m, 100 - 50 * (1 - level)))]


def summarise(rows: list[dict]) -> dict:
    """Per task: the planner's reductions, the grip failures and the fidelity (module docstring)."""
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
                               "interval_pct": _bootstrap_median(np.clip(fin, -1e3, None)),
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
            s["fidelity_median"] = {m: _median([f[m] for f in fid]) for m in models}
            s["fidelity_median_other_families"] = {m: _median([r["fidelity"][m] for r in rs if r.get("fidelity")
                                                               and r["kind"] == "other"]) for m in models}
        out[k] = s
    return out


def _commit() -> str | None:
    """The repository's commit and whether its tree had changes ('<sha>+dirty'), or None outside git."""
    import subprocess

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root, capture_output=True,
                               text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None
    return sha + ("+dirty" if dirty else "")


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tools", type=int, default=16, help="test tools per task (default %(default)s)")
    ap.add_argument("--n", type=int, default=256, help="candidates per tool (default %(default)s)")
    ap.add_argument("--draws", type=int, default=5, help="randomised rollouts per pick and grip (default %(default)s)")
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--quick", action="store_true", help="hammer and reach, 2 tools each, 24 candidates, 2 draws (tests)")
    ap.add_argument("--out", default="results/sealed")
    ap.add_argument("--round", type=int, default=ROUND,
                    help="the sealed evaluation's round, which salts the seeds (`round_salt`; default %(default)s)")
    ap.add_argument("--reopen", default=None, metavar="SEALED_JSON",
                    help="a finished run's tools (validation tools since) with the planner of this code")
    ap.add_argument("--planner-verify", type=int, default=DEFAULT_VERIFY, metavar="K",
                    help="with --reopen: the planner to re-plan with verifies K grasps (0: only where the guard fires; "
                    "default %(default)s, `itup plan`'s)")
    ap.add_argument("--planner-weak-grip", type=float, default=WEAK_GRIP, metavar="N",
                    help="with --reopen: its verification repeats each rollout at N per pad (0: none; default %(default)g)")
    ap.add_argument("--planner-guard-verify", type=int, default=GUARD_VERIFY_K, metavar="K",
                    help="with --reopen: where the guard fires it verifies max(--planner-verify, K) grasps (default "
                    "%(default)s, `itup plan`'s)")
    ap.add_argument("--headroom", type=int, default=0, metavar="R",
                    help="with --reopen: the oracle pick of the --tasks' tools from R rollouts of every candidate")
    ap.add_argument("--fidelity-of", nargs="*", default=None, metavar="[LABEL=]CHECKPOINT",
                    help="with --reopen: only the run's fidelity draw again, ranked by these checkpoints (none: "
                    "only) beside the shipped one and the analytic forms (fidelity_of.json; no re-planning)")
    ap.add_argument("--redraws", type=int, default=0, metavar="R",
                    help="with --fidelity-of: every candidate rolled out R more times, for the retest ceiling and "
                    "the ranking against the draws' mean (default %(default)s)")
    ap.add_argument("--model", default=None, metavar="CHECKPOINT",
                    help="with --reopen: re-plan with this SDG-Net checkpoint (its guard reference beside it, "
                    "<stem>.reference.npz) instead of the shipped one")
    ap.add_argument("--guard-threshold", type=float, default=None, metavar="T",
                    help="with --reopen: the guard's threshold for the re-planning (default: ood.GUARD_THRESHOLD, "
                    "the shipped checkpoint's; another checkpoint needs its own, experiments/ood_guard.py)")
    a = ap.parse_args(argv)
    if (a.model or a.guard_threshold is not None) and (not a.reopen or a.fidelity_of is not None):
        ap.error("--model and --guard-threshold apply to --reopen's re-planning")
    if a.model and not (os.path.isfile(a.model) and reference_path_of(a.model)):  # None: no reference on disk
        ap.error(f"--model {a.model}: needs the checkpoint and its guard reference ({reference_path(a.model)})")
    if a.guard_threshold is not None and not (np.isfinite(a.guard_threshold) and a.guard_threshold > 0):
        ap.error(f"--guard-threshold must be a finite number > 0, got {a.guard_threshold}")
    if a.fidelity_of is not None and not a.reopen:
        ap.error("--fidelity-of applies to --reopen")
    if a.redraws < 0 or (a.redraws and a.fidelity_of is None):
        ap.error(f"--redraws R >= 0 applies to --fidelity-of, got {a.redraws}")
    if a.fidelity_of is not None:
        return fidelity_of(a.reopen, a.out, a.fidelity_of, a.redraws)
    if (a.headroom or a.planner_verify != DEFAULT_VERIFY or a.planner_weak_grip != WEAK_GRIP
            or a.planner_guard_verify != GUARD_VERIFY_K) and not a.reopen:
        ap.error("--headroom, --planner-verify, --planner-weak-grip and --planner-guard-verify apply to --reopen")
    if a.round < 1:
        ap.error(f"--round must be >= 1, got {a.round}")
    if a.planner_verify < 0 or a.planner_guard_verify < 0:
        ap.error(f"--planner-verify and --planner-guard-verify must be >= 0, got {a.planner_verify}, "
                 f"{a.planner_guard_verify}")
    if a.reopen:
        return reopen(a.reopen, a.out, a.headroom, tuple(t for t in a.tasks.split(",") if t), a.planner_verify,
                      a.planner_weak_grip or None, a.planner_guard_verify, a.model, a.guard_threshold)
    if a.quick:
        a.tools, a.n, a.draws, a.tasks = 2, 24, 2, "hammer,reach"
    tasks = tuple(t for t in a.tasks.split(",") if t)
    if not a.quick and not families.sealed():
        ap.error(f"round {a.round}: no sealed-test family (role 'sealed' in itup_jax/tools/families.py): add the "
                 "round's new families and write its protocol in docs/results.md before its draw")
    bad = [t for t in tasks if t not in TASKS]
    if bad or a.tools < 1 or a.n < 1 or a.draws < 1:
        ap.error(f"--tasks among {','.join(TASKS)}, --tools, --n and --draws >= 1; got {a.tasks!r}, {a.tools}, {a.n}, {a.draws}")
    with open(DEFAULT_MODEL, "rb") as fh:
        checkpoint = fh.read()
    # --quick draws its tools from other seeds, so that a test run never rolls out a sealed tool
    draw_from = checkpoint + round_salt(a.round) + (QUICK_SALT if a.quick else b"")
    t0, rows, commit = time.perf_counter(), [], _commit()  # the code that runs, before any rollout
    os.makedirs(a.out, exist_ok=True)
    partial = os.path.join(a.out, "sealed.partial.json")
    for k in tasks:
        for e in sealed_tools(draw_from, k, a.tools):
            t = time.perf_counter()
            weak = e["i"] % 8 < 5 if not a.quick else True
            rows.append(evaluate_tool(e, k, a.n, a.draws, weak, with_fidelity=True))
            atomic_write_json(partial, {"commit": commit, "round": a.round, "per_tool": rows}, indent=1)  # kept if it stops
            r = rows[-1]
            picks = "  ".join(f"{m} {p['peak_torque_induced']:.2f}" for m, p in r["picks"].items())
            print(f"{k:7s} {r['tool']:28s} {r['candidates']:4d} cands  guard "
                  f"{'fired' if r.get('planner', {}).get('guard_fired') else 'quiet'}  {picks}  ({time.perf_counter() - t:.0f} s)"
                  + (f"  no task: {r['task_refused']}" if "task_refused" in r else ""), flush=True)
    from itup_jax.bench import machine_info

    out = {"schema": "itup.sealed/1", "checkpoint_sha256": hashlib.sha256(checkpoint).hexdigest(),
           "version": itup.__version__, "commit": commit, "config": {"tools": a.tools, "n": a.n, "draws": a.draws, "tasks": list(tasks),
                                                   "quick": a.quick, "round": a.round, "verify": DEFAULT_VERIFY, "guard_verify": GUARD_VERIFY_K,
                                                   "verify_weak_grip": WEAK_GRIP},
           "weights": ScoreWeights().__dict__, "paper": PAPER, "summary": summarise(rows),
           "per_tool": rows, "wall_s": time.perf_counter() - t0, "machine": machine_info()}
    atomic_write_json(os.path.join(a.out, "sealed.json"), out, indent=1)
    os.remove(partial)
    _print_summary(out["summary"])
    return out


if __name__ == "__main__":
    main()

"""A finished sealed run (experiments/sealed_eval.py) reopened: its tools, validation tools from then on,
re-planned, asked for their oracle pick, or re-ranked by other checkpoints.

    python experiments/sealed_reopen.py results/sealed_round5/sealed.json --out results/round5_now
    python experiments/sealed_reopen.py RUN/sealed.json --headroom 3 --tasks knock --out results/headroom
    python experiments/sealed_reopen.py RUN/sealed.json --model M.npz --guard-threshold T --out results/other
    python experiments/sealed_reopen.py RUN/sealed.json --fidelity-of [LABEL=]CKPT ... [--redraws R] --out results/f


A finished run's tools, validation tools from then on, with the planner of this
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
The protocol's parts (seeds, tools, measurements, summaries) are `itup_jax.sealed`'s.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

import itup_jax as itup
from itup_jax.atomic import atomic_write_json
from itup_jax.bench import machine_info
from itup_jax.dataset import WEAK_GRIP
from itup_jax.evaluate import MEASURED
from itup_jax.heldout import oracle_index
from itup_jax.ood import reference_path, reference_path_of
from itup_jax.planning import DEFAULT_VERIFY, GUARD_VERIFY_K
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sealed import (
    BASELINES,
    EARLIER_GUARD_VERIFY,
    HEADROOM_SEED,
    PLANNER,
    TASKS,
    bootstrap_median,
    code_commit,
    fidelity,
    fidelity_row,
    fidelity_summary,
    measure,
    planner_pick,
    print_summary,
    rebuild_row,
    retest_summary,
    round2,
    summarise,
    weak_failures,
)
from itup_jax.sim.physics import Randomization


def replan_row(row: dict, n: int, draws: int, was_verify: int, was_weak_grip: float | None, was_guard_verify: int,
               verify: int = DEFAULT_VERIFY, weak_grip: float | None = WEAK_GRIP, guard_verify: int = GUARD_VERIFY_K,
               model: str | None = None, guard_threshold: float | None = None) -> dict:
    """A guard-fired row of a finished run with the planner of this code (module docstring), with
    `model` and `guard_threshold` when given (the run's own planner is replayed with the shipped ones)."""
    tool, task, g, scene = rebuild_row(row, n)
    old, _ = planner_pick(tool, task, g, scene, verify=was_verify, weak_grip=was_weak_grip, guard_verify=was_guard_verify)
    if old != row["picks"][PLANNER]["index"]:
        raise RuntimeError(f"{tool.name} {row['task']}: the run's planner picked "
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
                  "interval_pct": bootstrap_median(red), "planner_vs_better_median_pct": float(np.median(red_p)),
                  "by_kind": {kind: {"tools": int(np.sum(sel)), "oracle": float(np.median(red[sel])),
                                     "planner": float(np.median(red_p[sel]))}
                              for kind in ("builtin", "other")
                              for sel in [np.array([r["kind"] == kind for r in rs])] if sel.any()}}
    return out


def reopen(path: str, out_dir: str, headroom: int = 0, headroom_tasks: tuple = (), verify: int = DEFAULT_VERIFY,
           weak_grip: float | None = WEAK_GRIP, guard_verify: int = GUARD_VERIFY_K, model: str | None = None,
           guard_threshold: float | None = None) -> dict:
    """The run at `path` re-planned with the planner of this code, and with `headroom` R > 0 the oracle
    pick of the `headroom_tasks`' tools (module docstring). Writes sealed.json."""
    with open(path) as fh:
        run = json.load(fh)
    if run.get("schema") != "itup.sealed/1":
        raise SystemExit(f"{path} is not a sealed run (schema itup.sealed/1)")
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
    res = {**run, "version": itup.__version__, "commit": code_commit(__file__), "summary": summarise(rows), "per_tool": rows,
           "wall_s": time.perf_counter() - t0, "machine": machine_info(),
           "reopened": {"from": os.path.abspath(path), "commit": run["commit"], "version": run["version"],
                        "verify": verify, "weak_grip": weak_grip, "guard_verify": guard_verify,
                        "model": model and os.path.abspath(model), "guard_threshold": guard_threshold,
                        "replaced": sum(r["replaced"] is not None for r in rows),
                        "headroom": {"repeats": headroom, "tasks": list(headroom_tasks),
                                     "summary": _oracle_summary(rows)} if headroom else None}}
    os.makedirs(out_dir, exist_ok=True)
    atomic_write_json(os.path.join(out_dir, "sealed.json"), res, indent=1)
    print_summary(res["summary"], run["summary"])
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
    with open(path) as fh:
        run = json.load(fh)
    if run.get("schema") != "itup.sealed/1":
        raise SystemExit(f"{path} is not a sealed run (schema itup.sealed/1)")
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
        rows.append(fidelity_row(row, f) | {"run_sdgnet": row["fidelity"]["sdgnet"]})
        print(f"{row['task']:7s} {row['tool']:34s} " + "  ".join(f"{m} {round2(v)}" for m, v in rows[-1]["rho"].items())
              + (f"  retest {round2(f['retest'])}" if redraws else ""), flush=True)

    summary = fidelity_summary(rows, scorers)
    res = {"schema": "itup.sealed_fidelity_of/1", "from": os.path.abspath(path), "models": named, "summary": summary,
           "per_tool": rows, "version": itup.__version__, "commit": code_commit(__file__), "wall_s": time.perf_counter() - t0,
           "machine": machine_info()}
    if redraws:
        res["redraws"], res["retest"] = redraws, retest_summary(rows)
    os.makedirs(out_dir, exist_ok=True)
    atomic_write_json(os.path.join(out_dir, "fidelity_of.json"), res, indent=1)
    for k, s in summary.items():
        for kind, d in s.items():
            line = f"{k:7s} {kind:7s} " + " ".join(f"{m} {round2(v)}" for m, v in d.items())
            if redraws:
                t = res["retest"][k][kind]
                line += (f"  | retest {round2(t['retest'])} ceiling {round2(t['ceiling'])}  vs the mean: "
                         + " ".join(f"{m} {round2(v)}" for m, v in t["rho_mean"].items()))
            print(line)
    return res




def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run", metavar="SEALED_JSON", help="a finished run's sealed.json (experiments/sealed_eval.py)")
    ap.add_argument("--out", default="results/reopened")
    ap.add_argument("--planner-verify", type=int, default=DEFAULT_VERIFY, metavar="K",
                    help="the planner to re-plan with verifies K grasps (0: only where the guard fires; "
                    "default %(default)s, `itup plan`'s)")
    ap.add_argument("--planner-weak-grip", type=float, default=WEAK_GRIP, metavar="N",
                    help="its verification repeats each rollout at N per pad (0: none; default %(default)g)")
    ap.add_argument("--planner-guard-verify", type=int, default=GUARD_VERIFY_K, metavar="K",
                    help="where the guard fires it verifies max(--planner-verify, K) grasps (default "
                    "%(default)s, `itup plan`'s)")
    ap.add_argument("--model", default=None, metavar="CHECKPOINT",
                    help="re-plan with this SDG-Net checkpoint (its guard reference beside it, <stem>.reference.npz) "
                    "instead of the shipped one")
    ap.add_argument("--guard-threshold", type=float, default=None, metavar="T",
                    help="the guard's threshold for the re-planning (default: ood.GUARD_THRESHOLD, the shipped "
                    "checkpoint's; another checkpoint needs its own, experiments/ood_guard.py)")
    ap.add_argument("--headroom", type=int, default=0, metavar="R",
                    help="also the oracle pick of the --tasks' tools from R rollouts of every candidate")
    ap.add_argument("--tasks", default=",".join(TASKS), help="the tasks --headroom asks (default all)")
    ap.add_argument("--fidelity-of", nargs="*", default=None, metavar="[LABEL=]CHECKPOINT",
                    help="only the run's fidelity draw again, ranked by these checkpoints (none: only) beside the "
                    "shipped one and the analytic forms (fidelity_of.json; no re-planning)")
    ap.add_argument("--redraws", type=int, default=0, metavar="R",
                    help="with --fidelity-of: every candidate rolled out R more times, for the retest ceiling and "
                    "the ranking against the draws' mean (default %(default)s)")
    a = ap.parse_args(argv)
    if not os.path.isfile(a.run):
        ap.error(f"SEALED_JSON: no file at {a.run}")
    if a.redraws < 0 or (a.redraws and a.fidelity_of is None):
        ap.error(f"--redraws R >= 0 applies to --fidelity-of, got {a.redraws}")
    replans = (a.model or a.guard_threshold is not None or a.headroom or a.planner_verify != DEFAULT_VERIFY
               or a.planner_weak_grip != WEAK_GRIP or a.planner_guard_verify != GUARD_VERIFY_K)
    if a.fidelity_of is not None and replans:
        ap.error("--fidelity-of re-ranks, it does not re-plan: --model, --guard-threshold, --headroom and the "
                 "--planner-* options do not apply to it")
    if a.model and not (os.path.isfile(a.model) and reference_path_of(a.model)):  # None: no reference on disk
        ap.error(f"--model {a.model}: needs the checkpoint and its guard reference ({reference_path(a.model)})")
    if a.guard_threshold is not None and not (np.isfinite(a.guard_threshold) and a.guard_threshold > 0):
        ap.error(f"--guard-threshold must be a finite number > 0, got {a.guard_threshold}")
    if a.planner_verify < 0 or a.planner_guard_verify < 0 or a.headroom < 0:
        ap.error(f"--planner-verify, --planner-guard-verify and --headroom must be >= 0, got {a.planner_verify}, "
                 f"{a.planner_guard_verify}, {a.headroom}")
    tasks = tuple(t for t in a.tasks.split(",") if t)
    if any(t not in TASKS for t in tasks):
        ap.error(f"--tasks among {','.join(TASKS)}, got {a.tasks!r}")
    if a.model:
        load_model(a.model)  # a checkpoint that cannot be read stops here, before any rollout
    if a.fidelity_of is not None:
        return fidelity_of(a.run, a.out, a.fidelity_of, a.redraws)
    return reopen(a.run, a.out, a.headroom, tasks, a.planner_verify, a.planner_weak_grip or None,
                  a.planner_guard_verify, a.model, a.guard_threshold)


if __name__ == "__main__":
    main()

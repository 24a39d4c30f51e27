"""The sealed evaluation: the protocol of docs/results.md ("The sealed evaluation"), run once per checkpoint.

    python experiments/sealed_eval.py --out results/sealed                   # the protocol (once)
    python experiments/sealed_eval.py --quick --out results/sealed_quick     # 1 tool per task, small (tests)

The protocol's parts live in `itup_jax.sealed`; a finished run's tools are re-planned, re-measured and
re-ranked by `experiments/sealed_reopen.py`. The test tools are drawn from the checkpoint itself, so no one chooses them and a new checkpoint gets
new ones: for task k and tool i (0-15) the seed is the first 8 bytes, big-endian, of
SHA-256(checkpoint bytes || salt || k || i), with k the task's name and i in decimal, both UTF-8
(`sealed.sealed_seed`), and the salt empty in round 1 and "/round<r>" in round r (`sealed.round_salt`, `sealed.ROUND`): a
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
    peak torque (the fidelity); from round 6 every candidate --redraws R more times (default
    `sealed.REDRAWS`): the retest correlation of two draws, the ceiling it sets, and each scorer against
    the mean of the draws.
Reported per task: the planner's reduction of the full induced torque against force closure, geometric
ranking and the better of the two on each tool (100 (1 - ratio) per tool: the median over the 16 tools
with a 90 % bootstrap interval, and beside it the paired geometric mean), the share of other-family
tools on which it is below force closure's; grip failures at 25 N (50 rollouts per method and task)
against the better baseline's; the median fidelity per task (pooled only beside it). The paper's
margins: 17.6 / 17.5 / 11.6 / 20.8 % over GQ-CNN, 10.2 / 14.3 / 10.4 / 13.5 % over GraspNet (hammer /
sweep / knock / reach). Writes sealed.json (schema `itup.sealed/1`); while it runs,
sealed.partial.json holds the rows so far.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import time

import itup_jax as itup
from itup_jax.atomic import atomic_write_json
from itup_jax.bench import machine_info
from itup_jax.dataset import WEAK_GRIP
from itup_jax.planning import DEFAULT_VERIFY, GUARD_VERIFY_K
from itup_jax.scoring import ScoreWeights
from itup_jax.sdgnet.config import DEFAULT_MODEL
from itup_jax.sealed import (
    PAPER,
    QUICK_SALT,
    REDRAWS,
    ROUND,
    TASKS,
    code_commit,
    evaluate_tool,
    print_summary,
    round_salt,
    sealed_tools,
    summarise,
)
from itup_jax.tools import families


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tools", type=int, default=16, help="test tools per task (default %(default)s)")
    ap.add_argument("--n", type=int, default=256, help="candidates per tool (default %(default)s)")
    ap.add_argument("--draws", type=int, default=5, help="randomised rollouts per pick and grip (default %(default)s)")
    ap.add_argument("--tasks", default=",".join(TASKS))
    ap.add_argument("--redraws", type=int, default=REDRAWS, metavar="R",
                    help="the fidelity draw's redraws: every candidate rolled out R more times (default %(default)s)")
    ap.add_argument("--quick", action="store_true",
                    help="hammer and reach, 2 tools each, 24 candidates, 2 draws, 1 redraw (tests)")
    ap.add_argument("--out", default="results/sealed")
    ap.add_argument("--round", type=int, default=ROUND,
                    help="the sealed evaluation's round, which salts the seeds (`sealed.round_salt`; default %(default)s)")
    a = ap.parse_args(argv)
    if a.round < 1:
        ap.error(f"--round must be >= 1, got {a.round}")
    if a.quick:
        a.tools, a.n, a.draws, a.redraws, a.tasks = 2, 24, 2, 1, "hammer,reach"
    tasks = tuple(t for t in a.tasks.split(",") if t)
    if not a.quick and not families.sealed():
        ap.error(f"round {a.round}: no sealed-test family (role 'sealed' in itup_jax/tools/families.py): add the "
                 "round's new families and write its protocol in docs/results.md before its draw")
    bad = [t for t in tasks if t not in TASKS]
    if bad or a.tools < 1 or a.n < 1 or a.draws < 1 or a.redraws < 0:
        ap.error(f"--tasks among {','.join(TASKS)}, --tools, --n and --draws >= 1, --redraws >= 0; got {a.tasks!r}, "
                 f"{a.tools}, {a.n}, {a.draws}, {a.redraws}")
    with open(DEFAULT_MODEL, "rb") as fh:
        checkpoint = fh.read()
    # --quick draws its tools from other seeds, so that a test run never rolls out a sealed tool
    draw_from = checkpoint + round_salt(a.round) + (QUICK_SALT if a.quick else b"")
    t0, rows, commit = time.perf_counter(), [], code_commit(__file__)  # the code that runs, before any rollout
    os.makedirs(a.out, exist_ok=True)
    partial = os.path.join(a.out, "sealed.partial.json")
    for k in tasks:
        for e in sealed_tools(draw_from, k, a.tools):
            t = time.perf_counter()
            weak = e["i"] % 8 < 5 if not a.quick else True
            rows.append(evaluate_tool(e, k, a.n, a.draws, weak, with_fidelity=True, redraws=a.redraws))
            atomic_write_json(partial, {"commit": commit, "round": a.round, "per_tool": rows}, indent=1)  # kept if it stops
            r = rows[-1]
            picks = "  ".join(f"{m} {p['peak_torque_induced']:.2f}" for m, p in r["picks"].items())
            print(f"{k:7s} {r['tool']:28s} {r['candidates']:4d} cands  guard "
                  f"{'fired' if r.get('planner', {}).get('guard_fired') else 'quiet'}  {picks}  ({time.perf_counter() - t:.0f} s)"
                  + (f"  no task: {r['task_refused']}" if "task_refused" in r else ""), flush=True)
    out = {"schema": "itup.sealed/1", "checkpoint_sha256": hashlib.sha256(checkpoint).hexdigest(),
           "version": itup.__version__, "commit": commit,
           "config": {"tools": a.tools, "n": a.n, "draws": a.draws, "redraws": a.redraws, "tasks": list(tasks), "quick": a.quick,
                      "round": a.round,
                      "verify": DEFAULT_VERIFY, "guard_verify": GUARD_VERIFY_K, "verify_weak_grip": WEAK_GRIP},
           "weights": ScoreWeights().__dict__, "paper": PAPER, "summary": summarise(rows),
           "per_tool": rows, "wall_s": time.perf_counter() - t0, "machine": machine_info()}
    atomic_write_json(os.path.join(a.out, "sealed.json"), out, indent=1)
    os.remove(partial)
    print_summary(out["summary"])
    return out


if __name__ == "__main__":
    main()

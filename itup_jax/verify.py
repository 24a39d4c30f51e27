"""Verified picks: SDG-Net screens every candidate, MuJoCo rolls out the k best, the best measured wins.

    v = itup.best_grasp_verified(tool, task, grasps, k=5)   # SDG-Net, then 5 nominal rollouts
    v.index, v.grasp, v.labels.peak_torque_induced, v.chosen_by
    v = itup.best_grasp_verified(tool, task, grasps, k=10, weights=itup.ScoreWeights.torque_first())
    v = itup.best_grasp_verified(tool, task, grasps, k=10, draws=3, randomize=itup.Randomization())
    v = itup.best_grasp_verified(tool, task, grasps, k=5, weak_grip=25.0)  # + each rollout again at 25 N per pad

SDG-Net ranks a tool's candidates fairly well (median Spearman 0.81 per unseen tool against the measured
full induced peak wrist torque) but its single pick is often not the best. Rolling the k best reachable
ones out once each (k = 5: 0.16-0.35 s per task on a 2-core CPU, `itup bench verify`) and taking the
lowest *measured* total catches picks the network got wrong: on the unseen test tools the verified
pick carries 2.65 N m of full induced torque against 2.96 N m for the scorer's own (mean over three
physics draws), and verifying the best of 1,024 or 4,096 candidates instead of 256 lowers it by
10-12 % (docs/results.md,
"Fidelity and training time", "Scoring more candidates"). With a torque-only `weights` the pick is the
lowest measured torque, which on most tools is a grasp that fails the task.

With `draws` r > 1 each shortlisted grasp is rolled out r times under r draws of the physical priors
(`randomize`), and its measured total is the mean over them: a grasp that misses the task or slips out
in one draw of three carries a third of that penalty. One nominal rollout cannot tell a grasp that does
the task from one that does it only at the priors' nominal values (docs/results.md).
The measured total is the SDG-Net total (`ScoreWeights`)
with each prediction replaced by what the rollout measured (`measured_total`): the full induced peak
torque (N m) and the grip demand (N per pad) for the wrench objective, the projected peak torque for the
paper's, slip (m), alignment drift (rad), whether the task was achieved (1/0) and whether the grasp
failed in the grip (1/0); with `weak_grip` (`plan_grasp` passes `robot.WEAK_GRIP`, 25 N per pad) each
rollout is repeated on the same physics draw at that fixed grip and a failure there (slip or turn in the
pads, or a rollout that diverges) adds w_weak, as the network's weak-grip head adds its predicted
probability: without it a verified shortlist picks by the default grip alone, and the grasp that carries
the least there is often one that slips out at 25 N (docs/results.md, "Verification at the weak grip").
Under nominal physics a grasp is rolled out at the weak grip only while it can still win
(`weak_where_it_can_win`): the same pick, usually with one call of weak-grip rollouts instead of k.
Grasps the arm cannot reach along the task (closed-form IK) are skipped before any
rollout; a grasp with a rollout that diverges cannot win and is replaced by the next reachable grasp; if
no grasp has valid rollouts, the scorer's own pick stands (`chosen_by` = "score").

Nothing here is jit-compiled: the scoring inside `score` is (one jit at its outer call); the rollouts are
native MuJoCo or MJX (`simulate`).
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np

from itup_jax.errors import InputError, is_integer
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.scoring import Scores, ScoreWeights, score
from itup_jax.sdgnet.objective import get as get_objective
from itup_jax.sim.arm import reachability_in_order
from itup_jax.sim.labels import LABEL_FIELDS, Labels
from itup_jax.sim.physics import Randomization
from itup_jax.sim.rollout import default_backend, simulate
from itup_jax.sim.scene import Scene, build_scene
from itup_jax.stress import check_grip, simulate_at_grip
from itup_jax.task import Task
from itup_jax.tools import Tool


@dataclasses.dataclass(frozen=True)
class Verified:
    """A verified pick.

    index: the chosen grasp's index into the candidates.  grasp: that grasp.  scores: the scorer's
    scores of every candidate.  shortlist: [M] the candidates rolled out, best score first (M > k when
    some rollouts diverged).  draws: r, rollouts per shortlisted candidate.  labels: their measured
    `Labels`, each [M * r], candidate-major (candidate j's draws at j r ... j r + r - 1;
    `candidate_labels` reshapes one to [M, r]).  measured_total: [M] the candidate's measured total, the
    mean over its draws (inf where one of its rollouts is not valid; for a candidate not rolled out at
    the weak grip, see weak_checked, its total at the default grip: a lower bound above the pick's).  chosen_by: "measured", or "score"
    when no candidate had valid rollouts (then the best-scored grasp stands, reachable or not).  backend:
    the rollouts' backend.  unreachable: the candidates skipped because the arm cannot follow their
    trajectory, best score first (those scored ahead of the last one rolled out; every candidate when
    none is reachable).  weak_grip: N per pad of the weak-grip rollouts, or None when there were none.
    weak_labels: their `Labels`, each [M * r], row for row with `labels` (the same physics draw), or None;
    `Labels.unmeasured` rows where a candidate was not rolled out at the weak grip.  weak_checked: [M * r]
    bool, the rows rolled out at the weak grip, or None without weak-grip rollouts. Under nominal physics
    only the candidates that could still win are (`weak_where_it_can_win`: the same pick as rolling out
    all of them); under randomised physics every one is.
    """

    index: int
    grasp: Grasps
    scores: Scores
    shortlist: np.ndarray
    labels: Labels
    measured_total: np.ndarray
    chosen_by: str
    backend: str
    unreachable: np.ndarray
    draws: int = 1
    weak_grip: float | None = None
    weak_labels: Labels | None = None
    weak_checked: np.ndarray | None = None

    @property
    def succeeded(self) -> bool:
        """Whether the pick was checked and did the task and held in every one of its rollouts (valid,
        success, not failed): False when none of the verified grasps did, or none was rolled out."""
        if self.chosen_by != "measured":
            return False
        r = int(np.nonzero(self.shortlist == self.index)[0][0])
        ok = (self.candidate_labels("valid") & self.candidate_labels("success") & ~self.candidate_labels("failed"))[r]
        return bool(ok.all())

    def candidate_labels(self, field: str, weak: bool = False) -> np.ndarray:
        """[M, r] one `Labels` field (e.g. "peak_torque_projected", "success") per shortlisted candidate and
        draw; weak=True: of the weak-grip rollouts (InputError when there were none)."""
        if field not in LABEL_FIELDS:
            raise InputError(f"Verified.candidate_labels: field must be one of {LABEL_FIELDS}, got {field!r}")
        if weak and self.weak_labels is None:
            raise InputError("Verified.candidate_labels: weak=True, but this pick was verified without weak-grip "
                             "rollouts (best_grasp_verified(weak_grip=...))")
        L = self.weak_labels if weak else self.labels
        return np.asarray(getattr(L, field)).reshape(len(self.shortlist), self.draws)

    @property
    def weak_failed(self) -> np.ndarray | None:
        """[M * r] bool per rollout, row for row with `labels`: the weak-grip rollout failed in the grip or
        was not valid (False where there was none: `weak_checked`); None without weak-grip rollouts."""
        if self.weak_labels is None:
            return None
        failed = weak_failures(self.weak_labels)
        return failed if self.weak_checked is None else failed & self.weak_checked


def objective_of(scores: Any) -> str:
    """The objective a set of scores was made under: 'wrench' when they carry a predicted grip demand
    (a wrench-objective SDG-Net), else 'paper'."""
    return "wrench" if getattr(scores, "grip", None) is not None else "paper"


def weak_failures(weak: Labels) -> np.ndarray:
    """[N] bool: a weak-grip rollout failed in the grip, or was not valid (diverged: the tool loose in
    the pads)."""
    return ~np.asarray(weak.valid, bool) | np.asarray(weak.failed, bool)


def measured_total(labels: Labels, weights: ScoreWeights = ScoreWeights(), objective: str = "paper",
                   weak_failed: np.ndarray | None = None) -> np.ndarray:
    """[N] the `ScoreWeights` total of measured labels: SDG-Net's total (`sdgnet_total`) with each
    prediction replaced by its measurement, success and failure counting as probabilities 1 or 0
    (w_tau tau + w_slip slip + w_align drift + w_grip grip + w_task (1 - success) + w_fail failed; tau
    the projected peak torque for the paper's objective, the full induced one for the wrench
    objective, which alone also counts the grip demand; + w_weak weak_failed when `weak_failed` [N]
    (1/0, `weak_failures` of the weak-grip rollouts) is given); inf where the rollout is not valid."""
    tau = get_objective(objective, what="measured_total").measured_tau
    grip = (weights.w_grip * np.asarray(labels.grip_demand, np.float64) if objective == "wrench"
            else np.zeros(len(labels.valid)))
    total = grip + (weights.w_tau * np.asarray(getattr(labels, tau), np.float64)
             + weights.w_slip * np.asarray(labels.slip_translation, np.float64)
             + weights.w_align * np.asarray(labels.alignment_drift, np.float64)
             + weights.w_task * (1.0 - np.asarray(labels.success, np.float64))
             + weights.w_fail * np.asarray(labels.failed, np.float64))
    if weak_failed is not None:
        weak_failed = np.asarray(weak_failed, np.float64)
        if weak_failed.shape != total.shape:
            raise InputError(f"measured_total: weak_failed must have shape {total.shape} like the labels, "
                             f"got {weak_failed.shape}")
        total = total + weights.w_weak * weak_failed
    return np.where(np.asarray(labels.valid, bool), total, np.inf)


def best_grasp_verified(tool: Tool, task: Task, grasps: Grasps, model: Any = None, *, k: int = 5, draws: int = 1,
                        seed: int = 0,
                        randomize: Randomization | None = None, weights: ScoreWeights = ScoreWeights(),
                        scores: Any = None, scene: Scene | None = None, backend: str | None = None,
                        nthread: int | None = None, order: Any = None, weak_grip: float | None = None) -> Verified:
    """Score every grasp, roll the k best reachable ones out in MuJoCo, pick the lowest measured total.

    The candidates are walked in score order: a grasp whose task trajectory the arm cannot follow
    (closed-form IK, `sim.arm.reachable`) is skipped, and a grasp with a rollout that is not valid
    (diverged) is replaced by the next reachable grasp, until k grasps have valid rollouts or the
    candidates run out.

    Args:
      tool, task, grasps: as for `score` (grasps [N]).
      model: as for `score` (default: the shipped SDG-Net checkpoint); ignored when `scores` is given.
      k: verified grasps wanted (>= 1; k = 1 with draws = 1 keeps the best-scored reachable grasp).
      draws: rollouts per verified grasp (>= 1), each under its own draw of `randomize` (required when
        draws > 1: nominal physics rolls out the same every time); the grasp's measured total is their
        mean.
      seed, randomize: the rollouts' physics: nominal priors by default (`randomize=None`); with a
        `Randomization`, one draw per rollout (round r of replacements draws from seed + r).
      weights: the total that both the scorer's ranking and the measured pick use (measured with the
        scorer's objective: the wrench objective's when the scores carry a grip demand).
      scores: precomputed scores of these grasps (`score(...)`, `wrench_costs(...)`, any object with a
        `total` [N], lower is better); skips scoring.
      scene, backend, nthread: passed to `simulate` (scene: a prebuilt `build_scene(tool, task)`).
      order: the candidates in the order to try, [M] distinct indices into grasps (default: by the
        scores' total, lowest first); the pick is still the lowest measured total among those rolled out
        (`planning.guard_order`: the planner's shortlist when the out-of-distribution guard fired).
      weak_grip: N per pad, or None (default): each rollout repeated on its physics draw at this fixed
        grip (`stress.simulate_at_grip`, as `dataset.weak_rollouts` labels the network's weak-grip head; the
        same backend), and `weights.w_weak` added to the measured total where it fails
        in the grip or diverges. Under randomised physics every rollout is repeated (twice the rollouts);
        under nominal physics only those of the grasps that can still win (`weak_where_it_can_win`).
    """
    validate_grasps(grasps)
    if not is_integer(k) or k < 1:
        raise InputError(f"best_grasp_verified: k must be an integer >= 1 (verified grasps wanted), got {k!r}")
    if not is_integer(draws) or draws < 1:
        raise InputError(f"best_grasp_verified: draws must be an integer >= 1 (rollouts per verified grasp), "
                         f"got {draws!r}")
    if weak_grip is not None:
        weak_grip = check_grip(weak_grip, "best_grasp_verified: weak_grip")
    if draws > 1 and randomize is None:
        raise InputError(f"best_grasp_verified: draws={draws} needs randomize (a Randomization): under nominal "
                         "physics every draw of a grasp rolls out the same")
    if scores is None:
        scores = score(tool, task, grasps, model, weights=weights, seed=seed)
    total = np.asarray(scores.total, np.float64)
    if total.shape != (len(grasps),):
        raise InputError(f"best_grasp_verified: scores.total must have shape ({len(grasps)},) like the grasps, "
                         f"got {total.shape}")
    if order is None:
        order = np.argsort(total, kind="stable")
    else:
        order = np.asarray(order)
        if (order.ndim != 1 or not np.issubdtype(order.dtype, np.integer) or len(np.unique(order)) != len(order)
                or (len(order) and (order.min() < 0 or order.max() >= len(grasps)))):
            raise InputError(f"best_grasp_verified: order must list distinct candidate indices in [0, {len(grasps)}), "
                             f"got {np.asarray(order).tolist()[:8]}{'...' if np.size(order) > 8 else ''}")
    scene = scene or build_scene(tool, task)
    host = grasps.to_host()  # the rows rolled out are taken on the host: no gather compiled per batch size
    # reachability is checked this many candidates at a time (IK ~0.2 ms each, warm)
    walk = reachability_in_order(task, host, order, chunk=max(4 * int(k), 16))
    queue: list[int] = []  # reachable, not yet rolled out, in score order
    unreachable: list[int] = []
    tried: list[int] = []
    parts: list[Labels] = []
    weak_parts: list[Labels] = []
    n_valid, r, backend_used = 0, 0, backend or default_backend()
    while n_valid < k:
        for i, ok in walk:
            (queue if ok else unreachable).append(i)
            if len(queue) >= k - n_valid:
                break
        if not queue:
            break
        batch, queue = queue[: k - n_valid], queue[k - n_valid:]
        # every grasp of the batch `draws` times, candidate-major; each rollout draws its own physics
        res = simulate(tool, task, host[np.repeat(np.asarray(batch), draws)], seed=seed + r, randomize=randomize,
                       scene=scene, backend=backend, nthread=nthread)
        parts.append(res.labels)
        if weak_grip is not None and randomize is not None:  # the same rows on the same draws, at weak_grip
            weak_parts.append(simulate_at_grip(tool, task, host[np.repeat(np.asarray(batch), draws)], weak_grip,
                                               seed=seed + r, randomize=randomize, scene=scene, backend=backend,
                                               nthread=nthread))
        tried += batch
        ok_all = np.asarray(res.labels.valid, bool).reshape(len(batch), draws).all(axis=1)
        n_valid, r, backend_used = n_valid + int(ok_all.sum()), r + 1, res.backend
    labels = Labels.concatenate(parts)
    objective = objective_of(scores)
    weak = weak_checked = None
    if weak_grip is None:
        # the mean over a candidate's draws; inf (it cannot win) when one of them is not valid
        m = measured_total(labels, weights, objective).reshape(len(tried), draws).mean(axis=1)
    elif randomize is None:  # nominal physics: a grasp's rollout is the same whichever rows it shares a call with
        m, weak, weak_checked = weak_where_it_can_win(tool, task, host, tried, labels, weights, objective, weak_grip,
                                                      scene=scene, backend=backend, nthread=nthread)
    else:
        weak = Labels.concatenate(weak_parts)
        weak_checked = np.ones(len(weak.valid), bool)
        m = measured_total(labels, weights, objective, weak_failures(weak)).reshape(len(tried), draws).mean(axis=1)
    if np.isfinite(m).any():
        i, chosen_by = tried[int(np.argmin(m))], "measured"
    else:
        i, chosen_by = int(order[0]), "score"
    return Verified(index=int(i), grasp=grasps[int(i)], scores=scores, shortlist=np.asarray(tried, np.int64),
                    labels=labels, measured_total=m, chosen_by=chosen_by, backend=backend_used,
                    unreachable=np.asarray(sorted(unreachable, key=lambda j: total[j]), np.int64), draws=int(draws),
                    weak_grip=weak_grip, weak_labels=weak, weak_checked=weak_checked)


def weak_where_it_can_win(tool: Tool, task: Task, grasps: Grasps, tried: list[int], labels: Labels,
                          weights: ScoreWeights, objective: str, weak_grip: float, *, scene: Scene,
                          backend: str | None, nthread: int | None) -> tuple[np.ndarray, Labels, np.ndarray]:
    """The weak-grip rollouts of a nominal-physics check, only where they can change the pick:
    (measured total [M], weak-grip labels [M] row for row with `labels`, rolled out [M] bool).

    A failure at the weak grip only adds w_weak >= 0 to a grasp's total, so its total at the default grip
    is a lower bound of its full one. The grasps are taken in the order of those bounds and rolled out at
    `weak_grip` (a few at a time: as many as the rollout threads) while the next bound is no higher than
    the lowest full total so far; a grasp left out has a bound above that total and cannot be the
    lowest. The pick (the lowest full total, the first of a tie in `tried`'s order) is the one that
    rolling every grasp out at `weak_grip` gives: under nominal physics a grasp's rollout does not
    depend on the other rows of its call (native MuJoCo: bit for bit; MJX's batched kernels can differ
    in the last float bits with the batch's size). A grasp left out keeps its bound as its measured total and
    `Labels.unmeasured` rows as its weak-grip labels. Usually the best at the default grip holds at
    25 N and one call of weak-grip rollouts replaces k. Host side.

    grasps: host arrays of the candidates; tried: [M] the indices rolled out, labels: their nominal
    `Labels` [M] (one draw each).
    """
    bound = measured_total(labels, weights, objective)
    total = bound.copy()
    checked = np.zeros(len(tried), bool)
    weak = Labels.unmeasured(len(tried)).as_dict()
    by_bound = [int(j) for j in np.argsort(bound, kind="stable") if np.isfinite(bound[j])]
    width = max(1, int(nthread or os.cpu_count() or 1))
    best = np.inf
    while by_bound and bound[by_bound[0]] <= best:
        take = [j for j in by_bound[:width] if bound[j] <= best]
        by_bound = by_bound[len(take):]
        rows = np.asarray(take)
        w = simulate_at_grip(tool, task, grasps[np.asarray(tried)[rows]], weak_grip, seed=0, randomize=None,
                             scene=scene, backend=backend, nthread=nthread)
        nominal = Labels(**{f: np.asarray(getattr(labels, f))[rows] for f in LABEL_FIELDS})
        total[rows] = measured_total(nominal, weights, objective, weak_failures(w))
        checked[rows] = True
        for f in LABEL_FIELDS:
            weak[f][rows] = np.asarray(getattr(w, f))
        best = min(best, float(total[rows].min()))
    return total, Labels(**weak), checked


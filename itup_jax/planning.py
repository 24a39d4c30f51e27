"""Planning a grasp for a task: sample, score, walk the ranking to the best grasp the arm can carry,
and optionally check the best ones in MuJoCo. `itup plan` is this function and a printout.

    plan = plan_grasp(tool, task, n=1000)     # SDG-Net ranks, MuJoCo checks the 5 best (verify=5, the default)
    plan = plan_grasp(tool, task, verify=0)   # the best-scored reachable grasp, no rollout (unless the guard fires)
    plan.sampling          # {"requested", "reachable", "drawn", "budget", "complete"}: every candidate is one
                           # the arm can carry through the task (sampling="all": n drawn, reachability walked)
    plan.status            # "ok", "no_reachable_candidate" or "no_verified_success"
    plan.pick              # index into plan.grasps of the recommended grasp (None unless status is "ok")
    plan.to_json()         # the `itup.plan/8` document (itup_jax/schemas/plan.schema.json)

Host-side orchestration: the scorers and the rollouts it calls jit themselves at their outer calls.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from itup_jax import robot
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, to_graspnet
from itup_jax.grasp_sampler import MAX_CANDIDATES
from itup_jax.tools import Tool

#: Candidates sampled by default.
DEFAULT_N = 1000
#: Ranking rows reported by default.
DEFAULT_TOP = 5
#: How candidates are drawn (`plan_grasp(sampling=...)`): "reachable" draws until n of them are grasps the
#: arm can carry through the task (`grasp_sampler.sample_reachable`); "all" draws n and walks the ranking to
#: the first reachable one.
SAMPLING_MODES = ("reachable", "all")
#: Grasps rolled out in MuJoCo by default (`plan_grasp(verify=)`): the pick is the lowest measured total of
#: the scorer's DEFAULT_VERIFY best reachable grasps (each also at the weak grip). Chosen on validation
#: tools: the verified pick carries less full induced torque than the best-scored one on every task
#: (docs/results.md, "The planner verifies its pick"). 20 carries less still on both sealed rounds' tools
#: but costs ~0.6-1.0 s more per plan on a 2-core CPU, over the plan's 3 s goal ("How many grasps to check").
DEFAULT_VERIFY = 5
#: Grasps rolled out in MuJoCo when the out-of-distribution guard fires (`plan_grasp(guard_verify=)`): the
#: check then covers max(verify, GUARD_VERIFY_K) grasps, also with verify 0. Where the guard fires the
#: network's ranking is least to be trusted and 20 rollouts reach further down it; where it is quiet (the
#: built-in tools) the plan keeps its DEFAULT_VERIFY and its time. Chosen on validation tools by a rule
#: written before the re-run (docs/results.md, "Checking more where the guard fires").
GUARD_VERIFY_K = 20
#: The share of a verified shortlist the analytic wrench cost chooses when the guard fired (`guard_order`):
#: 2 of 5. Chosen on the held-out families' calibration tools (`experiments/guard_shortlist.py`, rule
#: fixed before the run): picks that did the task and held in 3 random draws, 35 tools: SDG-Net's 5 best
#: 29, this mix 35, the analytic cost's 5 best 35, the best by SDG-Net along the handle 31.
GUARD_ANALYTIC_SHARE = 0.4
#: How a verified shortlist was chosen (`GraspPlan.shortlist_rule`).
SHORTLIST_RULES = ("scorer", "guard_mixed")
#: Statuses of a plan (`GraspPlan.status`).
STATUSES = ("ok", "no_reachable_candidate", "no_verified_success")
#: The measured labels reported per verification rollout.
VERIFY_FIELDS = ("valid", "peak_torque_induced", "peak_torque_projected", "grip_demand", "slip_translation", "slip_rotation",
                 "alignment_drift", "failed", "success", "infeasible", "task_metric")


@dataclasses.dataclass(frozen=True, eq=False)
class GraspPlan:
    """What `plan_grasp` found (host side).

    Attributes:
      grasps: the N candidates.  scores: the scorer's `Scores` of them ([N] arrays).
      sampling: how they were drawn: {"mode", "requested", "reachable", "drawn", "budget", "complete"}
        (mode "all": drawn = requested, and reachable counts only the candidates checked).
      guard: the out-of-distribution guard's reading (`ood.Guard`) for an SDG-Net scorer, else None;
        when it fired, the plan verified max(verify, guard_verify) grasps (`plan_grasp`).
      ranking: [N] candidate indices by increasing total.  top: the first `top` of them.
      reachable: {index: bool} for every candidate whose reachability was checked (closed-form IK).
      pick_rank: 0-based rank of the best-scored reachable candidate (0 when none is).
      pick: its index, or None when `status` is not "ok".
      status: "ok", "no_reachable_candidate", or "no_verified_success" (with verification: none of the
        verified grasps did the task and held in all of its rollouts).
      advice: what to try when `status` is not "ok".
      verified: `verify.Verified` of the MuJoCo check, or None.
      shortlist_rule: how the verified grasps were chosen: "scorer" (the best by the scorer) or "guard_mixed"
        (the guard fired: `guard_order`).
      verify_rows: one dict per verification rollout (`VERIFY_FIELDS`, index, draw, measured_total).
      weights: the scorer's weights as given to it (None for a baseline).  measure_weights: the
        `ScoreWeights` of the measured total (verification).  physics: "nominal" or "random".
    """

    tool: Tool
    task: Any
    grasps: Grasps
    scores: Any
    ranking: np.ndarray
    top: np.ndarray
    reachable: dict
    pick_rank: int
    pick: int | None
    status: str
    advice: tuple
    n: int
    seed: int
    scorer: str
    weights: dict | None
    regime: str
    graspnet_rotation: np.ndarray = None  # [N, 3, 3] the candidates' rotations in graspnetAPI's convention
    verified: Any = None
    verify_rows: tuple = ()
    verify_k: int = 0
    verify_draws: int = 1
    measure_weights: Any = None
    physics: str = "nominal"
    sampling: dict = dataclasses.field(default_factory=dict)
    guard: Any = None
    guard_verified: bool = False
    shortlist_rule: str = "scorer"

    @property
    def best_index(self) -> int:
        """The scorer's pick: the best-scored reachable candidate (the first when none is reachable)."""
        return int(self.ranking[self.pick_rank])

    def row(self, i: int) -> dict[str, Any]:
        """The JSON row of candidate i: pose, width, reachability, graspnet rotation, scores."""
        s, g = self.scores, self.grasps
        host = lambda a: np.asarray(a)[i]  # noqa: E731 - indexed on the host: no device op per field
        return {
            "index": int(i),
            "p_tool_grasp_m": host(g.p_tool_grasp).astype(float).round(6).tolist(),
            "q_tool_grasp_wxyz": host(g.q_tool_grasp).astype(float).round(6).tolist(),
            "width_m": round(float(host(g.width)), 6),
            "reachable": self.reachable.get(int(i)),
            "graspnet_rotation_matrix": np.asarray(self.graspnet_rotation[i], float).round(6).tolist(),
            "costs": {k: round(float(host(getattr(s, k))), 6) for k in ("tau", "slip", "align", "total", "tau_closure",
                                                                         "grip", "p_success", "p_failed",
                                                                         "p_failed_weak")
                      if getattr(s, k, None) is not None},
        }

    def report(self) -> str:
        """The plan as `itup plan` prints it: the ranking, the pick, the verification rollouts and what to
        try when there is no pick."""
        lines: list[str] = []
        out = lines.append
        tool, grasps, costs = self.tool, self.grasps, self.scores
        sm = self.sampling
        drawn = (f"{sm['reachable']} reachable of {sm['drawn']} drawn" if sm["mode"] == "reachable"
                 else f"{sm['drawn']} drawn")
        out(f"task {self.task.kind} | tool {tool.name} ({tool.mass:.3f} kg) | regime {self.regime} | "
            f"{self.n} antipodal candidates ({drawn}, seed {self.seed}) | scorer {self.scorer}")
        if sm["mode"] == "reachable" and not sm["complete"]:
            out(f"warning: the arm can carry {sm['reachable']} of {sm['drawn']} drawn candidates through the task, "
                f"fewer than the {sm['requested']} asked for (--budget {sm['budget']} spent)")
        if sm.get("unreachable"):
            from itup_jax.sim.arm import describe_unreachable

            out(f"note: the arm can carry {100.0 * sm['reachable'] / sm['drawn']:.1f} % of the drawn candidates through "
                f"the task; {describe_unreachable(sm['unreachable'], self.task)}")
        g = self.guard
        if g is not None and g.fired:
            if self.verified is not None:
                what = f"{self.verify_k} grasps are rolled out in MuJoCo and the pick is the best measured"
            else:
                what = "--no-guard: the learned score decides the pick"
            if self.shortlist_rule == "guard_mixed":
                m = int(GUARD_ANALYTIC_SHARE * self.verify_k)
                what += (f"; the grasps verified are SDG-Net's {self.verify_k - m} best and the analytic wrench cost's "
                         f"{m} best (--guard-verify K: how many where the guard fires; --no-guard: trust the learned "
                         "score)")
            out("warning: " + g.message(tool.name, self.task.kind) + "; " + what)
        if costs is None:  # the reachable sampler found none: nothing was scored
            out(f"no pick: none of the {sm['drawn']} drawn candidates is reachable for the arm along the task "
                "(closed-form IK); " + "; ".join(self.advice))
            return "\n".join(lines)
        # analytic costs are wrench components (N m, N, rad); SDG-Net predicts measured torque, slip, drift
        # (N m, m, rad); the baselines' scores are dimensionless
        units = {"analytic": ("N·m", "N", "rad"), "analytic_wrench": ("N·m", "N", "rad"), "sdgnet": ("N·m", "m", "rad"),
                 "sdgnet_paper": ("N·m", "m", "rad")}.get(self.scorer, ("", "", ""))
        grip = getattr(costs, "grip", None) is not None  # a wrench-objective SDG-Net: predicted grip demand (N per pad)
        p_task = getattr(costs, "p_success", None) is not None  # SDG-Net with a success head: P(task achieved)
        p_fail = getattr(costs, "p_failed", None) is not None  # and with a failure head: P(fails in the grip)
        p_weak = getattr(costs, "p_failed_weak", None) is not None  # and with a weak-grip head: P(fails at 25 N)
        out(f"{'rank':>4} {'idx':>5} {'C_tau ' + units[0]:>10} {'C_s ' + units[1]:>9} {'C_alpha ' + units[2]:>11} "
            + (f"{'grip N':>7} " if grip else "")
            + (f"{'P(task)':>7} " if p_task else "") + (f"{'P(fail)':>7} " if p_fail else "")
            + (f"{'P(f@25)':>7} " if p_weak else "")
            + f"{'C':>9} {'reach':>5}  grasp origin (tool frame, m)")
        listed = [(rank, int(i)) for rank, i in enumerate(self.top)]
        pick_rank, best = self.pick_rank, self.best_index
        if pick_rank >= len(self.top):  # the pick lies below the listed ones: its row follows them
            listed.append((pick_rank, best))
        marked = self.status == "ok" and self.verified is None
        for rank, i in listed:
            c = self.row(i)["costs"]
            if rank > len(self.top):  # a gap between the listed rows and the pick
                out(f"{'...':>4}")
            out(f"{rank + 1:>4} {i:>5} {c['tau']:>10.3f} {c['slip']:>9.3f} {c['align']:>11.3f} "
                + (f"{c['grip']:>7.1f} " if grip else "")
                + (f"{c['p_success']:>7.2f} " if p_task else "") + (f"{c['p_failed']:>7.2f} " if p_fail else "")
                + (f"{c['p_failed_weak']:>7.2f} " if p_weak else "")
                + f"{c['total']:>9.3f} {'yes' if self.reachable[i] else 'no':>5}  "
                f"{np.asarray(grasps.p_tool_grasp)[i].astype(float).round(4).tolist()}"
                f"{' <- pick' if i == best and marked else ''}")
        if self.status == "no_reachable_candidate":
            out(f"no pick: none of the {self.n} candidates is reachable for the arm along the task (closed-form IK); "
                + "; ".join(self.advice))
        elif pick_rank > 0:
            out(f"reach: whether the arm can follow the task trajectory with the grasp (closed-form IK); the pick is "
                f"the best-scored reachable grasp (rank {pick_rank + 1}); --verify K rolls out the K best reachable ones")
        total = np.asarray(costs.total)
        out(f"all candidates: C {total.min():.3f}..{total.max():.3f} (median {float(np.median(total)):.3f})")
        v = self.verified
        if v is None:
            return "\n".join(lines)
        draws = self.verify_draws
        out(f"MuJoCo ({self.physics} physics{', seed ' + str(self.seed) if self.physics == 'random' else ''}"
            f"{f', {draws} draws per grasp' if draws > 1 else ''}) for the {len(v.shortlist)} best reachable grasps "
            + ("by the scorer" if self.shortlist_rule == "scorer" else "by SDG-Net and by the analytic wrench cost")
            + f": the pick is the lowest measured total{' (mean over the draws)' if draws > 1 else ''} (*)"
            + (f"; each also at {v.weak_grip:g} N per pad, a failure there adding w_weak" if v.weak_grip else "")
            + ("; - : not rolled out there, its total without it already above the pick's"
               if v.weak_checked is not None and not v.weak_checked.all() else ""))
        weak = v.weak_grip is not None
        out(f"{'rank':>4} {'idx':>5} {'rollout':>8} {'tau_ind N·m':>11} {'tau_perp N·m':>12} {'slip mm':>8} {'rot deg':>7} "
            f"{'failed':>6} {'success':>7} " + (f"{'fail@' + format(v.weak_grip, 'g'):>7} " if weak else "")
            + f"{'measured C':>10}")
        for j, row in enumerate(self.verify_rows):
            r, d = divmod(j, draws)
            i = row["index"]
            status = "ok" if row["valid"] else "diverged"
            mean = (f"{v.measured_total[r]:>10.3f}{' *' if i == v.index else ''}" if d == draws - 1 else "")
            out(f"{(str(r + 1) if d == 0 else ''):>4} {(str(i) if d == 0 else ''):>5} {status:>8} "
                f"{row['peak_torque_induced']:>11.3f} {row['peak_torque_projected']:>12.3f} "
                f"{1e3 * row['slip_translation']:>8.2f} {np.degrees(row['slip_rotation']):>7.2f} "
                f"{str(row['failed']):>6} {str(row['success']):>7} "
                + (f"{'-' if row['weak_failed'] is None else str(row['weak_failed']):>7} " if weak else "") + mean)
        ahead = (int(np.sum(total[v.unreachable] <= total[v.shortlist].max())) if len(v.shortlist)
                 else len(v.unreachable))
        if ahead:
            out(f"({ahead} grasp(s) scored among these are unreachable for the arm along the task (IK) and were skipped)")
        if v.chosen_by == "score":
            out("no rollout was valid: the scorer's pick stands (it may be unreachable)")
        if self.status == "no_verified_success":
            out(f"no pick: none of the {len(v.shortlist)} verified grasps did the task and held in MuJoCo; "
                + "; ".join(self.advice))
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """The `itup.plan/8` document."""
        s = self.scores
        out = {
            "schema": "itup.plan/8",
            "task": self.task.kind,
            "tool": {"name": self.tool.name, "category": self.tool.category, "mass_kg": round(self.tool.mass, 6)},
            "regime": self.regime,
            "n_candidates": int(self.n),
            "sampling": dict(self.sampling),
            "guard": None if self.guard is None else {**self.guard.to_json(), "verified": self.guard_verified},
            "seed": self.seed,
            "scorer": self.scorer,
            "weights": self.weights,
            "best": {**self.row(self.best_index), "rank": self.pick_rank + 1} if self.status == "ok" else None,
            "top": [self.row(i) for i in self.top],
            "summary": None if s is None else {
                k: {"min": float(np.min(getattr(s, k))), "median": float(np.median(getattr(s, k))),
                    "max": float(np.max(getattr(s, k)))} for k in ("tau", "slip", "align", "total")},
            "status": self.status,
        }
        if self.advice:
            out["advice"] = list(self.advice)
        v = self.verified
        if v is not None:
            ok = self.status == "ok"
            out["verified"] = {
                "k": self.verify_k, "draws": self.verify_draws, "tried": len(v.shortlist), "backend": v.backend,
                "weak_grip": v.weak_grip,
                "unreachable": [int(i) for i in v.unreachable], "physics": self.physics,
                "weights": dataclasses.asdict(self.measure_weights),
                "candidates": [{"index": int(i), "measured_total": float(m) if np.isfinite(m) else None}
                               for i, m in zip(v.shortlist, v.measured_total)],
                "chosen_by": v.chosen_by, "shortlist_rule": self.shortlist_rule,
                "pick": {**self.row(v.index), "reachable": v.chosen_by == "measured" or None} if ok else None,
                "labels": list(self.verify_rows),
            }
        return out


def guard_order(scorer_total: np.ndarray, analytic_total: np.ndarray, k: int) -> np.ndarray:
    """[N] the order in which the verifier tries candidates when the out-of-distribution guard fired: the
    k - m best by the scorer, then the m = floor(GUARD_ANALYTIC_SHARE k) best by the analytic wrench cost
    (`costs.wrench_costs`, the grip-demand form: physics, no training data) that are not among them, then
    the rest by the scorer (replacements for rollouts that are not valid). Outside its training data
    SDG-Net's best can all lie where it extrapolates furthest; the analytic cost's best lie elsewhere.
    scorer_total, analytic_total: [N], lower is better."""
    net = np.argsort(np.asarray(scorer_total, np.float64), kind="stable")
    m = int(GUARD_ANALYTIC_SHARE * k)
    head = net[: k - m]
    taken = set(head.tolist())
    physics = [int(i) for i in np.argsort(np.asarray(analytic_total, np.float64), kind="stable") if int(i) not in taken][:m]
    taken.update(physics)
    return np.concatenate([head, np.asarray(physics, np.int64), [i for i in net if int(i) not in taken]]).astype(np.int64)


def verified_pick(tool: Tool, task, grasps: Grasps, scores: Any, *, k: int = DEFAULT_VERIFY, guard_fired: bool = False,
                  draws: int = 1, seed: int = 0, randomize: Any = None, weights: Any = None,
                  weak_grip: float | None = robot.WEAK_GRIP, scene: Any = None) -> tuple[Any, str]:
    """The planner's MuJoCo check of scored candidates: (`verify.Verified`, the shortlist rule).

    The k best reachable by `scores.total` are rolled out (`verify.best_grasp_verified`; when the guard
    fired, `guard_order`'s mix of them and the analytic wrench cost's best, rule "guard_mixed", else
    "scorer"), each `draws` times (physics `randomize`, None: nominal) and again at `weak_grip` N per pad,
    and the lowest measured total under `weights` (default `ScoreWeights()`) wins. Host side."""
    import itup_jax as itup
    from itup_jax.scoring import ScoreWeights
    from itup_jax.sdgnet.objective import OBJECTIVES
    from itup_jax.verify import best_grasp_verified

    order, rule = None, "scorer"
    if guard_fired:
        analytic = itup.wrench_costs(tool, task, grasps, OBJECTIVES["wrench"].analytic)
        order, rule = guard_order(np.asarray(scores.total), np.asarray(analytic.total), k), "guard_mixed"
    v = best_grasp_verified(tool, task, grasps, k=k, draws=draws, seed=seed, scores=scores,
                            weights=ScoreWeights() if weights is None else weights, randomize=randomize, order=order,
                            weak_grip=weak_grip, scene=scene)
    return v, rule


def checked_count(verify: int, guard_fired: bool, guard_verify: int = GUARD_VERIFY_K,
                  candidates: int | None = None) -> int:
    """How many grasps `itup plan`'s check rolls out: `verify`, or max(verify, guard_verify) where the
    out-of-distribution guard fired, never more than the `candidates` there are (0: none, the best-scored
    grasp is the pick)."""
    k = max(verify, guard_verify) if guard_fired else verify
    return k if candidates is None else min(k, candidates)


def guarded_check(tool: Tool, task, grasps: Grasps, scores: Any, *, model: Any = None, k: int = DEFAULT_VERIFY,
                  seed: int = 0, scene: Any = None, weak_grip: float | None = robot.WEAK_GRIP,
                  reading: Any = None, guard_k: int = GUARD_VERIFY_K) -> tuple[Any, Any, str]:
    """`itup plan`'s default check of SDG-Net's `scores` of the candidates: the out-of-distribution guard
    read (`ood.check` for `model`, unless its `reading` is given), then `verified_pick` under nominal
    physics of k grasps, or of max(k, guard_k) and the guard's shortlist where it fired
    (`checked_count`; never more than there are candidates, at least one), each again at `weak_grip`.
    Returns (the `verify.Verified`, the guard's reading, the shortlist rule). Host side."""
    if reading is None:
        from itup_jax import ood

        reading = ood.check(tool, task, grasps, model=model)
    k = max(1, checked_count(k, bool(reading.fired), guard_k, len(grasps)))
    v, rule = verified_pick(tool, task, grasps, scores, k=k, guard_fired=bool(reading.fired), seed=seed,
                            weak_grip=weak_grip, scene=scene)
    return v, reading, rule


def default_pick(tool: Tool, task, grasps: Grasps, *, model: Any = None, seed: int = 0, scene: Any = None,
                 verify: int = DEFAULT_VERIFY, weak_grip: float | None = robot.WEAK_GRIP,
                 scores: Any = None, guard_verify: int = GUARD_VERIFY_K,
                 guard_threshold: float | None = None) -> tuple[int | None, dict]:
    """`itup plan`'s default pick among given candidates (the arm can carry them): SDG-Net's scores under
    the default weights (`scores`, when already computed for `model` and these grasps), the
    out-of-distribution guard read, `verified_pick` of `verify` grasps under nominal physics, of
    max(verify, guard_verify) where the guard fired (`guarded_check`; none checked: the best-scored).
    Returns (the pick's index, or None when no verified grasp did the task and held, as `itup plan` then
    recommends none; {"guard_score", "guard_fired", "verified_succeeded" (when verified), "shortlist":
    [the grasps rolled out], "measured_total": [their lowest measured totals, None where no rollout was
    valid]}). `guard_threshold`: as `plan_grasp`'s (None: `ood.GUARD_THRESHOLD`, the shipped checkpoint's;
    another checkpoint needs its own, `experiments/ood_guard.py`). Host side; the scorer jits itself."""
    import itup_jax as itup
    from itup_jax import ood

    s = itup.score(tool, task, grasps, model=model, seed=seed) if scores is None else scores
    reading = ood.check(tool, task, grasps, model=model, threshold=guard_threshold)
    info: dict[str, Any] = {"guard_score": float(reading.score), "guard_fired": bool(reading.fired)}
    if checked_count(verify, bool(reading.fired), guard_verify) == 0:
        total = np.asarray(s.total, float)
        if not np.isfinite(total).any():
            raise InputError(f"default_pick: the scorer gave all {len(total)} candidates a non-finite score")
        return int(np.argmin(np.where(np.isfinite(total), total, np.inf))), info  # a non-finite score never wins
    v, _, _ = guarded_check(tool, task, grasps, s, k=verify, seed=seed, scene=scene, weak_grip=weak_grip,
                            reading=reading, guard_k=guard_verify)
    info.update(verified_succeeded=bool(v.succeeded), shortlist=[int(i) for i in v.shortlist],
                measured_total=[float(m) if np.isfinite(m) else None for m in v.measured_total])
    return (int(v.index) if v.succeeded else None), info


def plan_grasp(tool: Tool, task, *, n: int = DEFAULT_N, seed: int = 0, scorer: str = "sdgnet", model: Any = None,
               weights: dict | None = None, torque_first: bool = False, top: int = DEFAULT_TOP, verify: int = DEFAULT_VERIFY,
               verify_draws: int = 1, verify_physics: str | None = None, sampling: str = "reachable",
               budget: int | None = None, guard: bool = True, guard_threshold: float | None = None,
               verify_weak_grip: float | None = robot.WEAK_GRIP, guard_verify: int = GUARD_VERIFY_K) -> GraspPlan:
    """Sample `n` candidates, score them, and pick the best-scored one the arm can carry along the task.

    Args:
      n: candidates to score. sampling "reachable" (default): n grasps the arm can carry through the task
        (closed-form IK along the trajectory, joint limits, the arm above the table), drawn until n are
        found or `budget` candidates are spent (`grasp_sampler.sample_reachable`; fewer are scored when
        the budget runs out, none: status "no_reachable_candidate"). "all": n drawn, scored, and the
        ranking walked to the best reachable one.
      scorer: "sdgnet" (the checkpoint `model`, a path or a loaded `sdgnet.model.Model`; default the shipped
        one), "sdgnet_paper" (the paper objective's shipped checkpoint), "analytic" (the paper's form),
        "analytic_wrench" (the grip-demand form), or a baseline.
      weights: the total's weights: for the analytic scorers `CostParams` fields (w_tau, w_slip,
        w_align), for the SDG-Net ones `ScoreWeights` fields (also w_task, w_fail, w_weak, w_grip); each keeps
        its default when left out.
      torque_first: SDG-Net's total weighs torque alone with the task and grip penalties
        (`ScoreWeights.torque_first`).
      top: ranking rows to report (their reachability is checked too).
      verify: K > 0 (default DEFAULT_VERIFY, 5) rolls the K best reachable out in MuJoCo and keeps the
        lowest measured total (`verify.best_grasp_verified`; ~0.3-0.7 s per 5 on a 2-core CPU, twice that
        with the weak-grip rollouts); 0: the best-scored reachable grasp, no rollout (unless the guard
        fires). verify_draws R > 1 rolls each out under R draws of the priors (verify_physics "random",
        the default then) and keeps the lowest mean.
      verify_weak_grip: N per pad (default `robot.WEAK_GRIP`, 25): every verification rollout is
        repeated at this fixed grip on the same physics draw, and a failure there adds the measured total's
        w_weak (`verify.best_grasp_verified(weak_grip=...)`); None: verification at the default grip alone.
      guard: an SDG-Net scorer's plan reads the out-of-distribution guard (`ood.check`) always; with guard
        True, when the tool lies outside the network's training data the verified grasps mix the analytic
        wrench cost's best into SDG-Net's (`guard_order`; the plan's `shortlist_rule` "guard_mixed"), and
        the check covers max(verify, guard_verify) grasps (default GUARD_VERIFY_K, 20), with verify 0
        too, instead of trusting the learned score (then the plan's `guard_verified`).
      guard_threshold: the guard's threshold (default `ood.GUARD_THRESHOLD`, calibrated for the shipped
        checkpoint; a checkpoint of your own: calibrate it with `experiments/ood_guard.py`).
    Returns:
      `GraspPlan`; its status says whether a grasp is recommended.
    Raises:
      InputError: an invalid option or combination, before any work.
    """
    import itup_jax as itup
    from itup_jax.scoring import ANALYTIC_SCORERS, SCORERS, SDGNET_SCORERS, ScoreWeights
    from itup_jax.sdgnet.objective import OBJECTIVES

    for flag, v, lowest in (("n", n, 1), ("top", top, 1), ("verify", verify, 0), ("verify_draws", verify_draws, 1),
                            ("guard_verify", guard_verify, 0)):
        if not isinstance(v, (int, np.integer)) or v < lowest:
            raise InputError(f"plan_grasp: {flag} must be an integer >= {lowest}, got {v!r}")
    if n > MAX_CANDIDATES:
        raise InputError(f"plan_grasp: n must be at most {MAX_CANDIDATES:,} (candidates sampled, checked for reach and "
                         f"scored: ~45 s on a 2-core CPU at the most), got {n:,}")
    if scorer not in SCORERS:
        raise InputError(f"plan_grasp: scorer {scorer!r}: unknown; choose from {', '.join(SCORERS)}")
    physics = verify_physics or ("random" if verify_draws > 1 else "nominal")
    if physics not in ("nominal", "random"):
        raise InputError(f"plan_grasp: verify_physics must be 'nominal' or 'random', got {verify_physics!r}")
    if verify_draws > 1 and physics == "nominal":
        raise InputError(f"plan_grasp: verify_draws {verify_draws} needs verify_physics 'random': under nominal "
                         "physics every draw of a grasp rolls out the same")
    if verify_weak_grip is not None:
        from itup_jax.stress import check_grip

        verify_weak_grip = check_grip(verify_weak_grip, "plan_grasp: verify_weak_grip")
    if verify_draws > 1 and verify == 0:
        raise InputError("plan_grasp: verify_draws applies to the verified pick, and verification is off")
    if sampling not in SAMPLING_MODES:
        raise InputError(f"plan_grasp: sampling must be one of {', '.join(SAMPLING_MODES)}, got {sampling!r}")
    if budget is not None and (sampling != "reachable" or not isinstance(budget, (int, np.integer))
                               or isinstance(budget, bool) or budget < n):
        raise InputError(f"plan_grasp: budget (the most candidates drawn) applies to sampling 'reachable' and must "
                         f"be an integer >= n ({n}), got {budget!r}")
    if guard_threshold is not None and (isinstance(guard_threshold, bool) or not isinstance(guard_threshold, (int, float))
                                        or not np.isfinite(guard_threshold) or guard_threshold <= 0):
        raise InputError(f"plan_grasp: guard_threshold must be a finite number > 0, got {guard_threshold!r}")
    if guard_threshold is not None and scorer not in SDGNET_SCORERS:
        raise InputError(f"plan_grasp: guard_threshold applies to the SDG-Net scorers' guard; scorer {scorer!r} has none")
    given = dict(weights or {})
    if torque_first:
        clash = [k for k in ("w_tau", "w_slip", "w_align") if k in given]
        if clash or scorer not in SDGNET_SCORERS:
            raise InputError("plan_grasp: torque_first sets SDG-Net's weights (torque alone, the task and grip "
                             "penalties kept); " + (f"it cannot be combined with {', '.join(clash)}" if clash
                                                    else f"not the {scorer!r} scorer's"))
    if given and scorer not in ANALYTIC_SCORERS + SDGNET_SCORERS:
        raise InputError(f"plan_grasp: weights {sorted(given)}: the {scorer!r} scorer has no weights (they apply "
                         "to the analytic and sdgnet scorers)")
    if {"w_task", "w_fail", "w_weak", "w_grip"} & set(given) and scorer in ANALYTIC_SCORERS:
        raise InputError("plan_grasp: w_task/w_fail/w_weak/w_grip weigh SDG-Net's predictions; the analytic cost "
                         "has no such terms (its grip-demand form is the analytic_wrench scorer)")

    if sampling == "reachable":
        from itup_jax.grasp_sampler import sample_reachable

        found = sample_reachable(tool, task, n, seed=seed, budget=budget)
        sampled = {"mode": "reachable", **found.to_json()}
        if len(found.grasps) == 0:
            return _unreachable_plan(tool, task, found.grasps, n, seed, scorer, sampled)
        grasps = found.grasps
    else:
        grasps = itup.sample_grasps(tool, n, seed=seed)
        sampled = None
    n_scored = len(grasps)
    sw = None
    if scorer in ANALYTIC_SCORERS:
        params = OBJECTIVES["wrench" if scorer == "analytic_wrench" else "paper"].analytic.replace(**given)
        used = {k: float(getattr(params, k)) for k in ("w_tau", "w_slip", "w_align")}
        scores = itup.wrench_costs(tool, task, grasps, params)
    else:
        sw = ScoreWeights.torque_first(**given) if torque_first else ScoreWeights(**given)
        used = dataclasses.asdict(sw) if scorer in SDGNET_SCORERS else None
        scores = itup.score(tool, task, grasps, model=model if scorer == "sdgnet" and model is not None else scorer, seed=seed,
                            weights=sw)
    reading, guard_verified = None, False
    if scorer in SDGNET_SCORERS:
        from itup_jax import ood
        from itup_jax.sdgnet.config import PAPER_MODEL

        reading = ood.check(tool, task, grasps, model=PAPER_MODEL if scorer == "sdgnet_paper" else model,
                            threshold=guard_threshold)
        if guard and reading.fired:
            guard_verified = verify == 0 and guard_verify > 0
            verify = checked_count(verify, True, guard_verify, len(grasps))
    total = np.asarray(scores.total)
    if not np.all(np.isfinite(total)):
        bad = int(np.sum(~np.isfinite(total)))
        raise InputError(f"plan_grasp: the {scorer!r} scorer gave {bad} of {n_scored} candidates a non-finite score"
                         + (f" (checkpoint {model!r})" if isinstance(model, str) else ""))
    ranking = np.argsort(total, kind="stable")
    order = ranking[:top]
    if sampled is not None:  # every candidate is reachable
        rank_found, reachable = 0, {int(i): True for i in order}
    else:
        from itup_jax.sim.arm import first_reachable  # MuJoCo's kinematics: imported only when asked

        rank_found, reachable = first_reachable(task, grasps, ranking, check_first=len(order))
        sampled = {"mode": "all", "requested": n, "reachable": sum(reachable.values()), "drawn": n, "budget": n,
                   "complete": rank_found is not None}
    regime = itup.classify_regime(tool, task).name.lower()
    base = dict(tool=tool, task=task, grasps=grasps, scores=scores, ranking=ranking, top=order, reachable=reachable,
                n=n_scored, seed=seed, scorer=scorer, weights=used, regime=regime,
                graspnet_rotation=np.asarray(to_graspnet(grasps)["rotation_matrix"]), sampling=sampled, guard=reading,
                guard_verified=guard_verified)
    if rank_found is None:
        return GraspPlan(**base, pick_rank=0, pick=None, status="no_reachable_candidate",
                         advice=_unreachable_advice(n))
    pick = int(ranking[rank_found])
    if verify == 0:
        return GraspPlan(**base, pick_rank=rank_found, pick=pick, status="ok", advice=())

    from itup_jax.sim.physics import Randomization
    from itup_jax.verify import measured_total, objective_of

    # the measured total weighs measured torque (N m), slip (m), drift (rad) and the outcomes: SDG-Net's
    # weights, whatever the scorer (the analytic cost's weights are for N, not m)
    measure_w = sw if scorer in SDGNET_SCORERS else ScoreWeights()
    v, rule = verified_pick(tool, task, grasps, scores, k=verify, guard_fired=bool(guard and reading is not None
                                                                                   and reading.fired),
                            draws=verify_draws, seed=seed, randomize=None if physics == "nominal" else Randomization(),
                            weights=measure_w, weak_grip=verify_weak_grip)
    L = v.labels
    weak_failed = v.weak_failed
    per_rollout = measured_total(L, measure_w, objective_of(scores), weak_failed)
    rows = []
    for r, i in enumerate(v.shortlist):
        for d in range(verify_draws):
            j = r * verify_draws + d
            row = {f: (bool(x) if x.dtype == bool else float(x)) for f, x in ((f, getattr(L, f)[j]) for f in VERIFY_FIELDS)}
            row["index"], row["draw"] = int(i), d
            if weak_failed is not None:  # None: not rolled out at the weak grip (it could not win)
                row["weak_failed"] = bool(weak_failed[j]) if v.weak_checked[j] else None
            row["measured_total"] = float(per_rollout[j]) if np.isfinite(per_rollout[j]) else None
            rows.append(row)
    # a verified pick must have done the task and held in every one of its rollouts
    status, advice = "ok", ()
    if not v.succeeded:
        status = "no_verified_success"
        advice = (f"verify more grasps (verify, now {verify}) or sample more (n, now {n})",
                  "another grasp region in the tool's spec (grasp_region)",
                  "a stronger grip, or another tool: none of the rolled-out grasps did the task and held")
    return GraspPlan(**base, pick_rank=rank_found, pick=int(v.index) if status == "ok" else None, status=status,
                     advice=advice, verified=v, verify_rows=tuple(rows), verify_k=verify, verify_draws=verify_draws,
                     measure_weights=measure_w, physics=physics, shortlist_rule=rule)


def _unreachable_advice(n: int) -> tuple[str, ...]:
    return (f"sample more candidates (n, now {n}; with sampling 'reachable', a larger budget) or another seed",
            "widen the spec's grasp_region, or check the tool's size and frame",
            "the task's placement may put the tool out of the arm's reach: another task parameter")


def _unreachable_plan(tool: Tool, task, grasps: Grasps, n: int, seed: int, scorer: str, sampled: dict) -> GraspPlan:
    """The plan when the reachable sampler found no candidate within its budget: nothing to score."""
    import itup_jax as itup

    empty = np.zeros(0, np.int64)
    return GraspPlan(tool=tool, task=task, grasps=grasps, scores=None, ranking=empty, top=empty, reachable={},
                     pick_rank=0, pick=None, status="no_reachable_candidate", advice=_unreachable_advice(n), n=0,
                     seed=seed, scorer=scorer, weights=None, regime=itup.classify_regime(tool, task).name.lower(),
                     graspnet_rotation=np.zeros((0, 3, 3)), sampling=sampled)

"""`plan_grasp`: the library function behind `itup plan`."""

import dataclasses

import numpy as np
import pytest
from jsonschema import validate

import itup_jax as itup
from itup_jax.schemas import load_schema
from itup_jax.sim.arm import first_reachable, reachable


def test_the_pick_is_the_best_scored_reachable_candidate(tasks):
    tool, task = tasks["reach"]
    plan = itup.plan_grasp(tool, task, n=40, scorer="random", top=3, verify=0)
    assert plan.status == "ok" and plan.pick == plan.best_index and plan.verified is None
    ok = reachable(task, plan.grasps[plan.ranking])
    assert plan.pick_rank == int(np.argmax(ok)) and ok[plan.pick_rank]
    assert all(plan.reachable[int(i)] == bool(reachable(task, plan.grasps[int(i)][None])[0]) for i in plan.top)
    doc = plan.to_json()
    validate(doc, load_schema("plan"))
    assert doc["best"]["index"] == plan.pick and doc["best"]["rank"] == plan.pick_rank + 1
    # scoring.best_grasp walks the same ranking to the same grasp
    i, _, _ = itup.best_grasp(tool, task, plan.grasps, "random", reachable_only=True)
    assert i == plan.pick


def test_first_reachable_reports_none_when_nothing_is(tasks, monkeypatch):
    import importlib

    sim = importlib.import_module("itup_jax.sim.arm")

    tool, task = tasks["knock"]
    g = itup.sample_grasps(tool, 20, seed=0)
    monkeypatch.setattr(sim, "reachable", lambda task, g: np.zeros(len(g), bool))
    rank, checked = first_reachable(task, g, np.arange(20))
    assert rank is None and len(checked) == 20 and not any(checked.values())


@pytest.mark.parametrize("kw,match", [
    (dict(n=0), "n must be an integer >= 1"),
    (dict(verify=2, verify_draws=2, verify_physics="nominal"), "verify_draws 2 needs verify_physics 'random'"),
    (dict(verify=0, verify_draws=2), "verify_draws applies to the verified pick, and verification is off"),
    (dict(torque_first=True, scorer="analytic"), "not the 'analytic' scorer's"),
    (dict(weights={"w_task": 1.0}, scorer="analytic"), "w_task/w_fail"),
    (dict(guard_threshold=0.0), "guard_threshold must be a finite number > 0"),
    (dict(guard_threshold=float("nan")), "guard_threshold must be a finite number > 0"),
    (dict(guard_threshold=1.0, scorer="force_closure"), "has none"),
])
def test_bad_options_are_refused_before_any_work(tasks, kw, match, monkeypatch):
    tool, task = tasks["hammer"]
    monkeypatch.setattr(itup, "sample_grasps", lambda *a, **k: pytest.fail("sampled before the check"))
    with pytest.raises(itup.InputError, match=match):
        itup.plan_grasp(tool, task, **kw)


def test_guard_order_takes_the_analytic_costs_best_beside_the_scorers():
    from itup_jax.planning import guard_order

    net = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8])  # the scorer's order: 0, 1, 2, ...
    physics = np.array([0.0, 9.0, 8.0, 7.0, 6.0, 5.0, 1.0, 2.0])  # the analytic cost's: 0, 6, 7, 5, ...
    order = guard_order(net, physics, 5)
    assert order.tolist() == [0, 1, 2, 6, 7, 3, 4, 5]  # 3 by the scorer, 2 by the cost not among them, the rest
    assert sorted(order.tolist()) == list(range(8))
    assert guard_order(net, physics, 1).tolist() == list(range(8))  # K = 1: the scorer's best alone
    assert guard_order(net, physics, 10)[:6].tolist() == [0, 1, 2, 3, 4, 5]  # 6 by the scorer, then 4 by the cost
    assert guard_order(net, physics, 10)[6:].tolist() == [6, 7]


def test_a_verification_order_is_checked_and_followed(tasks):
    from itup_jax.verify import best_grasp_verified

    tool, task = tasks["sweep"]
    g = itup.sample_grasps(tool, 64, seed=3)
    ok = np.nonzero(reachable(task, g))[0]
    order = ok[::-1][:3]  # the last reachable ones first
    v = best_grasp_verified(tool, task, g, k=2, order=order)
    assert v.shortlist.tolist() == order[:2].tolist()  # not the scores' order: the given one
    for bad in ([0, 0], [64], [-1], np.array([0.5])):
        with pytest.raises(itup.InputError, match="order must list distinct candidate indices"):
            best_grasp_verified(tool, task, g, k=2, order=bad)


def test_unreachable_reasons_take_the_reachability_test_apart(tasks):
    """Each unreachable grasp gets the reason `arm_trajectory` refuses it for, and only those do."""
    from itup_jax.grasp_sampler import sample_grasps
    from itup_jax.sim.arm import UNREACHABLE_REASONS, unreachable_reasons, unreachable_summary

    for kind in ("hammer", "reach"):
        tool, task = tasks[kind]
        g = sample_grasps(tool, 300, seed=3)
        code, first = unreachable_reasons(task, g)
        np.testing.assert_array_equal(code < 0, reachable(task, g))
        assert ((first >= 0) == (code >= 0)).all() and (first < task.num_steps).all()
        summary = unreachable_summary(task, g)
        assert summary["checked"] == 300 and summary["reachable"] == int((code < 0).sum())
        assert sum(summary[r]["count"] for r in UNREACHABLE_REASONS if r in summary) == int((code >= 0).sum())
    assert {UNREACHABLE_REASONS[c] for c in code[code >= 0]} >= {"below_table", "joint_limits"}


def test_plan_says_why_when_few_candidates_are_reachable(tasks, monkeypatch):
    """Under REACHABLE_NOTE_SHARE reachable, the plan's report and JSON say why the rest are not."""
    from itup_jax import grasp_sampler

    monkeypatch.setattr(grasp_sampler, "REACHABLE_NOTE_SHARE", 1.01)  # every plan falls under it
    tool, task = tasks["hammer"]
    p = itup.plan_grasp(tool, task, n=8, seed=0, scorer="analytic")
    why = p.sampling["unreachable"]
    assert why["checked"] >= 8 and why["reachable"] < why["checked"]
    note = [line for line in p.report().splitlines() if line.startswith("note: the arm can carry")]
    assert len(note) == 1 and "below the table" in note[0] and "first impact" in note[0]
    validate(p.to_json(), load_schema("plan"))
    monkeypatch.setattr(grasp_sampler, "REACHABLE_NOTE_SHARE", 0.10)
    q = itup.plan_grasp(tool, task, n=8, seed=0, scorer="analytic")
    assert "unreachable" not in q.sampling and "note: the arm can carry" not in q.report()


def test_the_guard_threshold_decides_whether_the_plan_verifies(tasks):
    """The same candidates read by the guard at two thresholds around their score: below it the guard
    fires and the plan verifies (its reading records the threshold), above it the learned score decides."""
    tool, task = tasks["hammer"]
    plan = itup.plan_grasp(tool, task, n=16, seed=2, guard=False)
    score = plan.guard.score
    low = itup.plan_grasp(tool, task, n=16, seed=2, guard=False, guard_threshold=0.5 * score)
    high = itup.plan_grasp(tool, task, n=16, seed=2, guard_threshold=2.0 * score)
    assert low.guard.fired and low.guard.threshold == pytest.approx(0.5 * score) and low.guard.score == score
    assert not high.guard.fired and not high.guard_verified and high.pick == plan.pick


def test_where_the_guard_fires_the_check_covers_guard_verify_grasps(tasks, monkeypatch):
    """The guard fired (a threshold below the candidates' score): the check covers max(verify,
    guard_verify) grasps of the guard's mixed shortlist, also with verify 0; guard_verify 0 keeps verify;
    `default_pick` and `itup plan` agree on it."""
    from itup_jax import ood, planning

    assert planning.checked_count(5, False) == 5 and planning.checked_count(5, True, 20) == 20
    assert planning.checked_count(30, True, 20) == 30 and planning.checked_count(0, True, 0) == 0
    assert planning.checked_count(1, True, 20, candidates=8) == 8 and planning.checked_count(5, False, 20, 3) == 3
    tool, task = tasks["hammer"]
    score = itup.plan_grasp(tool, task, n=8, seed=2, verify=0, guard=False).guard.score
    kw = dict(n=8, seed=2, guard_threshold=0.5 * score, verify_weak_grip=None)
    more = itup.plan_grasp(tool, task, verify=1, guard_verify=3, **kw)
    assert more.guard.fired and more.verify_k == 3 and len(more.verified.shortlist) == 3
    assert more.shortlist_rule == "guard_mixed" and not more.guard_verified and "3 grasps are rolled out" in more.report()
    off = itup.plan_grasp(tool, task, verify=0, guard_verify=2, **kw)
    assert off.guard_verified and off.verify_k == 2 and len(off.verified.shortlist) == 2
    few = itup.plan_grasp(tool, task, verify=1, guard_verify=20, **kw)  # never more than the 8 candidates
    assert few.verify_k == 8 == len(few.verified.shortlist) and "8 grasps are rolled out" in few.report()
    none = itup.plan_grasp(tool, task, verify=0, guard_verify=0, **kw)
    assert none.verified is None and not none.guard_verified and none.pick == none.best_index
    i, info = planning.default_pick(tool, task, more.grasps, verify=1, guard_verify=3, weak_grip=None,
                                    guard_threshold=0.5 * score)
    assert info["guard_fired"] and info["shortlist"] == more.verified.shortlist.tolist() and i == more.pick
    _, quiet = planning.default_pick(tool, task, more.grasps, verify=1, guard_verify=3, weak_grip=None,
                                     guard_threshold=2.0 * score)
    assert not quiet["guard_fired"] and len(quiet["shortlist"]) == 1
    monkeypatch.setattr(ood, "GUARD_THRESHOLD", 0.5 * score)  # None: the module's threshold
    j, _ = planning.default_pick(tool, task, more.grasps, verify=1, guard_verify=3, weak_grip=None)
    assert j == more.pick
    with pytest.raises(itup.InputError, match="guard_verify must be an integer >= 0"):
        itup.plan_grasp(tool, task, guard_verify=-1)


def test_default_pick_is_itup_plans_pick_among_given_candidates(tasks):
    """`default_pick` among the candidates `plan_grasp` drew gives `plan_grasp`'s pick: the verified one by
    default (each rollout again at 25 N per pad), the best-scored one with verify=0 (the guard quiet)."""
    from itup_jax.planning import default_pick

    tool, task = tasks["hammer"]
    plan = itup.plan_grasp(tool, task, n=12, verify=2)
    assert plan.verified is not None and plan.verified.weak_grip == 25.0 and not plan.guard.fired
    i, info = default_pick(tool, task, plan.grasps, verify=2)
    assert i == plan.pick and info["shortlist"] == plan.verified.shortlist.tolist() and info["verified_succeeded"]
    assert not info["guard_fired"] and info["guard_score"] == pytest.approx(float(plan.guard.score))
    j, info0 = default_pick(tool, task, plan.grasps, verify=0)
    assert j == int(np.argmin(np.asarray(plan.scores.total))) and "shortlist" not in info0
    # a non-finite score never wins the unchecked pick; none finite is refused
    total = np.asarray(plan.scores.total, float).copy()
    total[j] = np.nan
    k, _ = default_pick(tool, task, plan.grasps, verify=0, scores=dataclasses.replace(plan.scores, total=total))
    assert k == int(np.nanargmin(total)) and k != j
    with pytest.raises(itup.InputError, match="non-finite score"):
        default_pick(tool, task, plan.grasps, verify=0, scores=dataclasses.replace(plan.scores, total=total * np.nan))

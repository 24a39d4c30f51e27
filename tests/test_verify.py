"""Verified picks (`itup_jax.verify`): the measured total in closed form and against SDG-Net's total, and
the shortlist-then-simulate pick against single rollouts of native MuJoCo."""

import types

import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.scoring import Scores, ScoreWeights, sdgnet_total
from itup_jax.sim.arm import reachable
from itup_jax.sim.labels import Labels
from itup_jax.sim.scene import build_scene
from itup_jax.verify import best_grasp_verified, measured_total


def _labels(**given) -> Labels:
    base = Labels.unmeasured(len(next(iter(given.values())))).as_dict()
    base.update({k: np.asarray(v) for k, v in given.items()})
    return Labels(**base)


def test_measured_total_closed_form_and_sdgnet_total():
    L = _labels(peak_torque_projected=[0.5, 0.2, 3.0], slip_translation=[0.001, 0.004, 0.0],
                alignment_drift=[0.1, 0.05, 0.0], success=[True, False, True], failed=[False, True, False],
                valid=[True, True, False])
    w = ScoreWeights(w_tau=2.0, w_slip=100.0, w_align=1.0, w_task=10.0, w_fail=5.0)
    m = measured_total(L, w)
    assert m[0] == pytest.approx(2 * 0.5 + 100 * 0.001 + 0.1)
    assert m[1] == pytest.approx(2 * 0.2 + 100 * 0.004 + 0.05 + 10.0 + 5.0)  # missed the task and failed
    assert m[2] == np.inf  # not a valid rollout: it cannot be picked
    # SDG-Net's total with every prediction replaced by its measurement (outcomes as probabilities 1/0)
    costs = np.stack([L.peak_torque_projected, L.slip_translation, L.alignment_drift, np.zeros(3)], 1)
    probs = np.stack([L.success, L.failed], 1).astype(float)
    ref = sdgnet_total(jnp.asarray(costs), jnp.asarray(probs), w.costs(jnp.float64),
                       w.heads(("label_success", "label_failed"), jnp.float64))
    np.testing.assert_allclose(m[:2], np.asarray(ref)[:2], rtol=1e-12)
    # the wrench objective: the full induced torque stands for tau, and the grip demand counts
    Lw = _labels(peak_torque_induced=[0.7, 0.3, 1.0], grip_demand=[50.0, 120.0, 10.0], slip_translation=[0.001, 0.004, 0.0],
                 alignment_drift=[0.1, 0.05, 0.0], success=[True, False, True], failed=[False, True, False],
                 valid=[True, True, False])
    w = ScoreWeights(w_tau=2.0, w_slip=100.0, w_align=1.0, w_task=10.0, w_fail=5.0, w_grip=0.01)
    mw = measured_total(Lw, w, "wrench")
    assert mw[0] == pytest.approx(2 * 0.7 + 100 * 0.001 + 0.1 + 0.5)
    assert mw[1] == pytest.approx(2 * 0.3 + 100 * 0.004 + 0.05 + 1.2 + 10.0 + 5.0)
    assert measured_total(Lw, w, "paper")[0] != mw[0]
    # a failure at the weak grip adds w_weak, as the weak-grip head's predicted probability does
    ww = ScoreWeights(w_tau=2.0, w_slip=100.0, w_align=1.0, w_task=10.0, w_fail=5.0, w_grip=0.01, w_weak=30.0)
    mk = measured_total(Lw, ww, "wrench", weak_failed=np.array([True, False, True]))
    assert mk[0] == pytest.approx(mw[0] + 30.0) and mk[1] == pytest.approx(mw[1]) and mk[2] == np.inf
    with pytest.raises(itup.InputError, match="weak_failed must have shape"):
        measured_total(Lw, ww, "wrench", weak_failed=np.zeros(2))


@pytest.fixture(scope="module")
def hammer_case(tasks):
    """The hammer's scene, 24 sampled grasps and which of them the arm can reach (nominal physics)."""
    tool, task = tasks["hammer"]
    scene = build_scene(tool, task)
    g = itup.sample_grasps(tool, 24, seed=3)
    reach = reachable(task, g)
    return tool, task, scene, g, reach


def _scores(total) -> Scores:
    z = jnp.zeros(len(total))
    return Scores(tau=z, slip=z, align=z, total=jnp.asarray(total, float), scorer="sdgnet")


def test_verified_pick_is_the_lowest_measured_of_the_best_scored(hammer_case):
    tool, task, scene, g, reach = hammer_case
    assert reach.sum() >= 3 and (~reach).sum() >= 1, "the fixture needs reachable and unreachable grasps"
    # an unreachable grasp scored best, then three reachable ones
    bad, good = np.nonzero(~reach)[0][0], np.nonzero(reach)[0][:3]
    total = np.full(len(g), 10.0)
    total[bad], total[good] = 0.0, [1.0, 2.0, 3.0]
    v = best_grasp_verified(tool, task, g, k=2, scores=_scores(total), scene=scene)
    # the unreachable one is skipped before any rollout, and the next two best-scored are rolled out
    assert v.shortlist.tolist() == [good[0], good[1]] and v.unreachable[0] == bad
    assert not set(v.unreachable) & set(v.shortlist) and v.labels.valid.all()
    assert v.index in good[:2] and v.chosen_by == "measured" and v.backend == "native"
    assert v.measured_total[list(v.shortlist).index(v.index)] == v.measured_total.min()
    # nominal physics: rolled out alone, each checked grasp measures what it measured in the batch
    for j in (0, 1):
        alone = itup.simulate(tool, task, g[v.shortlist[j:j + 1]], randomize=None, scene=scene).labels
        assert alone.peak_torque_projected[0] == pytest.approx(v.labels.peak_torque_projected[j], rel=1e-9)
    # k = 1 keeps the best-scored reachable grasp
    one = best_grasp_verified(tool, task, g, k=1, scores=_scores(total), scene=scene)
    assert one.index == good[0] and one.shortlist.tolist() == [good[0]]


def test_verified_pick_falls_back_to_the_score_when_nothing_is_reachable(hammer_case):
    tool, task, scene, g, reach = hammer_case
    bad = np.nonzero(~reach)[0][:1]
    v = best_grasp_verified(tool, task, g[bad], k=1, scores=_scores([0.0]), scene=scene)
    assert v.index == 0 and v.chosen_by == "score" and v.unreachable.tolist() == [0]
    assert len(v.shortlist) == 0 and len(v.labels.valid) == 0 and len(v.measured_total) == 0


@pytest.mark.parametrize("kw, match", [({"k": 0}, "k must be"), ({"k": True}, "k must be"),
                                       ({"k": 1, "scores": _scores([0.0, 1.0])}, "scores.total must have shape")])
def test_verified_pick_refuses_bad_arguments(hammer_case, kw, match):
    tool, task, scene, g, _ = hammer_case
    with pytest.raises(itup.InputError, match=match):
        best_grasp_verified(tool, task, g, scene=scene, **kw)


def test_verified_pick_over_draws_is_the_lowest_mean_measured_total(hammer_case):
    """draws = 3: each shortlisted grasp rolled out under three draws of the priors, candidate-major, the
    same rollouts `simulate` gives for the repeated grasps; the pick has the lowest mean measured total."""
    tool, task, scene, g, reach = hammer_case
    good = np.nonzero(reach)[0][:2]
    total = np.full(len(g), 10.0)
    total[good] = [1.0, 2.0]
    rnd = itup.Randomization()
    w = ScoreWeights.torque_first()
    v = best_grasp_verified(tool, task, g, k=2, draws=3, seed=4, randomize=rnd, weights=w, scores=_scores(total),
                            scene=scene)
    assert v.draws == 3 and v.shortlist.tolist() == good.tolist() and len(v.labels.valid) == 6
    ref = itup.simulate(tool, task, g[np.repeat(good, 3)], seed=4, randomize=rnd, scene=scene).labels
    np.testing.assert_allclose(v.labels.peak_torque_projected, ref.peak_torque_projected, rtol=1e-9)
    tau = v.candidate_labels("peak_torque_projected")
    assert tau.shape == (2, 3) and np.ptp(tau, axis=1).min() > 0  # the draws differ
    per_rollout = measured_total(ref, w).reshape(2, 3)
    np.testing.assert_allclose(v.measured_total, per_rollout.mean(axis=1), rtol=1e-12)
    assert v.index == good[int(np.argmin(per_rollout.mean(axis=1)))] and v.chosen_by == "measured"
    with pytest.raises(itup.InputError, match="field must be one of"):
        v.candidate_labels("torque")


def test_verified_pick_over_draws_penalises_a_miss_and_replaces_a_divergence(hammer_case, monkeypatch):
    """The pick rule with scripted rollouts: a grasp that misses the task in one draw of two carries half
    the task penalty; a grasp with one diverged draw cannot win and the next reachable one is rolled out."""
    import itup_jax.verify as verify_mod

    tool, task, scene, g, reach = hammer_case
    good = np.nonzero(reach)[0][:3]
    total = np.full(len(g), 10.0)
    total[good] = [1.0, 2.0, 3.0]
    # per call, per rollout (candidate-major, 2 draws): torque, success, valid
    script = [dict(tau=[0.5, 0.5, 2.0, 2.0], success=[True, False, True, True], valid=[True, True, True, False]),
              dict(tau=[3.0, 3.0], success=[True, True], valid=[True, True])]
    calls = []

    def fake_simulate(tool_, task_, grasps, seed=0, **kw):
        s = script[len(calls)]
        calls.append((len(grasps), seed))
        return types.SimpleNamespace(backend="native", labels=_labels(
            peak_torque_projected=s["tau"], success=s["success"], valid=s["valid"],
            slip_translation=np.zeros(len(s["tau"])), alignment_drift=np.zeros(len(s["tau"])),
            failed=np.zeros(len(s["tau"]), bool)))

    monkeypatch.setattr(verify_mod, "simulate", fake_simulate)
    w = ScoreWeights.torque_first()
    v = best_grasp_verified(tool, task, g, k=2, draws=2, seed=7, randomize=itup.Randomization(), weights=w,
                            scores=_scores(total), scene=scene)
    assert calls == [(4, 7), (2, 8)]  # the diverged candidate is replaced in a second round (seed + 1)
    assert v.shortlist.tolist() == good.tolist()
    # grasp 0: torque 0.5, half a miss (w_task / 2 = 5); grasp 1: a diverged draw; grasp 2: 3.0, always done
    np.testing.assert_allclose(v.measured_total, [0.5 + w.w_task / 2, np.inf, 3.0])
    assert v.index == good[2]


@pytest.mark.parametrize("kw, match", [({"draws": 0}, "draws must be"), ({"draws": 2.5}, "draws must be"),
                                       ({"draws": 2}, "needs randomize")])
def test_verified_pick_refuses_bad_draws(hammer_case, kw, match):
    tool, task, scene, g, _ = hammer_case
    with pytest.raises(itup.InputError, match=match):
        best_grasp_verified(tool, task, g, k=1, scores=_scores(np.zeros(len(g))), scene=scene, **kw)


def test_verified_pick_at_the_weak_grip_repeats_each_rollout_as_the_dataset_labels_it(hammer_case):
    """weak_grip=25: every verification rollout repeated at 25 N per pad on its own physics draw, the rows
    `dataset.weak_rollouts` gives the same grasps on the same seed (the rule that labels the network's
    weak-grip head); a weak-grip failure adds w_weak to the measured total, and the pick is its lowest."""
    from itup_jax.dataset import WEAK_GRIP, GenerateConfig, weak_rollouts

    tool, task, scene, g, reach = hammer_case
    good = np.nonzero(reach)[0][:2]
    total = np.full(len(g), 10.0)
    total[good] = [1.0, 2.0]
    rnd, w = itup.Randomization(), ScoreWeights()
    v = best_grasp_verified(tool, task, g, k=2, draws=2, seed=5, randomize=rnd, weights=w, scores=_scores(total),
                            scene=scene, weak_grip=WEAK_GRIP)
    assert v.weak_grip == 25.0 and len(v.weak_labels.valid) == len(v.labels.valid) == 4
    ref = weak_rollouts(tool, task, g[np.repeat(good, 2)], GenerateConfig(tasks=("hammer",)), seed=5, scene=scene)
    for f in ("failed", "valid", "slip_translation"):
        np.testing.assert_allclose(np.asarray(getattr(v.weak_labels, f), float), np.asarray(ref[f"label_weak_{f}"], float),
                                   rtol=1e-9)
    assert v.candidate_labels("failed", weak=True).shape == (2, 2)
    per_rollout = measured_total(v.labels, w, "paper", v.weak_failed).reshape(2, 2)
    np.testing.assert_allclose(v.measured_total, per_rollout.mean(axis=1), rtol=1e-12)
    assert v.measured_total[list(v.shortlist).index(v.index)] == v.measured_total.min()
    # at a grip of 1 N per pad the tool slips out in every rollout: each weighs w_weak more than at 100 N
    loose = best_grasp_verified(tool, task, g, k=2, draws=2, seed=5, randomize=rnd, weights=w, scores=_scores(total),
                                scene=scene, weak_grip=1.0)
    plain = best_grasp_verified(tool, task, g, k=2, draws=2, seed=5, randomize=rnd, weights=w, scores=_scores(total),
                                scene=scene)
    assert loose.weak_failed.all() and plain.weak_labels is None and plain.weak_failed is None
    np.testing.assert_allclose(loose.measured_total, plain.measured_total + w.w_weak, rtol=1e-12)
    with pytest.raises(itup.InputError, match="without weak-grip rollouts"):
        plain.candidate_labels("failed", weak=True)


@pytest.mark.parametrize("grip", [25.0, 1.0])
def test_nominal_check_rolls_out_at_the_weak_grip_only_what_can_win_and_picks_as_if_all_were(hammer_case, grip):
    """Under nominal physics a grasp is rolled out at the weak grip only while its total without that
    rollout (a lower bound) is no higher than the lowest full total so far: the pick, and every row that
    was rolled out, are those of rolling out all of them; a grasp left out has a bound above the pick's
    total. At 1 N per pad every grasp slips, so each bound is raised by w_weak and more are rolled out."""
    from itup_jax.stress import simulate_at_grip
    from itup_jax.verify import LABEL_FIELDS, objective_of, weak_failures

    tool, task, scene, g, reach = hammer_case
    good = np.nonzero(reach)[0][:4]
    total = np.full(len(g), 10.0)
    total[good] = [1.0, 2.0, 3.0, 4.0]
    w = ScoreWeights()
    v = best_grasp_verified(tool, task, g, k=4, weights=w, scores=_scores(total), scene=scene, weak_grip=grip,
                            nthread=1)
    host = g.to_host()
    every = simulate_at_grip(tool, task, host[v.shortlist], grip, seed=0, randomize=None, scene=scene)
    full = measured_total(v.labels, w, objective_of(v.scores), weak_failures(every))
    assert v.chosen_by == "measured" and v.index == v.shortlist[int(np.argmin(full))]
    c = v.weak_checked
    assert c.dtype == bool and c.shape == (len(v.shortlist),) and c[list(v.shortlist).index(v.index)]
    for f in LABEL_FIELDS:
        np.testing.assert_array_equal(np.asarray(getattr(v.weak_labels, f))[c], np.asarray(getattr(every, f))[c])
    np.testing.assert_array_equal(v.measured_total[c], full[c])
    bound = measured_total(v.labels, w, objective_of(v.scores))
    np.testing.assert_array_equal(v.measured_total[~c], bound[~c])
    assert (bound[~c] > full.min()).all() and not v.weak_failed[~c].any()
    if grip == 1.0:  # everything slips at 1 N: a grasp is rolled out while bound <= min(bound) + w_weak
        assert weak_failures(every).all()
        np.testing.assert_array_equal(c, np.isfinite(bound) & (bound <= np.min(bound) + w.w_weak))
    else:
        assert (~c).any(), "the fixture should leave some grasp out at 25 N"


@pytest.mark.parametrize("grip", [0.0, -5.0, 300.0])
def test_verified_pick_refuses_a_weak_grip_out_of_range(hammer_case, grip):
    tool, task, scene, g, _ = hammer_case
    with pytest.raises(itup.InputError, match="weak_grip: grip force must be in"):
        best_grasp_verified(tool, task, g, k=1, scene=scene, weak_grip=grip)


def test_labels_concatenate_keeps_the_parts_rows_in_order():
    a = _labels(peak_torque_induced=[1.0, 2.0], valid=[True, False])
    b = _labels(peak_torque_induced=[3.0], valid=[True])
    c = Labels.concatenate([a, b])
    np.testing.assert_array_equal(c.peak_torque_induced, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(c.valid, [True, False, True])
    assert len(Labels.concatenate([]).valid) == 0

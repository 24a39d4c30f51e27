"""The out-of-distribution guard and SDG-Net's output ranges: the guard reads about one training standard
deviation on the built-in tools and fires on a tool far outside the training data; the network's outputs
stay physical there; the planner switches to verified picking when it fires and says so."""

from __future__ import annotations

import json
import warnings

import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import ood
from itup_jax.cli import main
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sdgnet.model import predict_from_features
from itup_jax.task import DEFAULT_TOOL


def _reachable(tool, kind, n=24):
    from itup_jax.grasp_sampler import sample_reachable

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        task = itup.make_task(kind, tool)
    return task, sample_reachable(tool, task, n, seed=0).grasps


@pytest.fixture(scope="module")
def far_tool():
    """A 4 kg screwdriver: a shape and a mass no training tool had."""
    return itup.load_tool("screwdriver").with_params(mass=4.0)


@pytest.mark.parametrize("kind", ["hammer", "sweep", "knock", "reach"])
def test_guard_stays_quiet_on_the_builtin_tools(kind):
    tool = itup.load_tool(DEFAULT_TOOL[kind])
    task, g = _reachable(tool, kind)
    r = ood.check(tool, task, g)
    assert not r.fired and r.score < ood.GUARD_THRESHOLD, r
    assert set(r.groups) == set(ood.FEATURE_GROUPS) and r.per_candidate.shape == (len(g),)


def test_guard_fires_far_outside_training_and_names_why(far_tool):
    task, g = _reachable(far_tool, "knock")
    r = ood.check(far_tool, task, g)
    assert r.fired and r.score > ood.GUARD_THRESHOLD
    assert r.farthest in ("physics", "geometry", "loads")
    assert "outside SDG-Net's training data" in r.message(far_tool.name, "knock")
    # group distances in standard deviations: features equal to the training mean read 0
    m = load_model().for_task("knock")
    x_mean = jnp.asarray(m.spec["x_mean"], jnp.float32)
    z = (x_mean[None] - x_mean) / jnp.asarray(m.spec["x_std"], jnp.float32)
    np.testing.assert_allclose(np.asarray(ood.group_distances(z, m.feature_spec)), 0.0, atol=1e-6)


def test_knn_distance_closed_form():
    ref = jnp.asarray([[0.0, 0.0], [3.0, 4.0], [6.0, 8.0]])
    np.testing.assert_allclose(np.asarray(ood.knn_distance(ref, ref, 1)), 0.0, atol=1e-6)
    q = jnp.asarray([[0.0, 0.0], [3.0, 0.0]])
    np.testing.assert_allclose(np.asarray(ood.knn_distance(q, ref, 2)), [(0.0 + 5.0) / 2, (3.0 + 4.0) / 2], atol=1e-5)


def test_a_trained_checkpoint_carries_its_reference_and_one_without_has_no_guard(tmp_path):
    from itup_jax.sdgnet.checkpoint import load_model as load
    from itup_jax.sdgnet.checkpoint import save_model

    feats = np.arange(24, dtype=np.float32).reshape(6, 4)
    ref = ood.sample_reference(feats, np.array(["hammer"] * 4 + ["knock"] * 2), rows=3)
    assert {k: len(v) for k, v in ref.features.items()} == {"hammer": 3, "knock": 2}
    ck = tmp_path / "m.npz"
    save_model(str(ck), load())
    tool = itup.load_tool("hammer")
    task, g = _reachable(tool, "hammer", n=4)
    assert ood.check(tool, task, g, model=str(ck)) is None  # no reference beside it
    assert ood.reference_path(str(ck)) == str(tmp_path / "m.reference.npz")
    assert ood.check(tool, task, g, model=load()) is not None  # the shipped weights: the shipped reference


def test_outputs_stay_physical_on_an_adversarial_input():
    """Features 50 standard deviations off in every direction: every regression output >= 0 and every
    probability in [0, 1]."""
    m = load_model().for_task("hammer")
    s = m.spec
    rng = np.random.default_rng(0)
    feats = np.asarray(s["x_mean"]) + 50 * np.asarray(s["x_std"]) * rng.choice([-1.0, 1.0], (256, len(s["x_mean"])))
    out, p = predict_from_features([(jnp.asarray(W), jnp.asarray(b)) for W, b in m.params], jnp.asarray(s["x_mean"]),
                                   jnp.asarray(s["x_std"]), jnp.asarray(s["y_mean"]), jnp.asarray(s["y_std"]),
                                   jnp.asarray(s["target_scales"]), jnp.asarray(feats))
    out, p = np.asarray(out), np.asarray(p)
    assert np.all(np.isfinite(out)) and out.min() >= 0.0
    assert p.min() >= 0.0 and p.max() <= 1.0


def test_plan_switches_to_verified_picking_when_the_guard_fires(tmp_path, capsys, monkeypatch, far_tool):
    import itup_jax.cli as cli

    monkeypatch.setattr(cli, "_load_tool_arg", lambda args: far_tool)
    out = tmp_path / "p.json"
    # verification on (the default): the guard checks 20 and mixes the analytic cost's best into them
    code = main(["plan", "--task", "knock", "--n", "24", "--json", str(out)])
    res = json.loads(out.read_text())
    g = res["guard"]
    assert g["fired"] and not g["verified"] and g["score"] > g["threshold"]
    assert res["verified"]["k"] == 20 and len(res["verified"]["labels"]) >= 20
    assert res["verified"]["shortlist_rule"] == "guard_mixed"
    text = capsys.readouterr().out
    assert "outside SDG-Net's training data" in text and "20 grasps are rolled out in MuJoCo" in text
    assert "SDG-Net's 12 best and the analytic wrench cost's 8 best (--guard-verify K" in text
    assert code == (0 if res["status"] == "ok" else 3)
    # --no-verify: the guard turns verification on, here with --guard-verify 5
    code = main(["plan", "--task", "knock", "--n", "24", "--no-verify", "--guard-verify", "5", "--json", str(out)])
    res = json.loads(out.read_text())
    g = res["guard"]
    assert g["fired"] and g["verified"] and res["verified"]["k"] == 5
    text = capsys.readouterr().out
    assert "5 grasps are rolled out in MuJoCo" in text and "SDG-Net's 3 best and the analytic wrench cost's 2 best" in text
    assert res["verified"]["shortlist_rule"] == "guard_mixed"
    assert code == (0 if res["status"] == "ok" else 3)
    # --no-guard reports the reading and trusts the learned score
    assert main(["plan", "--task", "knock", "--n", "24", "--no-guard", "--no-verify", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["guard"]["fired"] and not res["guard"]["verified"] and "verified" not in res
    assert "--no-guard: the learned score decides the pick" in capsys.readouterr().out


def test_the_guards_shortlist_mixes_in_the_analytic_costs_best(far_tool):
    """When the guard fired, the GUARD_VERIFY_K (20) verified grasps are SDG-Net's 12 best and the analytic
    wrench cost's 8 best of the others (`planning.guard_order`), in that order; the pick is the lowest
    measured total."""
    from itup_jax.planning import GUARD_VERIFY_K, guard_order, plan_grasp
    from itup_jax.sdgnet.objective import OBJECTIVES

    task = itup.make_task("knock", far_tool)
    plan = plan_grasp(far_tool, task, n=24, verify=0)  # the guard turns verification on
    assert plan.guard.fired and plan.guard_verified and plan.shortlist_rule == "guard_mixed"
    net = np.asarray(plan.scores.total)
    physics = np.asarray(itup.wrench_costs(far_tool, task, plan.grasps, OBJECTIVES["wrench"].analytic).total)
    order = guard_order(net, physics, GUARD_VERIFY_K)
    v = plan.verified
    assert plan.verify_k == GUARD_VERIFY_K == 20
    assert v.shortlist.tolist() == order[: len(v.shortlist)].tolist()  # every rollout valid: the first 20
    assert set(order[:12].tolist()) == set(np.argsort(net, kind="stable")[:12].tolist())
    assert v.index == v.shortlist[int(np.argmin(v.measured_total))]
    # the same candidates verified at the user's request with --no-guard: the scorer's 5 best
    plain = plan_grasp(far_tool, task, n=24, verify=5, guard=False)
    assert plain.shortlist_rule == "scorer"
    assert plain.verified.shortlist.tolist() == np.argsort(net, kind="stable")[: len(plain.verified.shortlist)].tolist()

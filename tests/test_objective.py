"""Objectives: what SDG-Net regresses and how its outputs make the scorer's costs (`itup_jax.sdgnet.objective`)."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.sdgnet import objective
from itup_jax.sdgnet.checkpoint import load_model, save_model
from itup_jax.sdgnet.config import CLASS_TARGETS, TrainConfig
from itup_jax.sdgnet.model import predict_costs
from itup_jax.sdgnet.training import train


def test_the_wrench_objective_recomposes_the_full_torque_and_keeps_the_grip_demand():
    y = jnp.asarray([[3.0, 4.0, 12.0, 50.0, 0.002, 0.1],   # third, closure, approach, grip, slip, align
                     [0.0, 2.0, 0.0, 200.0, 0.0, 0.0]])
    c = np.asarray(objective.costs_of(y, "wrench"))
    np.testing.assert_allclose(c[:, 0], [13.0, 2.0])  # |(3, 4, 12)| = 13: no component is discarded
    np.testing.assert_allclose(c[:, 1:], [[0.002, 0.1, 50.0], [0.0, 0.0, 200.0]])
    p = np.asarray(objective.costs_of(jnp.asarray([[1.5, 0.002, 0.1]]), "paper"))
    np.testing.assert_allclose(p, [[1.5, 0.002, 0.1, 0.0]])  # the paper's objective predicts no grip demand
    with pytest.raises(itup.InputError, match="objective"):
        objective.costs_of(y, "projected")


def test_a_torque_moved_onto_the_closure_axis_keeps_tau_and_raises_the_demand_and_the_total():
    """The gaming the paper's objective allows: the same torque turned onto the closure axis. The paper's
    C_tau drops to zero; the wrench objective's tau stays and the grip demand grows."""
    from itup_jax.grip_demand import grip_demand

    off = np.array([2.0, 0.0, 0.0])  # about the third axis
    on = np.array([0.0, 2.0, 0.0])  # the same magnitude, about the closure axis
    assert np.linalg.norm(on[[0, 2]]) == 0 < np.linalg.norm(off[[0, 2]])  # the projection sees none of it
    d_off, d_on = (grip_demand(np.zeros(3), t, 0.7, 0.03) for t in (off, on))
    assert d_on > d_off
    y_on = jnp.asarray([[on[0], on[1], on[2], d_on, 0.0, 0.0]])
    y_off = jnp.asarray([[off[0], off[1], off[2], d_off, 0.0, 0.0]])
    assert float(objective.costs_of(y_on, "wrench")[0, 0]) == pytest.approx(float(objective.costs_of(y_off, "wrench")[0, 0]))
    w = itup.ScoreWeights(w_grip=0.05)  # a total that weighs the grip demand
    tot = lambda y: float((objective.costs_of(y, "wrench") @ w.costs(jnp.float32))[0])  # noqa: E731
    assert tot(y_on) > tot(y_off)


def _synthetic_wrench(n=400, f=10, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, f))
    cols = {"label_peak_induced_third": np.exp(0.3 * X[:, 0]), "label_peak_induced_closure": np.exp(0.3 * X[:, 1]),
            "label_peak_induced_approach": np.exp(0.3 * X[:, 2]), "label_grip_demand": 50 * np.exp(0.5 * X[:, 3]),
            "label_slip_translation": 1e-3 * np.exp(X[:, 4]), "label_alignment_drift": 0.1 * (1 + np.tanh(X[:, 5]))}
    data = {"features": X, "task": np.array(["hammer"] * n), "tool_id": np.arange(n) % 8, **cols,
            CLASS_TARGETS[0]: X[:, 6] > 0, CLASS_TARGETS[1]: X[:, 7] > 0.5, CLASS_TARGETS[2]: X[:, 8] > 0}
    return data


@pytest.mark.slow
def test_a_wrench_model_trains_saves_loads_and_scores_its_own_targets(tmp_path, tasks):
    data = _synthetic_wrench()
    model = train(data, TrainConfig(objective="wrench", hidden=(32,), epochs=40, patience=40), progress=False,
                  log=lambda *a: None)
    assert model.objective == "wrench" and model.spec["targets"] == list(objective.WRENCH.targets)
    assert model.spec["target_scales"] == [0.02, 0.02, 0.02, 1.0, 1e-3, 0.1]
    path = str(tmp_path / "w.npz")
    save_model(path, model)
    back = load_model(path)
    out = {k: np.asarray(v) for k, v in predict_costs(back, data["features"][:20]).items()}
    np.testing.assert_allclose(out["tau"], np.sqrt(out["tau_third"] ** 2 + out["tau_closure"] ** 2
                                                   + out["tau_approach"] ** 2), rtol=1e-5)
    assert np.all(out["grip"] > 0)
    # a checkpoint whose targets do not match its objective is refused
    save_model(path, dataclasses.replace(back, spec=dict(back.spec, objective="paper")))
    with pytest.raises(itup.InputError, match="targets"):
        load_model(path)
    with pytest.raises(itup.InputError, match="objective"):
        TrainConfig(objective="projected")


def test_adapting_a_wrench_checkpoint_keeps_its_own_outputs(tmp_path):
    """`--keep` names the checkpoint's own outputs: a wrench model's torque components pass the check (the
    run then stops at the missing data), the paper objective's tau, which it does not regress, does not."""
    from itup_jax.sdgnet.recipes import adapt_on_datasets

    model = train(_synthetic_wrench(), TrainConfig(objective="wrench", hidden=(8,), epochs=2), progress=False,
                  log=lambda *a: None)
    path = str(tmp_path / "w.npz")
    save_model(path, model)
    missing = str(tmp_path / "no_data")
    with pytest.raises(itup.InputError, match="keep"):
        adapt_on_datasets(path, [missing], keep=("tau",))
    with pytest.raises(itup.InputError) as exc:
        adapt_on_datasets(path, [missing], keep=("tau_closure", "grip", "p_success"))
    assert "keep" not in str(exc.value) and "no_data" in str(exc.value)


@pytest.mark.slow
def test_an_old_checkpoint_without_an_objective_reads_as_the_papers(tmp_path):
    from itup_jax.sdgnet.config import TARGETS

    rng = np.random.default_rng(1)
    X = rng.normal(size=(200, 6))
    data = {"features": X, "task": np.array(["reach"] * 200), "tool_id": np.arange(200) % 8,
            **{t: np.exp(0.2 * X[:, i]) * s for i, (t, s) in enumerate(zip(TARGETS, (1.0, 1e-3, 0.1)))},
            CLASS_TARGETS[0]: X[:, 3] > 0, CLASS_TARGETS[1]: X[:, 4] > 0}
    # trained as the checkpoints before the weak-grip head were
    m = train(data, TrainConfig(objective="paper", hidden=(8,), epochs=3, weak_failure_weight=0.0), progress=False,
              log=lambda *a: None)
    with pytest.raises(itup.InputError, match="label_grip_demand"):  # the wrench objective needs its labels
        train(data, TrainConfig(objective="wrench", hidden=(8,), epochs=1), progress=False, log=lambda *a: None)
    spec = {k: v for k, v in m.spec.items() if k not in ("objective",)}
    path = str(tmp_path / "old.npz")
    save_model(path, dataclasses.replace(m, spec=spec))
    back = load_model(path)
    assert back.objective == "paper" and set(predict_costs(back, X[:3])) == {"tau", "slip", "align", "p_success",
                                                                             "p_failed"}


def _residual_spec():
    from itup_jax.sdgnet.features import FeatureSpec

    return FeatureSpec(num_points=256, residual=True)


def test_a_residual_network_that_learnt_nothing_scores_as_the_physics(tasks, tmp_path):
    """A residual SDG-Net (`FeatureSpec.residual`) adds its outputs to the rigid-body model's prediction: with
    every weight and offset zero its full induced torque is the analytic torque the pads pass on at the wrist
    (`costs` 'passed' at 100 N per pad) and its grip demand the analytic one, through the scorer's one jit,
    `predict_costs` and a saved checkpoint alike."""
    from itup_jax.costs import CostParams, wrench_costs
    from itup_jax.robot import PAD_TORSION
    from itup_jax.sdgnet.features import WRIST_GRIP_FORCE, batched_features, tool_field
    from itup_jax.sdgnet.model import Model
    from itup_jax.wrench import task_loads

    tool, task = tasks["hammer"]
    g = itup.sample_grasps(tool, 24, seed=3)
    spec = _residual_spec()
    n_out = len(objective.WRENCH.targets)
    model = Model(params=[(np.zeros((spec.size, n_out)), np.zeros(n_out))], spec={
        "feature_spec": spec.to_dict(), "objective": "wrench", "targets": list(objective.WRENCH.targets),
        "cost_names": list(objective.WRENCH.outputs), "target_scales": [0.02, 0.02, 0.02, 1.0, 1e-3, 0.1],
        "class_heads": [], "x_mean": [0.0] * spec.size, "x_std": [1.0] * spec.size, "y_mean": [0.0] * n_out,
        "y_std": [1.0] * n_out, "config": {"objective": "wrench"}})
    path = str(tmp_path / "residual.npz")
    save_model(path, model)
    assert load_model(path).residual
    passed = np.asarray(wrench_costs(tool, task, g, CostParams(lever_arm="wrist", torque_projection="passed",
                                                                  grip_force=WRIST_GRIP_FORCE)).tau, float)
    grip = np.asarray(wrench_costs(tool, task, g, CostParams.wrench()).tau, float) / (2 * PAD_TORSION)
    s = itup.score(tool, task, g, model=path)
    np.testing.assert_allclose(np.asarray(s.tau), passed, rtol=1e-4)  # float32 scorer
    np.testing.assert_allclose(np.asarray(s.grip), grip, rtol=1e-4)
    feats = batched_features(tool_field(tool, spec), task_loads(tool.params, task), tool.params, g, spec=spec)
    p = predict_costs(model, np.asarray(feats))
    np.testing.assert_allclose(np.asarray(p["tau"]), passed, rtol=1e-9)
    np.testing.assert_allclose(np.asarray(p["slip"]), 0.0, atol=0)  # no base: the network's own output, 0


@pytest.mark.slow
def test_a_residual_network_learns_what_it_adds_to_the_physics():
    """Trained on targets that are the base (the features' last block) times a factor the other features
    set, the network regresses the residual (the stored normalisation is the residual's: the base's
    spread is gone) and predicts the targets; the paper objective, whose targets the base does not
    predict, is refused by name."""
    from itup_jax.sdgnet.features import RESIDUAL_SCALES, RESIDUAL_SIZE

    data = _synthetic_wrench(f=10 + RESIDUAL_SIZE)
    X = data["features"]
    base = np.abs(X[:, -RESIDUAL_SIZE:]) + 0.5  # log1p(y / scale) of the physics' prediction
    X[:, -RESIDUAL_SIZE:] = base
    for i, t in enumerate(objective.WRENCH.targets[:RESIDUAL_SIZE]):
        data[t] = RESIDUAL_SCALES[i] * np.expm1(base[:, i] + 0.2 * np.tanh(X[:, 0]))
    fs = _residual_spec().to_dict()
    model = train(data, TrainConfig(objective="wrench", hidden=(32,), epochs=200, patience=200, lr=3e-3, ema=0.0),
                  feature_spec=fs,
                  progress=False, log=lambda *a: None)
    assert np.all(np.asarray(model.spec["y_std"][:RESIDUAL_SIZE]) < 0.2)  # the residual's spread, 0.2 tanh(.)
    out = predict_costs(model, X)
    for i, name in enumerate(objective.WRENCH.outputs[:RESIDUAL_SIZE]):
        z = np.log1p(np.asarray(out[name]) / RESIDUAL_SCALES[i])  # the target's transform: base + 0.2 tanh(x0)
        err = np.abs(z - base[:, i] - 0.2 * np.tanh(X[:, 0]))
        assert np.median(err) < 0.25 * np.median(np.abs(0.2 * np.tanh(X[:, 0])))  # well below the base alone's
    data["label_peak_torque_projected"] = data["label_peak_induced_third"]
    with pytest.raises(itup.InputError, match="residual"):
        train(data, TrainConfig(objective="paper", hidden=(8,), epochs=1), feature_spec=fs, progress=False,
              log=lambda *a: None)
    with pytest.raises(itup.InputError, match="residual"):  # torque targets at another scale than the base's
        train(data, TrainConfig(objective="wrench", torque_scale=1.0, hidden=(8,), epochs=1), feature_spec=fs,
              progress=False, log=lambda *a: None)

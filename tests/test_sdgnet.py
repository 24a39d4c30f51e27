"""SDG-Net training and scoring: synthetic training, checkpoint spec, one-jit scoring, the default model."""

import dataclasses
import json

import numpy as np
import pytest

import itup_jax as itup
from itup_jax import sdgnet
from itup_jax.scoring import sdgnet_scores_jit
from itup_jax.sdgnet import training as sdgnet_train
from itup_jax.sdgnet.checkpoint import load_model, save_model
from itup_jax.sdgnet.config import CLASS_TARGETS, SUCCESS_TARGET, TARGETS
from itup_jax.sdgnet.training import train


def TrainConfig(**kw):  # noqa: N802
    """These tests exercise the training machinery on the paper objective's three targets
    (`tests/test_objective.py` trains the wrench objective)."""
    return sdgnet.TrainConfig(**{"objective": "paper", **kw})


def _synthetic(n=400, f=12, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, f))
    raw = np.stack([np.exp(0.5 * X[:, 0]), 1e-3 * np.exp(X[:, 1] - X[:, 2]), 0.1 * (1 + np.tanh(X[:, 3]))], 1)
    data = {"features": X, "task": np.array(["hammer"] * n), "tool_id": np.arange(n) % 8}
    data.update({t: raw[:, i] for i, t in enumerate(TARGETS)})
    data[SUCCESS_TARGET] = X[:, 4] + 0.3 * X[:, 5] > 0  # the task succeeds on one side of a plane
    data["label_failed"] = X[:, 6] - 0.5 * X[:, 7] > 0.5  # the grip fails on one side of another
    data["label_weak_failed"] = X[:, 8] + 0.5 * X[:, 9] > 0.0  # and at the weak grip on one side of a third
    data["label_weak_valid"] = rng.random(n) > 0.1  # a tenth of the weak-grip rollouts not valid: not learned
    return data


def test_training_lowers_the_loss_tenfold_and_holds_out_tools():
    model = train(_synthetic(), TrainConfig(hidden=(64, 64), epochs=300, patience=300, lr=3e-3), progress=False,
                  log=lambda *a: None)
    hist = np.array(model.spec["history"])
    assert hist[:, 0].min() < hist[0, 0] / 10
    assert model.spec["n_val"] > 0 and model.spec["n_train"] > 0
    assert model.spec["n_val"] % 50 == 0  # whole tools (50 examples each) went to validation


@pytest.mark.slow
def test_weight_average_is_the_moving_average_of_the_steps():
    """`TrainConfig.ema`: the weights validated and kept are the exponential moving average of the steps'
    weights, started at the initial ones. One epoch of one full-batch step from scratch keeps
    d w0 + (1 - d) w1, where w0 is the initialisation (`mlp.init` with the training key) and w1 the weights
    after the step (the same run with ema 0)."""
    import jax

    from itup_jax.sdgnet import mlp

    data = _synthetic(n=200)
    quiet = dict(progress=False, log=lambda *_: None)
    cfg = TrainConfig(hidden=(8,), epochs=1, batch=10_000, lr=1e-2, seed=3)
    last = train(data, cfg, **quiet)
    d = 0.75
    avg = train(data, dataclasses.replace(cfg, ema=d), **quiet)
    k_init = jax.random.split(jax.random.key(cfg.seed))[1]
    w0 = mlp.init(k_init, [data["features"].shape[1], 8, len(TARGETS) + len(CLASS_TARGETS)])
    for (W0, b0), (W1, b1), (Wa, ba) in zip(w0, last.params, avg.params):
        assert not np.allclose(W1, W0)  # the step moved the weights
        np.testing.assert_allclose(Wa, d * np.asarray(W0, np.float32) + (1 - d) * W1, rtol=1e-5, atol=1e-7)
        np.testing.assert_allclose(ba, d * np.asarray(b0, np.float32) + (1 - d) * b1, rtol=1e-5, atol=1e-7)
    assert avg.train_config.ema == d and last.train_config.ema == 0.0
    for bad in (1.0, -0.1, float("nan"), True):
        with pytest.raises(itup.InputError, match="ema"):
            TrainConfig(ema=bad)


def test_checkpoint_carries_the_spec_and_predicts_the_same(tmp_path):
    model = train(_synthetic(), TrainConfig(hidden=(16,), epochs=5), feature_spec={"num_points": 8},
                  progress=False, log=lambda *a: None)
    path = str(tmp_path / "m.npz")
    save_model(path, model)
    back = load_model(path)
    assert back.spec["feature_spec"] == {"num_points": 8} and back.spec["targets"] == list(TARGETS)
    for (W, b), (W2, b2) in zip(model.params, back.params):
        assert np.array_equal(W, W2) and np.array_equal(b, b2)


@pytest.mark.slow
def test_checkpoint_gives_back_its_training_recipe(tmp_path):
    cfg = TrainConfig(hidden=(16, 8), epochs=3, lr=1e-3, weight_decay=0.05, seed=4, finetune_epochs=2)
    model = train(_synthetic(), cfg, feature_spec={"num_points": 8}, progress=False, log=lambda *a: None)
    save_model(str(tmp_path / "m.npz"), model)
    assert load_model(str(tmp_path / "m.npz")).train_config == cfg
    # a checkpoint made before a field existed: that field takes TrainConfig's default
    old = dataclasses.replace(model, spec={**model.spec, "config": {"hidden": [16], "lr": 1e-3}})
    assert old.train_config == TrainConfig(hidden=(16,), lr=1e-3)
    # the shipped recipe, what sdgnet_scaling / fidelity --train-model retrain: the recipe of the shipped
    # checkpoint's last adaptation (the reach step, `--finetune-epochs 150 --finetune-lr 1e-3
    # --ema 0.999`; itup_jax/models/MODEL_CARD.md)
    shipped = load_model().train_config
    assert shipped.finetune_epochs == 150 and shipped.hidden == (128, 128, 128)


def test_default_model_scores_in_one_jit_without_recompiling(tasks):
    tool, task = tasks["reach"]
    g = itup.sample_grasps(tool, 32, seed=0)
    s = itup.score(tool, task, g)
    assert s.scorer == "sdgnet" and s.total.shape == (32,) and np.all(np.isfinite(np.asarray(s.total)))
    assert np.all(np.asarray(s.align) > -0.05)  # drift (rad) predicted near or above zero
    before = sdgnet_scores_jit._cache_size()
    itup.score(tool, task, itup.sample_grasps(tool, 32, seed=1))
    assert sdgnet_scores_jit._cache_size() == before
    i, best, _ = itup.best_grasp(tool, task, g)
    assert float(s.total[i]) == pytest.approx(float(np.min(np.asarray(s.total))))
    a = itup.score(tool, task, g, model="analytic")
    assert a.scorer == "analytic" and a.total.shape == (32,)


def test_best_grasp_reachable_only_walks_the_ranking_to_the_first_reachable(tasks):
    """For the reach task's L-stick the seeded random scorer's best-scored raw candidate is unreachable
    for the arm (a scorer whose ranking has no ties and does not move when the shipped checkpoint is
    retrained): reachable_only returns the best-scored grasp that `sim.arm.reachable` accepts, and
    refuses a set with none."""
    from itup_jax.errors import InputError
    from itup_jax.sim.arm import reachable

    tool, task = tasks["reach"]
    g = itup.sample_grasps(tool, 40, seed=0)
    i_any, _, s = itup.best_grasp(tool, task, g, "random")
    order = np.argsort(np.asarray(s.total), kind="stable")
    ok = reachable(task, g[order])
    assert not ok[0] and ok.any(), "the case needs an unreachable best-scored grasp and a reachable one"
    i, pick, _ = itup.best_grasp(tool, task, g, "random", reachable_only=True)
    assert i == order[np.argmax(ok)] and i != i_any
    np.testing.assert_array_equal(np.asarray(pick.p_tool_grasp), np.asarray(g.p_tool_grasp[i]))
    with pytest.raises(InputError, match="none of the 3 grasps is reachable"):
        itup.best_grasp(tool, task, g[order[~ok][:3]], "random", reachable_only=True)


def test_predictions_are_decoded_with_the_checkpoints_own_target_scales(tasks, tmp_path):
    """A checkpoint trained with other log1p(y / scale) scales is decoded with its own (the spec's), by
    both `predict_costs` and the scorer: scales x (2, 3, 5) give exactly those multiples of the costs."""
    from itup_jax.sdgnet.config import PAPER_MODEL
    from itup_jax.sdgnet.model import predict_costs

    tool, task = tasks["reach"]
    g = itup.sample_grasps(tool, 16, seed=0)
    base = load_model(PAPER_MODEL)  # three outputs, one per cost
    k = np.array([2.0, 3.0, 5.0])
    other = dataclasses.replace(base, spec=dict(base.spec, target_scales=list(k * base.spec["target_scales"])))
    s0, s1 = itup.score(tool, task, g, model=base), itup.score(tool, task, g, model=other)
    for i, name in enumerate(("tau", "slip", "align")):
        np.testing.assert_allclose(np.asarray(getattr(s1, name)), k[i] * np.asarray(getattr(s0, name)), rtol=1e-5, atol=1e-9)
    net = base.for_task("reach")  # the shipped model is fine-tuned per task: each task's own normalisation
    feats = np.random.default_rng(0).normal(size=(8, len(net.spec["x_mean"]))) * net.spec["x_std"] + net.spec["x_mean"]
    p0, p1 = predict_costs(base, feats, "reach"), predict_costs(other, feats, "reach")
    np.testing.assert_allclose(np.asarray(p1["tau"]), k[0] * np.asarray(p0["tau"]), rtol=1e-5)
    path = str(tmp_path / "bad.npz")
    save_model(path, dataclasses.replace(base, spec=dict(base.spec, target_scales=[1.0, -1.0, 0.1])))
    with pytest.raises(itup.InputError, match="target_scales"):
        load_model(path)


@pytest.mark.slow
def test_torque_scale_sets_the_target_and_travels_with_the_checkpoint(tmp_path):
    """TrainConfig.torque_scale: the torque target is log1p(tau / scale), the checkpoint stores the scale,
    and the predictions come back in N m either way (a scale of 0 is refused)."""
    data = _synthetic()
    cfg = TrainConfig(hidden=(32,), epochs=60, patience=60, lr=3e-3)
    models = {k: train(data, dataclasses.replace(cfg, torque_scale=k), progress=False, log=lambda *a: None) for k in (1.0, 0.02)}
    assert models[0.02].spec["target_scales"][0] == 0.02 and models[1.0].spec["target_scales"][0] == 1.0
    assert models[0.02].spec["y_mean"][0] > models[1.0].spec["y_mean"][0] + 2  # log1p(tau / 0.02) is ~log(50) larger
    from itup_jax.sdgnet.model import predict_costs

    tau = data[TARGETS[0]]
    for m in models.values():  # both decode to torques of the data's size (N m), not off by the scale ratio
        pred = np.asarray(predict_costs(m, data["features"])["tau"])
        assert 0.5 < np.median(pred) / np.median(tau) < 2
    with pytest.raises(itup.InputError, match="torque_scale"):
        train(data, dataclasses.replace(cfg, torque_scale=0.0), progress=False, log=lambda *a: None)


def test_bad_model_argument(tasks, tmp_path):
    tool, task = tasks["reach"]
    g = itup.sample_grasps(tool, 4, seed=0)
    with pytest.raises(itup.InputError, match="model must be"):
        itup.score(tool, task, g, model=3)
    with pytest.raises(itup.InputError, match="not found"):
        itup.score(tool, task, g, model=str(tmp_path / "none.npz"))


def test_per_task_model_keeps_one_network_per_task(tmp_path):
    a, b = _synthetic(seed=1), _synthetic(seed=2)
    b["task"] = np.array(["reach"] * len(b["task"]))
    b[TARGETS[0]] = 5.0 * b[TARGETS[0]]  # another scale: each task gets its own normalisation
    data = {k: np.concatenate([a[k], b[k]]) for k in a}
    cfg = TrainConfig(hidden=(16,), epochs=30, patience=30, per_task=True)
    model = train(data, cfg, feature_spec={"num_points": 8}, progress=False, log=lambda *_: None)
    assert model.tasks == ["hammer", "reach"] and len(model.params) == 4  # 2 layers per task
    only = {k: (v[: len(a["task"])] if np.ndim(v) else v) for k, v in data.items()}
    alone = train(only, TrainConfig(hidden=(16,), epochs=30, patience=30), feature_spec={"num_points": 8},
                  progress=False, log=lambda *_: None)
    ham = model.for_task("hammer")  # the hammer network is exactly the one trained on hammer rows alone
    for (W, bb), (W2, b2) in zip(ham.params, alone.params):
        np.testing.assert_array_equal(W, W2)
        np.testing.assert_array_equal(bb, b2)
    assert ham.spec["y_mean"] == alone.spec["y_mean"]
    assert model.for_task("reach").spec["y_mean"] != ham.spec["y_mean"]
    save_model(str(tmp_path / "m.npz"), model)
    back = load_model(str(tmp_path / "m.npz"))
    assert back.tasks == model.tasks and back.spec["by_task"]["reach"]["layers"] == [2, 4]
    from itup_jax.sdgnet.model import predict_costs

    with pytest.raises(itup.InputError, match="per task"):
        predict_costs(back, a["features"][:5])  # which task's network? it must be said
    with pytest.raises(itup.InputError, match="knock"):
        back.for_task("knock")
    out = predict_costs(back, a["features"][:5], "hammer")
    assert np.asarray(out["tau"]).shape == (5,)


@pytest.mark.slow
def test_bench_score_takes_a_checkpoint_path(tmp_path):
    """`itup bench score --model PATH` times that checkpoint (it used to pass the path on as a Model)."""
    from itup_jax.bench import bench_score
    from itup_jax.sdgnet.features import FeatureSpec

    spec = FeatureSpec()
    data = _synthetic(f=spec.size)
    data["task"] = np.where(data["tool_id"] % 2 == 0, "hammer", "reach")
    # fine-tuned per task (as the shipped model): one 16-wide network per task in one checkpoint
    model = train(data, TrainConfig(hidden=(16,), epochs=2, finetune_epochs=1), feature_spec=spec.to_dict(),
                  progress=False, log=lambda *_: None)
    assert model.tasks == ["hammer", "reach"]
    path = str(tmp_path / "m.npz")
    save_model(path, model)
    res = bench_score(n=64, repeats=1, task_kind="reach", model=path)
    assert res["hidden"] == [16] and res["n"] == 64 and res["warm_ms"] > 0  # the reach network's layers


def test_a_feature_constant_in_training_is_not_blown_up():
    """Trained on tools that share a prior (a constant column), another value of it stays O(1) after
    normalisation instead of being divided by a ~1e-8 spread."""
    data = _synthetic()
    data["features"][:, 5] = 3.0
    model = train(data, TrainConfig(hidden=(8,), epochs=2), progress=False, log=lambda *_: None)
    assert model.spec["x_std"][5] == 1.0 and model.spec["x_mean"][5] == pytest.approx(3.0)
    assert all(s > 0.5 for i, s in enumerate(model.spec["x_std"]) if i != 5)  # the others are scaled by their spread


@pytest.mark.slow
def test_binary_heads_learn_success_and_failure_and_the_scorer_penalises_both(tasks, tmp_path):
    """Outputs 4, 5 and 6 learn P(success), P(failed) and P(failed at the weak grip) (held-out AUC on
    separable synthetic labels), travel with the checkpoint, and the scorer's total is the costs'
    weighted sum plus w_task x (1 - p_success) + w_fail x p_failed + w_weak x p_failed_weak."""
    from itup_jax.scoring import ScoreWeights
    from itup_jax.sdgnet.model import predict_costs
    from itup_jax.stats import roc_auc

    data = _synthetic(n=800)
    model = train(data, TrainConfig(hidden=(32, 32), epochs=150, patience=150, lr=3e-3), progress=False,
                  log=lambda *a: None)
    assert model.class_heads == list(CLASS_TARGETS) and model.params[-1][0].shape[1] == len(TARGETS) + 3
    vm = model.spec["val_metrics"]  # on the held-out tools: the separable labels are learned, the targets fit
    assert vm["auc_success"] > 0.95 and vm["auc_failed"] > 0.95 and vm["auc_weak_failed"] > 0.9
    assert all(0 <= vm[f"mse_{c}"] < 1.0 for c in ("tau", "slip", "align"))
    test = _synthetic(n=400, seed=7)
    pred = {k: np.asarray(v) for k, v in predict_costs(model, test["features"]).items()}
    for name, label in (("p_success", SUCCESS_TARGET), ("p_failed", "label_failed"),
                        ("p_failed_weak", "label_weak_failed")):
        assert np.all((pred[name] >= 0) & (pred[name] <= 1)) and roc_auc(pred[name], test[label]) > 0.95
    path = str(tmp_path / "m.npz")
    save_model(path, model)
    back = load_model(path)
    assert back.class_heads == list(CLASS_TARGETS) and back.has_success_head
    # a spec that disagrees with the network's outputs is refused, and so is an unknown head
    for heads, match in (([SUCCESS_TARGET], "outputs"), (["label_lucky", "label_failed"], "class_heads")):
        save_model(str(tmp_path / "bad.npz"), dataclasses.replace(model, spec=dict(model.spec, class_heads=heads)))
        with pytest.raises(itup.InputError, match=match):
            load_model(str(tmp_path / "bad.npz"))
    # one head, or none: fewer outputs and no such term (as every checkpoint before them)
    only_fail = train(data, TrainConfig(hidden=(8,), epochs=2, success_weight=0.0, weak_failure_weight=0.0),
                      progress=False, log=lambda *a: None)
    assert only_fail.class_heads == ["label_failed"] and not only_fail.has_success_head
    # a checkpoint that predates the weak-grip head: its recipe (what `adapt` continues) has none either

    def predating(m):
        return dataclasses.replace(m, spec=dict(m.spec, config={k: v for k, v in m.spec["config"].items()
                                                                if k != "weak_failure_weight"}))
    assert predating(only_fail).train_config.weak_failure_weight == 0.0
    assert predating(model).train_config.weak_failure_weight == TrainConfig().weak_failure_weight > 0
    assert set(predict_costs(only_fail, test["features"][:3])) == {"tau", "slip", "align", "p_failed"}
    plain = train(data, TrainConfig(hidden=(8,), epochs=2, success_weight=0.0, failure_weight=0.0,
                                    weak_failure_weight=0.0), progress=False, log=lambda *a: None)
    assert plain.class_heads == [] and set(predict_costs(plain, test["features"][:3])) == {"tau", "slip", "align"}
    for name in ("success_weight", "failure_weight", "weak_failure_weight"):
        with pytest.raises(itup.InputError, match=name):
            TrainConfig(**{name: -1.0})
    for bad in (dict(val_fraction=0.0), dict(val_fraction=1.0), dict(hidden=[128]), dict(epochs=2.5),
                dict(lr=float("nan")), dict(seed=True)):
        with pytest.raises(itup.InputError, match=f"train: {next(iter(bad))}"):
            TrainConfig(**bad)
    no_labels = {k: v for k, v in data.items() if k != "label_failed"}
    with pytest.raises(itup.InputError, match="label_failed"):
        train(no_labels, TrainConfig(hidden=(8,), epochs=2), progress=False, log=lambda *a: None)
    no_weak = {k: v for k, v in data.items() if not k.startswith("label_weak")}  # data made without weak rollouts
    with pytest.raises(itup.InputError, match="weak-failure-weight 0"):
        train(no_weak, TrainConfig(hidden=(8,), epochs=2), progress=False, log=lambda *a: None)
    assert train(no_weak, TrainConfig(hidden=(8,), epochs=2, weak_failure_weight=0.0), progress=False,
                 log=lambda *a: None).class_heads == list(CLASS_TARGETS[:2])
    # the scorer (on a real tool, with the shipped features): total = w . costs + w_task (1 - p_s) + w_fail p_f
    from itup_jax.sdgnet.features import FeatureSpec

    spec = FeatureSpec()
    real = train(_synthetic(f=spec.size), TrainConfig(hidden=(16,), epochs=5), feature_spec=spec.to_dict(),
                 progress=False, log=lambda *a: None)
    tool, task = tasks["reach"]
    g = itup.sample_grasps(tool, 16, seed=0)
    w = ScoreWeights(w_align=40.0, w_task=7.0, w_fail=3.0, w_weak=5.0)  # every term weighed
    s = itup.score(tool, task, g, model=real, weights=w)
    ps, pf, pw = np.asarray(s.p_success), np.asarray(s.p_failed), np.asarray(s.p_failed_weak)
    expect = (w.w_tau * np.asarray(s.tau) + w.w_slip * np.asarray(s.slip) + w.w_align * np.asarray(s.align)
              + w.w_task * (1 - ps) + w.w_fail * pf + w.w_weak * pw)
    np.testing.assert_allclose(np.asarray(s.total), expect, rtol=1e-5, atol=1e-5)
    for name in ("w_task", "w_fail", "w_weak"):
        with pytest.raises(itup.InputError, match=name):
            ScoreWeights(**{name: -1.0})  # a negative weight would reward a predicted miss or failure
    s0 = itup.score(tool, task, g, model=real, weights=ScoreWeights(w_align=40.0, w_task=0.0, w_fail=0.0, w_weak=0.0))
    np.testing.assert_allclose(np.asarray(s.total) - np.asarray(s0.total), 7.0 * (1 - ps) + 3.0 * pf + 5.0 * pw,
                               rtol=1e-5, atol=1e-5)
    bare = train(_synthetic(f=spec.size), TrainConfig(hidden=(8,), epochs=2, success_weight=0.0, failure_weight=0.0,
                                                       weak_failure_weight=0.0),
                 feature_spec=spec.to_dict(), progress=False, log=lambda *a: None)
    s1 = itup.score(tool, task, g, model=bare, weights=w)  # no heads: no such fields, no such terms
    assert s1.p_success is None and s1.p_failed is None and s1.p_failed_weak is None
    np.testing.assert_allclose(np.asarray(s1.total), w.w_tau * np.asarray(s1.tau) + w.w_slip * np.asarray(s1.slip)
                               + w.w_align * np.asarray(s1.align), rtol=1e-5, atol=1e-5)


@pytest.mark.slow
def test_finetuning_starts_from_the_shared_network_on_its_split_and_never_does_worse():
    import jax
    import jax.numpy as jnp

    a, b = _synthetic(seed=1), _synthetic(seed=2)
    b["task"] = np.array(["reach"] * len(b["task"]))
    b[TARGETS[0]] = np.exp(-0.5 * b["features"][:, 0])  # the reach's torque falls where the hammer's rises
    data = {k: np.concatenate([a[k], b[k]]) for k in a}
    cfg = TrainConfig(hidden=(16,), epochs=40, patience=40, lr=3e-3, finetune_epochs=40, finetune_lr=3e-3)
    model = train(data, cfg, progress=False, log=lambda *_: None)
    shared = train(data, dataclasses.replace(cfg, finetune_epochs=0), progress=False, log=lambda *_: None)
    assert model.tasks == ["hammer", "reach"] and len(model.params) == 4
    assert model.spec["shared"]["best_val_loss"] == shared.spec["best_val_loss"]  # the same shared network first
    # fine-tuning keeps the shared normalisation and the shared split: every held-out row stays held out
    for kind in model.tasks:
        assert model.spec["by_task"][kind]["x_mean"] == shared.spec["x_mean"]
        assert model.spec["by_task"][kind]["y_std"] == shared.spec["y_std"]
    assert sum(e["n_val"] for e in model.spec["by_task"].values()) == shared.spec["n_val"]
    val = sdgnet_train._val_tools(data, cfg.val_fraction, cfg.seed)
    names = sdgnet_train._tool_names(data)
    gains = []
    for kind in model.tasks:
        rows = (data["task"] == kind) & np.isin(names, list(val))
        x = (data["features"][rows] - np.array(shared.spec["x_mean"])) / np.array(shared.spec["x_std"])
        y = np.log1p(np.stack([data[t][rows] for t in TARGETS], 1) / np.array(cfg.target_scales))
        y = (y - np.array(shared.spec["y_mean"])) / np.array(shared.spec["y_std"])
        s = np.stack([sdgnet_train.head_labels(data, t)[rows] for t in CLASS_TARGETS], 1)  # NaN: not measured
        f32 = lambda v: jnp.asarray(v, jnp.float32)  # noqa: E731
        loss = lambda params: float(sdgnet_train.training_loss(jax.tree_util.tree_map(f32, params), f32(x), f32(y), f32(s),  # noqa: E731
                                                          f32(list(cfg.class_weights.values()))))
        before, after = loss(shared.params), loss(model.for_task(kind).params)
        assert after <= before + 1e-5
        assert model.spec["by_task"][kind]["best_val_loss"] == pytest.approx(after, rel=1e-4)
        gains.append(before - after)
    assert max(gains) > 0.05  # the tasks disagree: a network of their own fits the held-out rows better
    with pytest.raises(itup.InputError, match="finetune_epochs=0 with per_task"):
        TrainConfig(per_task=True, finetune_epochs=60)
    with pytest.raises(itup.InputError, match="finetune_epochs"):
        TrainConfig(finetune_epochs=-1)


@pytest.mark.slow
def test_rank_term_is_in_the_validation_loss_and_only_in_the_fine_tuning_stage():
    """With rank_weight > 0 the recorded validation loss is the paper's loss plus rank_weight x the
    listwise loss of every held-out tool's grasps as one group (recomputed here from the network it
    kept); with fine-tuning, the shared network before it is trained on the paper's loss alone."""
    import jax
    import jax.numpy as jnp

    from itup_jax import sdgnet

    data = _synthetic(n=480, seed=3)
    data["tool_id"] = np.arange(480) // 40  # 12 tools of 40 grasps; each tool's torque has its own offset
    data[TARGETS[0]] = data[TARGETS[0]] * np.exp(0.5 * data["tool_id"])
    cfg = TrainConfig(hidden=(16,), epochs=6, patience=6, rank_weight=2.0, rank_temperature=0.5, rank_tools=3,
                      rank_group=8)
    model = train(data, cfg, progress=False, log=lambda *_: None)
    sp = model.spec
    rows = np.isin(sdgnet_train._tool_names(data), list(sdgnet_train._val_tools(data, cfg.val_fraction, cfg.seed)))
    f32 = lambda v: jnp.asarray(v, jnp.float32)  # noqa: E731
    x = f32((data["features"][rows] - np.array(sp["x_mean"])) / np.array(sp["x_std"]))
    y = np.log1p(np.stack([data[t][rows] for t in TARGETS], 1) / np.array(cfg.target_scales))
    y = f32((y - np.array(sp["y_mean"])) / np.array(sp["y_std"]))
    s = f32(np.stack([sdgnet_train.head_labels(data, t)[rows] for t in CLASS_TARGETS], 1))
    params = jax.tree_util.tree_map(f32, model.params)
    plain = float(sdgnet_train.training_loss(params, x, y, s, f32(list(cfg.class_weights.values()))))
    pred = np.asarray(jax.vmap(sdgnet.mlp.apply, in_axes=(None, 0))(params, x))[:, 0]
    tools = data["tool_id"][rows]
    groups = [np.flatnonzero(tools == t) for t in np.unique(tools)]
    assert len(groups) == 3
    rank = np.mean([float(sdgnet_train.listwise_loss(f32(pred[g][None]), y[g, 0][None], cfg.rank_temperature))
                    for g in groups])
    assert rank > 0 and sp["best_val_loss"] == pytest.approx(plain + 2.0 * rank, rel=1e-4)
    tuned = train(data, dataclasses.replace(cfg, finetune_epochs=2), progress=False, log=lambda *_: None)
    alone = train(data, dataclasses.replace(cfg, rank_weight=0.0), progress=False, log=lambda *_: None)
    assert tuned.spec["shared"]["best_val_loss"] == alone.spec["best_val_loss"]
    # the groups a step draws: each holds rows of one tool only, and every row of a tool can be drawn
    names = np.array(["b", "a", "c", "a", "b", "a", "c", "c", "b", "a"])
    order, starts, counts = (jnp.asarray(v) for v in sdgnet_train._tool_groups(names))
    gi = np.asarray(sdgnet_train._draw_groups(jax.random.key(0), order, starts, counts, 200, 16))
    assert gi.shape == (200, 16) and all(len(set(names[row])) == 1 for row in gi)
    assert set(gi.ravel()) == set(range(len(names)))
    for bad in (dict(rank_weight=-1.0), dict(rank_temperature=0.0), dict(rank_group=1), dict(rank_tools=0)):
        with pytest.raises(itup.InputError, match=next(iter(bad))):
            TrainConfig(**bad)


@pytest.mark.slow
def test_ensemble_averages_its_members_log_costs_and_probabilities(tasks, tmp_path, capsys):
    """`sdgnet.model.ensemble` of two seeds: predictions (from features and through the scorer's one jit) are
    scale x expm1 of the members' mean log1p(y / scale) and the mean of their probabilities; the
    checkpoint round-trips bit for bit; mismatched or too few members are refused; `itup ensemble`
    writes it and `itup bench score --model` runs it."""
    from itup_jax.bench import bench_score
    from itup_jax.cli import main
    from itup_jax.sdgnet.features import FeatureSpec
    from itup_jax.sdgnet.model import ensemble, predict_costs

    spec = FeatureSpec()
    data = _synthetic(f=spec.size)
    data["task"] = np.where(data["tool_id"] % 2 == 0, "hammer", "reach")
    members = [train(data, TrainConfig(hidden=(16,), epochs=2, finetune_epochs=1, seed=s), feature_spec=spec.to_dict(),
                     progress=False, log=lambda *_: None) for s in (0, 1)]
    ens = ensemble(members)
    assert ens.ensemble_size == 2 and members[0].ensemble_size == 1 and ens.tasks == ["hammer", "reach"]
    assert ens.train_config == members[0].train_config

    def combined(outs, scales=(0.02, 1e-3, 0.1)):
        out = {n: sc * np.expm1(np.mean([np.log1p(np.asarray(o[n], float) / sc) for o in outs], 0))
               for n, sc in zip(("tau", "slip", "align"), scales)}
        return out | {n: np.mean([np.asarray(o[n], float) for o in outs], 0) for n in ("p_success", "p_failed")}

    X = data["features"][:20]
    got, want = predict_costs(ens, X, "reach"), combined([predict_costs(m, X, "reach") for m in members])
    for n, v in want.items():
        np.testing.assert_allclose(np.asarray(got[n]), v, rtol=1e-5, atol=1e-9, err_msg=n)
    assert not np.allclose(want["tau"], np.asarray(predict_costs(members[0], X, "reach")["tau"]))  # the members differ
    # through the scorer (float32, features and networks in one jit): the ensemble's float64 predictions
    from itup_jax.sdgnet.features import batched_features, tool_field
    from itup_jax.wrench import task_loads

    tool, task = tasks["hammer"]
    g = itup.sample_grasps(tool, 16, seed=0)
    s_ens = itup.score(tool, task, g, model=ens)
    feats = batched_features(tool_field(tool, spec), task_loads(tool.params, task), tool.params, g, spec=spec)
    want = predict_costs(ens, np.asarray(feats), "hammer")
    for n in ("tau", "slip", "align", "p_success", "p_failed"):
        np.testing.assert_allclose(np.asarray(getattr(s_ens, n)), np.asarray(want[n]), rtol=1e-3, atol=1e-4, err_msg=n)
    # round trip
    path = str(tmp_path / "ens.npz")
    save_model(path, ens)
    back = load_model(path)
    assert back.ensemble_size == 2 and back.spec == json.loads(json.dumps(ens.spec))
    for (W, b), (W2, b2) in zip(ens.params, back.params):
        assert W.shape[0] == 2 and np.array_equal(W, W2) and np.array_equal(b, b2)
    # refusals
    with pytest.raises(itup.InputError, match=">= 2 trained Models"):
        ensemble(members[:1])
    with pytest.raises(itup.InputError, match="itself an ensemble"):
        ensemble([ens, members[0]])
    other = train(data, TrainConfig(hidden=(8,), epochs=1, finetune_epochs=1), feature_spec=spec.to_dict(),
                  progress=False, log=lambda *_: None)
    with pytest.raises(itup.InputError, match="share an architecture"):
        ensemble([members[0], other])
    # the command line
    paths = []
    for k, m in enumerate(members):
        paths.append(str(tmp_path / f"m{k}.npz"))
        save_model(paths[-1], m)
    out = str(tmp_path / "cli_ens.npz")
    assert main(["ensemble", "--models", *paths, "--out", out]) == 0
    assert load_model(out).ensemble_size == 2 and "an ensemble of 2" in capsys.readouterr().out
    assert main(["ensemble", "--models", paths[0], "--out", paths[0]]) == 2
    res = bench_score(n=64, repeats=1, task_kind="reach", model=out)
    assert res["ensemble_size"] == 2 and res["hidden"] == [16] and res["warm_ms"] > 0


@pytest.mark.slow
def test_teacher_targets_are_the_teachers_predictions_and_soft_labels_are_learnt_exactly(tasks):
    """Distillation: `teacher_targets` replaces the cost targets and the binary labels by the teacher's
    predictions of each row, by task, and copies nothing else; the cross-entropy with a soft label s is
    least (zero gradient) at sigmoid(logit) = s."""
    import jax
    import jax.numpy as jnp

    from itup_jax.sdgnet.model import predict_costs
    from itup_jax.sdgnet.training import teacher_targets, training_loss

    data = _synthetic()
    data["task"] = np.where(data["tool_id"] % 2 == 0, "hammer", "reach")
    teacher = train(data, TrainConfig(hidden=(16,), epochs=3, finetune_epochs=1), progress=False, log=lambda *_: None)
    before = {k: np.array(v, copy=True) for k, v in data.items()}
    soft = teacher_targets(data, teacher)
    for k, v in before.items():  # the input is untouched
        np.testing.assert_array_equal(data[k], v)
    assert soft["features"] is data["features"] and soft["tool_id"] is data["tool_id"]
    for kind in ("hammer", "reach"):
        rows = data["task"] == kind
        p = predict_costs(teacher, data["features"][rows], kind)
        for name, key in zip(("tau", "slip", "align", "p_success", "p_failed"), list(TARGETS) + list(CLASS_TARGETS)):
            np.testing.assert_array_equal(soft[key][rows], np.asarray(p[name], np.float64))
    assert 0 < soft["label_success"].min() and soft["label_success"].max() < 1  # probabilities, not labels
    with pytest.raises(itup.InputError, match="no network for task 'knock'"):
        teacher_targets({**data, "task": np.array(["knock"] * len(data["task"]))}, teacher)
    with pytest.raises(itup.InputError, match="the rows have 5 features"):
        teacher_targets({**data, "features": data["features"][:, :5]}, teacher)
    # soft-label cross-entropy: d/dz [softplus(z) - s z] = sigmoid(z) - s, zero at z = logit(s)
    W = jnp.zeros((1, 5))
    s = jnp.array([[0.3, 0.8]])
    b = jnp.concatenate([jnp.zeros(3), jnp.log(s[0] / (1 - s[0]))])
    g = jax.grad(lambda b: training_loss([(W, b)], jnp.zeros((1, 1)), jnp.zeros((1, 3)), s, jnp.ones(2)))(b)
    np.testing.assert_allclose(np.asarray(g), 0.0, atol=1e-12)
    g2 = jax.grad(lambda b: training_loss([(W, b)], jnp.zeros((1, 1)), jnp.zeros((1, 3)), s, jnp.ones(2)))(b + 0.5)
    assert np.all(np.asarray(g2)[3:] > 0)  # a larger logit than the teacher's probability is pushed back


@pytest.mark.slow
def test_adapt_continues_each_network_on_new_data_and_keeps_the_rest(tmp_path, capsys):
    """`adapt` starts every network from the checkpoint (its normalisation kept), only keeps an epoch
    that beats the start on the new data's held-out tools, learns a shifted family, and leaves the
    networks of tasks the new data lacks bit for bit."""
    from itup_jax.sdgnet.training import adapt

    a, b = _synthetic(seed=1), _synthetic(seed=2)
    b["task"] = np.array(["reach"] * len(b["task"]))
    data = {k: np.concatenate([a[k], b[k]]) for k in a}
    cfg = TrainConfig(hidden=(16,), epochs=40, patience=40, lr=3e-3, finetune_epochs=20, finetune_lr=3e-3)
    quiet = dict(progress=False, log=lambda *_: None)
    model = train(data, cfg, feature_spec={"num_points": 8}, **quiet)
    new = _synthetic(seed=3)  # a new hammer family: its torque falls where the old one's rises
    new[TARGETS[0]] = np.exp(-0.5 * new["features"][:, 0])
    before = adapt(model, new, epochs=1, lr=1e-12, **quiet)  # a rate of ~0: what the start scores on the new split
    after = adapt(model, new, epochs=60, lr=3e-3, **quiet)
    ham0, ham1 = model.for_task("hammer"), after.for_task("hammer")
    assert ham1.spec["x_mean"] == ham0.spec["x_mean"] and ham1.spec["y_std"] == ham0.spec["y_std"]
    start = before.spec["by_task"]["hammer"]["history"][0][1]
    assert after.spec["by_task"]["hammer"]["best_val_loss"] < 0.5 * start  # it learnt the new family
    assert after.spec["by_task"]["hammer"]["best_val_loss"] <= before.spec["by_task"]["hammer"]["best_val_loss"] + 1e-6
    for (W, bb), (W2, b2) in zip(model.for_task("reach").params, after.for_task("reach").params):
        np.testing.assert_array_equal(W, W2)  # no reach rows: its network is the checkpoint's
        np.testing.assert_array_equal(bb, b2)
    assert after.tasks == ["hammer", "reach"] and after.spec["adapted_from"]["epochs"] == 60
    save_model(str(tmp_path / "adapted.npz"), after)
    assert load_model(str(tmp_path / "adapted.npz")).for_task("reach").spec["y_mean"] == model.for_task("reach").spec["y_mean"]
    with pytest.raises(itup.InputError, match="no network"):
        adapt(model, {**new, "task": np.array(["knock"] * len(new["task"]))}, epochs=5, **quiet)
    with pytest.raises(itup.InputError, match="epochs must be an integer >= 1"):
        adapt(model, new, epochs=0, **quiet)
    with pytest.raises(itup.InputError, match="features were made with"):
        adapt(model, new, epochs=5, feature_spec={"num_points": 7}, **quiet)


def test_adapt_holds_out_tools_of_every_task():
    """Adapting a per-task model draws its held-out tools task by task: a task with few tools, which a
    draw over all tools can leave without one (and whose network would then be chosen on its training
    loss), is judged on a held-out tool of its own."""
    from itup_jax.sdgnet.training import _val_tools, _val_tools_per_task, adapt

    a, b = _synthetic(seed=1), _synthetic(seed=2)
    b["task"] = np.array(["reach"] * len(b["task"]))
    cfg = TrainConfig(hidden=(8,), epochs=4, patience=4, lr=3e-3, finetune_epochs=2, finetune_lr=3e-3)
    quiet = dict(progress=False, log=lambda *_: None)
    model = train({k: np.concatenate([a[k], b[k]]) for k in a}, cfg, **quiet)
    new_a, new_b = _synthetic(seed=3), _synthetic(n=100, seed=4)
    new_b["task"], new_b["tool_id"] = np.array(["reach"] * 100), np.arange(100) % 2  # 8 hammers, 2 reach tools
    new = {k: np.concatenate([new_a[k], new_b[k]]) for k in new_a}
    assert not any(t.startswith("reach/") for t in _val_tools(new, cfg.val_fraction, 0))  # a draw over all tools
    held = _val_tools_per_task(new, cfg.val_fraction, 0)
    assert {t.split("/")[0] for t in held} == {"hammer", "reach"} and len(held) == 3
    logs = []
    out = adapt(model, new, epochs=2, seed=0, progress=False, log=logs.append)
    assert out.spec["by_task"]["reach"]["n_val"] == 50 and out.spec["by_task"]["hammer"]["n_val"] == 100
    assert not any("no held-out tool" in m for m in logs)
    one_tool = {k: v[new["task"] == "hammer"] for k, v in new.items()} | {"tool_id": np.zeros(400, int)}
    adapt(model, one_tool, epochs=2, seed=0, progress=False, log=logs.append)
    assert any("no held-out tool among the data's 1 tool(s)" in m for m in logs)


def test_train_init_refuses_to_change_the_recipe(tmp_path, capsys):
    from itup_jax.cli import main

    assert main(["train", "--data", str(tmp_path), "--out", str(tmp_path / "m.npz"), "--init", "x.npz",
                 "--hidden", "8"]) == 2
    assert "the recipe is the checkpoint's own; --hidden" in capsys.readouterr().err
    assert main(["train", "--data", str(tmp_path), "--out", str(tmp_path / "m.npz"), "--init", "x.npz",
                 "--val-fraction", "0.1"]) == 2
    assert "the recipe is the checkpoint's own; --val-fraction" in capsys.readouterr().err


@pytest.mark.slow
def test_adapting_with_held_outputs_learns_the_changed_label_and_holds_the_rest(tmp_path, capsys):
    """`teacher_targets(outputs=...)` swaps only the named outputs for the checkpoint's own predictions.
    Adapting on them (`itup train --init M --keep tau,align`) learns a changed slip label while the
    torque output stays where it was, closer than an adaptation to the labels leaves it."""
    from itup_jax.cli import main
    from itup_jax.sdgnet.model import predict_costs
    from itup_jax.sdgnet.training import adapt, teacher_targets

    quiet = dict(progress=False, log=lambda *_: None)
    model = train(_synthetic(seed=1), TrainConfig(hidden=(16,), epochs=40, patience=40, lr=3e-3), **quiet)
    new = _synthetic(seed=2)
    X = new["features"]
    new[TARGETS[1]] = 1e-3 * np.exp(X[:, 2] - X[:, 1])  # the slip label changed its meaning
    held = teacher_targets(new, model, outputs=("tau", "align"))
    p0 = predict_costs(model, X, "hammer")
    np.testing.assert_array_equal(held[TARGETS[0]], np.asarray(p0["tau"], np.float64))
    np.testing.assert_array_equal(held[TARGETS[2]], np.asarray(p0["align"], np.float64))
    assert held[TARGETS[1]] is new[TARGETS[1]] and held[CLASS_TARGETS[1]] is new[CLASS_TARGETS[1]]  # labels kept
    kept = adapt(model, held, epochs=60, lr=3e-3, **quiet)
    free = adapt(model, new, epochs=60, lr=3e-3, **quiet)
    p_kept, p_free = predict_costs(kept, X, "hammer"), predict_costs(free, X, "hammer")
    drift = lambda p: float(np.median(np.abs(np.log(np.asarray(p["tau"]) / np.asarray(p0["tau"])))))  # noqa: E731
    slip_err = lambda p: float(np.median(np.abs(np.asarray(p["slip"]) - new[TARGETS[1]])))  # noqa: E731
    assert drift(p_kept) < 0.5 * drift(p_free) and drift(p_kept) < 0.05
    assert slip_err(p_kept) < 0.5 * slip_err(p0)  # it learnt the new slip
    with pytest.raises(itup.InputError, match="outputs must be some of"):
        teacher_targets(new, model, outputs=("torque",))
    path = str(tmp_path / "m.npz")
    save_model(path, model)
    assert main(["train", "--data", str(tmp_path), "--out", str(tmp_path / "o.npz"), "--keep", "tau"]) == 2
    assert "it needs --init" in capsys.readouterr().err
    assert main(["train", "--data", str(tmp_path), "--out", str(tmp_path / "o.npz"), "--init", path, "--keep", "torque"]) == 2
    assert "--keep ['torque']" in capsys.readouterr().err and not (tmp_path / "o.npz").exists()

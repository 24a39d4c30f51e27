"""SDG-Net's building blocks: our MLP, our Adam, array-only checkpoints."""

import pickle

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.sdgnet import checkpoint, mlp
from itup_jax.sdgnet.optim import AdamConfig, adam_init, adam_update, learning_rate

# float64 throughout (conftest): the NumPy re-implementation differs by rounding only.
FWD_RTOL = 1e-12
FD_STEP = 1e-6
FD_RTOL = 1e-6


def _numpy_forward(layers, x):
    h = x
    for W, b in layers[:-1]:
        z = h @ W + b
        h = z / (1 + np.exp(-z))  # SiLU
    W, b = layers[-1]
    return h @ W + b


def test_forward_matches_numpy(rng):
    params = mlp.init(jax.random.key(0), [7, 16, 16, 3])
    x = rng.normal(size=(5, 7))
    out = jax.vmap(mlp.apply, in_axes=(None, 0))(params, jnp.asarray(x))
    ref = _numpy_forward([(np.asarray(W), np.asarray(b)) for W, b in params], x)
    np.testing.assert_allclose(np.asarray(out), ref, rtol=FWD_RTOL, atol=1e-14)
    assert mlp.num_params(params) == 7 * 16 + 16 + 16 * 16 + 16 + 16 * 3 + 3


def test_one_adam_step_matches_a_hand_computation():
    cfg = AdamConfig(lr=0.1, weight_decay=0.01, warmup_steps=1, total_steps=100)
    p = {"w": jnp.array([1.0, -2.0])}
    g = {"w": jnp.array([0.5, 0.25])}
    new, state = adam_update(g, adam_init(p), p, cfg)
    # step 1: m = (1-b1) g, v = (1-b2) g^2; bias-corrected m_hat = g, v_hat = g^2; lr at step 0 = 0.1
    m_hat, v_hat = np.array([0.5, 0.25]), np.array([0.25, 0.0625])
    expected = np.array([1.0, -2.0]) - 0.1 * (m_hat / (np.sqrt(v_hat) + 1e-8) + 0.01 * np.array([1.0, -2.0]))
    np.testing.assert_allclose(np.asarray(new["w"]), expected, rtol=1e-12)
    assert int(state.step) == 1


def test_schedule_warms_up_then_decays():
    cfg = AdamConfig(lr=1.0, warmup_steps=10, total_steps=110, final_fraction=0.1)
    lrs = np.array([float(learning_rate(s, cfg)) for s in range(0, 120)])
    assert lrs[0] == pytest.approx(0.1) and lrs[9] == pytest.approx(1.0)
    assert np.all(np.diff(lrs[10:110]) <= 1e-12) and lrs[110] == pytest.approx(0.1)


def test_loss_gradient_matches_finite_differences(rng):
    params = mlp.init(jax.random.key(1), [4, 8, 3])
    x, y = jnp.asarray(rng.normal(size=(6, 4))), jnp.asarray(rng.normal(size=(6, 3)))

    def loss(flat):
        W0 = flat[:32].reshape(4, 8)
        ps = [(W0, params[0][1]), params[1]]
        return jnp.sum((jax.vmap(mlp.apply, in_axes=(None, 0))(ps, x) - y) ** 2)

    w = params[0][0].ravel()
    g = np.asarray(jax.grad(loss)(w))
    fd = np.array([(float(loss(w.at[i].add(FD_STEP))) - float(loss(w.at[i].add(-FD_STEP)))) / (2 * FD_STEP)
                   for i in range(w.size)])
    np.testing.assert_allclose(g, fd, rtol=FD_RTOL, atol=1e-8)


@pytest.mark.slow
def test_sdgnet_loss_is_sse_plus_weighted_cross_entropy_and_its_gradient_matches_fd(rng):
    """sdgnet.training_loss: with a network whose outputs are known (zero last-layer weights, biases
    b), SSE = sum (b_k - y_k)^2 and each binary head adds its weight x -log sigma(+-b_{3+k}); its gradient
    (float64) matches central finite differences in every first-layer weight."""
    from itup_jax.sdgnet.training import training_loss

    params = mlp.init(jax.random.key(3), [4, 8, 5])
    x, y = jnp.asarray(rng.normal(size=(6, 4))), jnp.asarray(rng.normal(size=(6, 3)))
    s = jnp.asarray([[1.0, 0.0], [0.0, 0.0], [1.0, 1.0], [1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    cw = jnp.asarray([2.5, 0.5])
    b = jnp.asarray([0.3, -0.2, 0.5, 1.7, -0.4])
    const = [params[0], (jnp.zeros((8, 5)), b)]
    sse = np.mean(np.sum((np.asarray(b[:3]) - np.asarray(y)) ** 2, axis=1))

    def bce(z, lab):  # -log sigma(z) for label 1, -log(1 - sigma(z)) for 0
        return np.mean(np.where(lab > 0, np.log1p(np.exp(-z)), np.log1p(np.exp(z))))

    S = np.asarray(s)
    expect = sse + 2.5 * bce(1.7, S[:, 0]) + 0.5 * bce(-0.4, S[:, 1])
    assert float(training_loss(const, x, y, s, cw)) == pytest.approx(expect, rel=1e-12)
    three = [params[0], (jnp.zeros((8, 3)), b[:3])]  # no heads: the paper's loss alone
    assert float(training_loss(three, x, y, s[:, :0], cw[:0])) == pytest.approx(sse, rel=1e-12)
    # a NaN label (not measured: the weak-grip head on a row whose weak rollout is not valid) adds nothing,
    # and the mean stays over every row
    s_nan = s.at[2, 1].set(jnp.nan).at[4, 1].set(jnp.nan)
    measured = np.array([0, 1, 3, 5])
    expect_nan = sse + 2.5 * bce(1.7, S[:, 0]) + 0.5 * bce(-0.4, S[measured, 1]) * len(measured) / len(S)
    assert float(training_loss(const, x, y, s_nan, cw)) == pytest.approx(expect_nan, rel=1e-12)
    assert np.isfinite(np.asarray(jax.grad(lambda p: training_loss(p, x, y, s_nan, cw))(const)[1][1])).all()

    def loss(flat):
        return training_loss([(flat.reshape(4, 8), params[0][1]), params[1]], x, y, s, cw)

    w = params[0][0].ravel()
    g = np.asarray(jax.grad(loss)(w))
    fd = np.array([(float(loss(w.at[i].add(FD_STEP))) - float(loss(w.at[i].add(-FD_STEP)))) / (2 * FD_STEP)
                   for i in range(w.size)])
    np.testing.assert_allclose(g, fd, rtol=FD_RTOL, atol=1e-8)


def test_training_on_a_synthetic_problem_lowers_the_loss_tenfold(rng):
    x = rng.uniform(-1, 1, size=(256, 3))
    y = np.stack([np.sin(2 * x[:, 0]) + x[:, 1] * x[:, 2], x[:, 0] ** 2 - 0.5 * x[:, 1]], axis=1)
    X, Y = jnp.asarray(x), jnp.asarray(y)
    params = mlp.init(jax.random.key(2), [3, 32, 32, 2])
    cfg = AdamConfig(lr=3e-3, warmup_steps=20, total_steps=600, weight_decay=1e-5)

    def loss(p):
        return jnp.mean(jnp.sum((jax.vmap(mlp.apply, in_axes=(None, 0))(p, X) - Y) ** 2, axis=1))

    @jax.jit  # the outer call: one jitted train step
    def step(p, s):
        l, g = jax.value_and_grad(loss)(p)
        p, s = adam_update(g, s, p, cfg)
        return p, s, l

    state = adam_init(params)
    first = float(loss(params))
    for _ in range(600):
        params, state, _ = step(params, state)
    assert float(loss(params)) < first / 10


def test_checkpoint_round_trip_is_bit_exact(tmp_path):
    params = mlp.init(jax.random.key(3), [5, 8, 2])
    spec = {"features": ["a", "b"], "mean": [0.5, 1.5], "config": {"lr": 1e-3}}
    path = str(tmp_path / "net.npz")
    checkpoint.save(path, params, spec)
    layers, spec2 = checkpoint.load(path)
    assert spec2 == spec
    for (W, b), (W2, b2) in zip(params, layers):
        assert np.array_equal(np.asarray(W), W2) and np.asarray(W).dtype == W2.dtype
        assert np.array_equal(np.asarray(b), b2)
    assert [p.name for p in tmp_path.iterdir()] == ["net.npz"]  # no temporary left behind


def test_pickled_truncated_and_foreign_files_are_refused(tmp_path):
    pkl = tmp_path / "evil.npz"
    pkl.write_bytes(pickle.dumps({"W0": np.zeros(3)}))
    with pytest.raises(itup.InputError, match="not a checkpoint \\(not an .npz archive"):
        checkpoint.load(str(pkl))
    good = tmp_path / "good.npz"
    checkpoint.save(str(good), mlp.init(jax.random.key(4), [3, 4, 1]), {"x": 1})
    cut = tmp_path / "cut.npz"
    cut.write_bytes(good.read_bytes()[:200])
    with pytest.raises(itup.InputError, match="unreadable or truncated"):
        checkpoint.load(str(cut))
    obj = tmp_path / "obj.npz"
    np.savez(obj, meta_json=np.array([{"format": "x"}], dtype=object))
    with pytest.raises(itup.InputError, match="refused"):
        checkpoint.load(str(obj))
    plain = tmp_path / "plain.npz"
    np.savez(plain, W0=np.zeros(3))
    with pytest.raises(itup.InputError, match="not an itup checkpoint"):
        checkpoint.load(str(plain))


@pytest.mark.slow
def test_listwise_loss_is_the_kl_of_top1_distributions_and_its_gradient_matches_fd(rng):
    """sdgnet.listwise_loss on two grasps: q1 = sigmoid((t2 - t1) / T), p1 = sigmoid((a2 - a1) / T) and
    the loss is KL(q || p); it vanishes when the predictions are the targets plus a constant (the offset
    between tools is ignored), a padded entry changes nothing, and the float64 gradient, padding
    included, matches central finite differences."""
    from itup_jax.sdgnet.training import listwise_loss

    T = 0.3
    a, t = np.array([0.2, -0.5]), np.array([-0.1, 0.4])
    sig = lambda z: 1 / (1 + np.exp(-z))  # noqa: E731
    q1, p1 = sig((t[1] - t[0]) / T), sig((a[1] - a[0]) / T)
    kl = q1 * np.log(q1 / p1) + (1 - q1) * np.log((1 - q1) / (1 - p1))
    assert float(listwise_loss(jnp.asarray([a]), jnp.asarray([t]), T)) == pytest.approx(kl, rel=1e-12)
    padded = listwise_loss(jnp.asarray([[*a, 9.0]]), jnp.asarray([[*t, -9.0]]), T, jnp.asarray([[True, True, False]]))
    assert float(padded) == pytest.approx(kl, rel=1e-12)
    pred, target = jnp.asarray(rng.normal(size=(3, 5))), jnp.asarray(rng.normal(size=(3, 5)))
    shifted = target + jnp.asarray([[2.0], [-7.0], [0.5]])
    assert float(listwise_loss(shifted, target, T)) == pytest.approx(0.0, abs=1e-12)
    assert float(listwise_loss(pred, target, T)) > 0.01
    mask = jnp.asarray(rng.random((3, 5)) < 0.7).at[:, 0].set(True)
    g = np.asarray(jax.grad(lambda p: listwise_loss(p, target, T, mask))(pred))
    assert np.all(np.isfinite(g)) and np.all(g[~np.asarray(mask)] == 0)
    flat = np.asarray(pred).ravel()
    f = lambda v: float(listwise_loss(jnp.asarray(v.reshape(3, 5)), target, T, mask))  # noqa: E731
    fd = np.array([(f(flat + FD_STEP * e) - f(flat - FD_STEP * e)) / (2 * FD_STEP) for e in np.eye(flat.size)])
    np.testing.assert_allclose(g.ravel(), fd, rtol=FD_RTOL, atol=1e-8)

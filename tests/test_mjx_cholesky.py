"""Plain-JAX Cholesky for MJX on a CPU (itup_jax/mjx_cholesky.py): against LAPACK's, against solves of the
linear system, gradients against finite differences, MJX's physics unchanged, and no LAPACK call left in
the rollout program that `simulate` runs on a CPU (the calls that deadlock jaxlib 0.10.2's thread pool)."""

import importlib

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
import scipy.linalg

from itup_jax.sim.mjx import import_mjx
from itup_jax.sim.mjx_cholesky import cho_factor, cho_solve, cholesky_lower, jax_cholesky


def _spd(rng, shape, n):
    x = rng.normal(size=(*shape, n, n))
    return x @ np.swapaxes(x, -1, -2) + n * np.eye(n)


@pytest.mark.parametrize("n", [1, 2, 7, 24])
@pytest.mark.parametrize("lower", [False, True])
def test_factor_equals_lapack(rng, n, lower):
    a = _spd(rng, (3, 2), n)  # two leading batch dimensions
    c, flag = cho_factor(a, lower=lower)
    ref, _ = jax.scipy.linalg.cho_factor(a, lower=lower)  # jaxlib's LAPACK kernel on this CPU
    assert flag is lower
    np.testing.assert_allclose(np.asarray(c), np.asarray(ref), rtol=0, atol=1e-12 * np.abs(a).max())
    other = np.triu(np.asarray(c), 1) if lower else np.tril(np.asarray(c), -1)
    assert not other.any()  # the other triangle is zero, as JAX's
    low = np.asarray(c) if lower else np.swapaxes(np.asarray(c), -1, -2)
    np.testing.assert_allclose(low @ np.swapaxes(low, -1, -2), a, rtol=1e-12, atol=1e-12 * n)


def test_closed_form_and_not_positive_definite():
    # [[4, 2], [2, 5]] = L L^T with L = [[2, 0], [1, 2]]
    np.testing.assert_allclose(np.asarray(cholesky_lower(jnp.array([[4.0, 2.0], [2.0, 5.0]]))), [[2, 0], [1, 2]])
    assert np.isnan(np.asarray(cholesky_lower(jnp.array([[1.0, 2.0], [2.0, 1.0]])))[1, 1])


@pytest.mark.parametrize("lower", [False, True])
def test_solve_solves_the_system(rng, lower):
    a = _spd(rng, (4,), 9)
    b, bm = rng.normal(size=(4, 9)), rng.normal(size=(4, 9, 3))
    f = cho_factor(a, lower=lower)
    np.testing.assert_allclose(np.asarray(cho_solve(f, b)), np.linalg.solve(a, b[..., None])[..., 0], rtol=1e-10)
    np.testing.assert_allclose(np.asarray(cho_solve(f, bm)), np.linalg.solve(a, bm), rtol=1e-10)


def test_solve_reads_only_its_triangle(rng):
    # SciPy's cho_factor leaves the original entries in the unused triangle; LAPACK's solve ignores them
    a = _spd(rng, (), 6)
    b = rng.normal(size=6)
    for lower in (False, True):
        c = scipy.linalg.cho_factor(a, lower=lower)
        assert np.abs(np.tril(c[0], -1) if not lower else np.triu(c[0], 1)).max() > 0  # junk is there
        np.testing.assert_allclose(np.asarray(cho_solve(c, b)), np.linalg.solve(a, b), rtol=1e-10)


@pytest.mark.slow
def test_gradient_matches_finite_differences(rng):
    a0 = _spd(rng, (), 5)
    b = rng.normal(size=5)
    w = rng.normal(size=5)
    d = rng.normal(size=(5, 5))
    d = d + d.T  # a symmetric direction: the factor reads one triangle, the system is symmetric

    def f(t):
        return jnp.dot(w, cho_solve(cho_factor(a0 + t * d), b))

    g = jax.grad(f)(0.0)
    h = 1e-6
    fd = (f(h) - f(-h)) / (2 * h)
    np.testing.assert_allclose(float(g), float(fd), rtol=1e-7)
    # and the closed form: d/dt w^T a^-1 b = -w^T a^-1 d a^-1 b
    ai = np.linalg.inv(a0)
    np.testing.assert_allclose(float(g), -w @ ai @ d @ ai @ b, rtol=1e-9)


def test_block_swaps_and_restores():
    old = jax.scipy.linalg.cho_factor, jax.scipy.linalg.cho_solve
    with jax_cholesky():
        assert jax.scipy.linalg.cho_factor is cho_factor and jax.scipy.linalg.cho_solve is cho_solve
    assert (jax.scipy.linalg.cho_factor, jax.scipy.linalg.cho_solve) == old
    with pytest.raises(RuntimeError):
        with jax_cholesky():
            raise RuntimeError("inside")
    assert (jax.scipy.linalg.cho_factor, jax.scipy.linalg.cho_solve) == old


@pytest.mark.slow
def test_mjx_step_unchanged():
    """A three-link arm and a free capsule resting on a box (the mass matrix and the Newton solver's
    Hessian are both factored): one MJX step with plain-JAX Cholesky equals MJX's stock step, and both
    are native MuJoCo's."""
    mjx = import_mjx()
    m = mujoco.MjModel.from_xml_string("""
<mujoco><option cone="elliptic" impratio="10"/>
<worldbody><geom type="box" size="0.3 0.3 0.05"/>
<body pos="0 0 1"><joint type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
 <body pos="0.3 0 0"><joint type="hinge" axis="0 1 0"/><geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
  <body pos="0.3 0 0"><joint type="hinge" axis="1 0 0"/><geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.03"/></body>
 </body></body>
<body pos="0 0 0.07"><freejoint/><geom type="capsule" size="0.02 0.1" euler="0 90 10" condim="4"/></body>
</worldbody></mujoco>""")
    d = mujoco.MjData(m)
    d.qpos[:3] = [0.4, -0.7, 0.3]
    mujoco.mj_forward(m, d)
    assert d.ncon > 0  # the capsule rests on the box: the solver has contacts to handle
    mx = mjx.put_model(m)
    dx = mjx.put_data(m, d)
    stock = jax.jit(mjx.step)(mx, dx)
    with jax_cholesky():  # traced inside the block
        ours = jax.jit(mjx.step)(mx, dx)
    np.testing.assert_allclose(np.asarray(ours.qacc), np.asarray(stock.qacc), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(np.asarray(ours.qpos), np.asarray(stock.qpos), rtol=0, atol=1e-12)
    mujoco.mj_step(m, d)
    np.testing.assert_allclose(np.asarray(ours.qpos), d.qpos, rtol=0, atol=1e-6)


@pytest.mark.slow
def test_cpu_rollout_program_has_no_lapack_call(tasks):
    """The program `simulate` runs on this CPU calls no LAPACK kernel; the program it would trace for a GPU
    is MJX's stock one, which does (so the check reads the right thing). The two are traced one after the
    other from the same rollout function: each platform keeps its own trace, where JAX's trace cache,
    keyed by the function, would hand the second the first one's."""
    from itup_jax.sim.scene import build_scene

    sim = importlib.import_module("itup_jax.sim.mjx")
    phys = importlib.import_module("itup_jax.sim.physics")
    tool, task = tasks["hammer"]
    scene = build_scene(tool, task, timestep=0.002)
    fn = sim.mjx_rollout_fn(scene, float64=True)
    physics = phys.sample_physics(tool, 2, 0)
    args = [a.astype(fn.dtype) for a in phys.mjx_model_fields(scene, physics)]
    args += [np.tile(scene.model.qpos0, (2, 1)).astype(fn.dtype), np.zeros((2, 2, scene.model.nu), fn.dtype)]
    args = [jax.device_put(a, jax.devices("cpu")[0]) for a in args]
    ours = fn.lower(*args).as_text()
    stock = fn.lower(*args, platform="gpu").as_text()  # a GPU's tracing blocks, lowered for this CPU
    again = fn.lower(*args).as_text()
    assert "lapack_dpotrf" in stock
    assert "lapack" not in ours and "lapack" not in again

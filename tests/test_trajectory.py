"""Trajectories: quintic segments meet their knots; sampled twists are the pose's exact derivatives."""

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np
import pytest

from itup_jax.trajectory import Profile, quintic_coefficients, sample_pose_fn

# Central differences in float64 with h = 1e-5 s: truncation ~h^2 |f'''| ~ 1e-9, rounding ~eps/h ~ 1e-11.
FD_STEP = 1e-5
FD_ATOL = 1e-7


def test_quintic_meets_boundary_conditions():
    h, start, end = 0.7, (0.2, -1.0, 3.0), (1.5, 2.0, -4.0)
    c = quintic_coefficients(h, start, end)[::-1]
    for s, (q, v, a) in ((0.0, start), (h, end)):
        assert np.polyval(c, s) == pytest.approx(q, abs=1e-12)
        assert np.polyval(np.polyder(c), s) == pytest.approx(v, abs=1e-12)
        assert np.polyval(np.polyder(c, 2), s) == pytest.approx(a, abs=1e-11)


def test_profile_is_c2_across_knots():
    prof = Profile.through([(0.0, 0.0, 0.0, 0.0), (0.5, 1.0, 2.0, 0.0), (1.0, 0.0, 0.0, 0.0)])
    d1, d2 = jax.grad(prof), jax.grad(jax.grad(prof))
    for k in (0.5,):
        for f in (prof, d1, d2):
            assert float(f(jnp.asarray(k - 1e-9))) == pytest.approx(float(f(jnp.asarray(k + 1e-9))), abs=1e-6)
    assert float(d1(jnp.asarray(0.5))) == pytest.approx(2.0, abs=1e-9)


def _pose(t):
    """A generic motion: position along a curve, rotation about a turning axis."""
    axis = jnp.array([jnp.sin(t), 0.3, jnp.cos(2 * t)])
    R = jaxlie.SO3.exp(axis * (0.5 + t**2)).as_matrix()
    p = jnp.array([jnp.cos(3 * t), t**3, jnp.sin(t) * t])
    return p, R


def test_sampled_twist_matches_finite_differences():
    t = jnp.linspace(0.1, 1.0, 7)
    tr = sample_pose_fn(_pose, t)
    h = FD_STEP
    for i, ti in enumerate(np.asarray(t)):
        (p1, R1), (p0, R0) = _pose(ti + h), _pose(ti - h)
        np.testing.assert_allclose(tr.v_world[i], (p1 - p0) / (2 * h), atol=FD_ATOL)
        R_dot = (R1 - R0) / (2 * h)
        W = np.asarray(R_dot @ tr.R_world_tool[i].T)  # [w]_x
        np.testing.assert_allclose(tr.w_world[i], [W[2, 1], W[0, 2], W[1, 0]], atol=FD_ATOL)
        np.testing.assert_allclose(W, -W.T, atol=FD_ATOL)  # skew-symmetric, as it must be
    # second derivatives from the sampled first derivatives
    tr_p = sample_pose_fn(_pose, t + h)
    tr_m = sample_pose_fn(_pose, t - h)
    np.testing.assert_allclose(tr.a_world, (tr_p.v_world - tr_m.v_world) / (2 * h), atol=1e-6)
    np.testing.assert_allclose(tr.alpha_world, (tr_p.w_world - tr_m.w_world) / (2 * h), atol=1e-6)


def test_fixed_axis_rotation_has_the_closed_form_angular_velocity():
    axis = np.array([0.0, 1.0, 0.0])
    theta = lambda t: 0.3 * t**2  # noqa: E731
    tr = sample_pose_fn(lambda t: (jnp.zeros(3), jaxlie.SO3.exp(jnp.asarray(axis) * theta(t)).as_matrix()),
                        jnp.linspace(0, 1, 5))
    np.testing.assert_allclose(tr.w_world, np.outer(0.6 * np.linspace(0, 1, 5), axis), atol=1e-12)
    np.testing.assert_allclose(tr.alpha_world, np.outer(np.full(5, 0.6), axis), atol=1e-12)


def test_point_velocity_is_rigid_body_kinematics():
    t = jnp.linspace(0.1, 1.0, 5)
    c = jnp.array([0.1, -0.2, 0.3])
    tr = sample_pose_fn(_pose, t)
    moved = sample_pose_fn(lambda tt: (_pose(tt)[0] + _pose(tt)[1] @ c, _pose(tt)[1]), t)
    np.testing.assert_allclose(tr.point_velocity(c), moved.v_world, atol=1e-12)
    np.testing.assert_allclose(tr.point_position(c), moved.p_world_tool, atol=1e-12)

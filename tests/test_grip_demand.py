"""Grip demand: closed forms of the pads' friction limits, and the label from a rollout's wrist trace."""

import jax.numpy as jnp
import numpy as np
import pytest

from itup_jax.grip_demand import MIN_COUPLE_WIDTH, grip_demand, torque_about_grasp
from itup_jax.robot import FLANGE_TO_GRASP, PAD_TORSION, PAD_WIDTH
from itup_jax.sim.labels import induced

Z3 = np.zeros(3)


def test_each_load_alone_needs_its_friction_limit():
    mu, w = 0.6, 0.03
    # a tangential force is shared by two pads with sliding friction mu each
    assert grip_demand(np.array([12.0, 0, 0]), Z3, mu, w) == pytest.approx(12.0 / (2 * mu))
    assert grip_demand(np.array([0, 0, 12.0]), Z3, mu, w) == pytest.approx(12.0 / (2 * mu))
    # 1 N m about the closure axis: torsional friction only, 100 N per pad at c_t = 5 mm
    assert grip_demand(Z3, np.array([0, 1.0, 0]), mu, w) == pytest.approx(1.0 / (2 * PAD_TORSION)) == pytest.approx(100.0)
    # about the third axis: the friction couple across the jaw
    assert grip_demand(Z3, np.array([1.0, 0, 0]), mu, w) == pytest.approx(1.0 / (mu * w))
    # about the approach axis: the couple plus the pads' pressure arm
    assert grip_demand(Z3, np.array([0, 0, 1.0]), mu, w) == pytest.approx(1.0 / (mu * w + PAD_WIDTH))
    # the same torque costs most about the closure axis (the axis a projection would discard)
    d = [grip_demand(Z3, np.eye(3)[i], mu, w) for i in range(3)]
    assert d[1] > d[0] > d[2]


def test_demand_is_the_ellipsoid_norm_and_scales_with_the_load():
    rng = np.random.default_rng(0)
    f, t = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    mu, w = rng.uniform(0.3, 1.0, 50), rng.uniform(0.0, 0.08, 50)
    d = grip_demand(f, t, mu, w)
    np.testing.assert_allclose(grip_demand(3 * f, 3 * t, mu, w), 3 * d, rtol=1e-12)  # homogeneous
    parts = [grip_demand(f * m, t * n, mu, w) for m, n in ((np.array([1, 0, 1]), Z3), (np.array([0, 1, 0]), Z3),
                                                            (Z3, np.array([1, 0, 0])), (Z3, np.array([0, 1, 0])),
                                                            (Z3, np.array([0, 0, 1])))]
    np.testing.assert_allclose(np.sqrt(sum(p**2 for p in parts)), d, rtol=1e-12)
    # a thinner grip than the floor uses the floor's couple arm, not a zero one
    assert np.isfinite(grip_demand(Z3, np.array([1.0, 0, 0]), 0.5, 0.0))
    assert grip_demand(Z3, np.array([1.0, 0, 0]), 0.5, 0.0) == pytest.approx(1 / (0.5 * MIN_COUPLE_WIDTH))
    # numpy and JAX agree
    np.testing.assert_allclose(np.asarray(grip_demand(jnp.asarray(f), jnp.asarray(t), jnp.asarray(mu), jnp.asarray(w), xp=jnp)),
                               d, rtol=1e-5)


def test_a_force_through_the_grasp_centre_has_no_torque_there():
    """A force F applied at the grasp centre reads tau_s = r x F at the wrist (r from the sensor to the
    grasp centre, along the approach axis); moved back to the grasp centre it is zero."""
    rng = np.random.default_rng(1)
    F = rng.normal(size=(20, 3))
    r = np.array([0.0, 0.0, FLANGE_TO_GRASP])
    tau_s = np.cross(r, F)
    np.testing.assert_allclose(torque_about_grasp(F, tau_s), 0.0, atol=1e-15)
    tau = rng.normal(size=(20, 3))  # and a pure couple is the same about any point
    np.testing.assert_allclose(torque_about_grasp(np.zeros((20, 3)), tau), tau)


def test_the_label_is_the_peak_demand_of_the_rollouts_induced_wrist_wrench(tasks):
    import itup_jax as itup
    from itup_jax.sim.rollout import simulate
    from itup_jax.sim.scene import build_scene

    tool, task = tasks["hammer"]
    scene = build_scene(tool, task)
    g = itup.sample_grasps(tool, 16, seed=2)
    res = simulate(tool, task, g, scene=scene, seed=0, traces=True, backend="native")
    L = res.labels
    v = np.nonzero(L.valid)[0]
    assert len(v) >= 3
    p = res.plan
    tau = res.traces["gripper/wrist_torque"]
    force = res.traces["gripper/wrist_force"]
    d_tau, _ = induced(scene, p, tau)
    d_force, _ = induced(scene, p, force)
    tau_g = torque_about_grasp(d_force, d_tau)
    want = grip_demand(d_force, tau_g, res.physics.mu[:, None], np.asarray(g.width)[:, None]).max(1)
    np.testing.assert_allclose(L.grip_demand[v], want[v], rtol=1e-12)
    # it is at least what the torque about the closure axis alone needs
    assert np.all(L.grip_demand[v] >= np.abs(tau_g[v, :, 1]).max(1) / (2 * PAD_TORSION) - 1e-9)

"""The wrench model against closed forms: impulses, lever-arm torques, drag, inertial wrench."""

import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.costs import CostParams, grasp_cost_trace
from itup_jax.grasp import make_grasps
from itup_jax.task import custom_task
from itup_jax.tools import make_tool_params
from itup_jax.trajectory import sample_pose_fn
from itup_jax.wrench import drag_force, normal_impulse, task_loads

# Closed forms evaluated in float64: agreement to a few ulps of the operands.
CLOSED_RTOL = 1e-12


def rod(m=0.4, L=0.3, e=0.5, mu=0.6, dt=2e-3):
    """Uniform thin rod along tool x, centred at the origin (transverse inertia m L^2 / 12)."""
    It = m * L**2 / 12
    return make_tool_params(mass=m, com=[0, 0, 0], inertia=np.diag([1e-9 * It, It, It]), restitution=e,
                            mu=mu, contact_duration=dt)


def test_point_mass_against_a_wall():
    m, e, v = 0.5, 0.4, 2.0
    n = jnp.array([0.0, 0.0, 1.0])
    J = normal_impulse(1 / m, jnp.eye(3), jnp.zeros(3), n, jnp.array([0.0, 0.0, -v]), e, 0.0)
    assert float(J) == pytest.approx((1 + e) * m * v, rel=CLOSED_RTOL)


def test_uniform_rod_struck_at_its_end_has_a_quarter_of_its_mass():
    m, L, e, v = 0.4, 0.3, 0.5, 1.5
    I_inv = jnp.diag(jnp.array([1e9, 12 / (m * L**2), 12 / (m * L**2)]))
    J = normal_impulse(1 / m, I_inv, jnp.array([L / 2, 0, 0]), jnp.array([0.0, 1.0, 0.0]),
                       jnp.array([0.0, -v, 0.0]), e, 0.0)
    assert float(J) == pytest.approx((1 + e) * m * v / 4, rel=CLOSED_RTOL)
    # struck at its centre of mass, a rod behaves as a point mass
    J0 = normal_impulse(1 / m, I_inv, jnp.zeros(3), jnp.array([0.0, 1.0, 0.0]), jnp.array([0.0, -v, 0.0]), e, 0.0)
    assert float(J0) == pytest.approx((1 + e) * m * v, rel=CLOSED_RTOL)


def test_two_point_masses_share_the_reduced_mass_and_separation_gives_nothing():
    m1, m2, e, v = 0.5, 0.1, 0.6, 1.2
    n = jnp.array([1.0, 0.0, 0.0])
    J = normal_impulse(1 / m1, jnp.eye(3), jnp.zeros(3), n, jnp.array([-v, 0.0, 0.0]), e, 1 / m2)
    assert float(J) == pytest.approx((1 + e) * v / (1 / m1 + 1 / m2), rel=CLOSED_RTOL)
    assert float(normal_impulse(1 / m1, jnp.eye(3), jnp.zeros(3), n, jnp.array([v, 0.0, 0.0]), e, 0.0)) == 0.0


def test_drag_force_is_regularised_coulomb():
    f, vs = 2.0, 0.01
    v = jnp.array([0.3, -0.4, 0.0])
    F = drag_force(v, f, vs)
    assert float(jnp.linalg.norm(F)) == pytest.approx(f * 0.5 / np.sqrt(0.25 + vs**2), rel=CLOSED_RTOL)
    np.testing.assert_allclose(np.asarray(F) / np.linalg.norm(F), -np.asarray(v) / 0.5, atol=1e-15)
    assert float(jnp.linalg.norm(drag_force(1e-9 * v, f, vs))) < 1e-6 * f  # continuous through v = 0


def _translation_task(v_world, steps=16, impact_step=8, n=(0.0, 1.0, 0.0), c=(0.15, 0.0, 0.0)):
    """The rod translating at constant velocity (no rotation), striking at one step."""
    v_world = jnp.asarray(v_world)
    traj = sample_pose_fn(lambda t: (v_world * t, jnp.eye(3)), jnp.linspace(0.0, 1.0, steps))
    impact = np.zeros((steps, 1))
    impact[impact_step, 0] = 1.0
    return custom_task(traj, [c], [n], impact=impact)


def test_known_lever_arm_gives_the_known_torque():
    """Rod end (x = +L/2) strikes a wall (normal +y) at v; grasp at x = -ell along the rod."""
    m, L, e, dt, v, ell = 0.4, 0.3, 0.5, 2e-3, 1.5, 0.05
    tool = rod(m, L, e, dt=dt)
    task = _translation_task([0.0, -v, 0.0])
    F = (1 + e) * m * v / 4 / dt  # contact force on the tool, along +y
    lever = L / 2 + ell
    loads = task_loads(tool, task)
    np.testing.assert_allclose(np.asarray(loads.force_tool[8]), [0.0, -F, 0.0], rtol=CLOSED_RTOL)
    # closure axis along the normal (y): the full torque is destabilising, no slip, aligned
    R_y = np.eye(3)
    g = make_grasps([[-ell, 0.0, 0.0]], R_y[None], [0.02])
    c = itup.wrench_costs(tool, task, g)
    assert float(c.tau[0]) == pytest.approx(lever * F, rel=CLOSED_RTOL)
    assert float(c.slip[0]) == pytest.approx(0.0, abs=1e-9)
    assert float(c.align[0]) == pytest.approx(0.0, abs=1e-7)
    # closure axis along the torque (z): pad torsion holds it all, C_tau sees none of it
    R_z = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])  # columns x, y=z_tool, z=-y_tool
    c = itup.wrench_costs(tool, task, make_grasps([[-ell, 0.0, 0.0]], R_z[None], [0.02]))
    assert float(c.tau[0]) == pytest.approx(0.0, abs=1e-6 * lever * F)
    assert float(c.tau_closure[0]) == pytest.approx(lever * F, rel=CLOSED_RTOL)
    assert float(c.slip[0]) == pytest.approx(F, rel=CLOSED_RTOL)  # all tangential, no squeeze
    assert float(c.align[0]) == pytest.approx(np.pi / 2, rel=1e-12)
    # the squeeze-force variant: each pad's grip adds mu f to the friction capacity
    grip = 0.25 * F / 0.6
    c = itup.wrench_costs(tool, task, make_grasps([[-ell, 0.0, 0.0]], R_z[None], [0.02]), CostParams(grip_force=grip))
    assert float(c.slip[0]) == pytest.approx(F - 2 * 0.6 * grip, rel=1e-10)


@pytest.mark.slow
def test_uniform_acceleration_loads_the_grasp_with_m_a_about_the_com():
    m, a = 0.4, np.array([2.0, 0.0, -1.0])
    tool = rod(m)
    traj = sample_pose_fn(lambda t: (0.5 * jnp.asarray(a) * t**2, jnp.eye(3)), jnp.linspace(0.0, 1.0, 8))
    task = custom_task(traj, [[0.15, 0, 0]], [[0, 1.0, 0]])
    loads = task_loads(tool, task)
    np.testing.assert_allclose(np.asarray(loads.force_tool), np.tile(m * a, (8, 1)), rtol=CLOSED_RTOL)
    p = np.array([-0.1, 0.0, 0.0])
    g = make_grasps([p], np.eye(3)[None], [0.02])
    trace = grasp_cost_trace(loads, g[0], tool, CostParams(torque_projection="full"))
    np.testing.assert_allclose(np.asarray(trace.tau), np.linalg.norm(np.cross(-p, m * a)), rtol=CLOSED_RTOL)


@pytest.mark.slow
def test_static_tool_with_gravity_needs_the_holding_torque():
    """At rest, the grasp holds m g at the com's lever arm: |tau| = m g |(c_com - p) x z|."""
    m = 0.4
    tool = rod(m)
    traj = sample_pose_fn(lambda t: (jnp.zeros(3) * t, jnp.eye(3)), jnp.linspace(0.0, 1.0, 8))
    task = custom_task(traj, [[0.15, 0, 0]], [[0, 1.0, 0]])
    p = np.array([-0.12, 0.0, 0.0])
    g = make_grasps([p], np.eye(3)[None], [0.02])
    with_g = itup.wrench_costs(tool, task, g, CostParams(include_gravity=True, torque_projection="full"))
    assert float(with_g.tau[0]) == pytest.approx(m * itup.units.STANDARD_GRAVITY * 0.12, rel=CLOSED_RTOL)
    without = itup.wrench_costs(tool, task, g, CostParams(torque_projection="full"))
    assert float(without.tau[0]) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
def test_spinning_about_a_principal_axis_needs_no_torque_but_an_off_axis_spin_does():
    It, Ia = 2e-3, 5e-4
    tool = make_tool_params(mass=0.3, com=[0, 0, 0], inertia=np.diag([It, It, Ia]), restitution=0.5, mu=0.5,
                            contact_duration=1e-3)
    import jaxlie

    def spin(axis, rate=3.0):
        traj = sample_pose_fn(lambda t: (jnp.zeros(3), jaxlie.SO3.exp(jnp.asarray(axis) * rate * t).as_matrix()),
                              jnp.linspace(0.0, 1.0, 6))
        return task_loads(tool, custom_task(traj, [[0, 0, 0.1]], [[1.0, 0, 0]]))

    np.testing.assert_allclose(np.asarray(spin(np.array([0.0, 0.0, 1.0])).moment_tool), 0.0, atol=1e-15)
    axis = np.array([0.0, 1.0, 1.0]) / np.sqrt(2)
    M = np.asarray(spin(axis).moment_tool)
    # constant body-frame spin w_b: moment in the body frame is w_b x I w_b (Euler's equations)
    w_b = 3.0 * axis
    np.testing.assert_allclose(M, np.tile(np.cross(w_b, np.diag([It, It, Ia]) @ w_b), (6, 1)), atol=1e-12)

"""Rollouts and labels: closed-form static torque, lever-arm ordering, flags, MJX against native."""

import mujoco
import numpy as np
import pytest
from conftest import MJX_SLIP_ATOL, MJX_TORQUE_RTOL

import itup_jax as itup
from itup_jax.grasp import make_grasps
from itup_jax.sim.arm import plan, reachable
from itup_jax.sim.labels import LABEL_FIELDS
from itup_jax.sim.physics import Randomization, sample_physics
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import build_scene

# Static holding torque: the settled arm still creeps (servo residuals, pad creep): 1 %.
STATIC_RTOL = 0.01

# Closure axis along the tool's y, approach along +x (palm above the handle when it strikes).
R_FROM_ABOVE = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])


@pytest.fixture(scope="module")
def hammer(tasks):
    tool, task = tasks["hammer"]
    return tool, task, build_scene(tool, task)


@pytest.fixture(scope="module")
def hammer_native(hammer):
    tool, task, scene = hammer
    g = itup.sample_grasps(tool, 24, seed=0)
    return g, simulate(tool, task, g, scene=scene, randomize=None, backend="native")


def test_labels_have_the_documented_schema(hammer, hammer_native):
    g, res = hammer_native
    for f in LABEL_FIELDS:
        assert getattr(res.labels, f).shape == (len(g),), f
    L = res.labels
    np.testing.assert_array_equal(L.valid, ~(L.diverged | L.infeasible))
    assert L.valid.sum() >= 4 and L.infeasible.sum() >= 1  # from-below grasps cannot be reached
    # the kinematic check alone (no scene, no physics) flags exactly the rollouts that were not stepped
    np.testing.assert_array_equal(reachable(hammer[1], g), ~L.infeasible)
    for f in ("peak_torque", "slip_translation", "alignment_drift"):
        assert np.all(np.isfinite(getattr(L, f)[L.valid]))


def test_the_grasp_frame_components_recompose_the_induced_peak(hammer_native, rng):
    """At the step of its peak norm, the induced torque's three grasp-frame components recompose the
    full induced peak; a torque purely about the jaw's closure axis has no projected part and a full
    closure component."""
    from itup_jax.sim.labels import induced_components_at_peak

    _, res = hammer_native
    L = res.labels
    v = L.valid
    norm = np.sqrt(L.peak_induced_third**2 + L.peak_induced_closure**2 + L.peak_induced_approach**2)
    np.testing.assert_allclose(norm[v], L.peak_torque_induced[v], rtol=1e-12)
    assert np.all(L.peak_induced_closure[v] <= L.peak_torque_closure[v] + 1e-12)  # a peak over time bounds it
    d_tau = rng.normal(size=(5, 40, 3))
    comps = induced_components_at_peak(d_tau)
    k = np.argmax(np.linalg.norm(d_tau, axis=-1), axis=1)
    for i, name in enumerate(("third", "closure", "approach")):
        np.testing.assert_array_equal(comps[f"peak_induced_{name}"], np.abs(d_tau[np.arange(5), k, i]))
    pure = np.zeros((1, 40, 3))
    pure[0, :, 1] = np.sin(np.linspace(0, 3, 40))  # about the closure axis only
    comps = induced_components_at_peak(pure)
    assert comps["peak_induced_closure"][0] == pytest.approx(np.abs(pure[0, :, 1]).max())
    assert comps["peak_induced_third"][0] == 0 and comps["peak_induced_approach"][0] == 0
    assert np.hypot(pure[..., 0], pure[..., 2]).max() == 0  # the projected torque (C_tau's) sees none of it


def test_induced_is_the_motion_minus_the_settles_last_window(hammer, hammer_native):
    """`induced` on a synthetic trace: the static value is the mean over the settle's last
    `static_window` s only (earlier settle steps do not count), and the motion's part is the trace minus
    it. On a real rollout its (x, z) norm peaks at the label `peak_torque_projected`."""
    from itup_jax.sim.config import SimConfig
    from itup_jax.sim.labels import induced
    tool, task, scene = hammer
    g, res = hammer_native
    p = res.plan
    n_static = int(round(SimConfig().static_window / scene.model.opt.timestep))
    x = np.zeros((2, p.nstep, 3))
    x[:, :p.n_settle - n_static] = 100.0  # the settle's early transient: outside the window
    x[:, p.n_settle - n_static:p.n_settle] = [1.0, -2.0, 0.5]
    x[1, p.n_settle - 1, 0] += 3.0 * n_static  # one step of the window raises row 1's mean by 3 in x
    ramp = np.linspace(0.0, 1.0, p.nstep - p.n_settle)[:, None] * np.array([0.0, 0.0, 4.0])
    x[:, p.n_settle:] = ramp + [1.0, -2.0, 0.5]
    d, static = induced(scene, p, x)
    np.testing.assert_allclose(static, [[1.0, -2.0, 0.5], [4.0, -2.0, 0.5]], atol=1e-12)
    np.testing.assert_allclose(d[0], ramp, atol=1e-12)
    np.testing.assert_allclose(d[1], ramp + [-3.0, 0.0, 0.0], atol=1e-12)
    tr = simulate(tool, task, g[:2], scene=scene, randomize=None, backend="native", traces=True)
    d_tau, _ = induced(scene, tr.plan, tr.traces["gripper/wrist_torque"])
    np.testing.assert_allclose(np.hypot(d_tau[..., 0], d_tau[..., 2]).max(1), tr.labels.peak_torque_projected[:2],
                               rtol=1e-12)


def test_reachability_in_order_checks_chunks_lazily_in_the_given_order(hammer, hammer_native, monkeypatch):
    """The walk yields (index, reachable) in the given order, equal to `reachable`, and checks no chunk
    beyond the one the caller stops in; a bad chunk size is refused at the call."""
    import importlib

    sim = importlib.import_module("itup_jax.sim.arm")
    task, g = hammer[1], hammer_native[0]
    order = np.arange(len(g))[::-1]
    walked = list(sim.reachability_in_order(task, g, order, chunk=5))
    assert [i for i, _ in walked] == order.tolist()
    np.testing.assert_array_equal([ok for _, ok in walked], reachable(task, g[order]))
    calls = []
    monkeypatch.setattr(sim, "reachable", lambda t, gs: calls.append(len(gs)) or np.ones(len(gs), bool))
    walk = sim.reachability_in_order(task, g, order, chunk=5)
    assert next(walk) == (int(order[0]), True) and calls == [5]
    with pytest.raises(sim.InputError, match="chunk must be an integer >= 1"):
        sim.reachability_in_order(task, g, order, chunk=0)


def test_static_wrist_torque_equals_m_g_times_the_lever_arm(hammer):
    """After settling, the sensor holds the gripper and tool: tau = -sum (c_i - p_site) x m_i g."""
    tool, task, scene = hammer
    m = scene.model
    g = make_grasps([[0.0, 0.0, 0.15]], R_FROM_ABOVE[None], [0.029])
    p = plan(scene, task, g, sample_physics(tool, 1, spread=None))
    assert not p.infeasible[0]
    d = mujoco.MjData(m)
    d.qpos[:] = p.qpos0[0]
    for k in range(p.n_settle):
        d.ctrl[:] = p.ctrl[0, k]
        mujoco.mj_step(m, d)
    adr = scene.sensors["gripper/wrist_torque"][0]
    tau = d.sensordata[adr:adr + 3]
    ps, Rs = d.site_xpos[scene.ft_site], d.site_xmat[scene.ft_site].reshape(3, 3)
    held = [m.body(n).id for n in ("gripper/gripper_base", "gripper/finger_neg", "gripper/finger_pos", "tool")]
    closed = -sum(np.cross(d.xipos[b] - ps, m.body_mass[b] * m.opt.gravity) for b in held)
    np.testing.assert_allclose(tau, Rs.T @ closed, rtol=STATIC_RTOL, atol=STATIC_RTOL * np.linalg.norm(closed))


# Closure axis along the hammer's face normal (tool x), approach from the side (tool y).
R_FROM_SIDE = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


def test_both_pads_touch_the_tool_at_the_grip_force(hammer):
    """At the end of the settle phase both pads are in contact and share the commanded squeeze."""
    tool, task, scene = hammer
    g = make_grasps([[0.0, 0.0, 0.15]], R_FROM_SIDE[None], [0.029])
    res = simulate(tool, task, g, scene=scene, randomize=None, traces=True)
    k = res.plan.n_settle - 1
    grip = res.physics.grip_force[0]
    for side in ("neg", "pos"):
        found, normal = res.traces[f"pad_{side}_contact"][0, k, :2]
        assert found >= 1
        assert 0.25 * grip <= abs(normal) <= 1.05 * grip  # the strongest of the pad's contacts
    assert res.labels.peak_pad_force[0] > 0


def test_grasp_near_the_head_feels_less_torque_than_at_the_handle_end(hammer):
    """The torque the strike adds at the wrist (projected, as the labels and C_tau take it) grows as the
    grasp moves from the head towards the handle's end, as the lever arm to the contact does; so does
    the static holding torque (m g times its lever arm).

    Measured here with the closure axis along the face normal. Far less than the lever arms predict
    (4.35 against 5.44 N m, where the rigid-body cost grows 3.3x; the projected peak rises from the head
    to mid-handle, then stays): the grip is compliant and the arm's servos, not the nail, stop the
    hammer. The raw peak, the sum of the static and the strike's torque vectors, follows no order
    (4.07-4.99 N m over seven grasps along the handle).
    """
    tool, task, scene = hammer
    g = make_grasps([[0.0, 0.0, 0.22], [0.0, 0.0, 0.06]], np.stack([R_FROM_SIDE] * 2), [0.029] * 2)
    L = simulate(tool, task, g, scene=scene, randomize=None).labels
    assert L.valid.all() and L.success.all()  # both drive the nail
    assert L.peak_torque_projected[0] < L.peak_torque_projected[1]
    assert L.peak_torque_induced[0] < L.peak_torque_induced[1]
    assert L.static_torque[0] < L.static_torque[1]
    analytic = itup.wrench_costs(tool, task, g, itup.CostParams(torque_projection="full"))
    assert float(analytic.tau[0]) < float(analytic.tau[1])  # the lever arms predict this order


def test_absurd_speed_is_flagged_not_labelled(hammer, tools):
    tool, _, _ = hammer
    with pytest.warns(UserWarning):
        fast = itup.make_task("hammer", tool, impact_speed=25.0)
    g = itup.sample_grasps(tool, 8, seed=0)
    L = simulate(tool, fast, g, randomize=None).labels
    assert np.all(L.infeasible | L.diverged | L.failed | L.over_speed)
    assert np.any(L.over_speed | L.infeasible)


def test_unreachable_grasps_are_flagged_infeasible(hammer):
    tool, _, _ = hammer
    far = itup.make_task("hammer", tool, target=(1.6, 0.0, 0.06))
    L = simulate(tool, far, itup.sample_grasps(tool, 4, seed=0), randomize=None).labels
    assert L.infeasible.all() and not L.valid.any()


def test_infeasible_rollouts_are_not_stepped_and_measure_nothing(hammer, hammer_native):
    """In a mixed batch the unreachable rows carry NaN measurements, no failure or success, and the
    reachable rows are labelled exactly as when they are rolled out alone."""
    (tool, task, scene), (g, res) = hammer, hammer_native
    L, bad = res.labels, res.labels.infeasible
    assert bad.any() and (~bad).any()
    for f in ("peak_torque", "peak_torque_projected", "static_torque", "slip_translation", "alignment_drift",
              "task_metric"):
        assert np.isnan(getattr(L, f)[bad]).all() and np.isfinite(getattr(L, f)[~bad & L.valid]).all(), f
    assert not (L.failed | L.success | L.diverged)[bad].any()
    alone = simulate(tool, task, g[np.nonzero(~bad)[0]], randomize=None, scene=scene).labels
    np.testing.assert_array_equal(alone.peak_torque_projected, L.peak_torque_projected[~bad])


def test_same_seed_same_labels_and_randomisation_within_its_spread(hammer):
    tool, task, scene = hammer
    g = itup.sample_grasps(tool, 6, seed=2)
    a = simulate(tool, task, g, scene=scene, seed=3)
    b = simulate(tool, task, g, scene=scene, seed=3)
    for f in LABEL_FIELDS:
        np.testing.assert_array_equal(getattr(a.labels, f), getattr(b.labels, f))
    ph = sample_physics(tool, 500, seed=1, spread=Randomization(mass=0.1, mu=0.2))
    assert np.all(np.abs(ph.mass_scale - 1) <= 0.1) and ph.mass_scale.std() > 0.03
    assert np.all(np.abs(ph.mu / float(tool.params.mu) - 1) <= 0.2 + 1e-12)
    assert np.all((ph.grip_force >= 20) & (ph.grip_force <= 235))


def test_bad_backend_is_refused(hammer):
    tool, task, scene = hammer
    with pytest.raises(itup.InputError, match="backend"):
        simulate(tool, task, itup.sample_grasps(tool, 2, seed=0), scene=scene, backend="warp")
    with pytest.raises(itup.InputError, match="sample_physics: seed must be an integer >= 0, got -3"):
        simulate(tool, task, itup.sample_grasps(tool, 2, seed=0), scene=scene, seed=-3)
    for bad in (0.0, -0.001, 0.02, float("nan")):
        with pytest.raises(itup.InputError, match=r"build_scene: timestep must be in \(0, 0.01\] s"):
            itup.build_scene(tool, task, timestep=bad)


#: Three reach grasps of the L-stick (sample_grasps(l_stick, 64, seed=0), reachable rows 9, 1 and 13), held
#: 2-4 degrees off the pads' faces. MJX's own capsule-box collider reversed a pad's contact in the first
#: step of the first and third and dropped the stick (slip 0.23 m against native MuJoCo's 1.5 and 3.8 mm);
#: itup_jax/mjx_collision.py is why they agree now.
REACH_TILTED = (
    [[0.0007158222724683583, -0.0008330001728609204, 0.04753459617495537],
     [-0.0001558296353323385, -3.429329808568582e-05, 0.007331945467740297],
     [-0.0019509142730385065, 0.0010989232687279582, 0.09583447128534317]],
    [[-0.16466420888900757, 0.8601902723312378, -0.3859003782272339, -0.28989532589912415],
     [0.44510823488235474, -0.0971299260854721, 0.8868652582168579, 0.07690591365098953],
     [0.8728543519973755, 0.19774654507637024, 0.40699470043182373, -0.18269357085227966]],
    [0.011809447780251503, 0.011996095068752766, 0.011345715261995792],
)


@pytest.mark.slow
def test_mjx_holds_a_long_handle_as_native_mujoco_does(tasks):
    """One more small MJX compile (the reach scene, 2 ms, 3 rollouts padded to 4): the rollout path traces
    MJX with the fixed capsule-box collider, and the tool stays in the pads as in native MuJoCo."""
    from itup_jax.grasp import Grasps

    tool, task = tasks["reach"]
    scene = build_scene(tool, task, timestep=0.002)  # the collider does not depend on the step: 4x fewer steps
    g = Grasps(p_tool_grasp=np.array(REACH_TILTED[0]), q_tool_grasp=np.array(REACH_TILTED[1]),
               width=np.array(REACH_TILTED[2]))
    native = simulate(tool, task, g, scene=scene, randomize=None, backend="native").labels
    mjx = simulate(tool, task, g, scene=scene, randomize=None, backend="mjx").labels
    assert native.valid.all() and mjx.valid.all()
    np.testing.assert_array_equal(mjx.failed, native.failed)
    np.testing.assert_allclose(mjx.slip_translation, native.slip_translation, atol=MJX_SLIP_ATOL)
    np.testing.assert_allclose(mjx.peak_torque, native.peak_torque, rtol=MJX_TORQUE_RTOL)


def test_reachable_in_chunks_equals_one_call_on_the_whole_batch(hammer):
    """`reachable` checks REACHABLE_CHUNK candidates at a time; the answer is the one-call answer of
    `arm_trajectory` on the whole batch, over a batch of several chunks and a partial last one."""
    import sys

    sim = sys.modules["itup_jax.sim.arm"]
    tool, task, _ = hammer
    g = itup.sample_grasps(tool, 2 * sim.REACHABLE_CHUNK + 37, seed=3)
    ok = reachable(task, g)
    np.testing.assert_array_equal(ok, ~sim.arm_trajectory(task, g)[1])
    assert 0 < ok.sum() < len(g)  # both answers occur


def test_host_quaternion_matrix_equals_the_jax_one(rng):
    """The planner's float64 host conversion is the grasp module's rotation (x64 in the tests)."""
    import sys

    from itup_jax.rotations import quat_to_matrix

    q = rng.normal(size=(40, 4))
    R = sys.modules["itup_jax.rotations"].quat_to_matrix_np(q)
    np.testing.assert_allclose(R, np.asarray(quat_to_matrix(q)), atol=1e-14)
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-14)


def test_mjx_path_labels_infeasible_rows_like_the_native_path(hammer, hammer_native, monkeypatch):
    """The MJX branch steps and labels only the feasible rows, as the native path does: with its stepping
    replaced by native MuJoCo (no MJX compile here), its labels equal the native path's, NaN included."""
    from itup_jax.sim import native, rollout
    from itup_jax.sim import physics as physics_mod

    (tool, task, scene), (g, res) = hammer, hammer_native

    def stepped_natively(scene, p, physics, devices=None, float64=None):
        assert not p.infeasible.any() and len(p.qpos0) == len(physics.mu)  # unreachable rows are not stepped
        models = [physics_mod.randomized_model(scene, physics, i) for i in range(len(p.qpos0))]
        qv, sd = native.step_native(scene, p.qpos0, p.ctrl, p.nstep, models, 2)
        return np.repeat(qv[:, None], p.nstep, axis=1), sd  # MJX reports the peak per step

    monkeypatch.setattr(rollout, "rollout_mjx", stepped_natively)
    out = simulate(tool, task, g, scene=scene, randomize=None, backend="mjx", traces=True)
    assert out.labels.infeasible.any()
    for f in LABEL_FIELDS:
        np.testing.assert_array_equal(getattr(out.labels, f), getattr(res.labels, f), err_msg=f)
    assert np.isnan(out.traces["gripper/wrist_torque"][out.labels.infeasible]).all()


def _axis_angle_matrix(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


def test_slip_is_measured_at_the_grasp_centre_in_closed_form(rng):
    """`grasp_point_slip`: a tool turning about the grasp centre slides 0 there however far its frame's
    origin swings; turning by theta about a pivot at distance r (perpendicular to the axis) slides
    2 r sin(theta / 2); a translation d slides |d|."""
    from itup_jax.rotations import matrix_to_quat_np
    from itup_jax.sim.labels import grasp_point_slip

    p0, R0 = np.array([0.02, -0.01, -0.25]), _axis_angle_matrix(rng.normal(size=3), 0.7)  # tool origin 25 cm off
    axis, angles = np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.05, 0.2, 0.4])
    pivot = np.array([0.03, 0.5, 0.04])  # in the grasp frame; r = 5 cm from the axis through it
    d = np.array([0.004, -0.003, 0.012])

    def traces(pivot, shift):
        Rs = [_axis_angle_matrix(axis, a) for a in angles]
        pos = np.stack([pivot + R @ (p0 - pivot) + s * shift for R, s in zip(Rs, angles / angles[-1])])
        quat = np.stack([matrix_to_quat_np(R @ R0) for R in Rs])
        return pos[None], quat[None]

    pos, quat = traces(np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(grasp_point_slip(pos, quat, 0), 0.0, atol=1e-12)
    assert np.linalg.norm(pos[0, -1] - pos[0, 0]) > 0.09  # the origin swung 10 cm
    pos, quat = traces(pivot, np.zeros(3))
    np.testing.assert_allclose(grasp_point_slip(pos, quat, 0)[0], 2 * 0.05 * np.sin(angles / 2), rtol=1e-9)
    # measured from a later step: the distance from where the point was then
    np.testing.assert_allclose(grasp_point_slip(pos, quat, 1)[0, -1], 2 * 0.05 * np.sin((angles[-1] - angles[1]) / 2), rtol=1e-9)
    quat = np.broadcast_to(matrix_to_quat_np(R0), (1, 4, 4))
    pos = (p0 + np.outer(angles / angles[-1], d))[None]
    np.testing.assert_allclose(grasp_point_slip(pos, quat, 0)[0], angles / angles[-1] * np.linalg.norm(d), rtol=1e-12)


def test_slip_labels_do_not_depend_on_where_the_tools_mesh_has_its_origin(tasks):
    """The same rollouts with the L-stick's mesh frame moved 20 cm along its shaft: the physics is the
    same (up to rounding in the contacts), so slip and rotation in the pads must be too. The tool turns
    up to ~20 degrees in the pads here, so the frame origin's displacement (the label before code 0.5.0)
    differed by tens of millimetres between the two frames."""
    import dataclasses

    from transforms import move_tool_frame

    from itup_jax.tools import Box

    tool, task = tasks["reach"]
    shift = np.array([0.0, 0.0, -0.2])
    # point-contact grasps: they turn in the pads (flat-pad ones hardly do), which is what this test needs
    g = itup.sample_grasps(tool, 8, seed=0, config=itup.SamplerConfig(contact="point"))
    params, task2, g2 = move_tool_frame(tool.params, task, g, np.eye(3), shift)
    mesh = tool.mesh.copy()
    mesh.apply_translation(shift)
    tool2 = dataclasses.replace(
        tool, mesh=mesh, params=params, contact_point=tool.contact_point + shift,
        contact_points=tool.contact_points + shift, grasp_region=Box(tool.grasp_region.lo + shift, tool.grasp_region.hi + shift),
        # ("capsule", p0, p1, radius) and ("box", lo, hi): two points each
        primitives=tuple((kind, np.asarray(x0) + shift, np.asarray(x1) + shift, *rest) for kind, x0, x1, *rest in tool.primitives))
    a = simulate(tool, task, g, randomize=None, backend="native").labels
    b = simulate(tool2, task2, g2, randomize=None, backend="native").labels
    np.testing.assert_array_equal(a.valid, b.valid)
    assert a.valid.sum() >= 3
    v = a.valid
    assert a.slip_rotation[v].max() > 0.15  # turns enough that a 20 cm lever would move the origin 3 cm
    np.testing.assert_allclose(b.slip_translation[v], a.slip_translation[v], atol=3e-4)
    # contacts round differently in the other frame, and over the 0.5 ms step's 4x more steps (code 0.8.0)
    # a 17-degree turn in the pads ends up to ~4 % apart; torques agree to a few per cent likewise
    np.testing.assert_allclose(b.slip_rotation[v], a.slip_rotation[v], atol=0.01, rtol=0.05)
    np.testing.assert_array_equal(b.failed[v], a.failed[v])
    np.testing.assert_allclose(b.peak_torque_projected[v], a.peak_torque_projected[v], rtol=0.05)


def test_implausible_slip_rule():
    from itup_jax.sim.labels import implausible_slip

    dt = 5e-4
    steady = np.linspace(0.0, 0.004, 50)[None]  # 4 mm over 25 ms: a real slip
    dropped = np.linspace(0.0, 0.9, 400)[None]  # a tool falling out of the hand: 0.9 m in 0.2 s
    reset = np.concatenate([np.zeros(20), np.full(30, 0.4)])[None]  # a 0.4 m jump in one step
    runaway = np.linspace(0.0, 60.0, 2000)[None]  # 60 m at 60 m/s: no jump, but no scene is that big
    flags = [bool(implausible_slip(p, dt)[0]) for p in (steady, dropped, reset, runaway)]
    assert flags == [False, False, True, True]
    assert implausible_slip(np.array([[0.0, np.nan]]), dt)[0]


def test_blown_up_rollout_is_not_a_label(tools):
    """A rollout whose tool flies off by metres without a non-finite value or a fast joint (a nearly
    massless tool) is diverged and invalid, never an ordinary measurement; the scene keeps MuJoCo from
    resetting an unstable state silently."""
    import copy

    from itup_jax.grasp_sampler import sample_reachable
    from itup_jax.sim.labels import compute_labels
    from itup_jax.sim.native import rollout_native
    from itup_jax.task import make_task

    tool = tools["hammer"]
    task = make_task("hammer", tool)
    scene = build_scene(tool, task)
    assert scene.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_AUTORESET
    g = sample_reachable(tool, task, 1, 0).grasps
    physics = sample_physics(tool, 1, spread=None)
    p = plan(scene, task, g, physics)
    m = copy.copy(scene.model)
    m.body_mass[m.body("tool").id] *= 1e-9
    qvel_peak, sensordata = rollout_native(scene, p, physics, models=[m])
    labels = compute_labels(scene, task, p, qvel_peak, sensordata)
    assert labels.diverged[0] and not labels.valid[0]
    ordinary = compute_labels(scene, task, p, *rollout_native(scene, p, physics))
    assert ordinary.valid[0] and not ordinary.diverged[0]

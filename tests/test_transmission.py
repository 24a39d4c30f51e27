"""The arm in the physics: the blow's transmission (closed forms and limits) and the arm's operational-space
inertia against MuJoCo's own forward dynamics."""

import copy
import dataclasses

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from conftest import load_experiment, run_experiment

from itup_jax.errors import InputError
from itup_jax.grasp_sampler import sample_reachable
from itup_jax.sim.arm import arm_trajectory
from itup_jax.sim.arm_inertia import arm_impedance, spatial_inertia, task_blows
from itup_jax.sim.scene import build_scene, target_bodies
from itup_jax.task import make_task
from itup_jax.trajectory import Trajectory
from itup_jax.transmission import Blow, batched_wrist_response, impulse_share, wrist_response

ROD_MASS, ROD_LENGTH = 0.6, 0.4


def rod_about_end(mass=ROD_MASS, length=ROD_LENGTH) -> np.ndarray:
    """A uniform thin rod along +z from the site: com at length/2, I_com = m L^2 / 12 across it."""
    i = mass * length**2 / 12.0
    return spatial_inertia(mass, [0.0, 0.0, length / 2], np.diag([i, i, 1e-6]))


def unit_wrench(z, n=(1.0, 0.0, 0.0)) -> np.ndarray:
    c, n = np.array([0.0, 0.0, z]), np.asarray(n, float)
    return np.concatenate([n, np.cross(c, n)])


def blow(tool, wrench, *, arm, impulse=0.5, duration=0.003, stiffness=None, damping=None, hand=None, grip_force=np.inf):
    z = np.zeros((6, 6))
    return Blow(tool=jnp.asarray(tool), wrench=jnp.asarray(wrench), impulse=jnp.asarray(impulse), duration=jnp.asarray(duration),
                arm_inertia=jnp.asarray(arm), arm_stiffness=jnp.asarray(z if stiffness is None else stiffness),
                arm_damping=jnp.asarray(z if damping is None else damping), hand=jnp.asarray(z if hand is None else hand),
                grasp_axes=jnp.eye(3), grasp_offset=jnp.array([0.0, 0.0, 0.085]), mu=jnp.asarray(0.5),
                width=jnp.asarray(0.03), grip_force=jnp.asarray(grip_force))


def test_heavy_arm_and_stiff_pads_carry_the_contact_wrench():
    """The rigid limit: the sensor reads the contact's wrench, pi/2 J / T_c times the lever arm at the peak."""
    z, J, T = 0.35, 0.5, 0.003
    b = blow(rod_about_end(), unit_wrench(z), arm=1e7 * np.eye(6), impulse=J, duration=T)
    peak, trace = wrist_response(b, pads="rigid", step=1e-6, horizon=0.006, pad_timeconst=5e-5)
    assert float(peak) == pytest.approx(np.pi / 2 * J / T * z, rel=0.02)
    # the impulse the sensor reads over the blow is the contact's: J along n, J z about y
    total = np.asarray(trace).sum(0) * 1e-6
    np.testing.assert_allclose(total, unit_wrench(z) * J, atol=0.01 * J)


def test_share_limits():
    tool = rod_about_end()
    np.testing.assert_allclose(impulse_share(jnp.asarray(tool), jnp.zeros((6, 6)), 1e9 * jnp.eye(6)), np.eye(6), atol=1e-6)
    np.testing.assert_allclose(impulse_share(jnp.asarray(tool), jnp.zeros((6, 6)), 1e-12 * jnp.eye(6)), 0.0, atol=1e-5)


def test_centre_of_percussion():
    """A rod on a pin that resists translation only: struck at 2L/3 from the pin the pin feels no force;
    struck at the end it feels half the blow."""
    pin = np.diag([1e8, 1e8, 1e8, 1e-9, 1e-9, 1e-9])
    share = np.asarray(impulse_share(jnp.asarray(rod_about_end()), jnp.zeros((6, 6)), jnp.asarray(pin)))
    at_cop = share @ unit_wrench(2 * ROD_LENGTH / 3)
    at_end = share @ unit_wrench(ROD_LENGTH)
    assert np.linalg.norm(at_cop[:3]) < 1e-6
    assert np.linalg.norm(at_end[:3]) == pytest.approx(0.5, rel=1e-6)


def test_response_settles_to_the_share():
    """With no servo, the arm's momentum once the pads have settled is the share of the blow."""
    arm = spatial_inertia(4.0, [0.0, 0.0, -0.1], np.diag([0.05, 0.05, 0.02]))
    hand = spatial_inertia(0.9, [0.0, 0.0, 0.04], np.diag([1e-3, 1e-3, 5e-4]))
    b = blow(rod_about_end(), unit_wrench(0.3), arm=arm, hand=hand)
    _, trace = wrist_response(b, pads="rigid", step=2e-5, horizon=0.08)
    arm_momentum = np.asarray(trace).sum(0) * 2e-5  # the wrist impulse = the arm's momentum (no servo)
    # W_s = Lambda a_h here (hand's inertia taken out): its integral is Lambda v_h at the end
    expected = np.asarray(impulse_share(jnp.asarray(rod_about_end()), jnp.asarray(hand), jnp.asarray(arm))) @ (unit_wrench(0.3) * 0.5)
    np.testing.assert_allclose(arm_momentum, expected, atol=2e-3 * np.abs(expected).max())


def test_pads_pass_what_they_hold():
    """'torsion': the torque about the closure axis (y), about the grasp centre, clipped at 2 c_t mu f;
    'limit': the wrench scaled onto the grip's limit surface; both leave a wrench the grip holds as is."""
    from itup_jax.grip_demand import grip_demand_sq
    from itup_jax.robot import PAD_TORSION
    from itup_jax.transmission import pads_pass

    b = blow(rod_about_end(), unit_wrench(0.3), arm=np.eye(6), grip_force=100.0)
    W = jnp.array([2.0, -1.0, 3.0, 0.4, 5.0, -0.7])
    cap = 2 * PAD_TORSION * 0.5 * 100.0
    t = np.asarray(pads_pass(W, b, "torsion"))
    tau_g = t[3:] - np.cross([0.0, 0.0, 0.085], t[:3])
    assert tau_g[1] == pytest.approx(cap)
    np.testing.assert_allclose(t[[0, 1, 2, 3, 5]], np.asarray(W)[[0, 1, 2, 3, 5]])
    lim = np.asarray(pads_pass(W, b, "limit"))
    need = grip_demand_sq(lim[:3], lim[3:] - np.cross([0.0, 0.0, 0.085], lim[:3]), 0.5, 0.03)
    assert np.sqrt(need) == pytest.approx(100.0)
    np.testing.assert_allclose(lim / np.asarray(W), (lim / np.asarray(W))[0])  # scaled as a whole
    small = W * 1e-3
    for pads in ("torsion", "limit"):
        np.testing.assert_allclose(pads_pass(small, b, pads), small)
    with pytest.raises(InputError, match="pads"):
        wrist_response(b, pads="soft")


def test_torsion_cap_limits_the_closure_axis_torque_over_a_blow():
    b = blow(rod_about_end(), unit_wrench(0.3), arm=1e7 * np.eye(6), grip_force=100.0)
    _, trace = wrist_response(b, pads="torsion", step=1e-5, horizon=0.01)
    trace = np.asarray(trace)
    about_closure = trace[:, 4] - np.cross([0.0, 0.0, 0.085], trace[:, :3])[:, 1]
    assert np.abs(about_closure).max() <= 0.5 + 0.05  # 2 c_t mu f = 0.5 N m; the hand's inertia adds a little
    assert float(wrist_response(b, pads="rigid", step=1e-5, horizon=0.01)[0]) > 5.0


@pytest.mark.parametrize("pads", ["rigid", "torsion", "limit"])
def test_gradient_matches_finite_differences(pads):
    """d(peak)/d(strike height) against central differences, float64, for each pad model (the strike
    is off the closure axis's plane so that the torsion cap and the limit surface both act)."""
    arm = spatial_inertia(4.0, [0.0, 0.0, -0.1], np.diag([0.05, 0.05, 0.02]))

    def peak(z):
        c = jnp.array([0.0, 0.0, 1.0]) * z
        n = jnp.array([0.8, 0.0, 0.6])
        w = jnp.concatenate([n, jnp.cross(c, n)])
        b = blow(rod_about_end(), np.zeros(6), arm=arm, grip_force=100.0)
        return wrist_response(dataclasses.replace(b, wrench=w), pads=pads, step=1e-4, horizon=0.02)[0]

    z, h = 0.3, 1e-6
    g = float(jax.grad(peak)(z))
    fd = (float(peak(z + h)) - float(peak(z - h))) / (2 * h)
    assert g == pytest.approx(fd, rel=1e-5)


@pytest.fixture(scope="module")
def hammer_scene(tools):
    tool = tools["hammer"]
    task = make_task("hammer", tool)
    return tool, task, build_scene(tool, task)


def test_operational_inertia_matches_mujoco_forward_dynamics(hammer_scene):
    """Lambda^-1 W is the site's acceleration MuJoCo computes for a wrench W applied there (arm alone, at
    rest), by its own factorisation; K_x pulled back through J is the servos' diagonal gain."""
    tool, task, scene = hammer_scene
    q = np.array([0.3, -1.2, 1.5, -1.8, -1.5, 0.4])
    imp = arm_impedance(scene, q)
    m = scene.model
    arm_only = copy.copy(m)  # the gripper and everything on it weightless: the arm alone
    root = m.site_bodyid[scene.ft_site]
    for b in range(m.nbody):
        a = b
        while a > 0 and a != root:
            a = m.body_parentid[a]
        if a == root:
            arm_only.body_mass[b], arm_only.body_inertia[b] = 1e-9, 1e-12
    d = mujoco.MjData(arm_only)
    d.qpos[scene.arm_qpos] = q
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    mujoco.mj_forward(arm_only, d)
    mujoco.mj_jacSite(arm_only, d, jp, jr, scene.ft_site)
    J = np.vstack([jp, jr])
    base = d.qacc.copy()
    for W in (np.array([5.0, 0, 0, 0, 0, 0]), np.array([0, -3.0, 2.0, 0.1, 0, 0.3])):
        d.qfrc_applied[:] = J.T @ W
        mujoco.mj_forward(arm_only, d)
        acc = J[:, scene.arm_dof] @ (d.qacc - base)[scene.arm_dof]
        np.testing.assert_allclose(acc, np.linalg.solve(imp.inertia, W), rtol=1e-6, atol=1e-9)
    Ja = J[:, scene.arm_dof]
    np.testing.assert_allclose(Ja.T @ imp.stiffness @ Ja, np.diag(m.actuator_gainprm[scene.arm_actuators, 0]), atol=1e-6)
    assert np.all(np.linalg.eigvalsh(imp.inertia) > 0)
    gripper_root = m.site_bodyid[scene.ft_site]
    assert imp.hand[0, 0] == pytest.approx(m.body_subtreemass[gripper_root])


def test_task_blows(hammer_scene):
    tool, task, scene = hammer_scene
    g = sample_reachable(tool, task, 6, 0).grasps
    q_traj, infeasible = arm_trajectory(task, g)
    assert not infeasible.any()
    blows, k, arm = task_blows(scene, task, g, q_traj, grip_force=100.0)
    assert np.asarray(task.impact)[k].max() > 0
    assert blows.tool.shape == (6, 6, 6) and blows.wrench.shape == (6, 6) and arm.inertia.shape == (6, 6, 6)
    np.testing.assert_allclose(blows.grasp_axes @ blows.grasp_axes.transpose(0, 2, 1), np.broadcast_to(np.eye(3), (6, 3, 3)), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(blows.grasp_offset, axis=1), 0.085, atol=2e-3)  # the grasp site, 85 mm out
    peaks = np.asarray(jax.jit(batched_wrist_response, static_argnames="pads")(blows, pads="limit"))
    assert peaks.shape == (6,) and np.all(np.isfinite(peaks)) and np.all(peaks > 0)
    sweep = make_task("sweep", tool)
    with pytest.raises(InputError, match="no impact"):
        task_blows(scene, sweep, g, q_traj, grip_force=100.0)
    with pytest.raises(InputError, match="no IK solution"):
        task_blows(scene, task, g, np.full_like(q_traj, np.nan), grip_force=100.0)
    with pytest.raises(InputError, match="arm_impedance: q"):
        arm_impedance(scene, np.zeros(5))


@pytest.mark.slow
def test_arm_transmission_quick(tmp_path):
    import json

    run_experiment("arm_transmission", "--quick", "--out", str(tmp_path))
    out = json.loads((tmp_path / "arm_transmission.json").read_text())
    sets = out["tasks"]["hammer"]
    assert set(sets) == {"built-in family", "other families"}
    for s in sets.values():
        row = s["tools"][0]
        assert row["valid"] >= 8 and set(row["rho"]) == set(out["methods"])
        assert all(-1.0 <= v <= 1.0 for v in row["rho"].values())
        assert 0.0 < row["ceiling"] <= 1.0
        ph = row["phases"]
        assert 0 < ph["hit"] <= ph["valid"] == row["valid"]
        assert sum(ph["share"].values()) == pytest.approx(1.0)  # every peak lies in exactly one phase
        lo, mid, hi = ph["delay_ms"]
        assert lo <= mid <= hi and ph["lag_pads_mm"][0] <= ph["lag_pads_mm"][2]
    assert s["phases"]["hit_share"] <= 1.0


def test_phase_peaks_place_the_peak_the_delay_and_the_lag():
    """A synthetic rollout: the tool moves along world x at 1 m/s, the target starts to move 0.20 s into
    the motion, 0.05 s after the trajectory's impact; the wrist torque peaks 10 ms after that (the push),
    with a smaller bump in the blow's window; the gripper trails its plan by 2 mm and the tool sits 3 mm
    further back in the grasp than planned."""
    from types import SimpleNamespace

    mod = load_experiment("arm_transmission")
    dt, n_settle, n_motion = 0.001, 100, 400
    nstep = n_settle + n_motion
    sim_t = (np.arange(nstep) + 1 - n_settle) * dt
    t_m = sim_t[n_settle:]
    onset_k = n_settle + int(np.argmin(np.abs(t_m - 0.200)))
    tau = np.zeros((1, nstep, 3))
    tau[0, onset_k + 1, 0] = 2.0   # in the blow
    tau[0, onset_k + 10, 2] = 5.0  # the push, the peak
    target = np.zeros((1, nstep, 3))
    target[0, onset_k:, 0] = 1e-3
    gripper_x = sim_t - 0.002
    tool_pos = np.zeros((1, nstep, 3))
    tool_pos[0, :, 0] = gripper_x - 0.003
    pos_g = np.zeros((1, nstep, 3))
    pos_g[0, :, 0] = -0.003
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (1, nstep, 1))
    traces = {"gripper/wrist_torque": tau, f"target/{target_bodies('hammer')[0]}_pos": target, "tool_pos": tool_pos,
              "tool_quat": quat, "tool_pos_grasp": pos_g, "tool_quat_grasp": quat}
    res = SimpleNamespace(plan=SimpleNamespace(n_settle=n_settle, nstep=nstep, sim_t=sim_t), traces=traces)
    scene = SimpleNamespace(model=SimpleNamespace(opt=SimpleNamespace(timestep=dt)))
    t_traj = np.linspace(0.0, 0.4, 9)  # the impact at 0.15 s
    p_traj = np.stack([t_traj, np.zeros(9), np.zeros(9)], 1)
    impact = (np.abs(t_traj - 0.15) < 1e-9).astype(float)[:, None]
    still = np.zeros((9, 3))
    traj = Trajectory(t=t_traj, p_world_tool=p_traj, R_world_tool=np.tile(np.eye(3), (9, 1, 1)),
                      v_world=np.tile([1.0, 0.0, 0.0], (9, 1)), w_world=still, a_world=still, alpha_world=still)
    task = SimpleNamespace(kind="hammer", impact=impact, traj=traj)
    tool = SimpleNamespace(contact_points=np.array([[0.0, 0.0, 0.3]]))
    grasps = SimpleNamespace(p_tool_grasp=np.zeros((1, 3)), q_tool_grasp=np.array([[1.0, 0.0, 0.0, 0.0]]))
    ph = mod.phase_peaks(tool, scene, task, grasps, res)
    assert ph["delay"][0] == pytest.approx(0.05, abs=1e-9)
    assert ph["peak_after_onset"][0] == pytest.approx(0.010, abs=1e-9)
    assert ph["push"][0] == pytest.approx(5.0) and ph["blow"][0] == pytest.approx(2.0) and ph["swing"][0] == 0.0
    assert ph["lag_arm"][0] == pytest.approx(0.002, abs=1e-9) and ph["lag_pads"][0] == pytest.approx(0.003, abs=1e-9)
    summary = mod.phase_summary(ph, np.array([5.0]), {m: np.ones(1) for m in mod.PHASE_METHODS})
    assert summary["share"] == {"swing": 0.0, "blow": 0.0, "push": 1.0} and summary["hit"] == 1


def test_arm_transmission_refuses_a_grip_outside_the_gripper_before_any_work(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        run_experiment("arm_transmission", "--grip-force", "300", "--out", str(tmp_path / "out"))
    assert exc.value.code == 2 and "--grip-force must be within the gripper's 20-235 N, got 300" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()

"""UR5e kinematics: DH forward kinematics equals MuJoCo's flange; the closed-form inverse inverts it."""

import mujoco
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import ik
from itup_jax.sim.scene import build_scene

# FK is the same product of transforms in both: float64 rounding only.
FK_ATOL = 1e-12
# IK goes through arccos/arctan2 chains; near wrist singularities (sin q5 ~ 0) rounding grows.
IK_ATOL = 1e-8


@pytest.fixture(scope="module")
def hammer_scene(tasks):
    tool, task = tasks["hammer"]
    return build_scene(tool, task)


def test_dh_forward_kinematics_equals_mujoco(hammer_scene, rng):
    m = hammer_scene.model
    d = mujoco.MjData(m)
    flange = m.site("ur5e/flange").id
    q = rng.uniform(-np.pi, np.pi, (25, 6))
    T = ik.forward_kinematics(q)
    for i in range(len(q)):
        d.qpos[hammer_scene.arm_qpos] = q[i]
        mujoco.mj_kinematics(m, d)
        np.testing.assert_allclose(d.site_xpos[flange], T[i, :3, 3], atol=FK_ATOL)
        np.testing.assert_allclose(d.site_xmat[flange].reshape(3, 3), T[i, :3, :3], atol=FK_ATOL)


def test_inverse_kinematics_recovers_the_pose_and_the_joints(rng):
    q = rng.uniform(-np.pi, np.pi, (500, 6))
    q = q[np.abs(np.sin(q[:, 4])) > 0.05]  # away from the wrist singularity, where q4/q6 are not unique
    T = ik.forward_kinematics(q)
    sols = ik.inverse_kinematics(T)
    ok = np.isfinite(sols).all(-1)
    assert ok.sum(1).min() >= 2
    T_sol = ik.forward_kinematics(np.nan_to_num(sols))
    assert np.abs(T_sol - T[:, None])[ok].max() < IK_ATOL
    dist = np.abs((sols - q[:, None] + np.pi) % (2 * np.pi) - np.pi).max(-1)
    assert np.nanmin(np.where(ok, dist, np.nan), axis=1).max() < IK_ATOL


def test_track_is_continuous_and_stays_above_the_table(tasks):
    tool, task = tasks["sweep"]
    g = itup.sample_grasps(tool, 16, seed=0)
    from itup_jax.sim.arm import plan
    from itup_jax.sim.physics import sample_physics
    p = plan(build_scene(tool, task), task, g, sample_physics(tool, 16, spread=None))
    q = p.q_traj[~p.infeasible]
    assert len(q) > 0
    assert np.abs(np.diff(q, axis=1)).max() < 0.5  # no branch jumps between 16 ms samples
    assert ik.joint_heights(q)[..., 1:].min() >= 0.03


def test_unreachable_pose_has_no_solution():
    T = np.eye(4)
    T[:3, 3] = [2.0, 0.0, 0.3]  # beyond the UR5e's 0.85 m reach
    assert np.isnan(ik.inverse_kinematics(T)).all()


def _track_one_step_at_a_time(T06, q_ref):
    """The nearest-branch rule stepped naively (the reference `ik.track` vectorises): [B, T, 4, 4] -> [B, T, 6]."""
    sols = ik.inverse_kinematics(T06)
    q = np.empty(sols.shape[:-2] + (6,))
    prev = np.broadcast_to(q_ref, sols.shape[:1] + (6,))
    for t in range(sols.shape[1]):
        q[:, t] = ik.nearest_branch(sols[:, t], prev)
        prev = np.where(np.isnan(q[:, t]), prev, q[:, t])
    return q


def test_track_equals_the_step_by_step_rule(rng):
    """Smooth joint paths (one branch throughout), paths through an unreachable stretch (NaN, then the
    nearest branch again) and paths that wrap past +-pi: the vectorised track equals the naive loop."""
    B, T = 60, 40
    qa = rng.uniform(-np.pi, np.pi, (B, 1, 6))
    q = qa + rng.normal(0.0, 0.6, (B, 1, 6)) * np.linspace(0.0, 1.0, T)[None, :, None]
    T06 = ik.forward_kinematics(q)
    T06[:10, 15:25, :3, 3] *= 4.0  # out of reach for a stretch, then back
    T06[10:15, :5, :3, 3] *= 4.0  # unreachable at the start
    home = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
    ref = _track_one_step_at_a_time(T06, home)
    got = ik.track(T06, home)
    # ties between two branches (a straight elbow or wrist) are decided by rounding in either; keep clear of them
    sols = ik.inverse_kinematics(T06)
    clear = (np.nan_to_num(np.abs(np.sin(sols[..., [2, 4]])), nan=1.0) > 1e-3).all(axis=(-1, -2, -3))
    assert clear[:10].sum() >= 5 and clear[10:15].sum() >= 2 and clear.sum() > B // 2
    np.testing.assert_array_equal(np.isnan(got[clear]), np.isnan(ref[clear]))
    np.testing.assert_allclose(got[clear], ref[clear], atol=1e-9, equal_nan=True)
    assert np.isnan(got[:10, 15:25]).all() and np.isfinite(got[:10, 25:]).all()
    # the caller's own solutions give the same path, bit for bit, and are left as they were
    kept = sols.copy()
    np.testing.assert_array_equal(ik.track(T06, home, min_height=0.05, solutions=sols), ik.track(T06, home, min_height=0.05))
    np.testing.assert_array_equal(sols, kept)
    assert np.isnan(ik.track(T06, home, solutions=np.full_like(sols, np.nan))).all()  # they are what it follows


def test_joint_heights_equal_the_dh_chain(rng):
    q = rng.uniform(-np.pi, np.pi, (50, 6))
    T = ik.dh_transform(q[:, 0], 0)
    z = [T[:, 2, 3]]
    for j in range(1, 5):
        T = T @ ik.dh_transform(q[:, j], j)
        z.append(T[:, 2, 3])
    np.testing.assert_allclose(ik.joint_heights(q), np.stack(z, -1), atol=1e-14)

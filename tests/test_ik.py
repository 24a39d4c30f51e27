"""UR5e kinematics: DH forward kinematics equals MuJoCo's flange; the closed-form inverse inverts it."""

import mujoco
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import ik
from itup_jax.scene import build_scene

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
    from itup_jax.simulate import plan, sample_physics
    p = plan(build_scene(tool, task), task, g, sample_physics(tool, 16, spread=None))
    q = p.q_traj[~p.infeasible]
    assert len(q) > 0
    assert np.abs(np.diff(q, axis=1)).max() < 0.5  # no branch jumps between 16 ms samples
    assert ik.joint_heights(q)[..., 1:].min() >= 0.03


def test_unreachable_pose_has_no_solution():
    T = np.eye(4)
    T[:3, 3] = [2.0, 0.0, 0.3]  # beyond the UR5e's 0.85 m reach
    assert np.isnan(ik.inverse_kinematics(T)).all()

"""The grasp frame convention and its adapters (GraspNet, MuJoCo)."""

import jax.numpy as jnp
import jaxlie
import mujoco
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import robot
from itup_jax.grasp import GRASPNET_DEPTH, gripper_boxes, make_grasps
from itup_jax.rotations import quat_to_matrix

# Rotation round trips in float64: a few ulps of the matrix entries.
ROT_ATOL = 1e-12


def _random_rotations(rng, n):
    q = rng.normal(size=(n, 4))
    return np.asarray(quat_to_matrix(jnp.asarray(q / np.linalg.norm(q, axis=1, keepdims=True))))


def test_frame_convention_pads_on_closure_axis_and_right_handed(rng):
    R = _random_rotations(rng, 5)
    p = rng.normal(size=(5, 3)) * 0.05
    g = make_grasps(p, R, np.full(5, 0.03))
    pads = np.asarray(g.pad_centres())
    np.testing.assert_allclose(pads[:, 1] - pads[:, 0], 0.03 * R[:, :, 1], atol=ROT_ATOL)  # y: closure
    np.testing.assert_allclose(pads.mean(axis=1), p, atol=ROT_ATOL)  # origin between the pads
    np.testing.assert_allclose(np.asarray(g.approach_axis), R[:, :, 2], atol=ROT_ATOL)  # z: approach
    np.testing.assert_allclose(np.cross(R[:, :, 1], R[:, :, 2]), R[:, :, 0], atol=ROT_ATOL)  # x = y cross z
    np.testing.assert_allclose(np.asarray(g.rotation), R, atol=ROT_ATOL)


def test_gripper_outline_matches_the_convention():
    boxes = {name: (lo, hi) for name, lo, hi in gripper_boxes(0.04)}
    assert boxes["finger_neg"][1][1] == pytest.approx(-0.02) and boxes["finger_pos"][0][1] == pytest.approx(0.02)
    assert boxes["palm"][1][2] == pytest.approx(-robot.FINGER_LENGTH)  # palm behind the pads along -z
    assert boxes["finger_pos"][1][2] == pytest.approx(robot.PAD_LENGTH / 2)  # fingertips at +z
    assert boxes["finger_pos"][1][0] - boxes["finger_pos"][0][0] == pytest.approx(robot.PAD_WIDTH)


def test_graspnet_adapter_axes_and_round_trip(rng):
    R = _random_rotations(rng, 7)
    g = make_grasps(rng.normal(size=(7, 3)) * 0.05, R, rng.random(7) * 0.08)
    gn = itup.to_graspnet(g)
    np.testing.assert_allclose(gn["rotation_matrix"][:, :, 0], R[:, :, 2], atol=ROT_ATOL)  # graspnet x = approach
    np.testing.assert_allclose(gn["rotation_matrix"][:, :, 1], R[:, :, 1], atol=ROT_ATOL)  # graspnet y = closure
    np.testing.assert_allclose(np.linalg.det(gn["rotation_matrix"]), 1.0, atol=ROT_ATOL)
    assert np.all(gn["depth"] == GRASPNET_DEPTH)
    back = itup.from_graspnet(gn["rotation_matrix"], gn["translation"], gn["width"])
    np.testing.assert_allclose(np.asarray(back.rotation), R, atol=1e-9)
    np.testing.assert_allclose(np.asarray(back.p_tool_grasp), np.asarray(g.p_tool_grasp))


def test_mujoco_site_adapter_matches_mujoco_quaternions(rng):
    R = _random_rotations(rng, 6)
    g = make_grasps(rng.normal(size=(6, 3)), R, np.zeros(6))
    pos, quat = itup.to_mujoco_site(g)
    for i in range(6):
        q = np.zeros(4)
        mujoco.mju_mat2Quat(q, R[i].ravel())
        q = q if q[0] >= 0 else -q
        np.testing.assert_allclose(quat[i], q, atol=1e-9)
        back = np.zeros(9)
        mujoco.mju_quat2Mat(back, quat[i])
        np.testing.assert_allclose(back.reshape(3, 3), R[i], atol=1e-9)
    assert np.all(quat[:, 0] >= 0)
    np.testing.assert_allclose(pos, np.asarray(g.p_tool_grasp))


def test_quaternion_order_is_wxyz_like_jaxlie_and_mujoco():
    R = np.asarray(jaxlie.SO3.from_z_radians(0.7).as_matrix())
    g = make_grasps(np.zeros((1, 3)), R[None], [0.01])
    np.testing.assert_allclose(np.asarray(g.q_tool_grasp[0]), [np.cos(0.35), 0, 0, np.sin(0.35)], atol=1e-12)


@pytest.mark.parametrize("kwargs,match", [
    (dict(p_tool_grasp=[[0.0, np.nan, 0.0]], R_tool_grasp=np.eye(3)[None], width=[0.01]), r"p_tool_grasp.*NaN"),
    (dict(p_tool_grasp=[[0.0, 0.0, 0.0]], R_tool_grasp=np.eye(3)[None], width=[0.2]), r"width.*0.085"),
    (dict(p_tool_grasp=[[0.0, 0.0, 0.0]], R_tool_grasp=2 * np.eye(3)[None], width=[0.01]), r"rotation"),
    (dict(p_tool_grasp=[[0.0, 0.0, 0.0]], q_tool_grasp=[[0.0, 0, 0, 0]], width=[0.01]), r"non-zero quaternion"),
    (dict(p_tool_grasp=[[0.0, 0.0, 0.0]], q_tool_grasp=[[1.0, np.inf, 0, 0]], width=[0.01]), r"q_tool_grasp.*NaN"),
])
def test_bad_grasps_are_refused(kwargs, match):
    with pytest.raises(itup.InputError, match=match):
        make_grasps(**kwargs)

"""Rotations and rigid poses: quaternions (w, x, y, z), rotation matrices and 4 x 4 poses, in one place.

JAX, per example and differentiable (lift with `vmap`; leading axes are handled): `quat_to_matrix`,
`axis_angle_matrix`.

Host side, NumPy in float64, for the simulator's inputs and outputs, where dispatching a JAX op costs
more than the arithmetic: `quat_to_matrix_np`, `matrix_to_quat_np`, `axis_angle_matrix_np`,
`pose_matrix`, `quat_angle`, `quat_z_axis`, `quat_mul`, `quat_rotate`. The ones MuJoCo computes
(`mju_mat2Quat`, `mju_mulQuat`, `mju_rotVecQuat`) are MuJoCo's own, so that a pose written into a
model round-trips exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np


# ---------------------------------------------------------------------------------------------------
# JAX
# ---------------------------------------------------------------------------------------------------
def quat_to_matrix(q_wxyz: jax.Array) -> jax.Array:
    """[..., 4] quaternion (w, x, y, z) -> [..., 3, 3] rotation matrix (normalises the quaternion)."""
    q = q_wxyz / jnp.linalg.norm(q_wxyz, axis=-1, keepdims=True)
    fn = lambda qq: jaxlie.SO3(qq).as_matrix()  # noqa: E731
    for _ in range(q.ndim - 1):
        fn = jax.vmap(fn)
    return fn(q)


def axis_angle_matrix(axis: np.ndarray, angle: jax.Array) -> jax.Array:
    """[3, 3] rotation by `angle` (rad, traced) about the unit `axis` [3]."""
    return jaxlie.SO3.exp(jnp.asarray(axis) * angle).as_matrix()


# ---------------------------------------------------------------------------------------------------
# Host side (NumPy, float64)
# ---------------------------------------------------------------------------------------------------
def quat_to_matrix_np(q: np.ndarray) -> np.ndarray:
    """[..., 4] quaternions (w, x, y, z; normalised here) -> [..., 3, 3], host side in float64
    (`quat_to_matrix` is the jittable one; as a host call its dispatch costs more than this)."""
    w, x, y, z = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(q.shape[:-1] + (3, 3))


def matrix_to_quat_np(R: np.ndarray) -> np.ndarray:
    """[3, 3] rotation matrix -> [4] unit quaternion (w, x, y, z), by MuJoCo's `mju_mat2Quat`."""
    import mujoco  # MuJoCo's own conversion (a pose written into a model); imported when first needed

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).ravel())
    return q


def axis_angle_matrix_np(axis: Sequence[float], angle: float) -> np.ndarray:
    """[3, 3] rotation by `angle` (rad) about `axis` [3] (normalised here), by Rodrigues' formula."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * K @ K


def pose_matrix(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Rotations [..., 3, 3] and positions [..., 3] (m) -> homogeneous poses [..., 4, 4]."""
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R, p, 1.0
    return T


def quat_angle(q: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between unit quaternions [..., 4] (either sign): the measure of `slip_rotation`."""
    return 2.0 * np.arccos(np.clip(np.abs(np.einsum("...i,...i->...", q, q_ref)), 0.0, 1.0))


def quat_z_axis(q: np.ndarray) -> np.ndarray:
    """[..., 4] unit quaternions (w, x, y, z) -> [..., 3] the rotated frame's z axis."""
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """[4] x [4] -> [4] the quaternion product a b (w, x, y, z), by MuJoCo's `mju_mulQuat`."""
    import mujoco

    out = np.empty(4)
    mujoco.mju_mulQuat(out, np.asarray(a, float), np.asarray(b, float))
    return out


def quat_rotate(q_wxyz, v) -> np.ndarray:
    """v [3] rotated by the unit quaternion q (w, x, y, z), by MuJoCo's `mju_rotVecQuat`."""
    import mujoco

    out = np.zeros(3)
    mujoco.mju_rotVecQuat(out, np.asarray(v, float), np.asarray(q_wxyz, float))
    return out

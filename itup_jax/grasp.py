"""Parallel-jaw grasps: the grasp frame convention, the `Grasps` pytree and adapters.

The grasp frame (written down once, here; drawn in `docs/grasp_frame.png`)
--------------------------------------------------------------------------
A grasp is the pose of the *grasp frame* in the tool frame, `T_tool_grasp = (R_tool_grasp,
p_tool_grasp)`, plus the jaw opening `width` (m) at which both pads touch the tool.

* origin: midway between the two pad centres (the point the pads squeeze towards);
* +y, the **jaw-closure axis**: the pads sit at y = -width/2 and y = +width/2 and move along y when
  the gripper closes; the finger normal n_f of the cost model is this axis;
* +z, the **approach axis**: from the palm towards the fingertips; the palm face lies at
  z = -FINGER_LENGTH and the fingertips at z = +PAD_LENGTH/2;
* +x = y x z completes a right-handed frame (the pads' width direction).

Quaternions are (w, x, y, z), MuJoCo's and jaxlie's order.

Adapters
--------
* GraspNet / graspnetAPI: rotation columns are (approach, closure, approach x closure), so
  R_gn = R_tool_grasp @ P with P's columns (z, y, -x) of ours; translation is the same point (between
  the fingers) and graspnet's `depth` is how far the fingertips reach past it: PAD_LENGTH / 2.
* MuJoCo: the gripper model's `grasp` site (simulation issue) uses this very frame, so a grasp is the
  site pose in the tool body's frame: `to_mujoco_site` returns (pos, quat) with quat's w >= 0.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np

from itup_jax import robot
from itup_jax.errors import InputError
from itup_jax.kernel_cache import kept
from itup_jax.rotations import quat_to_matrix
from itup_jax.shapes import to_device

#: Column permutation from our grasp frame to graspnet's: graspnet (x, y, z) = ours (z, y, -x).
GRASPNET_FROM_OURS = np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
#: graspnet's `depth`: how far the fingertips reach past the grasp point along the approach axis, m.
GRASPNET_DEPTH = robot.PAD_LENGTH / 2


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Grasps:
    """A batch of parallel-jaw grasps in the tool frame (all leaves; differentiable).

    Attributes:
      p_tool_grasp: [N, 3] m, grasp-frame origin in the tool frame.
      q_tool_grasp: [N, 4] unit quaternion (w, x, y, z) of R_tool_grasp.
      width: [N] m, jaw opening at contact (0 <= width <= 0.085).

    A single grasp (as seen inside `vmap`) has shapes [3], [4], [].
    """

    p_tool_grasp: jax.Array
    q_tool_grasp: jax.Array
    width: jax.Array

    def __len__(self) -> int:
        return int(np.shape(self.width)[0]) if np.ndim(self.width) else 1

    def __getitem__(self, idx: Any) -> "Grasps":
        return jax.tree_util.tree_map(lambda a: a[idx], self)

    def to_host(self, dtype: Any = None) -> "Grasps":
        """The same grasps as NumPy arrays (of `dtype`, default their own): indexing them with varying
        index arrays compiles nothing, as indexing device arrays does (one gather per shape)."""
        return jax.tree_util.tree_map(lambda a: np.asarray(a, dtype), self)

    @property
    def rotation(self) -> jax.Array:
        """[..., 3, 3] R_tool_grasp."""
        return quat_to_matrix(self.q_tool_grasp)

    @property
    def closure_axis(self) -> jax.Array:
        """[..., 3] jaw-closure axis (grasp +y) in the tool frame: the finger normal n_f."""
        return self.rotation[..., :, 1]

    @property
    def approach_axis(self) -> jax.Array:
        """[..., 3] approach axis (grasp +z) in the tool frame."""
        return self.rotation[..., :, 2]

    def pad_centres(self) -> jax.Array:
        """[..., 2, 3] pad centres in the tool frame: origin -/+ (width / 2) * closure axis."""
        off = 0.5 * self.width[..., None] * self.closure_axis
        return jnp.stack([self.p_tool_grasp - off, self.p_tool_grasp + off], axis=-2)


#: [N, 3, 3] -> [N, 4] (w, x, y, z), the outer call of a host-side helper: one compiled kernel instead of
#: its ~15 ops dispatched one by one (each a compile of its own in a fresh process); the same float32
#: values as op by op (elementwise arithmetic, no reductions).
_matrix_to_wxyz = kept(jax.vmap(lambda m: jaxlie.SO3.from_matrix(m).wxyz), "grasp.matrix_to_wxyz")


def make_grasps(p_tool_grasp: Any, R_tool_grasp: Any = None, width: Any = None, *,
                q_tool_grasp: Any = None) -> Grasps:
    """Validated `Grasps` from positions [N, 3], rotations [N, 3, 3] (or quaternions) and widths [N].

    Raises `InputError` for NaN/inf, a non-rotation, a zero quaternion, or a width outside
    [0, GRIPPER_MAX_OPENING]. Host side: call it before jit, not inside.
    """
    p = np.atleast_2d(np.asarray(p_tool_grasp, dtype=float))
    n = p.shape[0]
    if p.shape != (n, 3):
        raise InputError(f"grasps.p_tool_grasp: expected shape [N, 3], got {np.shape(p_tool_grasp)}")
    if (R_tool_grasp is None) == (q_tool_grasp is None):
        raise InputError("grasps: give exactly one of R_tool_grasp and q_tool_grasp")
    if R_tool_grasp is not None:
        R = np.asarray(R_tool_grasp, dtype=float).reshape(-1, 3, 3)
        _check_finite(R, "grasps.R_tool_grasp")
        err = np.abs(np.einsum("nij,nkj->nik", R, R) - np.eye(3)).max(axis=(1, 2))
        if R.shape[0] != n or np.any(err > 1e-5) or np.any(np.linalg.det(R) < 0):
            raise InputError("grasps.R_tool_grasp: expected [N, 3, 3] proper rotation matrices")
        q = np.asarray(_matrix_to_wxyz(to_device(R)))
    else:
        q = np.atleast_2d(np.asarray(q_tool_grasp, dtype=float))
        _check_finite(q, "grasps.q_tool_grasp")
        norms = np.linalg.norm(q, axis=-1)
        if q.shape != (n, 4) or np.any(norms < 1e-9):
            raise InputError("grasps.q_tool_grasp: expected [N, 4] non-zero quaternions (w, x, y, z)")
        q = q / norms[:, None]
    w = np.broadcast_to(np.asarray(0.0 if width is None else width, dtype=float), (n,))
    _check_finite(p, "grasps.p_tool_grasp")
    _check_finite(w, "grasps.width")
    if np.any(w < 0) or np.any(w > robot.GRIPPER_MAX_OPENING + 1e-9):
        raise InputError(
            f"grasps.width: must lie in [0, {robot.GRIPPER_MAX_OPENING}] m (the gripper's stroke), "
            f"got range [{w.min():.4f}, {w.max():.4f}]"
        )
    f = lambda a: to_device(a, dtype=float)  # noqa: E731
    return Grasps(p_tool_grasp=f(p), q_tool_grasp=f(q), width=f(w))


def validate_grasps(grasps: Grasps, what: str = "grasps") -> None:
    """Host-side check of a `Grasps` batch built by hand: finite, unit-able quaternions, widths."""
    for name in ("p_tool_grasp", "q_tool_grasp", "width"):
        _check_finite(np.asarray(getattr(grasps, name)), f"{what}.{name}")
    if np.any(np.linalg.norm(np.asarray(grasps.q_tool_grasp), axis=-1) < 1e-9):
        raise InputError(f"{what}.q_tool_grasp: zero quaternion")


def _check_finite(a: np.ndarray, what: str) -> None:
    bad = ~np.isfinite(a)
    if np.any(bad):
        rows = np.unique(np.argwhere(bad)[:, 0])
        raise InputError(f"{what}: NaN or infinity in entries {rows[:10].tolist()}")


# ---------------------------------------------------------------------------------------------------
# Adapters
# ---------------------------------------------------------------------------------------------------
def to_graspnet(grasps: Grasps) -> dict[str, np.ndarray]:
    """graspnetAPI fields: rotation_matrix [N, 3, 3], translation [N, 3], width [N], depth [N]."""
    R = np.asarray(grasps.rotation).reshape(-1, 3, 3)
    n = R.shape[0]
    return {
        "rotation_matrix": R @ GRASPNET_FROM_OURS,
        "translation": np.asarray(grasps.p_tool_grasp).reshape(n, 3),
        "width": np.asarray(grasps.width).reshape(n),
        "depth": np.full(n, GRASPNET_DEPTH),
    }


def from_graspnet(rotation_matrix: Any, translation: Any, width: Any) -> Grasps:
    """Inverse of `to_graspnet` (graspnet's depth is implied by our frame's origin)."""
    R_gn = np.asarray(rotation_matrix, dtype=float).reshape(-1, 3, 3)
    return make_grasps(translation, R_gn @ GRASPNET_FROM_OURS.T, width)


def to_mujoco_site(grasps: Grasps) -> tuple[np.ndarray, np.ndarray]:
    """(pos [N, 3], quat [N, 4] wxyz with w >= 0) of the gripper's `grasp` site in the tool frame."""
    q = np.asarray(grasps.q_tool_grasp).reshape(-1, 4)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q = np.where(q[:, :1] < 0, -q, q)
    return np.asarray(grasps.p_tool_grasp).reshape(-1, 3).copy(), q


def gripper_boxes(opening: Any) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The gripper's collision outline in the grasp frame at jaw `opening` (m): (name, lo, hi) boxes.

    Two fingers (pad width x finger thickness x finger length) whose inner faces sit at
    y = -/+ opening / 2, and the palm behind them. `opening` may be a float or an array [...]; lo and
    hi then have shape [..., 3]. Used by the sampler's collision check and by plots.
    """
    o = 0.5 * np.asarray(opening, dtype=float)[..., None]
    hx, t = robot.PAD_WIDTH / 2, robot.FINGER_THICKNESS
    z_tip, z_palm = robot.PAD_LENGTH / 2, -robot.FINGER_LENGTH
    e_y = np.array([0.0, 1.0, 0.0])
    fixed = lambda v: np.broadcast_to(np.asarray(v, dtype=float), o.shape[:-1] + (3,))  # noqa: E731
    return [
        ("finger_neg", fixed([-hx, -t, z_palm]) - o * e_y, fixed([hx, 0.0, z_tip]) - o * e_y),
        ("finger_pos", fixed([-hx, 0.0, z_palm]) + o * e_y, fixed([hx, t, z_tip]) + o * e_y),
        ("palm", fixed([-robot.PALM_WIDTH_X / 2, -robot.PALM_WIDTH_Y / 2, z_palm - robot.PALM_DEPTH]),
         fixed([robot.PALM_WIDTH_X / 2, robot.PALM_WIDTH_Y / 2, z_palm])),
    ]

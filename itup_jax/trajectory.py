"""Tool trajectories xi(t): poses, twists and accelerations sampled at T steps.

A trajectory is written as a smooth pose function `pose(t) -> (p_world_tool [3], R_world_tool [3, 3])`
(built from quintic segments, so position, velocity and acceleration are continuous); its twist and
acceleration are its exact time derivatives, taken with forward-mode autodiff, not finite
differences:

    v = dp/dt,  [w]_x = dR/dt R^T,  a = dv/dt,  alpha = dw/dt     (world frame)

`v` and `a` are those of the tool-frame origin; the velocity of any tool point c is v + w x (c - p).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Trajectory:
    """Tool trajectory sampled at T steps (world frame, SI units).

    Attributes:
      t: [T] s, sample times.
      p_world_tool: [T, 3] m, tool-frame origin.
      R_world_tool: [T, 3, 3] tool orientation (columns: tool axes in the world).
      v_world: [T, 3] m/s, velocity of the tool-frame origin.
      w_world: [T, 3] rad/s, angular velocity.
      a_world: [T, 3] m/s^2, acceleration of the tool-frame origin.
      alpha_world: [T, 3] rad/s^2, angular acceleration.
    """

    t: jax.Array
    p_world_tool: jax.Array
    R_world_tool: jax.Array
    v_world: jax.Array
    w_world: jax.Array
    a_world: jax.Array
    alpha_world: jax.Array

    @property
    def num_steps(self) -> int:
        return int(self.t.shape[0])

    def point_velocity(self, c_tool: jax.Array) -> jax.Array:
        """[T, 3] m/s world velocity of the tool point `c_tool` [3] (tool frame)."""
        r = jnp.einsum("tij,j->ti", self.R_world_tool, c_tool)
        return self.v_world + jnp.cross(self.w_world, r)

    def point_position(self, c_tool: jax.Array) -> jax.Array:
        """[T, 3] m world position of the tool point `c_tool` [3]."""
        return jnp.einsum("tij,j->ti", self.R_world_tool, c_tool) + self.p_world_tool


def vee(S: jax.Array) -> jax.Array:
    """[3, 3] skew-symmetric -> [3] vector (the inverse of the cross-product matrix)."""
    return 0.5 * jnp.array([S[2, 1] - S[1, 2], S[0, 2] - S[2, 0], S[1, 0] - S[0, 1]])


def sample_pose_fn(pose_fn: Callable[[jax.Array], tuple[jax.Array, jax.Array]], t: jax.Array) -> Trajectory:
    """Sample `pose_fn` at times `t` [T] with exact derivatives (forward-mode AD)."""

    def twist(tt):
        (p, R), (v, R_dot) = jax.jvp(pose_fn, (tt,), (jnp.ones_like(tt),))
        return (p, R), (v, vee(R_dot @ R.T))

    def all_derivs(tt):
        ((p, R), (v, w)), (_, (a, alpha)) = jax.jvp(twist, (tt,), (jnp.ones_like(tt),))
        return p, R, v, w, a, alpha

    p, R, v, w, a, alpha = jax.vmap(all_derivs)(t)
    return Trajectory(t=t, p_world_tool=p, R_world_tool=R, v_world=v, w_world=w, a_world=a, alpha_world=alpha)


# ---------------------------------------------------------------------------------------------------
# Quintic (minimum-jerk-like) segments
# ---------------------------------------------------------------------------------------------------
def quintic_coefficients(h: float, start: Sequence[float], end: Sequence[float]) -> np.ndarray:
    """[6] coefficients c of q(s) = sum_k c_k s^k on s in [0, h] meeting (q, dq, ddq) at both ends."""
    q0, v0, a0 = start
    q1, v1, a1 = end
    dq = q1 - q0
    return np.array([
        q0,
        v0,
        a0 / 2,
        (20 * dq - (8 * v1 + 12 * v0) * h - (3 * a0 - a1) * h**2) / (2 * h**3),
        (-30 * dq + (14 * v1 + 16 * v0) * h + (3 * a0 - 2 * a1) * h**2) / (2 * h**4),
        (12 * dq - 6 * (v1 + v0) * h + (a1 - a0) * h**2) / (2 * h**5),
    ])


@dataclasses.dataclass(frozen=True)
class Profile:
    """A scalar C2 profile through knots (time s, value, rate, second derivative), quintic between.

    Before the first knot and after the last the profile holds its end state (zero rate expected).
    """

    knot_t: np.ndarray  # [K]
    coeffs: np.ndarray  # [K - 1, 6]

    @classmethod
    def through(cls, knots: Sequence[tuple[float, float, float, float]]) -> "Profile":
        kt = np.array([k[0] for k in knots], dtype=float)
        if np.any(np.diff(kt) <= 0):
            raise ValueError(f"profile knot times must increase, got {kt.tolist()}")
        coeffs = np.stack([
            quintic_coefficients(kt[i + 1] - kt[i], knots[i][1:], knots[i + 1][1:])
            for i in range(len(knots) - 1)
        ])
        return cls(kt, coeffs)

    def __call__(self, t: jax.Array) -> jax.Array:
        kt = jnp.asarray(self.knot_t)
        seg = jnp.clip(jnp.searchsorted(kt, t, side="right") - 1, 0, len(self.knot_t) - 2)
        s = jnp.clip(t, kt[0], kt[-1]) - kt[seg]
        c = jnp.asarray(self.coeffs)[seg]
        return jnp.polyval(c[::-1], s)

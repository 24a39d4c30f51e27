"""What a blow passes to the wrist when the arm is part of the physics: tool, pads, hand and arm as a
linear chain over the contact (per example, JAX, differentiable).

The rigid model of `wrench.py`/`costs.py` holds the tool on its trajectory, so the grasp carries the
whole contact force times its lever arm. Here the blow meets the real chain instead, in spatial
coordinates about the wrist sensor site s (world axes, twists (v, w), wrenches (F, tau)):

  tool      M_t  a_t = w J p(t) - W_p                          (the blow: impulse J along the unit
                                                               wrench w = (n, (c - s) x n), delivered
                                                               as a half sine p(t) over the contact
                                                               duration T_c, integral 1)
  pads      W_p = d M_r (b (v_t - v_h) + k (x_t - x_h))       (MuJoCo's soft constraint: time constant
                                                               tau_p, critically damped, b = 2/(d tau_p),
                                                               k = 1/(d tau_p)^2, M_r = (M_t^-1 +
                                                               (M_h + Lambda)^-1)^-1 the pair's
                                                               effective inertia, d the impedance),
                                                               then what the pads pass on
                                                               (`pads_pass`: all of it, the closure
                                                               axis's torque capped at the pads'
                                                               torsional friction 2 c_t mu f_grip,
                                                               or the wrench scaled onto the grip's
                                                               limit surface)
  hand+arm  (M_h + Lambda) a_h = W_p - D_x v_h - K_x x_h      (`sim.arm_inertia.ArmImpedance`)
  wrist     W_s = W_p - M_h a_h                                (what the sensor reads: the arm's side)

integrated by semi-implicit Euler (the arm's damping and stiffness implicitly) from rest over `horizon`.
The peak of |tau_s| over the steps is the predicted peak induced wrist torque of the blow.

Closed forms it reduces to (tests): with a heavy arm (Lambda, K, D -> infinity) and stiff pads the
sensor reads the contact wrench itself, (n, (c - s) x n) J p(t): the rigid model, whose peak is
pi/2 J / T_c times the lever arm; with no servo (K = D = 0) the arm's share of the blow's momentum
once the pads have settled is `impulse_share` = Lambda (M_t + M_h + Lambda)^-1, which for a pin that
resists translation only and a uniform rod vanishes in force when the rod is struck at its centre of
percussion (2/3 of its length from the pin).

`wrist_response` is per example; `batched_wrist_response` vmaps it. Nothing here is jitted: jit at the
call site (`experiments/arm_transmission.py` does).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp

from itup_jax.costs import torsion_cap
from itup_jax.errors import InputError
from itup_jax.grip_demand import grip_demand_sq
from itup_jax.robot import PAD_SOLIMP, PAD_SOLREF

#: s, the pads' contact time constant (their solref's)
PAD_TIMECONST = PAD_SOLREF[0]
#: -, the pads' constraint impedance at depth (their solimp's dmax)
PAD_IMPEDANCE = PAD_SOLIMP[1]


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Blow:
    """One blow at the wrist sensor site (world axes), the inputs of `wrist_response`.

    tool: [6, 6] the tool's spatial inertia about the site.  wrench: [6] the contact's unit wrench about
    the site, (n, (c - s) x n).  impulse: [] N s.  duration: [] s, the contact's duration.
    arm_inertia, arm_stiffness, arm_damping, hand: [6, 6] (`sim.arm_inertia.ArmImpedance`).
    grasp_axes: [3, 3] the grasp frame's axes as columns (x third, y the jaw's closure, z approach).
    grasp_offset: [3] m, the grasp centre minus the site.  mu: [] pad friction.  width: [] m, the jaw's
    opening.  grip_force: [] N per pad.
    """

    tool: Any
    wrench: Any
    impulse: Any
    duration: Any
    arm_inertia: Any
    arm_stiffness: Any
    arm_damping: Any
    hand: Any
    grasp_axes: Any
    grasp_offset: Any
    mu: Any
    width: Any
    grip_force: Any


#: What the pads pass on (`wrist_response(pads=...)`): all of it; all but the torque about the closure
#: axis beyond the pads' torsional friction; or the wrench scaled onto the grip's limit surface
PAD_MODELS = ("rigid", "torsion", "limit")


def impulse_share(tool: jax.Array, hand: jax.Array, arm_inertia: jax.Array) -> jax.Array:
    """[6, 6] Lambda (M_t + M_h + Lambda)^-1: the part of a blow's impulse wrench (about the site) that
    ends in the arm once tool and hand move together, with no servo acting. -> identity for a heavy arm,
    -> 0 for a weightless one."""
    return arm_inertia @ jnp.linalg.solve(tool + hand + arm_inertia, jnp.eye(6, dtype=tool.dtype))


def pads_pass(W: jax.Array, blow: Blow, pads: str) -> jax.Array:
    """The wrench [6] (about the site) the pads pass on when W [6] is what holding the tool takes.

    'rigid': W.  'torsion': the torque about the closure axis, taken about the grasp centre, clipped at
    the pads' torsional friction 2 c_t mu f_grip.  'limit': W scaled onto the grip's limit surface
    (`grip_demand`: the normal force per pad N that W needs) where N exceeds f_grip: the pads slide and
    pass on what friction holds.
    """
    if pads == "rigid":
        return W
    F, tau_g = W[:3], W[3:] - jnp.cross(blow.grasp_offset, W[:3])
    if pads == "torsion":
        y = blow.grasp_axes[:, 1]
        c = tau_g @ y
        cap = torsion_cap(blow.mu, blow.grip_force)
        return W.at[3:].add((jnp.clip(c, -cap, cap) - c) * y)
    need_sq = grip_demand_sq(F @ blow.grasp_axes, tau_g @ blow.grasp_axes, blow.mu, blow.width, xp=jnp)
    f_sq = blow.grip_force**2
    scale = jnp.where(need_sq > f_sq, jnp.sqrt(f_sq / jnp.where(need_sq > f_sq, need_sq, 1.0)), 1.0)
    return W * scale


def wrist_response(blow: Blow, *, pads: str = "torsion", step: float = 1e-4, horizon: float = 0.03,
                   pad_timeconst: float = PAD_TIMECONST, pad_impedance: float = PAD_IMPEDANCE) -> tuple[jax.Array, jax.Array]:
    """(peak |tau_s| [] N m, the sensor's wrench over the steps [S, 6]) of ONE blow (module docstring).

    pads (one of PAD_MODELS), step (s) and horizon (s) are static: S = round(horizon / step) steps, from
    the blow's start.
    """
    if pads not in PAD_MODELS:
        raise InputError(f"wrist_response: pads {pads!r}; choose one of {PAD_MODELS}")
    dtype = blow.tool.dtype
    n = int(round(horizon / step))
    h = jnp.asarray(step, dtype)
    k = 1.0 / (pad_impedance * pad_timeconst) ** 2
    b = 2.0 / (pad_impedance * pad_timeconst)
    eye = jnp.eye(6, dtype=dtype)
    m_ha = blow.hand + blow.arm_inertia
    tool_inv = jnp.linalg.solve(blow.tool, eye)
    m_rel = jnp.linalg.solve(tool_inv + jnp.linalg.solve(m_ha, eye), eye)
    # hand + arm, damping and stiffness implicit: (M + h D + h^2 K) a = W_p - D v - K (x + h v)
    arm_solve = jnp.linalg.solve(m_ha + h * blow.arm_damping + h * h * blow.arm_stiffness, eye)
    duration = blow.duration

    def one(state, i):
        x_t, v_t, x_h, v_h = state
        t = i * h
        pulse = jnp.where(t < duration, (jnp.pi / (2.0 * duration)) * jnp.sin(jnp.pi * t / duration), 0.0)
        W_p = pad_impedance * m_rel @ (b * (v_t - v_h) + k * (x_t - x_h))
        W_p = pads_pass(W_p, blow, pads)
        a_t = tool_inv @ (blow.wrench * blow.impulse * pulse - W_p)
        a_h = arm_solve @ (W_p - blow.arm_damping @ v_h - blow.arm_stiffness @ (x_h + h * v_h))
        v_t, v_h = v_t + h * a_t, v_h + h * a_h
        x_t, x_h = x_t + h * v_t, x_h + h * v_h
        W_s = W_p - blow.hand @ a_h
        return (x_t, v_t, x_h, v_h), W_s

    z = jnp.zeros(6, dtype)
    _, trace = jax.lax.scan(one, (z, z, z, z), jnp.arange(n, dtype=dtype))
    tau_sq = jnp.sum(trace[:, 3:] ** 2, axis=-1)
    return jnp.sqrt(jnp.max(tau_sq) + 1e-30) - 1e-15, trace


def batched_wrist_response(blows: Blow, **kw: Any) -> jax.Array:
    """[N] peak wrist torques (N m) of a batch of blows (leading [N] on every leaf). Pure; jit it outside
    with `kw` static (e.g. `jax.jit(batched_wrist_response, static_argnames="pads")`)."""
    return jax.vmap(lambda b: wrist_response(b, **kw)[0])(blows)

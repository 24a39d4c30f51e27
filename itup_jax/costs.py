"""Wrench-conditioned grasp costs C_tau, C_s, C_alpha and C, and the regime classifier.

For one grasp g (grasp-frame origin p and jaw-closure axis n_f, both in the tool frame) and the
grasp-independent loads of `wrench.task_loads` (force F and moment M about the tool origin that the
grasp must apply, tool frame), at every step t:

  tau(t)     = M(t) - (P - O) x F(t)       P = p (default, 'grasp'), the com ('com', the seed's r), or
                                           the wrist's force/torque site, FLANGE_TO_GRASP behind p
                                           along the grasp's approach axis ('wrist': where the labels
                                           and the paper measure the wrist torque)
  C_tau(t)   = || (I - n_f n_f^T) tau ||   ('perp', the paper's choice) or ||tau|| ('full') or
               2 c_t N_grip(F, tau)       ('grip': the grip demand of `grip_demand.py`, the normal force
                                           per pad that holds (F, tau) by friction, in the grasp frame,
                                           expressed as the torque about the closure axis that needs
                                           the same force, c_t the pads' torsional friction length)
               sqrt(||tau_perp||^2 + min(|tau . n_f|, 2 c_t mu f_grip)^2)   ('passed': what the
                                           pads pass on, the closure-axis part capped by their
                                           torsional friction at the squeeze f_grip)
  tau_n(t)   = |tau . n_f|                 (about the closure axis: only torsional pad friction holds it)
  F_n(t)     = (F . n_f) n_f,  F_t = F - F_n
  C_s(t)     = max(0, ||F_t|| - mu (||F_n|| + 2 f_grip))   (f_grip = 0: the seed form; > 0: the
                                                            variant with each pad's squeeze force)
  C_alpha(t) = angle between the lines n_f and n (in [0, pi/2]) while a contact acts, else 0

and each cost is the peak over t. C = w_tau C_tau + w_s C_s + w_alpha C_alpha.

Two named presets: `CostParams.paper()` (the paper's objective: 'perp', the default) and
`CostParams.wrench()` ('grip': every component of the wrench counts by how hard it loads the grip, so
turning the jaw to put the torque on the closure axis, which 'perp' discards, costs most instead).

`grasp_cost_trace` and `grasp_costs` are per-example (one grasp); `batched_wrench_costs` vmaps them.
`wrench_costs` is the public entry point: it validates on the host, then calls one module-level
`jax.jit` of `batched_wrench_costs`, so a second call with the same shapes does not recompile.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.grip_demand import grip_demand_sq
from itup_jax.kernel_cache import kept
from itup_jax.precision import full_precision
from itup_jax.robot import FLANGE_TO_GRASP, PAD_TORSION
from itup_jax.rotations import quat_to_matrix
from itup_jax.shapes import pad_batch, unpad_batch
from itup_jax.task import Task
from itup_jax.tools import Tool, ToolParams
from itup_jax.wrench import Loads, task_loads

LEVER_ARMS = ("grasp", "com", "wrist")
TORQUE_PROJECTIONS = ("perp", "full", "grip", "passed")


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class CostParams:
    """Weights and model variants of the cost.

    Leaves (differentiable): w_tau [] 1/(N m), w_slip [] 1/N, w_align [] 1/rad, grip_force [] N (squeeze
    of each pad; 0 gives the seed's slip form). Static: lever_arm ('grasp' | 'com' | 'wrist'), torque_projection
    ('perp' | 'full'), include_gravity (add the tool's weight to the inertial wrench).

    The default weights are 1 in SI units (N m, N, rad): the experiments decide better ones.
    """

    w_tau: Any = 1.0
    w_slip: Any = 1.0
    w_align: Any = 1.0
    grip_force: Any = 0.0
    lever_arm: str = dataclasses.field(default="grasp", metadata=dict(static=True))
    torque_projection: str = dataclasses.field(default="perp", metadata=dict(static=True))
    include_gravity: bool = dataclasses.field(default=False, metadata=dict(static=True))

    def __post_init__(self):
        if self.lever_arm not in LEVER_ARMS:
            raise InputError(f"CostParams.lever_arm: {self.lever_arm!r}; choose one of {LEVER_ARMS}")
        if self.torque_projection not in TORQUE_PROJECTIONS:
            raise InputError(f"CostParams.torque_projection: {self.torque_projection!r}; choose one of {TORQUE_PROJECTIONS}")

    def replace(self, **changes: Any) -> "CostParams":
        return dataclasses.replace(self, **changes)

    @classmethod
    def paper(cls, **changes: Any) -> "CostParams":
        """The paper's objective: C_tau the torque perpendicular to the jaw's closure axis ('perp')."""
        return cls(torque_projection="perp", **changes)

    @classmethod
    def wrench(cls, **changes: Any) -> "CostParams":
        """The grip-demand objective: C_tau = 2 c_t N_grip, every wrench component weighed by the normal
        force the pads need to hold it ('grip')."""
        return cls(torque_projection="grip", **changes)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Costs:
    """Peak costs of a batch of grasps, each [N] (or [] for one grasp, or [T] in a trace).

    tau: C_tau, N m.  slip: C_s, N.  align: C_alpha, rad.  total: C (weighted sum).
    tau_closure: torque about the jaw-closure axis, N m (reported, not in C).
    """

    tau: jax.Array
    slip: jax.Array
    align: jax.Array
    total: jax.Array
    tau_closure: jax.Array

    def __getitem__(self, idx: Any) -> "Costs":
        return jax.tree_util.tree_map(lambda a: a[idx], self)


# sqrt(x + TINY) - sqrt(TINY): equals sqrt(x) to ~1e-15 relative for the magnitudes here, and has a
# finite gradient at x = 0 (where a plain sqrt's is infinite and would turn into NaN).
TINY = 1e-30
SQRT_TINY = 1e-15


def _safe_sqrt(sq: jax.Array) -> jax.Array:
    """sqrt(sq) for sq >= 0 with a zero (not NaN) gradient at sq = 0."""
    pos = sq > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, sq, 1.0)), 0.0)


def _safe_norm(x: jax.Array) -> jax.Array:
    """Euclidean norm over the last axis with a zero (not NaN) gradient at x = 0."""
    return _safe_sqrt(jnp.sum(x * x, axis=-1))


def line_angle(u: jax.Array, v: jax.Array) -> jax.Array:
    """Angle between the lines spanned by unit vectors u and v [..., 3], in [0, pi/2] rad."""
    return jnp.arctan2(_safe_norm(jnp.cross(u, v)), jnp.abs(jnp.sum(u * v, axis=-1)))


def _off_axis_sq(tau: jax.Array, R: jax.Array) -> jax.Array:
    """[T]: ||(I - n_f n_f^T) tau||^2 of a vector tau [T, 3] (a torque, N^2 m^2, or a force, N^2) off the
    closure axis n_f = R[:, 1], as the sum of its two grasp-frame components. Not ||tau||^2 - (tau . n_f)^2:
    where the vector lies nearly on the closure axis that difference cancels, and in float32 leaves an
    error of ~1e-7 ||tau||^2 (on a flat spanner, up to 1e-2 N m where the exact part is 0); the sum of
    the components' squares errs by ~1e-7 ||tau|| in the norm."""
    return (tau @ R[:, 0]) ** 2 + (tau @ R[:, 2]) ** 2


def torsion_cap(mu, grip_force):
    """N m: the most torque about the jaw's closure axis the pads hold by their torsional friction,
    2 c_t mu f_grip (module docstring)."""
    return 2.0 * PAD_TORSION * mu * grip_force


def passed_torque_sq(off_sq: jax.Array, tau_n: jax.Array, mu, grip_force) -> jax.Array:
    """[T] N^2 m^2: the torque the pads pass on, squared: the part off the closure axis (`off_sq`, its
    square) in full, the part about it up to the pads' torsional friction (`torsion_cap`)."""
    return off_sq + jnp.minimum(jnp.abs(tau_n), torsion_cap(mu, grip_force)) ** 2


def _grip_torque_sq(F: jax.Array, tau: jax.Array, R: jax.Array, mu, width) -> jax.Array:
    """(2 c_t N_grip)^2 [T] of the wrench (F, tau about the grasp point) [T, 3] in the tool frame, turned
    into the grasp frame (R = R_tool_grasp): the 'grip' C_tau before its square root."""
    return (2.0 * PAD_TORSION) ** 2 * grip_demand_sq(F @ R, tau @ R, mu, width, xp=jnp)


def _pivot(loads: Loads, grasp: Grasps, R: jax.Array, lever_arm: str) -> jax.Array:
    """[3] m, the point the torque is taken about (tool frame; module docstring)."""
    if lever_arm == "com":
        return loads.com_tool
    if lever_arm == "wrist":
        return grasp.p_tool_grasp - FLANGE_TO_GRASP * R[:, 2]
    return grasp.p_tool_grasp


def grasp_cost_trace(loads: Loads, grasp: Grasps, tool: ToolParams, params: CostParams) -> Costs:
    """Per-step costs [T] of ONE grasp (shapes [3], [4], []). Not jitted; see `wrench_costs`."""
    R = quat_to_matrix(grasp.q_tool_grasp)
    n_f = R[:, 1]
    pivot = _pivot(loads, grasp, R, params.lever_arm)
    tau = loads.moment_tool - jnp.cross(pivot, loads.force_tool)  # [T, 3]
    tau_n = tau @ n_f
    F = loads.force_tool
    if params.torque_projection == "grip":
        c_tau = _safe_sqrt(_grip_torque_sq(F, tau, R, tool.mu, grasp.width))
    elif params.torque_projection == "passed":
        c_tau = _safe_sqrt(passed_torque_sq(_off_axis_sq(tau, R), tau_n, tool.mu, params.grip_force))
    elif params.torque_projection == "perp":
        c_tau = _safe_sqrt(_off_axis_sq(tau, R))
    else:
        c_tau = _safe_norm(tau)
    F_n = F @ n_f
    F_t = _safe_sqrt(_off_axis_sq(F, R))
    c_slip = jnp.maximum(F_t - tool.mu * (jnp.abs(F_n) + 2.0 * params.grip_force), 0.0)
    c_align = jnp.where(loads.active > 0, line_angle(n_f[None, :], loads.normal_tool), 0.0)
    total = params.w_tau * c_tau + params.w_slip * c_slip + params.w_align * c_align
    return Costs(tau=c_tau, slip=c_slip, align=c_align, total=total, tau_closure=jnp.abs(tau_n))


def grasp_costs(loads: Loads, grasp: Grasps, tool: ToolParams, params: CostParams) -> Costs:
    """Peak-over-time costs of ONE grasp (each []); C is the weighted sum of the peaks.

    Equal to the maxima of `grasp_cost_trace`, computed with one square root per cost and one
    arctangent per grasp instead of per step: a norm peaks where its square peaks, and the line angle
    is largest where |n_f . n| is smallest among the steps in contact.
    """
    R = quat_to_matrix(grasp.q_tool_grasp)
    n_f = R[:, 1]
    pivot = _pivot(loads, grasp, R, params.lever_arm)
    F = loads.force_tool
    tau = loads.moment_tool - jnp.cross(pivot, F)  # [T, 3]
    tau_n = tau @ n_f
    tau_sq = jnp.sum(tau * tau, axis=-1)
    if params.torque_projection == "grip":
        c_tau_sq = _grip_torque_sq(F, tau, R, tool.mu, grasp.width)
    elif params.torque_projection == "passed":
        c_tau_sq = passed_torque_sq(_off_axis_sq(tau, R), tau_n, tool.mu, params.grip_force)
    else:
        c_tau_sq = _off_axis_sq(tau, R) if params.torque_projection == "perp" else tau_sq
    tau = jnp.sqrt(jnp.maximum(jnp.max(c_tau_sq), 0.0) + TINY) - SQRT_TINY
    F_n = F @ n_f
    F_t_sq = _off_axis_sq(F, R)  # the force across the closure axis, from its two components
    F_t = jnp.sqrt(F_t_sq + TINY) - SQRT_TINY
    slip = jnp.max(jnp.maximum(F_t - tool.mu * (jnp.abs(F_n) + 2.0 * params.grip_force), 0.0))
    cos = jnp.min(jnp.where(loads.active > 0, jnp.abs(loads.normal_tool @ n_f), 1.0))
    sin = jnp.sqrt(jnp.maximum(1.0 - cos**2, 0.0) + TINY) - SQRT_TINY
    align = jnp.arctan2(sin, cos)
    total = params.w_tau * tau + params.w_slip * slip + params.w_align * align
    return Costs(tau=tau, slip=slip, align=align, total=total, tau_closure=jnp.max(jnp.abs(tau_n)))


def batched_wrench_costs(tool: ToolParams, task: Task, grasps: Grasps, params: CostParams) -> Costs:
    """Costs [N] of a batch of grasps: loads once, then `vmap(grasp_costs)`. Pure; jit it outside."""
    loads = task_loads(tool, task, params.include_gravity)
    return jax.vmap(grasp_costs, in_axes=(None, 0, None, None))(loads, grasps, tool, params)


#: The one jit of the public entry point (module level, so its cache lives as long as the process).
wrench_costs_jit = jax.jit(full_precision(batched_wrench_costs))


def wrench_costs(tool: Tool | ToolParams, task: Task, grasps: Grasps, params: CostParams | None = None) -> Costs:
    """C_tau, C_s, C_alpha and C for every grasp: `costs.tau`, `.slip`, `.align`, `.total`, shape [N].

    Validates the grasps on the host (finite poses, non-zero quaternions), then runs one jitted
    computation (`wrench_costs_jit`); calls with the same shapes and static params reuse it.
    Differentiable with respect to `tool.params`, the grasps and `params`' weights: differentiate
    `batched_wrench_costs` (or this function's jitted core) directly.
    """
    tool_params = tool.params if isinstance(tool, Tool) else tool
    if not isinstance(task, Task):
        raise InputError(f"wrench_costs: task must be a Task (from make_task), got {type(task).__name__}")
    if not isinstance(grasps, Grasps):
        raise InputError(f"wrench_costs: grasps must be a Grasps batch, got {type(grasps).__name__}")
    if np.ndim(grasps.width) != 1:
        raise InputError(f"wrench_costs: grasps must be a batch [N]; got width shape {np.shape(grasps.width)}")
    validate_grasps(grasps)
    padded, n = pad_batch(grasps)  # one compile per bucket of candidate counts (shapes.py)
    return unpad_batch(wrench_costs_jit(tool_params, task, padded, params or CostParams()), n)


# ---------------------------------------------------------------------------------------------------
# Regime classifier
# ---------------------------------------------------------------------------------------------------
class Regime(enum.IntEnum):
    """Contact regimes of docs/design.md: quasi-static (reach), dynamic (hammer, knock), clustered (sweep)."""

    QUASI_STATIC = 0
    DYNAMIC = 1
    CLUSTERED = 2


#: Dynamic when impulsive plus inertial forces exceed this multiple of drag plus weight (-).
DYNAMIC_FORCE_RATIO = 1.0


def regime_code(tool: ToolParams, task: Task) -> jax.Array:
    """[] int32 `Regime` of a task for a tool. Pure; jit it outside.

    clustered: two or more contacts act at the same step; else dynamic: the peak of impulsive contact
    forces plus the tool's inertial force (without gravity) exceeds DYNAMIC_FORCE_RATIO times the
    peak of drag forces plus the tool's weight; else quasi-static.
    """
    loads = task_loads(tool, task, include_gravity=False)
    active = (jnp.maximum(task.impact, task.drag) > 0).sum(axis=1)
    F_imp = jnp.linalg.norm(task.impact[..., None] * loads.contact_force_world, axis=-1).sum(-1)
    F_drag = jnp.linalg.norm(task.drag[..., None] * loads.contact_force_world, axis=-1).sum(-1)
    dynamic_load = jnp.max(F_imp + jnp.linalg.norm(loads.inertial_force_world, axis=-1))
    static_load = jnp.max(F_drag) + tool.mass * jnp.linalg.norm(task.gravity_world)
    return jnp.where(active.max() >= 2, Regime.CLUSTERED,
                     jnp.where(dynamic_load > DYNAMIC_FORCE_RATIO * static_load, Regime.DYNAMIC, Regime.QUASI_STATIC))


_regime_code_jit = kept(regime_code, "costs.regime_code")


def classify_regime(tool: Tool | ToolParams, task: Task) -> Regime:
    """Host-side convenience: the `Regime` of `task` for `tool` (`regime_code` under one jit: op by op it
    took ~1 s of dispatch)."""
    tool_params = tool.params if isinstance(tool, Tool) else tool
    return Regime(int(_regime_code_jit(tool_params, task)))

"""The wrench a task trajectory induces on the tool, and the wrench the grasp must therefore carry.

Per-example functions (one contact, one time step); batch them with `vmap` at the call site.
SI units; world frame unless a name says otherwise.

Physics (docs/design.md, "Physics"):
  lever arm for the impact   r = c_contact - c_com,   contact velocity  v_c = v + w x (c - p_origin)
  normal impulse             J = max(0, -(1 + e)(v_c . n)) / (1/m + 1/m_obj + n . [I^-1 (r x n)] x r)
  impact force               F = (J / dt) n
  drag (pushing a target)    F = -f v_c / sqrt(|v_c|^2 + v_s^2)     (regularised Coulomb)
  inertial wrench (com)      F_in = m (a_com - g),   M_in = I alpha + w x I w
The grasp carries what the trajectory demands beyond the contact forces (Newton-Euler):
  F_grasp = F_in - sum_k F_k,   M_grasp(about O) = (c_com - O) x F_in + M_in - sum_k (c_k - O) x F_k
and about any point P:  tau_P = M_grasp(about O) - (P - O) x F_grasp.

`1/m_obj` generalises the seed's rigid-wall impulse to a movable target (0 for a wall or a nail held
by wood); with it, a point mass striking a wall gives J = (1 + e) m v and a uniform free rod struck at
its end perpendicular to it gives J = (1 + e) m v / 4.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp

from itup_jax.task import Task
from itup_jax.tools import ToolParams


def normal_impulse(
    inv_mass: jax.Array, inv_inertia: jax.Array, r: jax.Array, n: jax.Array, v_c: jax.Array,
    restitution: jax.Array, inv_mass_obj: jax.Array,
) -> jax.Array:
    """Normal impulse J (N s, >= 0) of one impact.

    Args:
      inv_mass: [] 1/kg, tool's inverse mass.
      inv_inertia: [3, 3] 1/(kg m^2), tool's inverse inertia about its com (same frame as r, n).
      r: [3] m, contact point minus the tool's centre of mass.
      n: [3] unit target normal, pointing from the target into the tool.
      v_c: [3] m/s, velocity of the tool's contact point before impact.
      restitution: [] e in [0, 1].
      inv_mass_obj: [] 1/kg, target's inverse mass (0: immovable).
    Returns:
      [] J >= 0; zero when the contact point separates (v_c . n >= 0).
    """
    k = inv_mass + inv_mass_obj + jnp.dot(n, jnp.cross(inv_inertia @ jnp.cross(r, n), r))
    approach = jnp.maximum(-jnp.dot(v_c, n), 0.0)
    return (1.0 + restitution) * approach / k


def drag_force(v_c: jax.Array, magnitude: jax.Array, slip_velocity: jax.Array) -> jax.Array:
    """[3] N, regularised Coulomb resistance against the contact point's velocity v_c [3] m/s.

    |F| -> magnitude when |v_c| >> slip_velocity; F -> 0 continuously as v_c -> 0.
    """
    return -magnitude * v_c / jnp.sqrt(jnp.dot(v_c, v_c) + slip_velocity**2)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Loads:
    """Grasp-independent loads along a trajectory, in the tool frame (T steps).

    Attributes:
      force_tool: [T, 3] N, force the grasp must apply to the tool.
      moment_tool: [T, 3] N m, moment about the tool-frame origin the grasp must apply.
      normal_tool: [T, 3] primary interaction normal n in the tool frame.
      active: [T] in [0, 1], whether any contact acts at the step.
      contact_force_world: [T, K, 3] N, each contact's force on the tool (world).
      impulse: [T, K] N s, normal impulse of each contact (zero where it does not strike).
      inertial_force_world: [T, 3] N, m (a_com - g) (g included only when asked for).
      com_tool: [3] m, the tool's centre of mass (pivot of the 'com' lever-arm variant).
      contact_point_tool: [3] m, the primary contact point (tool frame).
    """

    force_tool: jax.Array
    moment_tool: jax.Array
    normal_tool: jax.Array
    active: jax.Array
    contact_force_world: jax.Array
    impulse: jax.Array
    inertial_force_world: jax.Array
    com_tool: jax.Array
    contact_point_tool: jax.Array


def _step_loads(tool: ToolParams, task: Task, include_gravity: bool, t_index: jax.Array):
    """Loads at one time step (world), then expressed in the tool frame."""
    tr = task.traj
    R = tr.R_world_tool[t_index]
    v, w, a, alpha = tr.v_world[t_index], tr.w_world[t_index], tr.a_world[t_index], tr.alpha_world[t_index]
    I_w = R @ tool.inertia @ R.T
    I_inv_w = R @ jnp.linalg.inv(tool.inertia) @ R.T
    com_rel = R @ tool.com  # com minus tool origin, world axes

    def one_contact(c_tool, n, inv_mass_obj, f_drag, s_impact, s_drag):
        c_rel = R @ c_tool  # contact point minus tool origin
        v_c = v + jnp.cross(w, c_rel)
        J = normal_impulse(1.0 / tool.mass, I_inv_w, c_rel - com_rel, n, v_c, tool.restitution, inv_mass_obj)
        F = s_impact * (J / tool.contact_duration) * n + s_drag * drag_force(v_c, f_drag, task.slip_velocity)
        return F, jnp.cross(c_rel, F), s_impact * J

    F_k, M_k, J_k = jax.vmap(one_contact)(
        task.c_tool, task.n_world, task.inv_mass_obj, task.drag_force,
        task.impact[t_index], task.drag[t_index])
    a_com = a + jnp.cross(alpha, com_rel) + jnp.cross(w, jnp.cross(w, com_rel))
    g = task.gravity_world if include_gravity else jnp.zeros(3)
    F_in = tool.mass * (a_com - g)
    M_in = jnp.cross(com_rel, F_in) + I_w @ alpha + jnp.cross(w, I_w @ w)
    F_grasp = F_in - F_k.sum(0)
    M_grasp = M_in - M_k.sum(0)
    active = jnp.max(jnp.maximum(task.impact[t_index], task.drag[t_index]))
    return R.T @ F_grasp, R.T @ M_grasp, R.T @ task.n_world[0], active, F_k, J_k, F_in


def task_loads(tool: ToolParams, task: Task, include_gravity: bool = False) -> Loads:
    """Loads for every step of `task` (grasp-independent; computed once, shared by all grasps).

    `include_gravity` (static): add the tool's weight to the inertial force. The default leaves it
    out: the costs measure the wrench the task *induces*, beyond holding the tool still (which is
    what the simulation labels call the induced torque), so that v, w -> 0 leaves only alignment.
    """
    steps = jnp.arange(task.num_steps)
    F, M, n, active, F_k, J_k, F_in = jax.vmap(lambda i: _step_loads(tool, task, include_gravity, i))(steps)
    return Loads(force_tool=F, moment_tool=M, normal_tool=n, active=active, contact_force_world=F_k,
                 impulse=J_k, inertial_force_world=F_in, com_tool=tool.com, contact_point_tool=task.c_tool[0])

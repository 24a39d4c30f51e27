"""Rigid transforms of a whole problem, shared by the invariance tests (C1)."""

import dataclasses

import jax.numpy as jnp
import numpy as np

from itup_jax.grasp import make_grasps


def move_world(task, Q, t):
    """The same task seen from a world frame rotated by Q and shifted by t."""
    tr = task.traj
    rot = lambda x: x @ Q.T  # noqa: E731  (rows are vectors)
    traj = dataclasses.replace(tr, p_world_tool=rot(tr.p_world_tool) + t, R_world_tool=jnp.einsum("ij,tjk->tik", Q, tr.R_world_tool),
                               v_world=rot(tr.v_world), w_world=rot(tr.w_world), a_world=rot(tr.a_world),
                               alpha_world=rot(tr.alpha_world))
    return task.replace(traj=traj, c_obj_world=rot(task.c_obj_world) + t, n_world=rot(task.n_world),
                        d_world=Q @ task.d_world, gravity_world=Q @ task.gravity_world)


def move_tool_frame(tool_params, task, grasps, Q, t):
    """The same problem with the tool's mesh frame re-chosen: x_new = Q x_old + t."""
    tp = tool_params.replace(com=Q @ tool_params.com + t, inertia=Q @ tool_params.inertia @ Q.T)
    tr = task.traj
    R_new = jnp.einsum("tij,kj->tik", tr.R_world_tool, Q)  # R_world_old Q^T
    d = -jnp.einsum("tij,j->ti", R_new, t)  # new origin minus old origin, world
    traj = dataclasses.replace(
        tr, R_world_tool=R_new, p_world_tool=tr.p_world_tool + d,
        v_world=tr.v_world + jnp.cross(tr.w_world, d),
        a_world=tr.a_world + jnp.cross(tr.alpha_world, d) + jnp.cross(tr.w_world, jnp.cross(tr.w_world, d)))
    Rg = np.asarray(grasps.rotation)
    g = make_grasps(np.asarray(grasps.p_tool_grasp) @ Q.T + t, np.einsum("ij,njk->nik", Q, Rg), grasps.width)
    return tp, task.replace(traj=traj, c_tool=task.c_tool @ Q.T + t), g

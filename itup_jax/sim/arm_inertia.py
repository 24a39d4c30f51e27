"""The arm as the hand feels it: operational-space inertia, servo impedance and the hand's own inertia at
the wrist force/torque site, from MuJoCo's mass matrix and Jacobian (host side).

    imp = arm_impedance(scene, q)       # ArmImpedance: arrays [N, 6, 6] / [N, 3], q [N, 6] rad

For the arm's six joints at configuration q, with M(q) the joint-space mass matrix of the arm alone (the
gripper and the tool below the sensor weigh nothing in it; armature included: `mj_fullM`) and J(q) the
6x6 Jacobian of the sensor site (`mj_jacSite`; rows: linear velocity, then angular):

  Lambda = (J M^-1 J^T)^-1          the operational-space inertia (Khatib 1987), what a wrench at the
                                    site meets in the first instant of a blow
  K_x = J^-T K_q J^-1               the position servos' stiffness seen at the site (K_q = diag(kp))
  D_x = J^-T D_q J^-1               the velocity servos' and joints' damping (D_q = diag(kv + damping))

and the gripper's spatial inertia about the site (`spatial_inertia` of each body below the sensor but the
tool). All in world axes, about the site, twists ordered (v, w) and wrenches (F, tau). A configuration
where J is singular has no K_x, D_x: those rows are NaN (`ArmImpedance.singular`).

`transmission.py` joins these to the tool to predict the share of a blow the wrist carries.
"""

from __future__ import annotations

import copy
import dataclasses

import jax
import mujoco
import numpy as np

from itup_jax.errors import InputError
from itup_jax.grasp import Grasps
from itup_jax.rotations import quat_to_matrix_np
from itup_jax.sim.scene import Scene
from itup_jax.task import Task
from itup_jax.transmission import Blow
from itup_jax.wrench import task_loads

#: kg and kg m^2 given to the bodies below the sensor in the arm-only model (zero makes MuJoCo warn that
#: the tool's free joint has a singular inertia; this is ~1e-9 of the lightest arm link)
WEIGHTLESS = (1e-9, 1e-12)
#: condition number above which the site's Jacobian counts as singular (a wrist or elbow singularity)
SINGULAR_CONDITION = 1e8


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class ArmImpedance:
    """The arm at the wrist sensor site, arrays with a leading [N] (or none for one configuration).

    inertia: [6, 6] Lambda (kg | kg m | kg m^2 blocks).  stiffness: [6, 6] K_x (N/m | N | N m/rad).
    damping: [6, 6] D_x (N s/m | N s | N m s/rad).  hand: [6, 6] the gripper's spatial inertia about the
    site.  site: [3] m, the site's position (world).
    """

    inertia: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    hand: np.ndarray
    site: np.ndarray

    @property
    def singular(self) -> np.ndarray:
        """[N] bool: configurations at a kinematic singularity (NaN stiffness and damping)."""
        return ~np.isfinite(np.asarray(self.stiffness)).all(axis=(-2, -1))


def skew(c: np.ndarray) -> np.ndarray:
    """[..., 3] -> [..., 3, 3], the cross-product matrix: skew(c) @ x = c x x."""
    c = np.asarray(c, float)
    z = np.zeros(c.shape[:-1])
    return np.stack([np.stack([z, -c[..., 2], c[..., 1]], -1),
                     np.stack([c[..., 2], z, -c[..., 0]], -1),
                     np.stack([-c[..., 1], c[..., 0], z], -1)], -2)


def spatial_inertia(mass, com, inertia) -> np.ndarray:
    """[6, 6] spatial inertia about a point O of a body of `mass` kg, centre of mass `com` [3] m from O
    and rotational inertia `inertia` [3, 3] kg m^2 about its centre of mass (same axes): the matrix
    that maps a twist at O (v_O, w) to the momentum (p, L_O):
        p = m (v_O + w x c),   L_O = I w + c x p."""
    C = skew(com)
    m = float(mass)
    return np.block([[m * np.eye(3), -m * C], [m * C, np.asarray(inertia, float) - m * C @ C]])


class _ArmModel:
    """The scene's model twice: as built (the gripper's bodies), and arm-only (everything below the sensor
    weightless), with one MjData each."""

    def __init__(self, scene: Scene):
        m = scene.model
        root = m.site_bodyid[scene.ft_site]
        below = [b for b in range(m.nbody) if _descends(m, b, root)]
        tool = m.body("tool").id
        self.hand = np.array([b for b in below if b != tool and not _descends(m, b, tool)])
        self.arm_only = copy.copy(m)
        for b in below:
            self.arm_only.body_mass[b], self.arm_only.body_inertia[b] = WEIGHTLESS[0], WEIGHTLESS[1]
        self.d_full, self.d_arm = mujoco.MjData(m), mujoco.MjData(self.arm_only)
        self.kq = m.actuator_gainprm[scene.arm_actuators, 0].astype(float)
        self.dq = m.actuator_gainprm[scene.arm_vel_actuators, 0].astype(float) + m.dof_damping[scene.arm_dof]


def _descends(m: mujoco.MjModel, b: int, root: int) -> bool:
    while b > 0:
        if b == root:
            return True
        b = int(m.body_parentid[b])
    return root == 0


def arm_impedance(scene: Scene, q: np.ndarray) -> ArmImpedance:
    """The arm's impedance and the hand's inertia at the wrist sensor site for each configuration.

    Args:
      scene: a built scene (its model holds the UR5e, the gripper and the tool).
      q: [N, 6] or [6] arm joint angles (rad), e.g. `Plan.q_traj[:, k]` at a trajectory sample k.
    Returns:
      `ArmImpedance` with leading [N] (none for a single [6] configuration).
    """
    q = np.asarray(q, float)
    if q.shape[-1:] != (6,) or q.ndim > 2 or not np.isfinite(q).all():
        raise InputError(f"arm_impedance: q must be finite joint angles [N, 6] or [6] (rad), got shape {q.shape}")
    single = q.ndim == 1
    q = np.atleast_2d(q)
    am = _ArmModel(scene)
    m, dof = scene.model, scene.arm_dof
    out = {f.name: [] for f in dataclasses.fields(ArmImpedance)}
    M = np.zeros((m.nv, m.nv))
    jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for qi in q:
        for model, d in ((am.arm_only, am.d_arm), (m, am.d_full)):
            d.qpos[scene.arm_qpos] = qi
            mujoco.mj_fwdPosition(model, d)
        mujoco.mj_fullM(am.arm_only, am.d_arm, M)
        mujoco.mj_jacSite(am.arm_only, am.d_arm, jp, jr, scene.ft_site)
        J = np.vstack([jp[:, dof], jr[:, dof]])
        Lam = np.linalg.inv(J @ np.linalg.solve(M[np.ix_(dof, dof)], J.T))
        if np.linalg.cond(J) > SINGULAR_CONDITION:
            K = D = np.full((6, 6), np.nan)
        else:
            Jinv = np.linalg.inv(J)
            K, D = Jinv.T @ np.diag(am.kq) @ Jinv, Jinv.T @ np.diag(am.dq) @ Jinv
        site = am.d_arm.site_xpos[scene.ft_site].copy()
        hand = np.zeros((6, 6))
        for b in am.hand:
            R = am.d_full.ximat[b].reshape(3, 3)
            hand += spatial_inertia(m.body_mass[b], am.d_full.xipos[b] - site, R @ np.diag(m.body_inertia[b]) @ R.T)
        for name, value in (("inertia", 0.5 * (Lam + Lam.T)), ("stiffness", K), ("damping", D), ("hand", hand),
                            ("site", site)):
            out[name].append(value)
    stacked = {k: (v[0] if single else np.stack(v)) for k, v in out.items()}
    return ArmImpedance(**stacked)


def task_blows(scene: Scene, task: Task, grasps: Grasps, q_traj: np.ndarray, *, grip_force: float):
    """The blow of `task`'s strongest impact for each grasp, as `transmission.Blow` inputs [N].

    The tool's pose and the impulse J come from the task (`wrench.task_loads`: the free tool's impulse,
    what the rigid model uses too); the arm's configuration at that sample from `q_traj` [N, T, 6]
    (`sim.arm.arm_trajectory` or `Plan.q_traj`); the pads hold with `grip_force` N each at the tool's mu.
    Returns (blows, step index k of the impact, ArmImpedance [N]).
    Raises InputError for a task without an impact (its contacts are slow: the servos hold, and the rigid
    model applies) or a grasp whose IK failed at the impact.
    """
    impulse = np.asarray(task_loads(scene.tool.params, task).impulse).sum(axis=1)  # [T]
    if not (impulse > 0).any():
        raise InputError(f"task_blows: task {task.kind!r} has no impact (its contacts are slow: the rigid model applies)")
    k = int(np.argmax(impulse))
    q = np.asarray(q_traj, float)[:, k]
    if not np.isfinite(q).all():
        raise InputError(f"task_blows: {int((~np.isfinite(q).all(1)).sum())} grasp(s) have no IK solution at the impact (sample {k})")
    arm = arm_impedance(scene, q)
    p = scene.tool.params
    R = np.asarray(task.traj.R_world_tool, float)[k]
    P = np.asarray(task.traj.p_world_tool, float)[k]
    com = R @ np.asarray(p.com, float) + P
    inertia = R @ np.asarray(p.inertia, float) @ R.T
    contact = R @ np.asarray(task.c_tool, float)[0] + P
    n = np.asarray(task.n_world, float)[0]
    site = arm.site  # [N, 3]
    tool6 = np.stack([spatial_inertia(float(p.mass), com - s, inertia) for s in site])
    wrench = np.concatenate([np.broadcast_to(n, site.shape), np.cross(contact - site, n)], axis=-1)
    axes = R @ quat_to_matrix_np(np.asarray(grasps.q_tool_grasp, float))  # [N, 3, 3] grasp axes (world)
    centre = np.asarray(grasps.p_tool_grasp, float) @ R.T + P  # [N, 3] the grasp centres (world)
    N = len(site)
    full = lambda v: np.full(N, float(v))  # noqa: E731
    blows = Blow(tool=tool6, wrench=wrench, impulse=full(impulse[k]), duration=full(p.contact_duration),
                 arm_inertia=arm.inertia, arm_stiffness=arm.stiffness, arm_damping=arm.damping, hand=arm.hand,
                 grasp_axes=axes, grasp_offset=centre - site, mu=full(p.mu),
                 width=np.asarray(grasps.width, float), grip_force=full(grip_force))
    return blows, k, arm

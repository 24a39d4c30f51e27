"""The arm's side of a rollout: inverse kinematics along the task, reachability, and the plan of controls.

    ok = reachable(task, grasps)                            # [N] bool: the arm can carry each grasp through
    p = plan(scene, task, grasps, physics, SimConfig())     # Plan: initial states and servo targets [N, ...]

The flange follows the task trajectory xi(t) through the closed-form UR5e inverse kinematics (`ik.py`),
the tool held at grasp g; a grasp is reachable when every sample has a solution within the joint limits
with the elbow and wrist above the table (`robot.ARM_CLEARANCE`). The plan holds what a backend steps:
each rollout's initial state (the tool in the closed pads) and its position and velocity servo targets.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from itup_jax import ik, robot
from itup_jax.errors import InputError, is_integer
from itup_jax.grasp import Grasps
from itup_jax.robot import ARM_CLEARANCE, FLANGE_TO_GRASP, HOME_Q, JOINT_LIMITS
from itup_jax.rotations import matrix_to_quat_np, pose_matrix, quat_to_matrix_np
from itup_jax.sim.config import SimConfig
from itup_jax.sim.physics import Physics
from itup_jax.sim.scene import Scene
from itup_jax.task import Task

#: Pads start this much inside the tool's surface so contact exists at step 0 (m).
INITIAL_SQUEEZE = 3e-4


@dataclasses.dataclass(frozen=True)
class Plan:
    """Everything a backend needs, arrays with leading [N]."""

    qpos0: np.ndarray  # [N, nq]
    ctrl: np.ndarray  # [N, nstep, nu]
    q_traj: np.ndarray  # [N, T, 6] IK solution at the trajectory samples
    infeasible: np.ndarray  # [N] bool
    over_speed: np.ndarray  # [N] bool, a joint faster than 180 deg/s
    nstep: int
    n_settle: int
    sim_t: np.ndarray  # [nstep] s, time of each recorded step from the start of the motion
    traj_index: np.ndarray  # [nstep] nearest trajectory sample of each step (-1 during settling)
    width: np.ndarray  # [N] m, the grasp's jaw opening
    mu: np.ndarray  # [N] -, the rollout's pad friction


def concat_plans(plans: list[Plan]) -> Plan:
    first = plans[0]
    cat = lambda f: np.concatenate([getattr(q, f) for q in plans])  # noqa: E731
    return dataclasses.replace(first, qpos0=cat("qpos0"), ctrl=cat("ctrl"), q_traj=cat("q_traj"),
                               infeasible=cat("infeasible"), over_speed=cat("over_speed"), width=cat("width"),
                               mu=cat("mu"))


def take_plan(p: Plan, idx: np.ndarray) -> Plan:
    """The plan of rollouts `idx` only."""
    return dataclasses.replace(p, qpos0=p.qpos0[idx], ctrl=p.ctrl[idx], q_traj=p.q_traj[idx],
                               infeasible=p.infeasible[idx], over_speed=p.over_speed[idx], width=p.width[idx],
                               mu=p.mu[idx])


def _as_slice(idx: np.ndarray):
    """A run of consecutive indices as a slice (a view, faster to assign through); others unchanged."""
    idx = np.asarray(idx)
    if idx.ndim == 1 and len(idx) and np.all(np.diff(idx) == 1):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def tool_grasp_poses(grasps: Grasps) -> np.ndarray:
    """[N, 4, 4] the grasp frames in the tool frame."""
    return pose_matrix(quat_to_matrix_np(np.asarray(grasps.q_tool_grasp, float)), np.asarray(grasps.p_tool_grasp, float))


def grasp_flange_pose() -> np.ndarray:
    """[4, 4] the flange in the grasp frame."""
    return pose_matrix(np.eye(3), np.array([0.0, 0.0, -FLANGE_TO_GRASP]))


def flange_poses(task: Task, grasps: Grasps, samples: slice = slice(None)) -> np.ndarray:
    """[N, T, 4, 4] the flange poses (world) that carry each grasp along the task's trajectory samples
    `samples` (all by default)."""
    tr = task.traj
    T_world_tool = pose_matrix(np.asarray(tr.R_world_tool, float)[samples], np.asarray(tr.p_world_tool, float)[samples])
    return T_world_tool[None] @ tool_grasp_poses(grasps)[:, None] @ grasp_flange_pose()


def _infeasible(q_traj: np.ndarray) -> np.ndarray:
    """[N] bool: IK failed at some sample of q_traj [N, T, 6] or a joint leaves its limits."""
    return np.isnan(q_traj).any(axis=(1, 2)) | (np.abs(np.nan_to_num(q_traj)) > JOINT_LIMITS).any(axis=(1, 2))


def arm_trajectory(task: Task, grasps: Grasps) -> tuple[np.ndarray, np.ndarray]:
    """The arm's joint trajectory that carries each grasp along the task: q_traj [N, T, 6] (rad, closed-form
    IK at the trajectory's samples; NaN where IK fails) and infeasible [N] (IK failed somewhere or a joint
    leaves its limits). Kinematics only: no scene, no physics."""
    q_traj = ik.track(flange_poses(task, grasps), HOME_Q, min_height=ARM_CLEARANCE)
    return q_traj, _infeasible(q_traj)


def infeasible_at_start(task: Task, grasps: Grasps) -> np.ndarray:
    """[N] bool: the grasps the arm cannot carry through the trajectory's first two samples. `ik.track`
    chooses each sample's posture from the samples before it alone, so each of them is infeasible for the
    whole task too (`arm_trajectory`); the converse does not hold."""
    return _infeasible(ik.track(flange_poses(task, grasps, slice(0, 2)), HOME_Q, min_height=ARM_CLEARANCE))


#: Candidates per `arm_trajectory` call in `reachable`: the IK's temporaries of 128 candidates x 64 samples
#: x 8 branches stay below the allocator's mmap threshold and are reused; one call on 2,000 candidates
#: costs ~3x the same work in chunks of 128 (each ~50 MB temporary is mapped and zeroed afresh).
REACHABLE_CHUNK = 128


def reachable(task: Task, grasps: Grasps) -> np.ndarray:
    """[N] bool: whether the arm can follow the task's trajectory holding each grasp (`arm_trajectory`;
    the complement of `plan(...).infeasible`, without building controls). The grasps the arm cannot
    carry through the first two samples are ruled out first (`infeasible_at_start`), the others checked
    over the whole trajectory in chunks of REACHABLE_CHUNK."""
    g = grasps.to_host(float)
    ok = np.zeros(len(g), bool)
    idx = np.nonzero(~infeasible_at_start(task, g))[0]
    for s in range(0, len(idx), REACHABLE_CHUNK):
        part = idx[s: s + REACHABLE_CHUNK]
        ok[part] = ~arm_trajectory(task, g[part])[1]
    return ok


#: Why a grasp is not reachable (`unreachable_reasons`), in the order they are tested.
UNREACHABLE_REASONS = ("out_of_reach", "below_table", "joint_limits")
#: What a reason means, for messages.
REASON_TEXT = {"out_of_reach": "put the flange where no arm posture reaches",
               "below_table": "would take the elbow or wrist below the table",
               "joint_limits": "would turn a joint past its limits"}


def unreachable_reasons(task: Task, grasps: Grasps) -> tuple[np.ndarray, np.ndarray]:
    """Why each grasp is (not) reachable: (code [N] int, -1 reachable or an index into UNREACHABLE_REASONS;
    first [N] int, the first trajectory sample where it fails, -1 when reachable).

    out_of_reach: at some sample no IK branch exists (the flange pose lies outside the arm's workspace);
    below_table: every sample has a branch, but the tracked posture dips below `robot.ARM_CLEARANCE`;
    joint_limits: the tracked posture leaves `robot.JOINT_LIMITS`. The same test as `arm_trajectory`,
    taken apart (its infeasible flag is code >= 0), in chunks of REACHABLE_CHUNK."""
    g = grasps.to_host(float)
    codes, firsts = [], []
    for s in range(0, len(g), REACHABLE_CHUNK):
        T06 = flange_poses(task, g[s: s + REACHABLE_CHUNK])
        sols = ik.inverse_kinematics(T06)
        none = np.isnan(sols).all(axis=-1).all(axis=-1)  # [n, T] no branch at a sample
        q = ik.track(T06, HOME_Q, min_height=ARM_CLEARANCE, solutions=sols)
        dips = np.isnan(q).any(-1)
        past = (np.abs(np.nan_to_num(q)) > JOINT_LIMITS).any(-1)
        code = np.full(len(T06), -1)
        first = np.full(len(T06), -1)
        for c, bad in ((2, past), (1, dips), (0, none)):  # the earliest-tested reason wins
            hit = bad.any(1)
            code[hit], first[hit] = c, np.argmax(bad[hit], axis=1)
        codes.append(code)
        firsts.append(first)
    return np.concatenate(codes), np.concatenate(firsts)


def unreachable_summary(task: Task, grasps: Grasps) -> dict:
    """{"checked", "reachable", reason: {"count", "first_t"}} over `grasps`: how many fail for each of
    UNREACHABLE_REASONS and the earliest time (s, on the task's trajectory) one of them fails."""
    code, first = unreachable_reasons(task, grasps)
    t = np.asarray(task.traj.t, float)
    out: dict = {"checked": int(len(code)), "reachable": int((code < 0).sum())}
    for c, name in enumerate(UNREACHABLE_REASONS):
        hit = code == c
        if hit.any():
            out[name] = {"count": int(hit.sum()), "first_t": round(float(t[first[hit].min()]), 3)}
    return out


def describe_unreachable(summary: dict, task: Task) -> str:
    """One sentence saying why the checked candidates are unreachable (`unreachable_summary`)."""
    parts = [f"{summary[name]['count']} {REASON_TEXT[name]} (from t = {summary[name]['first_t']} s)"
             for name in UNREACHABLE_REASONS if name in summary]
    impact = np.nonzero(np.asarray(task.impact).max(1) > 0)[0]
    when = (f"; the {task.kind} task's first impact is at t = {float(np.asarray(task.traj.t)[impact[0]]):.3f} s of "
            f"{float(np.asarray(task.traj.t)[-1]):.3f} s" if len(impact) else
            f"; the {task.kind} task lasts {float(np.asarray(task.traj.t)[-1]):.3f} s")
    return (f"of {summary['checked']} candidates checked, {summary['reachable']} are reachable: "
            + ", ".join(parts) + when)


def reachability_in_order(task: Task, grasps: Grasps, order, chunk: int = 16):
    """Yield (index, reachable) for the candidates `order` [M] (indices into grasps), in that order,
    checking `reachable` `chunk` candidates at a time (closed-form IK, ~0.2 ms a grasp warm): a caller
    that stops at the first reachable grasps of a ranking checks only as many chunks as it needs."""
    order = np.asarray(order, np.int64)
    if not is_integer(chunk) or chunk < 1:
        raise InputError(f"reachability_in_order: chunk must be an integer >= 1, got {chunk!r}")

    def walk():
        for s in range(0, len(order), chunk):
            idx = order[s: s + chunk]
            yield from zip(idx.tolist(), reachable(task, grasps[idx]).tolist())

    return walk()


def first_reachable(task: Task, grasps: Grasps, ranking: np.ndarray, *, check_first: int = 0) -> tuple[int | None, dict]:
    """(rank of the first reachable candidate of `ranking` or None, {index: reachable} of every candidate
    checked). Walks the ranking in chunks (`reachability_in_order`) until a reachable one is
    found and at least the first `check_first` are checked."""
    reachable: dict[int, bool] = {}
    rank_found = None
    for rank, (i, ok) in enumerate(reachability_in_order(task, grasps, ranking)):
        reachable[i] = ok
        if ok and rank_found is None:
            rank_found = rank
        if rank_found is not None and rank + 1 >= check_first:
            break
    return rank_found, reachable


def plan(scene: Scene, task: Task, grasps: Grasps, physics: Physics, config: SimConfig = SimConfig()) -> Plan:
    """Initial states and control sequences (IK of the grasp-frame trajectory), host side."""
    m = scene.model
    dt = m.opt.timestep
    n = len(grasps)
    tr = task.traj
    T_tool_grasp = tool_grasp_poses(grasps)  # [N]
    T_grasp_flange = grasp_flange_pose()
    q_traj, infeasible = arm_trajectory(task, grasps)
    t_traj = np.asarray(tr.t, float)
    q_safe = np.where(infeasible[:, None, None], HOME_Q, q_traj)
    over_speed = (np.abs(np.diff(q_safe, axis=1)) / np.diff(t_traj)[None, :, None] > robot.UR5E_MAX_JOINT_SPEED * 1.001).any(axis=(1, 2))

    n_settle = int(round(config.settle_time / dt))
    n_motion = int(round(t_traj[-1] / dt))
    nstep = n_settle + n_motion
    sim_t = (np.arange(nstep) + 1 - n_settle) * dt  # time after the motion started, at the end of each step
    t_clip = np.clip(sim_t, 0.0, t_traj[-1])
    traj_index = np.where(sim_t > 0, np.abs(t_traj[None, :] - t_clip[:, None]).argmin(1), -1)
    ctrl = np.zeros((n, nstep, m.nu))
    qd_safe = np.gradient(q_safe, t_traj, axis=1)  # joint velocities at the samples (rad/s)
    moving = (sim_t > 0) & (sim_t < t_traj[-1])
    # linear interpolation of the IK samples at each step's end (one time grid for every rollout)
    hi = np.clip(np.searchsorted(t_traj, t_clip, side="right"), 1, len(t_traj) - 1)
    w = ((t_clip - t_traj[hi - 1]) / (t_traj[hi] - t_traj[hi - 1]))[None, :, None]
    # (gathers of the samples and of their differences: two temporaries fewer than q[hi - 1] + w (q[hi] - q[hi - 1]),
    # the same numbers)
    seg = hi - 1
    ctrl[:, :, _as_slice(scene.arm_actuators)] = np.take(q_safe, seg, axis=1) + w * np.take(np.diff(q_safe, axis=1), seg, axis=1)
    ctrl[:, :, _as_slice(scene.arm_vel_actuators)] = moving[None, :, None] * (
        np.take(qd_safe, seg, axis=1) + w * np.take(np.diff(qd_safe, axis=1), seg, axis=1))
    ctrl[:, :, scene.grip_actuator] = physics.grip_force[:, None]

    # initial state: arm at the first IK sample, tool where the (actual) grasp frame holds it
    qpos0 = np.tile(m.qpos0, (n, 1))
    qpos0[:, scene.arm_qpos] = q_safe[:, 0]
    T_world_grasp0 = ik.forward_kinematics(q_safe[:, 0]) @ np.linalg.inv(T_grasp_flange)
    T_world_tool0 = T_world_grasp0 @ np.linalg.inv(T_tool_grasp)
    half = np.maximum(np.asarray(grasps.width, float) / 2 - INITIAL_SQUEEZE, 0.0)
    qpos0[:, scene.finger_qpos[0]] = half
    qpos0[:, scene.finger_qpos[1]] = half
    qpos0[:, scene.tool_qpos:scene.tool_qpos + 3] = T_world_tool0[:, :3, 3]
    qpos0[:, scene.tool_qpos + 3:scene.tool_qpos + 7] = [matrix_to_quat_np(T[:3, :3]) for T in T_world_tool0]
    return Plan(qpos0=qpos0, ctrl=ctrl, q_traj=q_traj, infeasible=infeasible, over_speed=over_speed, nstep=nstep,
                n_settle=n_settle, sim_t=sim_t, traj_index=traj_index,
                width=np.asarray(grasps.width, float).copy(), mu=np.asarray(physics.mu, float).copy())

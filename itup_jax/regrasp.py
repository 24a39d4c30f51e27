"""After a pick that cannot go on: the tool put back down, or turned over, and the table at rest again.

    back = regrasp.put_back(top, i, result, cands.q_path[k])   # lower, release, rise; the table at rest
    over = regrasp.turn_over(top, i, result)                    # lift, turn about the handle, let it fall

Both go on from a pick's end state (`pickup.execute_pick(..., keep_state=True)`) in the same MuJoCo
scene, and return the table with every tool's new rest pose, which the pipeline plans on again
(`pipeline.run(max_attempts=)`). A tool lying where no grasp the task can use is pickable is turned over
(`can_turn_over` says which picks can).
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from itup_jax import ik, robot
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps
from itup_jax.pickup import (
    OPEN_FORCE,
    PATH_SAMPLES,
    PICK_APPROACH,
    PICK_LIFT,
    PickResult,
    corners,
    ik_ok,
    jaw_preshape,
    mj_warnings,
    to_flange,
)
from itup_jax.rotations import axis_angle_matrix_np, quat_to_matrix_np
from itup_jax.tabletop import REST_SPEED, Tabletop, point_speeds, tool_poses

#: s, putting a tool back after a pick that cannot go on (`put_back`): lower it along the lift's path to
#: its first sample above the grasp (PICK_LIFT / PATH_SAMPLES, 10 mm), open the jaw, raise the open
#: gripper back up the lift's path; then the arm holds still until every tool is at rest (at least
#: PUT_BACK_SETTLE[0], at most PUT_BACK_SETTLE[1]).
PUT_BACK_PHASES = (0.8, 0.3, 0.8)
PUT_BACK_SETTLE = (0.3, 3.0)
#: Turning a tool over (`turn_over`), for a rest pose from which no grasp the task can use is pickable
#: (an L-stick lying with its hook up is picked from above only along the hook, and the reach needs the
#: opposite): m, the grasp point's height above the table while the tool turns; rad, the turn about the
#: tool's handle axis (either way, whichever the arm can follow): held tilted by it past where it
#: balanced, the tool falls onto another face when let go (turned a quarter turn, the lower finger
#: lies under it and carries it along as it withdraws); m, the gripper's lowest point above the table
#: when the jaw opens (to the pick's pre-shape opening only, so the lower finger does not sweep down
#: onto the table); s, the phases: rise, turn, lower, open, withdraw (back along the approach), then
#: the settling of PUT_BACK_SETTLE.
TURN_HEIGHT = 0.25
TURN_ANGLE = math.pi / 4
TURN_RELEASE = 0.01
TURN_PHASES = (0.6, 1.2, 0.8, 0.3, 0.8)


@dataclasses.dataclass(frozen=True)
class PutBack:
    """What putting a tool back did (`put_back`).

    Attributes:
      tabletop: the table with every tool's new rest pose (`settle_time`: this settling's time), or None
        when the simulation went unstable, the tools did not come to rest, or a tool was left touching
        the gripper (it does not rest on the table).
      why: None, or one sentence on why `tabletop` is None.
      trace: with `put_back(record_every=k)`, as `PickResult.trace` (times go on from the pick's).
    """

    tabletop: Tabletop | None
    why: str | None = None
    trace: dict | None = None


class _Going:
    """Drives a pick's MuJoCo state on (`put_back`, `turn_over`): the arm's servos along joint paths, the
    grip's force, every body's pose recorded every `record_every` steps."""

    def __init__(self, pick: PickResult, record_every: int | None):
        from itup_jax.robot import ARM_JOINTS

        self.m, self.d = pick.state
        m = self.m
        self.act = np.array([m.actuator(f"ur5e/{j}").id for j in ARM_JOINTS])
        self.act_v = np.array([m.actuator(f"ur5e/{j}_vel").id for j in ARM_JOINTS])
        self.arm_q = np.array([m.joint(f"ur5e/{j}").qposadr[0] for j in ARM_JOINTS])
        self.grip = m.actuator("gripper/grip").id
        self.every = record_every
        self.bodies = [b for b in range(1, m.nbody) if np.any(m.geom_bodyid == b)]
        self.rec_t, self.rec_p, self.rec_q, self.count = [], [], [], 0

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            mujoco.mj_step(self.m, self.d)
            if self.every and self.count % self.every == 0:
                self.rec_t.append(self.d.time)
                self.rec_p.append(self.d.xpos[self.bodies].copy())
                self.rec_q.append(self.d.xquat[self.bodies].copy())
            self.count += 1

    def hold(self, q: np.ndarray, force: float, duration: float) -> None:
        d = self.d
        d.ctrl[self.act], d.ctrl[self.act_v], d.ctrl[self.grip] = q, np.zeros(6), force
        self.step(int(round(duration / self.m.opt.timestep)))

    def open_to(self, q: np.ndarray, width: float, duration: float) -> None:
        """Hold the arm at `q` [6] while the jaw opens to `approach_opening(width)` (the pre-shape servo,
        within +-OPEN_FORCE, as the pick approaches): the tool is let go of without the fingers
        sweeping their whole stroke."""
        m, d = self.m, self.d
        _, servo = jaw_preshape(m, d, width)
        self.jaw = servo
        d.ctrl[self.act], d.ctrl[self.act_v] = q, np.zeros(6)
        for _ in range(int(round(duration / m.opt.timestep))):
            d.ctrl[self.grip] = servo()
            self.step()

    def follow(self, path: np.ndarray, duration: float, force: float | None) -> None:
        """Along joint path [P, 6] in `duration` s (linear between samples, the servos' velocity feed-forward),
        the grip at `force` N (None: the jaw held at the opening of the last `open_to`)."""
        d, dt, n = self.d, self.m.opt.timestep, len(path) - 1
        for k in range(int(round(duration / dt))):
            s = (k + 1) * dt / duration * n
            i0 = min(int(s), n - 1)
            d.ctrl[self.act] = path[i0] + (s - i0) * (path[i0 + 1] - path[i0])
            d.ctrl[self.act_v] = (path[i0 + 1] - path[i0]) * n / duration
            d.ctrl[self.grip] = self.jaw() if force is None else force
            self.step()

    def settle(self, top: Tabletop, what: str) -> PutBack:
        """Hold the arm still until every tool is at rest (PUT_BACK_SETTLE); the table as it then lies."""
        m, d = self.m, self.d
        d.ctrl[self.act], d.ctrl[self.act_v] = d.qpos[self.arm_q], np.zeros(6)
        t, speed, check = 0.0, math.inf, int(round(0.05 / m.opt.timestep))
        unstable = f"{what} went unstable (MuJoCo)"
        while t < PUT_BACK_SETTLE[1]:
            self.step(check)
            t += check * m.opt.timestep
            if not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel))):
                return self.result(None, unstable)
            speed = point_speeds(m, d, top.tools)
            if t >= PUT_BACK_SETTLE[0] and speed < REST_SPEED:
                break
        else:
            return self.result(None, f"the tools had not come to rest {PUT_BACK_SETTLE[1]:g} s after {what} "
                               f"(fastest point {speed:.3f} m/s)")
        if mj_warnings(d):
            return self.result(None, unstable)
        # a tool still touching the gripper (left in the open jaw) is not at rest on the table
        gripper = {g for g in range(m.ngeom) if m.geom(g).name.startswith("gripper/")}
        tool_bodies = {m.body(f"tool_{i}").id for i in range(len(top.tools))}
        for c in d.contact[:d.ncon]:
            g1, g2 = int(c.geom1), int(c.geom2)
            if (g1 in gripper and int(m.geom_bodyid[g2]) in tool_bodies) or (
                    g2 in gripper and int(m.geom_bodyid[g1]) in tool_bodies):
                return self.result(None, f"a tool stayed in the open jaw after {what}")
        return self.result(dataclasses.replace(top, poses=tool_poses(m, d, len(top.tools)), settle_time=float(t),
                                               rest_speed=float(speed)))

    def result(self, tabletop: Tabletop | None, why: str | None = None) -> PutBack:
        trace = None
        if self.every:
            nb = len(self.bodies)
            trace = {"t": np.array(self.rec_t), "bodies": self.bodies, "pos": np.array(self.rec_p).reshape(-1, nb, 3),
                     "quat": np.array(self.rec_q).reshape(-1, nb, 4), "model": self.m}
        return PutBack(tabletop=tabletop, why=why, trace=trace)


def _check_state(pick: PickResult, what: str) -> None:
    if pick.state is None:
        raise InputError(f"{what}: the pick was run without keep_state=True; there is no state to go on from")


def put_back(top: Tabletop, index: int, pick: PickResult, q_path: np.ndarray, *,
             grip_force: float = robot.GRIP_FORCE, record_every: int | None = None) -> PutBack:
    """Put table tool `index` back down after `pick` (run with `keep_state=True` along `q_path`) and let
    the table settle: the arm lowers along the lift's path to PICK_LIFT / PATH_SAMPLES above the grasp
    (10 mm; a tool that came up turned or only partly drops at most that far), the jaw opens, the open
    gripper rises back up the lift's path and holds still while the tools come to rest (PUT_BACK_PHASES,
    PUT_BACK_SETTLE). The pick's state goes on (it is used up)."""
    _check_state(pick, "put_back")
    go = _Going(pick, record_every)
    up = np.asarray(q_path, float)[PATH_SAMPLES + 1:]  # the lift's path from its first sample above the grasp
    t_lower, t_open, t_raise = PUT_BACK_PHASES
    go.follow(up[::-1], t_lower, grip_force)
    go.hold(up[0], -OPEN_FORCE, t_open)
    go.follow(up, t_raise, -OPEN_FORCE)
    return go.settle(top, "putting it back down")


def turn_path(T_world_grasp: np.ndarray, axis: np.ndarray, width: float, angle: float) -> np.ndarray:
    """[4 PATH_SAMPLES + 1, 4, 4] flange poses that turn a held tool over: from the grasp frame
    `T_world_grasp` [4, 4] straight up to TURN_HEIGHT, a turn by `angle` rad about the world `axis` [3]
    through the grasp point, down until the gripper's lowest point (its boxes at the jaw's `width` m) is
    TURN_RELEASE above the table; then (after the jaw opens) back along the turned approach axis by
    PICK_APPROACH."""
    s = np.linspace(0.0, 1.0, PATH_SAMPLES + 1)
    T0 = np.asarray(T_world_grasp, float)
    poses = [T0.copy() for _ in s]
    for T, x in zip(poses, s):
        T[2, 3] += x * (TURN_HEIGHT - T0[2, 3])
    top = poses[-1]
    for x in s[1:]:
        T = top.copy()
        T[:3, :3] = axis_angle_matrix_np(axis, angle * x) @ top[:3, :3]
        poses.append(T)
    turned = poses[-1]
    lowest = float(np.min(np.einsum("j,cj->c", turned[:3, :3][2], corners(np.array([width]))[0])))
    drop = turned[2, 3] + lowest - TURN_RELEASE
    for x in s[1:]:
        T = turned.copy()
        T[2, 3] -= x * drop
        poses.append(T)
    down = poses[-1]
    for x in s[1:]:
        T = down.copy()
        T[:3, 3] -= x * PICK_APPROACH * down[:3, 2]
        poses.append(T)
    return to_flange(np.stack(poses))


def _turn_axis(R_world_tool: np.ndarray) -> np.ndarray | None:
    """The horizontal direction of the tool's handle axis (+z), or None when the handle stands too
    steeply (more than ~72 degrees) for a turn about it to lay the tool on another face."""
    h = np.asarray(R_world_tool, float)[:, 2]
    axis = np.array([h[0], h[1], 0.0])
    return axis if np.linalg.norm(axis) >= 0.3 else None


def can_turn_over(top: Tabletop, index: int, grasps: Grasps, q_paths: np.ndarray) -> np.ndarray:
    """[M] bool: the arm can follow `turn_path` (either way) from the end of each pick's planned lift:
    grasps [M] of table tool `index` (tool frame, as `pick_candidates` returns them) with their joint
    paths `q_paths` [M, P, 6]. The planned grasp stands in for the achieved one (`turn_over` plans again
    from the achieved)."""
    T_wt = np.asarray(top.poses[index], float)
    axis = _turn_axis(T_wt[:3, :3])
    m = len(np.asarray(grasps.width).reshape(-1))
    if axis is None or m == 0:
        return np.zeros(m, bool)
    R_wg = T_wt[:3, :3] @ quat_to_matrix_np(np.asarray(grasps.q_tool_grasp, float).reshape(-1, 4))
    p_wg = np.asarray(grasps.p_tool_grasp, float).reshape(-1, 3) @ T_wt[:3, :3].T + T_wt[:3, 3]
    width = np.asarray(grasps.width, float).reshape(-1)
    ok = np.zeros(m, bool)
    for angle in (TURN_ANGLE, -TURN_ANGLE):
        paths = []
        for k in range(m):
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R_wg[k], p_wg[k] + [0.0, 0.0, PICK_LIFT]
            paths.append(turn_path(T, axis, float(width[k]), angle))
        q = ik.track(np.stack(paths), np.asarray(q_paths, float)[:, -1], min_height=robot.ARM_CLEARANCE)
        ok |= ik_ok(q)
    return ok


def turn_over(top: Tabletop, index: int, pick: PickResult, *, grip_force: float = robot.GRIP_FORCE,
              record_every: int | None = None) -> PutBack:
    """Turn table tool `index`, lifted by `pick` (run with `keep_state=True`), over about its handle axis
    and let it fall onto another face: up to TURN_HEIGHT, a turn of TURN_ANGLE (whichever way the arm can
    follow, `turn_path`, closed-form IK with the elbow and wrist above the table), down until the gripper
    is TURN_RELEASE above the table, the jaw opened to the pick's pre-shape opening (`approach_opening`),
    the gripper back along its approach, the table settled (PUT_BACK_SETTLE).
    The pick's state goes on (it is used up). `PutBack.tabletop` is None, with why, when neither way
    can be followed, the tool was not held, or the table did not come to rest."""
    _check_state(pick, "turn_over")
    if not pick.lifted:
        return PutBack(tabletop=None, why="the tool was not held; it cannot be turned over")
    go = _Going(pick, record_every)
    m, d = go.m, go.d
    site = m.site("gripper/grasp").id
    T_wg = np.eye(4)
    T_wg[:3, :3], T_wg[:3, 3] = d.site_xmat[site].reshape(3, 3), d.site_xpos[site]
    tq = m.joint(f"tool_{index}").qposadr[0]
    axis = _turn_axis(quat_to_matrix_np(d.qpos[tq + 3:tq + 7].copy()))
    if axis is None:
        return PutBack(tabletop=None, why="the tool's handle is not lying along the table; it cannot be turned over")
    width = float(np.asarray(pick.achieved.width, float)[0])
    q_now = d.qpos[go.arm_q].copy()
    n = PATH_SAMPLES
    for angle in (TURN_ANGLE, -TURN_ANGLE):
        q = ik.track(turn_path(T_wg, axis, width, angle)[None], q_now, min_height=robot.ARM_CLEARANCE)[0]
        if ik_ok(q):
            break
    else:
        return PutBack(tabletop=None, why="the arm cannot turn the tool over either way (IK)")
    t_rise, t_turn, t_lower, t_open, t_back = TURN_PHASES
    go.follow(np.concatenate([q_now[None], q[:n + 1]]), t_rise, grip_force)
    go.follow(q[n:2 * n + 1], t_turn, grip_force)
    go.follow(q[2 * n:3 * n + 1], t_lower, grip_force)
    go.open_to(q[3 * n], width, t_open)
    go.follow(q[3 * n:], t_back, None)
    return go.settle(top, "turning it over")

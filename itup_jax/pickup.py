"""Picking a tool up from the table: grasps the arm can take from above, and the pick rolled out in MuJoCo.

    from itup_jax import pickup
    cands = pickup.pick_candidates(top, i, tool, grasps)   # which grasps can be picked from the rest pose
    result = pickup.execute_pick(top, i, cands.grasps[k:k+1], cands.q_path[k], keep_state=True)

After a pick that cannot go on, `regrasp` puts the tool back down or turns it over.

A grasp sampled on the tool (`grasp_sampler`, tool frame) is turned into a pick from the tool's resting
pose (`tabletop.Tabletop.poses`):

  * its approach axis must point down, within MAX_APPROACH_TILT of the vertical;
  * the gripper must clear the table: where the pads would reach below it (a handle lying on the
    table is thinner than the pads are long), the grasp moves up along its approach axis until the
    gripper's lowest point is TABLE_CLEARANCE above the table, so that the tool sits nearer the
    fingertips; at most by MAX_PAD_SHIFT (the pads must still cover the grasp point);
  * the open gripper (pads, fingers and palm boxes, `grasp.gripper_boxes`, pre-shaped to the opening it
    approaches with, `approach_opening`: the grasp's width plus PICK_CLEARANCE a side) must touch no
    other tool and not the tool itself, at the grasp and along the approach;
  * the tool must not turn in the pads as it comes up: the torque about the jaw's closure axis (the axis
    the pads resist only by torsional friction) of the tool's weight and of the other tools' loads as
    it is carried straight up (`lift_loads`: a tool lying across it, or hooked under it, is carried
    too) must stay within LIFT_TORQUE_SHARE of the pads' torsional capacity, 2 PAD_TORSION x grip force
    (`lift_torque`; a broom held at the top of its handle turned ~20 degrees in the pads during the
    lift, and a stick under a heavy tool turned 16 degrees and dragged three tools with it; chosen with
    `experiments/lift_torque.py`), and the weight alone never past LIFT_TORQUE_LIMIT. When no grasp
    stays within the share the pipeline plans with the ones that load it least (`pipeline.LIFT_FALLBACK_SPREAD`);
  * closed-form IK must reach the pre-grasp (PICK_APPROACH back along the approach axis), the grasp and
    the lift (PICK_LIFT straight up), with the elbow and wrist above the table.
The shifted grasps are what the pipeline then scores and plans with (`pipeline`).

`execute_pick` rolls the pick out natively in MuJoCo (step PICK_TIMESTEP) in a scene with the table,
every tool at rest, the UR5e and the gripper: the arm starts at the pre-grasp with the jaw pre-shaped
to `approach_opening` (a servo on the grip actuator holds it there),
descends along the approach, closes (the grip force rises to `grip_force` per pad over GRIP_RAMP),
lifts PICK_LIFT and holds. It measures, rather than assumes, the grasp it achieved: the tool's pose in
the grasp frame after the lift (`PickResult.achieved`), its error against the planned grasp, and
whether the tool came up in the pads. The gripper's actuator opens the jaw with a negative force in
this scene only (the task scenes hold a closed grip throughout).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import mujoco
import numpy as np

from itup_jax import ik, robot, units
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, gripper_boxes, make_grasps
from itup_jax.grasp_sampler import collision_points, gripper_collides
from itup_jax.rotations import quat_to_matrix_np
from itup_jax.sim.scene import attach_robot
from itup_jax.tabletop import (
    NOSLIP_ITERATIONS,
    ROLLING_FRICTION,
    TABLE_FRICTION,
    Tabletop,
    add_table_tool,
    rest_loads,
    tool_contacts,
    tools_spec,
)
from itup_jax.tools import Tool

#: rad, the largest angle between a pick's approach axis and straight down.
MAX_APPROACH_TILT = math.radians(35.0)
#: m, the gripper's lowest point above the table at the grasp.
TABLE_CLEARANCE = 0.002
#: m, how far a grasp may move up its approach axis to clear the table: the pad's half-length less
#: 0.5 mm, so that the grasp point stays on the pad (a 6 mm rod lying on the table, grasped from straight
#: above, needs 14.75 mm: a fingertip pinch).
MAX_PAD_SHIFT = robot.PAD_LENGTH / 2 - 0.0005
#: m, the narrowest jaw opening that counts as holding something after the lift.
MIN_HELD_WIDTH = 0.001
#: m, the pre-grasp's distance back along the approach axis, and the lift's height.
PICK_APPROACH = 0.10
PICK_LIFT = 0.12
#: m, the open gripper's extra opening per side, and the margin of its boxes against other tools.
PICK_CLEARANCE = 0.005
PICK_MARGIN = 0.002
#: N/m, N s/m: the jaw's pre-shape servo (pad opening held at `approach_opening` while the arm settles
#: and approaches; its force within +-OPEN_FORCE), as a position-controlled 2F-85 opens to a set width.
PRESHAPE_GAIN = 4000.0
PRESHAPE_DAMPING = 40.0
#: s, the pick's step and phases: settle at the pre-grasp, approach, close (the force ramps over
#: GRIP_RAMP), lift, hold.
PICK_TIMESTEP = 0.002
PICK_PHASES = (0.1, 0.7, 0.5, 0.8, 0.3)
GRIP_RAMP = 0.15
#: N, the force that holds the jaw open while approaching.
OPEN_FORCE = 20.0
#: -, share of PICK_LIFT the tool must rise for the pick to count as lifted.
LIFT_SHARE = 0.7
#: -, shares of the pads' torsional capacity (`lift_torque`): a pick is planned within LIFT_TORQUE_SHARE
#: with the other tools' loads over the simulated lift counted (`lift_loads`), and the tool's weight alone
#: may never load more than LIFT_TORQUE_LIMIT. Chosen on tables 0-9 (`experiments/lift_torque.py`: the
#: largest share below which every band of 0.25 held in >= 95 % of picks, a pick holding when it came up
#: turned less than the labels' 10 degrees in the pads): without clutter 558 of 564 picks within the
#: capacity held, 52 of 76 past it; with four extra tools 397 of 401 within it, 88 of 227 past it.
LIFT_TORQUE_SHARE = 1.0
LIFT_TORQUE_LIMIT = 1.0
#: s: the step of the simulated rigid lift (`lift_loads`), and the window its torques are averaged over
#: (a grip turns under a sustained torque, not under a contact's spike).
LIFT_SIM_STEP = 0.002
LIFT_WINDOW = 0.05
#: IK samples per straight segment of the pick's path.
PATH_SAMPLES = 12


@dataclasses.dataclass(frozen=True)
class PickCandidates:
    """Grasps that can be picked from the rest pose (tool frame, shifted to clear the table).

    Attributes:
      grasps: `Grasps` [M], the pickable grasps (shifted).
      index: [M] their indices in the grasps given.
      shift: [M] m, how far each moved up its approach axis.
      q_path: [M, 2 PATH_SAMPLES + 1, 6] rad, the arm's joint path: pre-grasp -> grasp -> lift.
      lift_load: [M] the torque about the closure axis that the tool's weight and the other tools' loads
        over the lift load the grasp with, as a share of the pads' torsional capacity (`lift_torque`).
      counts: how many were given, pointed down, cleared the table, cleared the tools, would hold in the
        lift (`lift_torque`), had IK.
    """

    grasps: Grasps
    index: np.ndarray
    shift: np.ndarray
    q_path: np.ndarray
    lift_load: np.ndarray
    counts: dict


def approach_opening(width: np.ndarray) -> np.ndarray:
    """m: the jaw opening a pick approaches with (pre-shaped), per grasp width [M] m: the width plus
    PICK_CLEARANCE a side, at most the stroke. The clearance checks and `execute_pick` both use it."""
    return np.minimum(np.asarray(width, float) + 2 * PICK_CLEARANCE, robot.GRIPPER_MAX_OPENING)


def corners(width: np.ndarray) -> np.ndarray:
    """[M, 24, 3] the corners of the pre-shaped gripper's boxes (`approach_opening`) in the grasp frame."""
    out = []
    for _, lo, hi in gripper_boxes(approach_opening(width)):
        for c in range(8):
            out.append(np.where([(c >> k) & 1 for k in range(3)], hi, lo))
    return np.stack(out, axis=1)


def to_flange(T_world_grasp: np.ndarray) -> np.ndarray:
    """[..., 4, 4] the flange poses (what the IK solves for) of grasp-frame poses [..., 4, 4]: FLANGE_TO_GRASP
    back along the approach axis."""
    flange = np.eye(4)
    flange[2, 3] = -robot.FLANGE_TO_GRASP
    return T_world_grasp @ flange


def ik_ok(q: np.ndarray) -> np.ndarray:
    """[...] bool: joint paths q [..., P, 6] (`ik.track`) reachable at every sample and within the joint limits."""
    return ~np.isnan(q).any(axis=(-2, -1)) & ~(np.abs(np.nan_to_num(q)) > robot.JOINT_LIMITS).any(axis=(-2, -1))


def mj_warnings(d: mujoco.MjData) -> int:
    """How often MuJoCo met a bad acceleration, velocity or position (and reset the state)."""
    return sum(int(d.warning[w].number) for w in (mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL,
                                                  mujoco.mjtWarning.mjWARN_BADQPOS))


def jaw_preshape(m: mujoco.MjModel, d: mujoco.MjData, width: float):
    """(q_open, servo): the finger joints' position at which the pads stand `approach_opening(width)` apart
    (pad faces INITIAL_SQUEEZE past qpos), and the grip actuator's force that holds them there
    (PRESHAPE_GAIN, PRESHAPE_DAMPING, within +-OPEN_FORCE) in the state `d`."""
    from itup_jax.sim.arm import INITIAL_SQUEEZE

    fq = [m.joint(f"gripper/finger_{s}").qposadr[0] for s in ("neg", "pos")]
    fv = [m.joint(f"gripper/finger_{s}").dofadr[0] for s in ("neg", "pos")]
    q_open = float(approach_opening(np.array([width], float))[0]) / 2 - INITIAL_SQUEEZE

    def servo() -> float:
        f = PRESHAPE_GAIN * (d.qpos[fq].mean() - q_open) + PRESHAPE_DAMPING * d.qvel[fv].mean()
        return float(np.clip(f, -OPEN_FORCE, OPEN_FORCE))
    return q_open, servo


def world_paths(T_world_grasp: np.ndarray) -> np.ndarray:
    """[M, 2 PATH_SAMPLES + 1, 4, 4] flange poses: pre-grasp -> grasp -> lift (straight lines)."""
    s = np.linspace(0.0, 1.0, PATH_SAMPLES + 1)
    approach = T_world_grasp[:, :3, 2]
    offs = np.concatenate([-PICK_APPROACH * (1 - s)[None, :, None] * approach[:, None, :],
                           np.broadcast_to(PICK_LIFT * s[1:, None] * np.array([0.0, 0.0, 1.0]),
                                           (len(approach), PATH_SAMPLES, 3))], axis=1)  # [M, P, 3]
    T = np.repeat(T_world_grasp[:, None], offs.shape[1], axis=1).copy()
    T[..., :3, 3] += offs
    return to_flange(T)


@functools.lru_cache(maxsize=8)
def lift_loads(top: Tabletop, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The forces the other tools exert on tool `index` while it is carried rigidly straight up from its
    rest pose: PICK_LIFT at constant speed over the pick's lift time, then held for its hold time (a
    MuJoCo scene of the table and the tools, the lifted one moved as a mocap body; the others fall,
    slide and are carried as they would be). Returns (t [S] s, h [S] m the height it has risen, F [S, 3] N
    the total force on it, M [S, 3] N m their moment about the world origin), every LIFT_SIM_STEP.
    At t = 0 they are the loads at rest on the tool held fixed (near `tabletop.rest_loads`; a tool lying
    on it and on the table shares its weight between them differently when one of them cannot sink);
    a tool lying across it, or hooked under it, is carried. Cached per table (a `Tabletop` is
    immutable)."""
    if not 0 <= index < len(top.tools):
        raise InputError(f"lift_loads: index {index} is not one of the table's 0-{len(top.tools) - 1}")
    spec = tools_spec(top.tools, top.poses, LIFT_SIM_STEP)
    spec.delete(spec.joint(f"tool_{index}"))
    spec.body(f"tool_{index}").mocap = True
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    body = m.body(f"tool_{index}").id
    mocap = int(m.body_mocapid[body])
    start = d.mocap_pos[mocap].copy()
    t_lift, t_hold = PICK_PHASES[3], PICK_PHASES[4]
    n = int(round((t_lift + t_hold) / LIFT_SIM_STEP))
    t = np.arange(n + 1) * LIFT_SIM_STEP
    h = PICK_LIFT * np.minimum(t / t_lift, 1.0)
    F, M = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    for s in range(n + 1):
        if s:
            d.mocap_pos[mocap] = start + [0.0, 0.0, h[s]]
            mujoco.mj_step(m, d)
        at, f = tool_contacts(m, d, body)
        F[s], M[s] = f.sum(0), np.cross(at, f).sum(0)
    for a in (t, h, F, M):  # cached: shared by every caller
        a.flags.writeable = False
    return t, h, F, M


def lift_torque(top: Tabletop, index: int, tool: Tool, p_tool_grasp: np.ndarray, R_tool_grasp: np.ndarray, *,
                grip_force: float = robot.GRIP_FORCE, loads: str | None = "lift") -> np.ndarray:
    """[M] the torque about each grasp's closure axis, at the grasp point, that the lift must hold, as a
    share of the pads' torsional capacity 2 PAD_TORSION x `grip_force`: the tool's weight and, by
    `loads`, the forces of the other tools, 'lift' (`lift_loads`: the largest over the simulated lift
    of their torque averaged over LIFT_WINDOW), 'rest' (`tabletop.rest_loads`) or None (the weight
    alone). Grasps [M] in the tool frame: `p_tool_grasp` [M, 3] m, `R_tool_grasp` [M, 3, 3]; the tool
    `index` of `top` at its rest pose. About the closure axis the pads hold by torsional friction alone
    (the other two axes are held by the pads' faces), so a grasp far from the centre of mass, or from a
    tool lying across it, turns in the pads as it comes up."""
    if loads not in ("lift", "rest", None):
        raise InputError(f"lift_torque: loads must be 'lift', 'rest' or None, got {loads!r}")
    T_wt = np.asarray(top.poses[index], float)
    p_w = np.asarray(p_tool_grasp, float) @ T_wt[:3, :3].T + T_wt[:3, 3]
    closure = np.einsum("ij,mj->mi", T_wt[:3, :3], np.asarray(R_tool_grasp, float)[:, :, 1])
    com_w = T_wt[:3, :3] @ np.asarray(tool.params.com, float) + T_wt[:3, 3]
    weight = np.array([0.0, 0.0, -float(tool.params.mass) * units.STANDARD_GRAVITY])
    tau = np.einsum("mj,mj->m", np.cross(com_w - p_w, weight), closure)  # the weight's: the same all along
    if loads is not None and len(tau):
        # the other tools' loads as a series (h [S] m risen, F [S, 3] N, M [S, 3] N m about the origin):
        # the simulated lift's, or the rest loads as one step
        if loads == "lift":
            _, h, F, M = lift_loads(top, index)
        else:
            c, f = rest_loads(top, index)
            h, F, M = np.zeros(1), f.sum(0)[None], np.cross(c, f).sum(0)[None]
        # about the grasp point as it rises: M - (p + h z) x F, on the closure axis (it does not turn)
        lever = p_w[None, :, :] + h[:, None, None] * np.array([0.0, 0.0, 1.0])
        on_axis = np.einsum("sj,mj->sm", M, closure) - np.einsum("smj,mj->sm", np.cross(lever, F[:, None, :]), closure)
        w = min(max(int(round(LIFT_WINDOW / LIFT_SIM_STEP)), 1), len(h))
        run = np.cumsum(np.concatenate([np.zeros((1, len(tau))), tau[None, :] + on_axis]), axis=0)
        tau = np.abs((run[w:] - run[:-w]) / w).max(axis=0)
    return np.abs(tau) / (2 * robot.PAD_TORSION * float(grip_force))


def pick_candidates(top: Tabletop, index: int, tool: Tool, grasps: Grasps, *,
                    grip_force: float = robot.GRIP_FORCE, lift_torque_share: float = LIFT_TORQUE_SHARE,
                    lift_torque_limit: float = LIFT_TORQUE_LIMIT) -> PickCandidates:
    """The grasps [N] (tool frame) of the table's tool `index` that can be picked from its rest pose with
    `grip_force` N per pad, shifted to clear the table (module docstring). `tool` is that tool (its
    grounded form: the mass and mesh are the table's tool's). `lift_torque_share`: the largest
    `PickCandidates.lift_load` kept; `lift_torque_limit`: the largest share the tool's weight alone may
    load (math.inf for either keeps all, as the calibration does)."""
    if not 0 <= index < len(top.tools):
        raise InputError(f"pick_candidates: index {index} is not one of the table's 0-{len(top.tools) - 1}")
    T_wt = np.asarray(top.poses[index], float)
    p = np.asarray(grasps.p_tool_grasp, float)
    R_tg = quat_to_matrix_np(np.asarray(grasps.q_tool_grasp, float))
    w = np.asarray(grasps.width, float)
    R_wg = T_wt[:3, :3] @ R_tg
    counts = {"given": len(p)}
    down = -R_wg[:, 2, 2] >= math.cos(MAX_APPROACH_TILT)
    counts["pointing_down"] = int(down.sum())
    # lowest gripper corner above the table; raise along -approach (world +z share -R_wg[2, 2])
    gripper = corners(w)  # [M, 24, 3]
    p_w = p @ T_wt[:3, :3].T + T_wt[:3, 3]
    z_low = p_w[:, 2] + np.einsum("mj,mcj->mc", R_wg[:, 2, :], gripper).min(1)
    rise = np.maximum(-R_wg[:, 2, 2], 1e-6)
    shift = np.maximum(TABLE_CLEARANCE - z_low, 0.0) / rise
    ok = down & (shift <= MAX_PAD_SHIFT)
    counts["clear_of_table"] = int(ok.sum())
    p_s = p - shift[:, None] * R_tg[:, :, 2]
    # the open gripper against every tool at the grasp and along the approach (in this tool's frame)
    T_tw = np.linalg.inv(T_wt)
    opening = approach_opening(w)
    for j, (other, T_wo) in enumerate(zip(top.tools, top.poses)):
        if not ok.any():
            break
        pts = collision_points(other, 0.004) @ T_wo[:3, :3].T + T_wo[:3, 3]
        pts = pts @ T_tw[:3, :3].T + T_tw[:3, 3]
        idx = np.nonzero(ok)[0]
        steps = (0.0,) if j == index else (0.0, PICK_APPROACH / 3, 2 * PICK_APPROACH / 3, PICK_APPROACH)
        for back in steps:
            if len(idx) == 0:
                break
            hit = gripper_collides(pts, R_tg[idx], p_s[idx] - back * R_tg[idx, :, 2], opening[idx],
                                   PICK_MARGIN if j != index else 0.0)
            ok[idx[hit]] = False
            idx = idx[~hit]
    counts["clear_of_tools"] = int(ok.sum())
    lift_load = np.full(len(p), np.inf)  # computed for the grasps still in (the lift's is [steps, M])
    idx = np.nonzero(ok)[0]
    if len(idx):
        lift_load[idx] = lift_torque(top, index, tool, p_s[idx], R_tg[idx], grip_force=grip_force)
        ok[idx] &= (lift_load[idx] <= lift_torque_share) & (
            lift_torque(top, index, tool, p_s[idx], R_tg[idx], grip_force=grip_force, loads=None) <= lift_torque_limit)
    counts["held_in_lift"] = int(ok.sum())
    idx = np.nonzero(ok)[0]
    T_wg = np.tile(np.eye(4), (len(idx), 1, 1))
    T_wg[:, :3, :3] = R_wg[idx]
    T_wg[:, :3, 3] = p_s[idx] @ T_wt[:3, :3].T + T_wt[:3, 3]
    q = ik.track(world_paths(T_wg), robot.HOME_Q, min_height=robot.ARM_CLEARANCE) if len(idx) else np.zeros((0, 2 * PATH_SAMPLES + 1, 6))
    good = ik_ok(q)
    counts["reachable"] = int(good.sum())
    idx, q = idx[good], q[good]
    out = make_grasps(p_s[idx], R_tg[idx], w[idx]) if len(idx) else None
    return PickCandidates(grasps=out, index=idx, shift=shift[idx], q_path=q, lift_load=lift_load[idx], counts=counts)


#: The pick's typical error (measured: a few millimetres, a few degrees): a candidate is carried through
#: the task with margin when the grasp moved REACH_MARGIN_SHIFT along its x axis or turned
#: REACH_MARGIN_TURN about its closure axis, either way, still is (`reachable_with_margin`).
REACH_MARGIN_SHIFT = 0.005
REACH_MARGIN_TURN = math.radians(4.0)


def reachable_with_margin(task, grasps: Grasps) -> np.ndarray:
    """[N] bool: each grasp and its four perturbations (+-REACH_MARGIN_SHIFT along the grasp's x axis,
    +-REACH_MARGIN_TURN about its closure axis) can all be carried through `task` (`sim.arm.reachable`):
    the grasp a pick achieves, a few millimetres and degrees off, can still do the task."""
    from itup_jax.sim.arm import reachable

    p = np.asarray(grasps.p_tool_grasp, float)
    R = quat_to_matrix_np(np.asarray(grasps.q_tool_grasp, float))
    w = np.asarray(grasps.width, float)
    ps, Rs = [p], [R]
    for sgn in (-1.0, 1.0):
        ps.append(p + sgn * REACH_MARGIN_SHIFT * R[:, :, 0])
        Rs.append(R)
        c, s_ = math.cos(sgn * REACH_MARGIN_TURN), math.sin(sgn * REACH_MARGIN_TURN)
        turn = np.array([[c, 0.0, s_], [0.0, 1.0, 0.0], [-s_, 0.0, c]])  # about the grasp's y (closure) axis
        ps.append(p)
        Rs.append(R @ turn)
    allg = make_grasps(np.concatenate(ps), np.concatenate(Rs), np.tile(w, len(ps)))
    return reachable(task, allg).reshape(len(ps), len(p)).all(axis=0)


@dataclasses.dataclass(frozen=True)
class PickResult:
    """What a pick did.

    Attributes:
      lifted: the tool rose at least LIFT_SHARE of PICK_LIFT, both pads touch it and the jaw is open at
        least MIN_HELD_WIDTH (the tool is between the pads).
      rise: m, how far the tool's centre of mass rose.
      achieved: `Grasps` [1], the grasp after the lift (tool frame), measured; None when not lifted.
      position_error: m, the achieved grasp origin's distance from the planned one (tool frame).
      angle_error: rad, the rotation between the achieved and the planned grasp frames.
      pads_touching: how many pads touch the tool at the end (0-2).
      diverged: the simulation went unstable (a non-finite state, MuJoCo's warning); never lifted.
      trace: with `execute_pick(record_every=k)`: {"t" [S] s, "bodies" [B], "pos" [S, B, 3],
        "quat" [S, B, 4]} every body's world pose every k-th step, and "model" (for `mcap_log`).
      state: with `execute_pick(keep_state=True)`: (MjModel, MjData) at the end of the hold, from which
        `put_back` goes on; not in the JSON.
    """

    lifted: bool
    rise: float
    achieved: Grasps | None
    position_error: float
    angle_error: float
    pads_touching: int
    diverged: bool = False
    trace: dict | None = None
    state: tuple | None = dataclasses.field(default=None, repr=False, compare=False)

    def to_json(self) -> dict:
        finite = lambda x, k: round(x, k) if math.isfinite(x) else None  # noqa: E731
        out = {"lifted": self.lifted, "diverged": self.diverged, "rise_m": finite(self.rise, 4),
               "pads_touching": self.pads_touching, "position_error_m": finite(self.position_error, 5),
               "angle_error_deg": finite(math.degrees(self.angle_error), 3)}
        if self.achieved is not None:
            out["achieved"] = {"p_tool_grasp": np.round(np.asarray(self.achieved.p_tool_grasp)[0], 5).tolist(),
                               "q_tool_grasp": np.round(np.asarray(self.achieved.q_tool_grasp)[0], 6).tolist(),
                               "width": round(float(np.asarray(self.achieved.width)[0]), 5)}
        return out


def pick_model(top: Tabletop, index: int) -> tuple[mujoco.MjModel, list[str]]:
    """The pick scene: table, the table's tools at rest, the UR5e and the gripper (module docstring).
    Returns (model, the geom names of tool `index`)."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1.5, 1.5, 0.01],
                            friction=[TABLE_FRICTION, 0.005, ROLLING_FRICTION], contype=1, conaffinity=1, condim=6)
    # the robot's files' options, set before attaching (attach keeps the parent's and warns on a conflict)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    attach_robot(spec, PICK_TIMESTEP)
    spec.option.noslip_iterations = NOSLIP_ITERATIONS
    names = {}
    for i, (t, T) in enumerate(zip(top.tools, top.poses)):
        names[i] = add_table_tool(spec, i, t, T)
    for i, t in enumerate(top.tools):
        mu = float(t.params.mu)
        for pad in ("gripper/pad_neg", "gripper/pad_pos"):
            for g in names[i]:
                spec.add_pair(name=f"{pad}-{g}", geomname1=pad, geomname2=g, condim=4,
                              friction=[mu, mu, robot.PAD_TORSION, 1e-4, 1e-4], solref=list(robot.PAD_SOLREF),
                              solimp=list(robot.PAD_SOLIMP))
    grip = spec.actuator("gripper/grip")
    grip.ctrlrange = [-OPEN_FORCE, robot.GRIPPER_MAX_GRIP_FORCE]
    for key in list(spec.keys):
        spec.delete(key)
    return spec.compile(), names[index]


def execute_pick(top: Tabletop, index: int, grasp: Grasps, q_path: np.ndarray, *,
                 grip_force: float = robot.GRIP_FORCE, record_every: int | None = None, keep_state: bool = False) -> PickResult:
    """Roll the pick of table tool `index` with `grasp` ([1] or a single grasp, tool frame) along its
    joint path `q_path` [P, 6] (`PickCandidates.q_path`) out in MuJoCo (module docstring); with
    `record_every` k, every body's pose every k-th step (`PickResult.trace`, for `mcap_log.bodies_mcap_bytes`);
    with `keep_state`, the simulation's end state (`PickResult.state`, for `put_back`)."""
    from itup_jax.robot import ARM_JOINTS
    from itup_jax.sim.arm import INITIAL_SQUEEZE

    m, geoms = pick_model(top, index)
    d = mujoco.MjData(m)
    arm_q = np.array([m.joint(f"ur5e/{j}").qposadr[0] for j in ARM_JOINTS])
    act = np.array([m.actuator(f"ur5e/{j}").id for j in ARM_JOINTS])
    act_v = np.array([m.actuator(f"ur5e/{j}_vel").id for j in ARM_JOINTS])
    grip = m.actuator("gripper/grip").id
    fq = [m.joint(f"gripper/finger_{s}").qposadr[0] for s in ("neg", "pos")]
    tq = m.joint(f"tool_{index}").qposadr[0]
    d.qpos[arm_q] = q_path[0]
    # the jaw pre-shaped to the opening the clearance checks assumed
    q_open, preshape = jaw_preshape(m, d, float(np.asarray(grasp.width, float).reshape(-1)[0]))
    d.qpos[fq] = q_open
    mujoco.mj_forward(m, d)
    body = m.body(f"tool_{index}").id
    z0 = float(d.xipos[body][2])
    settle, t_app, t_close, t_lift, t_hold = PICK_PHASES
    n_half = PATH_SAMPLES
    q_down, q_up = q_path[:n_half + 1], q_path[n_half:]
    dt = m.opt.timestep
    total = sum(PICK_PHASES)
    nstep = int(round(total / dt))
    bodies = [b for b in range(1, m.nbody) if np.any(m.geom_bodyid == b)]
    rec_t, rec_p, rec_q = [], [], []
    for k in range(nstep):
        t = (k + 1) * dt
        if t <= settle:
            q, qd, f = q_path[0], np.zeros(6), preshape()
        elif t <= settle + t_app:
            s = (t - settle) / t_app * n_half
            i0 = min(int(s), n_half - 1)
            q = q_down[i0] + (s - i0) * (q_down[i0 + 1] - q_down[i0])
            qd = (q_down[i0 + 1] - q_down[i0]) * n_half / t_app
            f = preshape()
        elif t <= settle + t_app + t_close:
            q, qd = q_down[-1], np.zeros(6)
            f = grip_force * min((t - settle - t_app) / GRIP_RAMP, 1.0)
        elif t <= settle + t_app + t_close + t_lift:
            s = (t - settle - t_app - t_close) / t_lift * n_half
            i0 = min(int(s), n_half - 1)
            q = q_up[i0] + (s - i0) * (q_up[i0 + 1] - q_up[i0])
            qd = (q_up[i0 + 1] - q_up[i0]) * n_half / t_lift
            f = grip_force
        else:
            q, qd, f = q_up[-1], np.zeros(6), grip_force
        d.ctrl[act], d.ctrl[act_v], d.ctrl[grip] = q, qd, f
        mujoco.mj_step(m, d)
        if record_every and k % record_every == 0:
            rec_t.append(d.time)
            rec_p.append(d.xpos[bodies].copy())
            rec_q.append(d.xquat[bodies].copy())
    # MuJoCo resets the state when it meets a bad value (and counts a warning): either means unstable
    diverged = mj_warnings(d) > 0 or not (np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.qvel)))
    rise = float(d.xipos[body][2]) - z0
    tool_geoms = {m.geom(g).id for g in geoms}
    pads = {m.geom("gripper/pad_neg").id, m.geom("gripper/pad_pos").id}
    touching = set()
    for c in d.contact[:d.ncon]:
        pair = {int(c.geom1), int(c.geom2)}
        if pair & pads and pair & tool_geoms:
            touching |= pair & pads
    width = float(d.qpos[fq].mean() * 2 + 2 * INITIAL_SQUEEZE)
    lifted = not diverged and rise >= LIFT_SHARE * PICK_LIFT and len(touching) == 2 and width >= MIN_HELD_WIDTH
    site = m.site("gripper/grasp").id
    T_wg = np.eye(4)
    T_wg[:3, :3], T_wg[:3, 3] = d.site_xmat[site].reshape(3, 3), d.site_xpos[site]
    T_wt = np.eye(4)
    T_wt[:3, :3] = quat_to_matrix_np(d.qpos[tq + 3:tq + 7].copy())
    T_wt[:3, 3] = d.qpos[tq:tq + 3]
    T_tg = np.linalg.inv(T_wt) @ T_wg
    p_plan = np.asarray(grasp.p_tool_grasp, float).reshape(3)
    R_plan = quat_to_matrix_np(np.asarray(grasp.q_tool_grasp, float).reshape(4))
    pos_err = float(np.linalg.norm(T_tg[:3, 3] - p_plan))
    cos = (np.trace(R_plan.T @ T_tg[:3, :3]) - 1) / 2
    ang_err = float(np.arccos(np.clip(cos, -1.0, 1.0)))
    achieved = None
    if lifted:
        achieved = make_grasps(T_tg[None, :3, 3], T_tg[None, :3, :3], np.array([min(width, robot.GRIPPER_MAX_OPENING)]))
    trace = None
    if record_every:
        trace = {"t": np.array(rec_t), "bodies": bodies, "pos": np.array(rec_p), "quat": np.array(rec_q), "model": m}
    return PickResult(lifted=bool(lifted), rise=rise, achieved=achieved, position_error=pos_err,
                      angle_error=ang_err, pads_touching=len(touching), diverged=diverged, trace=trace,
                      state=(m, d) if keep_state else None)



"""Task specifications: Omega = {c_tool, c_obj, n, d}, the contact schedule and the trajectory xi(t).

A task holds K contact elements. Element k has a contact point on the tool `c_tool[k]` (tool frame),
the matching point on the target `c_obj_world[k]`, and the target's surface normal `n_world[k]`
(unit, pointing from the target into the tool: the direction of the force the target exerts on the
tool). Element 0 is the primary contact, so Omega is (c_tool[0], c_obj_world[0], n_world[0], d_world).

Two schedules [T, K] in [0, 1] say what each element does at each step:
  * `impact[t, k] = 1`: the tool strikes the target at step t; the contact delivers the impulse
    J = -(1 + e)(v_c . n) / (1/m + 1/m_obj + n . [I^-1 (r x n)] x r) over the contact duration;
  * `drag[t, k] = 1`: the tool pushes or pulls the target, which resists with a regularised Coulomb
    force of magnitude `drag_force[k]` opposing the contact point's velocity (smooth through v = 0,
    with slip velocity `slip_velocity`; see `wrench.drag_force`).

`make_task(kind, tool, **overrides)` builds one of the four tasks with defaults inside the UR5e's
speed limits. All positions are in the robot base (world) frame; the tasks' targets sit in front of
the robot at table height.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np

from itup_jax import units
from itup_jax.errors import InputError
from itup_jax.tool import Tool
from itup_jax.trajectory import Profile, Trajectory, sample_pose_fn

TASK_KINDS = ("hammer", "sweep", "knock", "reach")
#: The built-in tool each task uses by default.
DEFAULT_TOOL = {"hammer": "hammer", "sweep": "broom", "knock": "mallet", "reach": "l_stick"}


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Task:
    """A task: contact elements, schedules and the tool trajectory (pytree; `kind` is static).

    Attributes:
      c_tool: [K, 3] m, contact points on the tool (tool frame).
      c_obj_world: [K, 3] m, matching target points (world) at their first contact.
      n_world: [K, 3] unit target surface normals, from the target into the tool (world).
      d_world: [3] unit task direction (where the tool drives the target).
      inv_mass_obj: [K] 1/kg, inverse mass of each element's target (0: immovable, e.g. a nail in wood).
      drag_force: [K] N, resisting force magnitude while dragging.
      impact: [T, K] impact schedule in [0, 1].
      drag: [T, K] drag schedule in [0, 1].
      gravity_world: [3] m/s^2, gravity (part of the world: it rotates with a change of world frame).
      slip_velocity: [] m/s, regularisation velocity of the drag force.
      traj: `Trajectory` with T steps.
      kind: task kind (static).
    """

    c_tool: jax.Array
    c_obj_world: jax.Array
    n_world: jax.Array
    d_world: jax.Array
    inv_mass_obj: jax.Array
    drag_force: jax.Array
    impact: jax.Array
    drag: jax.Array
    gravity_world: jax.Array
    slip_velocity: jax.Array
    traj: Trajectory
    kind: str = dataclasses.field(metadata=dict(static=True), default="custom")

    @property
    def omega(self) -> dict[str, jax.Array]:
        """Omega = {c_tool, c_obj, n, d} of the primary contact."""
        return {"c_tool": self.c_tool[0], "c_obj": self.c_obj_world[0], "n": self.n_world[0], "d": self.d_world}

    @property
    def num_steps(self) -> int:
        return self.traj.num_steps

    @property
    def num_contacts(self) -> int:
        return int(self.c_tool.shape[0])

    def replace(self, **changes: Any) -> "Task":
        return dataclasses.replace(self, **changes)


# ---------------------------------------------------------------------------------------------------
# Task parameters (defaults), one dataclass per kind
# ---------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class HammerParams:
    """Hammer: wind-up, swing, impact on a nail head, short follow-through (a vertical swing).

    The tool swings about a horizontal axis (world y) through a pivot `pivot_offset` behind the
    handle's butt; at impact the handle is horizontal (along world +x) and the face points down.
    The swing and follow-through last 2 x angle / impact rate each (see `_swing_task`), which keeps
    the angular speed monotonic up to the impact (no overshoot of the impact rate).
    """

    steps: int = 64
    impact_speed: float = 0.8  # m/s, speed of the contact point at impact
    wind_up: float = 0.9  # rad, swing angle raised before the strike
    t_wind: float = 0.8  # s (a rest-to-rest quintic peaks at 1.875 x its mean rate)
    # rad past the impact pose: the reference ends ~6 mm past the nail head's top (lever ~0.4 m), inside
    # the nail's 9 mm travel; a deeper reference makes the position servos press the stopped nail (0.05 rad,
    # the default until session 21, on a nail that holds: 11 of 27 reachable grasps of the built-in hammer
    # lost their grip, session 22)
    follow_through: float = 0.015
    t_hold: float = 0.2  # s held after the follow-through: the arm lags its reference by ~30 ms, and without
    # a hold the 0.015 rad follow-through would land the blow in the rollout's last 2 ms
    rest_angle: float = 0.15  # rad short of the impact pose at the start (the face clear of the nail)
    pivot_offset: float = 0.10  # m, pivot behind the handle butt along the handle
    target: tuple = (0.55, 0.0, 0.05)  # m, nail head (world)
    target_mass: float = math.inf  # kg: the nail is held by the wood


@dataclasses.dataclass(frozen=True)
class KnockParams:
    """Knock: a horizontal swing that strikes the top block of a tower at the end of a long lever."""

    steps: int = 64
    impact_speed: float = 1.0  # m/s
    wind_up: float = 0.8  # rad
    t_wind: float = 0.7  # s
    follow_through: float = 0.25  # rad
    rest_angle: float = 0.15  # rad short of the impact pose at the start
    pivot_offset: float = 0.10  # m
    target: tuple = (0.50, 0.0, 0.21)  # m, struck face of a tower's top block (world)
    target_mass: float = 0.05  # kg, one wooden block


@dataclasses.dataclass(frozen=True)
class SweepParams:
    """Sweep: one straight stroke along world +y with the broom tilted back; debris piles up on it.

    Debris i sits `debris_gaps[i]` ahead of bristle contact point i (cycling through the tool's
    contact points); once struck it is pushed along (drag), so several contacts act at once.
    """

    steps: int = 64
    stroke: float = 0.30  # m
    t_stroke: float = 0.8  # s
    t_rest: float = 0.1  # s still at each end
    tilt: float = 0.5  # rad, handle leaning back from vertical
    start: tuple = (0.50, -0.15, 0.0)  # m, primary bristle contact at the start (table top z = 0)
    debris_gaps: tuple = (0.04, 0.08, 0.12)  # m
    debris_mass: float = 0.05  # kg
    debris_friction: float = 0.4  # - , debris on the table
    bristle_drag: float = 2.0  # N, bristles dragged over the table
    slip_velocity: float = 0.01  # m/s


@dataclasses.dataclass(frozen=True)
class ReachParams:
    """Reach: slow extension past a block, lowering behind it, then a pull (or push) that slides it.

    The stick lies horizontal along world +x with the hook pointing down; it extends `lift` above
    its working height (the hook clears the block), lowers during `t_pause`, then moves. At the
    working height the tool's lowest point (the hook's tip) is `clearance` above the table top, so the
    height follows from the tool's mesh: a longer hook works higher. (Until 0.7.0 the tool-frame origin
    sat at a fixed 0.10 m, which put the built-in stick's tip on the table and drove a procedural
    variant's longer hook up to 21 mm into it: those labels measured the arm pressing the stick into the
    table, not the reach.) A grasp that lets the stick sag in the pads by more than `clearance` at the
    tip still presses it on the table, and the labels measure that.
    """

    steps: int = 64
    mode: str = "pull"  # "pull" with the hook's inner face, or "push" with its outer face
    extension: float = 0.20  # m
    t_extend: float = 1.2  # s
    t_pause: float = 0.4  # s, lowering the hook behind the block
    lift: float = 0.12  # m, clearance above the working height while extending (the hook sags in the grasp)
    move: float = 0.15  # m, pull (or push) distance
    t_move: float = 1.0  # s
    start: tuple = (0.30, 0.0)  # m, x and y of the tool-frame origin at the start (its height: `clearance`)
    clearance: float = 0.010  # m, the hook's tip above the table top at the working height (before any sag)
    block_mass: float = 0.5  # kg
    block_friction: float = 0.4  # -, block on the table
    slip_velocity: float = 0.01  # m/s


#: m, the reach's block (mjcf/scenes/reach.xml: 80 x 80 x 60 mm on the table)
REACH_BLOCK_HEIGHT = 0.06

_PARAMS = {"hammer": HammerParams, "knock": KnockParams, "sweep": SweepParams, "reach": ReachParams}

# Tool orientation with its +z (handle) along world +x and its +x (face) along world -z.
_R_HANDLE_X_FACE_DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
# Tool +z along world +x, tool +x (face) along world +y, tool +y along world +z.
_R_HANDLE_X_FACE_SIDE = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def make_task(kind: str, tool: Tool, **overrides: Any) -> Task:
    """Build a task of `kind` ('hammer', 'sweep', 'knock', 'reach') for `tool`.

    Keyword overrides replace the defaults of the kind's params dataclass (`HammerParams`, ...), e.g.
    `make_task("hammer", tool, impact_speed=1.0, steps=128)`. Host side; returns a `Task` pytree.

    Raises:
      InputError: unknown kind or override, or an invalid value.
    Warns:
      UserWarning when the trajectory exceeds the UR5e's joint-speed or tool-speed limit.
    """
    if kind not in _PARAMS:
        raise InputError(f"task kind {kind!r}: unknown; known: {', '.join(TASK_KINDS)}")
    cls = _PARAMS[kind]
    allowed = {f.name for f in dataclasses.fields(cls)}
    unknown = set(overrides) - allowed
    if unknown:
        raise InputError(f"make_task({kind!r}): unknown parameter(s) {sorted(unknown)}; allowed: {sorted(allowed)}")
    params = cls(**overrides)
    _validate_params(kind, params)
    task = _BUILDERS[kind](tool, params)
    _warn_speed_limits(task, tool)
    return task


def _validate_params(kind: str, params: Any) -> None:
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        what = f"make_task({kind!r}).{f.name}"
        if f.name == "steps":
            if not isinstance(value, (int, np.integer)) or value < 8:
                raise InputError(f"{what}: must be an integer >= 8, got {value!r}")
        elif f.name == "mode":
            if value not in ("pull", "push"):
                raise InputError(f"{what}: must be 'pull' or 'push', got {value!r}")
        elif f.name == "start" and kind == "reach":
            a = np.asarray(value, dtype=float)
            if a.shape != (2,) or not np.all(np.isfinite(a)):
                raise InputError(f"{what}: expected two finite numbers, the x and y (m) of the tool-frame origin "
                                 f"(its height follows from the tool and `clearance`), got {value!r}")
        elif f.name in ("target", "start"):
            a = np.asarray(value, dtype=float)
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise InputError(f"{what}: expected three finite numbers, got {value!r}")
        elif f.name == "debris_gaps":
            a = np.asarray(value, dtype=float)
            if a.ndim != 1 or a.size == 0 or np.any(~np.isfinite(a)) or np.any(a <= 0):
                raise InputError(f"{what}: expected positive distances (m), got {value!r}")
        elif f.name in ("tilt", "t_hold", "clearance"):
            if not math.isfinite(value) or value < 0:
                raise InputError(f"{what}: must be finite and >= 0, got {value!r}")
        elif f.name == "target_mass":
            if not value > 0:
                raise InputError(f"{what}: must be > 0 kg (inf for an immovable target), got {value!r}")
        else:
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"{what}: must be a finite number > 0, got {value!r}")


def _time_grid(steps: int, durations: list[float]) -> tuple[np.ndarray, list[float]]:
    """Uniform grid over the phases and knot times snapped to grid points (so the impact is sampled)."""
    total = float(sum(durations))
    t = np.linspace(0.0, total, steps)
    dt = t[1] - t[0]
    knots = [0.0]
    for d in durations:
        knots.append(round((knots[-1] + d) / dt) * dt)
    knots[-1] = total
    for i in range(1, len(knots)):  # keep knots strictly increasing after snapping
        knots[i] = max(knots[i], knots[i - 1] + dt)
    if knots[-1] > total + 1e-9 * max(total, 1.0):
        raise InputError(f"the task's phases ({', '.join(f'{d:.3g}' for d in durations)} s) do not fit {steps} "
                         f"samples: a phase shorter than one sample ({dt:.3g} s) falls off the end; use more steps")
    return t, knots


def _rot(axis: np.ndarray, angle: jax.Array) -> jax.Array:
    return jaxlie.SO3.exp(jnp.asarray(axis) * angle).as_matrix()


def _swing_task(tool: Tool, prm: Any, *, axis: np.ndarray, R_impact: np.ndarray, kind: str, t_hold: float = 0.0) -> Task:
    """Shared by hammer and knock: a rotation about a fixed world `axis` through a pivot, then `t_hold` s
    held at the follow-through pose (the knock's follow-through is long enough without one)."""
    c_tool = np.asarray(tool.contact_point, float)
    target = np.asarray(prm.target, float)
    p_impact = target - R_impact @ c_tool  # tool origin at impact
    pivot = p_impact + R_impact @ np.array([0.0, 0.0, -prm.pivot_offset])
    lever = float(np.linalg.norm(target - pivot))
    omega_impact = prm.impact_speed / lever
    # A quintic from rest to rate w over angle A peaks above w unless it lasts >= ~1.8 A / w; with
    # 2 A / w the rate rises monotonically to w (and falls monotonically to rest after the impact).
    t_swing, t_follow = 2.0 * prm.wind_up / omega_impact, 2.0 * prm.follow_through / omega_impact
    t, knots = _time_grid(prm.steps, [prm.t_wind, t_swing, t_follow] + ([t_hold] if t_hold > 0 else []))
    k0, k1, k2, k3 = knots[:4]
    theta = Profile.through([
        (k0, -prm.rest_angle, 0.0, 0.0),
        (k1, -prm.wind_up, 0.0, 0.0),
        (k2, 0.0, omega_impact, 0.0),
        (k3, prm.follow_through, 0.0, 0.0),
    ] + [(k, prm.follow_through, 0.0, 0.0) for k in knots[4:]])

    def pose(tt):
        R_swing = _rot(axis, theta(tt))
        return jnp.asarray(pivot) + R_swing @ jnp.asarray(p_impact - pivot), R_swing @ jnp.asarray(R_impact)

    traj = sample_pose_fn(pose, jnp.asarray(t))
    i_impact = int(np.argmin(np.abs(t - k2)))
    impact = np.zeros((prm.steps, 1))
    impact[i_impact, 0] = 1.0
    n = -R_impact @ tool.contact_normal
    return _assemble(
        kind, traj, c_tool[None], c_obj=np.asarray(traj.point_position(jnp.asarray(c_tool)))[i_impact][None],
        n=n[None], d=-n, inv_mass_obj=[1.0 / prm.target_mass], drag_force=[0.0],
        impact=impact, drag=np.zeros_like(impact), slip_velocity=0.01,
    )


def _hammer(tool: Tool, prm: HammerParams) -> Task:
    return _swing_task(tool, prm, axis=np.array([0.0, 1.0, 0.0]), R_impact=_R_HANDLE_X_FACE_DOWN, kind="hammer",
                       t_hold=prm.t_hold)


def _knock(tool: Tool, prm: KnockParams) -> Task:
    return _swing_task(tool, prm, axis=np.array([0.0, 0.0, 1.0]), R_impact=_R_HANDLE_X_FACE_SIDE, kind="knock")


def _sweep(tool: Tool, prm: SweepParams) -> Task:
    R0 = np.asarray(_rot(np.array([1.0, 0.0, 0.0]), prm.tilt))  # lean the handle back (towards -y)
    d = np.array([0.0, 1.0, 0.0])
    p0 = np.asarray(prm.start, float) - R0 @ tool.contact_points[0]
    t, (k0, k1, k2, k3) = _time_grid(prm.steps, [prm.t_rest, prm.t_stroke, prm.t_rest])
    s = Profile.through([(k0, 0.0, 0.0, 0.0), (k1, 0.0, 0.0, 0.0), (k2, prm.stroke, 0.0, 0.0), (k3, prm.stroke, 0.0, 0.0)])

    def pose(tt):
        return jnp.asarray(p0) + s(tt) * jnp.asarray(d), jnp.asarray(R0)

    traj = sample_pose_fn(pose, jnp.asarray(t))
    travelled = np.asarray(jax.vmap(s)(jnp.asarray(t)))
    n_face = -R0 @ tool.contact_normal
    g = units.STANDARD_GRAVITY
    gaps = np.asarray(prm.debris_gaps, float)
    if gaps.max() >= prm.stroke:
        raise InputError(f"make_task('sweep').debris_gaps: every gap must be shorter than the stroke ({prm.stroke} m)")
    K = len(gaps) + 1
    c_tool = np.zeros((K, 3))
    c_obj = np.zeros((K, 3))
    n = np.zeros((K, 3))
    impact = np.zeros((prm.steps, K))
    drag = np.zeros((prm.steps, K))
    for i, gap in enumerate(gaps):  # debris elements 0..K-2; element 0 is the primary contact
        c_tool[i] = tool.contact_points[i % len(tool.contact_points)]
        first = int(np.argmax(travelled >= gap))
        c_obj[i] = np.asarray(traj.point_position(jnp.asarray(c_tool[i])))[first]
        n[i] = n_face
        impact[first, i] = 1.0
        drag[first + 1:, i] = 1.0
    c_tool[-1] = tool.contact_points[0]  # last element: the bristles dragged over the table
    c_obj[-1] = prm.start
    n[-1] = (0.0, 0.0, 1.0)
    drag[:, -1] = 1.0
    inv_mass = np.r_[np.full(len(gaps), 1.0 / prm.debris_mass), 0.0]
    drag_force = np.r_[np.full(len(gaps), prm.debris_friction * prm.debris_mass * g), prm.bristle_drag]
    return _assemble("sweep", traj, c_tool, c_obj=c_obj, n=n, d=d, inv_mass_obj=inv_mass,
                     drag_force=drag_force, impact=impact, drag=drag, slip_velocity=prm.slip_velocity)


def _reach(tool: Tool, prm: ReachParams) -> Task:
    R0 = _R_HANDLE_X_FACE_DOWN
    x = np.array([1.0, 0.0, 0.0])
    sign = -1.0 if prm.mode == "pull" else 1.0
    t, (k0, k1, k2, k3) = _time_grid(prm.steps, [prm.t_extend, prm.t_pause, prm.t_move])
    s = Profile.through([
        (k0, 0.0, 0.0, 0.0), (k1, prm.extension, 0.0, 0.0), (k2, prm.extension, 0.0, 0.0),
        (k3, prm.extension + sign * prm.move, 0.0, 0.0),
    ])
    h = Profile.through([(k0, prm.lift, 0.0, 0.0), (k1, prm.lift, 0.0, 0.0), (k2, 0.0, 0.0, 0.0), (k3, 0.0, 0.0, 0.0)])
    z = np.array([0.0, 0.0, 1.0])
    # the working height: the tool's lowest point (R0 applied to its mesh) `clearance` above the table
    lowest = float(np.min(np.asarray(tool.mesh.vertices, float) @ R0[2]))
    p0 = np.array([prm.start[0], prm.start[1], prm.clearance - lowest])

    def pose(tt):
        return jnp.asarray(p0) + s(tt) * jnp.asarray(x) + h(tt) * jnp.asarray(z), jnp.asarray(R0)

    traj = sample_pose_fn(pose, jnp.asarray(t))
    # Pull: the hook's inner face (the tool's contact normal) drives the block towards the robot.
    # Push: the hook's outer face, at the same point to within the rod's diameter, drives it away.
    face = tool.contact_normal if prm.mode == "pull" else -tool.contact_normal
    n = -R0 @ face
    i_move = int(np.argmin(np.abs(t - k2)))
    drag = np.zeros((prm.steps, 1))
    drag[i_move:, 0] = 1.0
    c_obj = np.asarray(traj.point_position(jnp.asarray(tool.contact_point)))[i_move]
    if not 0.0 < c_obj[2] < REACH_BLOCK_HEIGHT:
        raise InputError(f"make_task('reach'): the hook's contact point would meet the block at z = {c_obj[2]:.3f} m, "
                         f"off its face (0 to {REACH_BLOCK_HEIGHT} m); with clearance {prm.clearance} m the contact "
                         f"point lies {c_obj[2] - prm.clearance:.3f} m above the hook's tip")
    return _assemble("reach", traj, tool.contact_point[None], c_obj=c_obj[None], n=n[None], d=sign * x,
                     inv_mass_obj=[1.0 / prm.block_mass],
                     drag_force=[prm.block_friction * prm.block_mass * units.STANDARD_GRAVITY],
                     impact=np.zeros_like(drag), drag=drag, slip_velocity=prm.slip_velocity)


_BUILDERS = {"hammer": _hammer, "knock": _knock, "sweep": _sweep, "reach": _reach}


def _assemble(kind, traj, c_tool, *, c_obj, n, d, inv_mass_obj, drag_force, impact, drag, slip_velocity) -> Task:
    f = lambda a: jnp.asarray(np.asarray(a, dtype=float))  # noqa: E731
    n = np.asarray(n, float)
    norms = np.linalg.norm(n, axis=-1)
    if np.any(norms < 1e-9):
        raise InputError(f"task {kind!r}: zero-length interaction normal")
    return Task(
        c_tool=f(c_tool), c_obj_world=f(c_obj), n_world=f(n / norms[:, None]),
        d_world=f(np.asarray(d, float) / np.linalg.norm(d)), inv_mass_obj=f(inv_mass_obj),
        drag_force=f(drag_force), impact=f(impact), drag=f(drag),
        gravity_world=f([0.0, 0.0, -units.STANDARD_GRAVITY]), slip_velocity=f(slip_velocity),
        traj=traj, kind=kind,
    )


def custom_task(
    traj: Trajectory,
    c_tool: Any,
    n_world: Any,
    *,
    impact: Any = None,
    drag: Any = None,
    c_obj_world: Any = None,
    d_world: Any = None,
    inv_mass_obj: Any = 0.0,
    drag_force: Any = 0.0,
    slip_velocity: float = 0.01,
    kind: str = "custom",
) -> Task:
    """A task from your own trajectory and contacts (host side, validated).

    Args:
      traj: `Trajectory` with T steps (e.g. from `trajectory.sample_pose_fn`).
      c_tool: [K, 3] m contact points (tool frame).  n_world: [K, 3] target normals (world; normalised).
      impact, drag: [T, K] schedules in [0, 1] (default: zeros).
      c_obj_world: [K, 3] m target points (default: the contact points at the first step).
      d_world: [3] task direction (default: -n_world[0]).
      inv_mass_obj: [K] 1/kg.  drag_force: [K] N.  slip_velocity: m/s.
    """
    c_tool = np.atleast_2d(np.asarray(c_tool, float))
    K, T = c_tool.shape[0], traj.num_steps
    zeros = np.zeros((T, K))
    sched = {}
    for name, value in (("impact", impact), ("drag", drag)):
        a = zeros if value is None else np.asarray(value, float)
        if a.shape != (T, K) or np.any(~np.isfinite(a)) or np.any(a < 0) or np.any(a > 1):
            raise InputError(f"custom_task.{name}: expected [T, K] = [{T}, {K}] values in [0, 1]")
        sched[name] = a
    n = np.atleast_2d(np.asarray(n_world, float))
    if n.shape != (K, 3) or not np.all(np.isfinite(n)):
        raise InputError(f"custom_task.n_world: expected [K, 3] = [{K}, 3] finite normals")
    if c_obj_world is None:
        c_obj_world = np.stack([np.asarray(traj.point_position(jnp.asarray(c)))[0] for c in c_tool])
    if d_world is None:
        d_world = -n[0] / max(np.linalg.norm(n[0]), 1e-300)
    return _assemble(kind, traj, c_tool, c_obj=c_obj_world, n=n, d=d_world,
                     inv_mass_obj=np.broadcast_to(np.asarray(inv_mass_obj, float), (K,)),
                     drag_force=np.broadcast_to(np.asarray(drag_force, float), (K,)),
                     impact=sched["impact"], drag=sched["drag"], slip_velocity=slip_velocity)


def peak_speeds(task: Task, tool: Tool) -> dict[str, float]:
    """Peak angular speed (rad/s) and peak contact-point speed (m/s) along the trajectory."""
    w = float(jnp.max(jnp.linalg.norm(task.traj.w_world, axis=-1)))
    v = float(jnp.max(jnp.linalg.norm(task.traj.point_velocity(jnp.asarray(tool.contact_point)), axis=-1)))
    return {"angular": w, "contact_point": v}


def _warn_speed_limits(task: Task, tool: Tool) -> None:
    peaks = peak_speeds(task, tool)
    # The tool's angular speed is a sum of joint rates; a single joint's limit is a conservative cap.
    if peaks["angular"] > units.UR5E_MAX_JOINT_SPEED * (1 + 1e-6):
        warnings.warn(
            f"task {task.kind!r}: peak tool angular speed {peaks['angular']:.2f} rad/s exceeds the UR5e's "
            f"joint-speed limit {units.UR5E_MAX_JOINT_SPEED:.2f} rad/s", UserWarning, stacklevel=3)
    if peaks["contact_point"] > 2 * units.UR5E_MAX_TCP_SPEED:
        warnings.warn(
            f"task {task.kind!r}: peak contact-point speed {peaks['contact_point']:.2f} m/s is over twice the "
            f"UR5e's typical tool speed {units.UR5E_MAX_TCP_SPEED} m/s", UserWarning, stacklevel=3)

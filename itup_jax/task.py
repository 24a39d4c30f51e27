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

`make_task(kind, tool, **overrides)` builds a task of a registered kind (`itup_jax.tasks`: one module
per kind, with its parameters, trajectory, scene placement and success measure) with defaults inside
the UR5e's speed limits. This module holds what the kinds share: the `Task` pytree, the generic
parameter checks, the time grid, the swing both strikes use, and `custom_task` for your own trajectory.
All positions are in the robot base (world) frame; the tasks' targets sit in front of the robot at
table height.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax import robot, units
from itup_jax.errors import InputError
from itup_jax.rotations import axis_angle_matrix
from itup_jax.tools import Tool
from itup_jax.trajectory import Profile, Trajectory, sample_pose_fn


def __getattr__(name: str):
    """`TASK_KINDS` (the registered kinds) and `DEFAULT_TOOL` (kind -> built-in tool), read from the
    registry each time, so a kind registered later is listed too."""
    if name == "TASK_KINDS":
        from itup_jax import tasks

        return tasks.names()
    if name == "DEFAULT_TOOL":
        from itup_jax import tasks

        return tasks.default_tools()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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


# Tool orientation with its +z (handle) along world +x and its +x (face) along world -z.
R_HANDLE_X_FACE_DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
# Tool +z along world +x, tool +x (face) along world +y, tool +y along world +z.
R_HANDLE_X_FACE_SIDE = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def make_task(kind: str, tool: Tool, **overrides: Any) -> Task:
    """Build a task of `kind` (a registered kind: 'hammer', 'sweep', 'knock', 'reach') for `tool`.

    Keyword overrides replace the defaults of the kind's params dataclass (`tasks.get(kind).params`,
    e.g. `tasks.hammer.HammerParams`): `make_task("hammer", tool, impact_speed=1.0, steps=128)`.
    Host side; returns a `Task` pytree.

    Raises:
      InputError: unknown kind or override, or an invalid value.
    Warns:
      UserWarning when the trajectory exceeds the UR5e's joint-speed or tool-speed limit.
    """
    from itup_jax import tasks

    spec = tasks.get(kind)
    cls = spec.params
    allowed = {f.name for f in dataclasses.fields(cls)}
    unknown = set(overrides) - allowed
    if unknown:
        raise InputError(f"make_task({kind!r}): unknown parameter(s) {sorted(unknown)}; allowed: {sorted(allowed)}")
    params = cls(**overrides)
    if spec.validate is not None:  # the kind's own checks first: their messages say more
        spec.validate(params)
    _validate_params(kind, params)
    task = spec.build(tool, params)
    _warn_speed_limits(task, tool)
    return task


_COUNT = {2: "two", 3: "three"}


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
        elif f.name in ("target", "start"):  # a position of as many numbers as the kind's default
            n = len(f.default)
            a = np.asarray(value, dtype=float)
            if a.shape != (n,) or not np.all(np.isfinite(a)):
                raise InputError(f"{what}: expected {_COUNT.get(n, n)} finite numbers, got {value!r}")
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


def time_grid(steps: int, durations: list[float]) -> tuple[np.ndarray, list[float]]:
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


#: The share of the UR5e's joint-speed limit a swing may reach at impact (`swing_pivot_offset`).
SWING_SPEED_SHARE = 0.9
#: m, the farthest behind the handle's butt a swing's pivot moves for a short tool: beyond it the arc
#: leaves the arm's workspace, and a swing that still needs more speed is warned about.
SWING_MAX_PIVOT_OFFSET = 0.35


def swing_pivot_offset(c_tool: np.ndarray, impact_speed: float, pivot_offset: float) -> float:
    """m, how far behind the handle's butt (along the handle) a swing's pivot lies: `pivot_offset`, or more
    for a tool so short that the contact's lever about that pivot would need an angular speed above
    SWING_SPEED_SHARE of the UR5e's joint-speed limit to reach `impact_speed` (a screwdriver's 0.2 m):
    then the pivot moves back until the lever |c_tool + offset z| is impact_speed / (share x limit), at most
    to SWING_MAX_PIVOT_OFFSET."""
    lever_min = impact_speed / (SWING_SPEED_SHARE * robot.UR5E_MAX_JOINT_SPEED)
    c = np.asarray(c_tool, float)
    if np.linalg.norm(c + np.array([0.0, 0.0, pivot_offset])) >= lever_min:
        return float(pivot_offset)
    return min(float(-c[2] + math.sqrt(max(lever_min**2 - c[0] ** 2 - c[1] ** 2, 0.0))),
               max(SWING_MAX_PIVOT_OFFSET, float(pivot_offset)))


def swing_task(tool: Tool, prm: Any, *, axis: np.ndarray, R_impact: np.ndarray, kind: str, t_hold: float = 0.0) -> Task:
    """Shared by hammer and knock: a rotation about a fixed world `axis` through a pivot, then `t_hold` s
    held at the follow-through pose (the knock's follow-through is long enough without one)."""
    c_tool = np.asarray(tool.contact_point, float)
    target = np.asarray(prm.target, float)
    p_impact = target - R_impact @ c_tool  # tool origin at impact
    offset = swing_pivot_offset(c_tool, prm.impact_speed, prm.pivot_offset)
    pivot = p_impact + R_impact @ np.array([0.0, 0.0, -offset])
    lever = float(np.linalg.norm(target - pivot))
    omega_impact = prm.impact_speed / lever
    # A quintic from rest to rate w over angle A peaks above w unless it lasts >= ~1.8 A / w; with
    # 2 A / w the rate rises monotonically to w (and falls monotonically to rest after the impact).
    t_swing, t_follow = 2.0 * prm.wind_up / omega_impact, 2.0 * prm.follow_through / omega_impact
    t, knots = time_grid(prm.steps, [prm.t_wind, t_swing, t_follow] + ([t_hold] if t_hold > 0 else []))
    k0, k1, k2, k3 = knots[:4]
    theta = Profile.through([
        (k0, -prm.rest_angle, 0.0, 0.0),
        (k1, -prm.wind_up, 0.0, 0.0),
        (k2, 0.0, omega_impact, 0.0),
        (k3, prm.follow_through, 0.0, 0.0),
    ] + [(k, prm.follow_through, 0.0, 0.0) for k in knots[4:]])

    def pose(tt):
        R_swing = axis_angle_matrix(axis, theta(tt))
        return jnp.asarray(pivot) + R_swing @ jnp.asarray(p_impact - pivot), R_swing @ jnp.asarray(R_impact)

    traj = sample_pose_fn(pose, jnp.asarray(t))
    i_impact = int(np.argmin(np.abs(t - k2)))
    impact = np.zeros((prm.steps, 1))
    impact[i_impact, 0] = 1.0
    n = -R_impact @ tool.contact_normal
    return assemble(
        kind, traj, c_tool[None], c_obj=np.asarray(traj.point_position(jnp.asarray(c_tool)))[i_impact][None],
        n=n[None], d=-n, inv_mass_obj=[1.0 / prm.target_mass], drag_force=[0.0],
        impact=impact, drag=np.zeros_like(impact), slip_velocity=0.01,
    )


def assemble(kind, traj, c_tool, *, c_obj, n, d, inv_mass_obj, drag_force, impact, drag, slip_velocity) -> Task:
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
    return assemble(kind, traj, c_tool, c_obj=c_obj_world, n=n, d=d_world,
                     inv_mass_obj=np.broadcast_to(np.asarray(inv_mass_obj, float), (K,)),
                     drag_force=np.broadcast_to(np.asarray(drag_force, float), (K,)),
                     impact=sched["impact"], drag=sched["drag"], slip_velocity=slip_velocity)


def contact_motion(task: Task) -> np.ndarray:
    """[3] unit direction (tool frame) in which the primary contact point moves at its first contact (the
    first step its impact or drag schedule is on; the step of the fastest motion when neither is)."""
    on = (np.asarray(task.impact)[:, 0] > 0) | (np.asarray(task.drag)[:, 0] > 0)
    v = np.asarray(task.traj.point_velocity(task.c_tool[0]), float)  # [T, 3] world
    k = int(np.argmax(on)) if on.any() else int(np.argmax(np.linalg.norm(v, axis=-1)))
    if on.any() and np.linalg.norm(v[k]) < 1e-9:  # a drag that starts from rest: where it heads next
        k = k + int(np.argmax(np.linalg.norm(v[k:], axis=-1) > 1e-9))
    v_tool = np.asarray(task.traj.R_world_tool, float)[k].T @ v[k]
    norm = np.linalg.norm(v_tool)
    return v_tool / norm if norm > 0 else v_tool


def peak_speeds(task: Task, tool: Tool) -> dict[str, float]:
    """Peak angular speed (rad/s) and peak contact-point speed (m/s) along the trajectory."""
    w = float(jnp.max(jnp.linalg.norm(task.traj.w_world, axis=-1)))
    v = float(jnp.max(jnp.linalg.norm(task.traj.point_velocity(jnp.asarray(tool.contact_point)), axis=-1)))
    return {"angular": w, "contact_point": v}


def _warn_speed_limits(task: Task, tool: Tool) -> None:
    peaks = peak_speeds(task, tool)
    # The tool's angular speed is a sum of joint rates; a single joint's limit is a conservative cap.
    if peaks["angular"] > robot.UR5E_MAX_JOINT_SPEED * (1 + 1e-6):
        warnings.warn(
            f"task {task.kind!r}: peak tool angular speed {peaks['angular']:.2f} rad/s exceeds the UR5e's "
            f"joint-speed limit {robot.UR5E_MAX_JOINT_SPEED:.2f} rad/s", UserWarning, stacklevel=3)
    if peaks["contact_point"] > 2 * robot.UR5E_MAX_TCP_SPEED:
        warnings.warn(
            f"task {task.kind!r}: peak contact-point speed {peaks['contact_point']:.2f} m/s is over twice the "
            f"UR5e's typical tool speed {robot.UR5E_MAX_TCP_SPEED} m/s", UserWarning, stacklevel=3)

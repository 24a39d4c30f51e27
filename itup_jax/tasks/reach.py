"""Reach: a slow extension past a block, lowering behind it, then a pull (or push) that slides it
(the lever-arm dominated, quasi-static regime).

The stick lies horizontal along world +x with the hook pointing down; it extends `lift` above its
working height (the hook clears the block), lowers during `t_pause`, then moves. At the working height
the tool's lowest point (the hook's tip) is `clearance` above the table top, so the height follows from
the tool's mesh: a longer hook works higher. A grasp that lets the stick sag in the pads by more than
`clearance` at the tip still presses it on the table, and the labels measure that.

Scene (`mjcf/scenes/reach.xml`): a 0.5 kg block, 80 x 80 x 60 mm, on the table. Success: the block moves
at least `SUCCESS_FRACTION` of the commanded pull (or push) along the task direction.
"""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np

from itup_jax import units
from itup_jax.errors import InputError
from itup_jax.task import R_HANDLE_X_FACE_DOWN, assemble, time_grid
from itup_jax.tasks import TaskKind, register
from itup_jax.trajectory import Profile, sample_pose_fn

#: m, the block's height (`mjcf/scenes/reach.xml`): the hook must meet its face between 0 and this.
BLOCK_HEIGHT = 0.06
#: m, from the hook's contact point to the block's centre along the interaction normal: the block's 40 mm
#: half depth plus a 1 mm gap (tested against the MJCF).
FACE_TO_CENTRE = 0.041
#: share of the commanded pull (or push) the block must follow.
SUCCESS_FRACTION = 0.5


@dataclasses.dataclass(frozen=True)
class ReachParams:
    """Reach: extend past the block, lower behind it, pull it (or push it) along world x."""

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


def validate(prm: ReachParams) -> None:
    """The reach's `start` is two numbers (x, y); its height follows from the tool."""
    a = np.asarray(prm.start, dtype=float)
    if a.shape != (2,) or not np.all(np.isfinite(a)):
        raise InputError(f"make_task('reach').start: expected two finite numbers, the x and y (m) of the tool-frame "
                         f"origin (its height follows from the tool and `clearance`), got {prm.start!r}")


def build(tool, prm: ReachParams):
    """The reach's `Task` for `tool` (host side)."""
    R0 = R_HANDLE_X_FACE_DOWN
    x = np.array([1.0, 0.0, 0.0])
    sign = -1.0 if prm.mode == "pull" else 1.0
    t, (k0, k1, k2, k3) = time_grid(prm.steps, [prm.t_extend, prm.t_pause, prm.t_move])
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
    if not 0.0 < c_obj[2] < BLOCK_HEIGHT:
        raise InputError(f"make_task('reach'): the hook's contact point would meet the block at z = {c_obj[2]:.3f} m, "
                         f"off its face (0 to {BLOCK_HEIGHT} m); with clearance {prm.clearance} m the contact "
                         f"point lies {c_obj[2] - prm.clearance:.3f} m above the hook's tip")
    return assemble("reach", traj, tool.contact_point[None], c_obj=c_obj[None], n=n[None], d=sign * x,
                    inv_mass_obj=[1.0 / prm.block_mass],
                    drag_force=[prm.block_friction * prm.block_mass * units.STANDARD_GRAVITY],
                    impact=np.zeros_like(drag), drag=drag, slip_velocity=prm.slip_velocity)


def place(spec, task) -> None:
    """Put the block just beyond the hook's contact face, resting on the table at its MJCF height."""
    c_obj = np.asarray(task.c_obj_world, float)
    n = np.asarray(task.n_world[0], float)
    centre = c_obj[0] - FACE_TO_CENTRE * n
    block = spec.body("block")
    block.pos = [centre[0], centre[1], block.pos[2]]


def outcome(scene, task, sensordata, p):
    """metric: m the block moved along the task direction; success: >= SUCCESS_FRACTION of the command."""
    block = scene.sensor(sensordata, "block")
    d = np.asarray(task.d_world, float)
    moved = (block[:, -1] - block[:, 0]) @ d
    first = int(np.argmax(np.asarray(task.drag)[:, 0] > 0))  # the pull (or push) starts
    p_tool = np.asarray(task.traj.p_world_tool, float)
    commanded = float((p_tool[-1] - p_tool[first]) @ d)
    return moved, moved >= SUCCESS_FRACTION * commanded


KIND = register(TaskKind(
    name="reach", params=ReachParams, build=build, default_tool="l_stick", timestep=0.0005,
    target_geoms=("block",), target_bodies=("block",), place=place, outcome=outcome, works_on_table=True,
    validate=validate, summary="hook a block out of reach and pull it closer (lever arm, quasi-static)",
))

"""Sweep: one straight stroke of a tilted broom that pushes three pieces of debris along the table
(the clustered multi-contact regime).

Debris i sits `debris_gaps[i]` ahead of bristle contact point i (cycling through the tool's contact
points); once struck it is pushed along with the bristles' drag, so up to four contacts act at once
(three pieces and the bristles on the table). Scene (`mjcf/scenes/sweep.xml`): three 40 mm cubes of
50 g on the table. Success: at least two pieces end 10 cm past the debris line.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax import units
from itup_jax.errors import InputError
from itup_jax.rotations import axis_angle_matrix
from itup_jax.task import assemble, time_grid
from itup_jax.tasks import TaskKind, register
from itup_jax.trajectory import Profile, sample_pose_fn

#: The debris cubes.
DEBRIS = ("debris_0", "debris_1", "debris_2")
#: m, from a bristle contact point to its cube's centre along the (horizontal) push: the cube's 20 mm
#: half size plus a 1 mm gap (tested against the MJCF).
FACE_TO_CENTRE = 0.021
#: m, how far past the debris line a piece must end to count as swept.
SWEPT_PAST = 0.10
#: pieces that must be swept for success.
SWEPT_COUNT = 2


@dataclasses.dataclass(frozen=True)
class SweepParams:
    """Sweep: one straight stroke along world +y with the broom tilted back; debris piles up on it."""

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


def build(tool, prm: SweepParams):
    """The sweep's `Task` for `tool` (host side)."""
    R0 = np.asarray(axis_angle_matrix(np.array([1.0, 0.0, 0.0]), prm.tilt))  # lean the handle back (towards -y)
    d = np.array([0.0, 1.0, 0.0])
    p0 = np.asarray(prm.start, float) - R0 @ tool.contact_points[0]
    t, (k0, k1, k2, k3) = time_grid(prm.steps, [prm.t_rest, prm.t_stroke, prm.t_rest])
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
    return assemble("sweep", traj, c_tool, c_obj=c_obj, n=n, d=d, inv_mass_obj=inv_mass,
                    drag_force=drag_force, impact=impact, drag=drag, slip_velocity=prm.slip_velocity)


def place(spec, task) -> None:
    """Put each cube just ahead of its bristle contact, along the normal's horizontal part, on the table."""
    c_obj = np.asarray(task.c_obj_world, float)
    n = np.asarray(task.n_world[0], float)
    push = -n[:2] / np.linalg.norm(n[:2])  # horizontal direction the bristles push the debris
    for i, name in enumerate(DEBRIS):
        centre = c_obj[i, :2] + FACE_TO_CENTRE * push
        cube = spec.body(name)
        cube.pos = [centre[0], centre[1], cube.pos[2]]  # resting on the table, at the MJCF's height


def outcome(scene, task, sensordata, p):
    """metric: pieces that ended SWEPT_PAST beyond the debris line; success: >= SWEPT_COUNT of them."""
    d = np.asarray(task.d_world, float)
    line = float(np.asarray(task.c_obj_world, float)[:3].mean(0) @ d) + SWEPT_PAST
    past = sum((scene.sensor(sensordata, f"debris_{i}")[:, -1] @ d > line).astype(int) for i in range(len(DEBRIS)))
    return past.astype(float), past >= SWEPT_COUNT


KIND = register(TaskKind(
    name="sweep", params=SweepParams, build=build, default_tool="broom", timestep=0.0005,
    target_geoms=DEBRIS, target_bodies=DEBRIS, place=place, outcome=outcome, works_on_table=True,
    summary="sweep three pieces of debris along the table (clustered contacts)",
))

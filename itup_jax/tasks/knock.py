"""Knock: a horizontal swing that strikes the top block of a tower at the end of a long lever.

Scene (`mjcf/scenes/knock.xml`): a tower of four 50 g wooden blocks; the tool strikes the top one.
Success: the swing moves the top block `TOPPLE_SUCCESS` during the motion, and the tower still stood
when the motion began. A grasp that cannot hold the tool lets it droop in the pads during the settle,
onto the tower 6 cm from its face, and pushes the tower over before the swing: that is not a knock.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from itup_jax.errors import InputError
from itup_jax.task import R_HANDLE_X_FACE_SIDE, swing_task
from itup_jax.tasks import TaskKind, register

#: m the top block must move during the motion.
TOPPLE_SUCCESS = 0.03
#: m, the top block's largest horizontal move during the settle for a tower left standing. A tower
#: nobody touches sinks 1.4 mm into its soft contacts straight down and moves 0.000 mm sideways; one the
#: drooping tool touched moved 0.85 mm to 0.6 m.
TOWER_STANDING = 5e-4
#: m, from the struck point to the top block's centre along the interaction normal: the block's 25 mm
#: half depth plus a 0.5 mm gap (tested against the MJCF).
FACE_TO_CENTRE = 0.0255
#: m, how far the struck point may sit above or below the top block's centre (its half height is 0.03 m).
FACE_HEIGHT_TOL = 0.02
#: The tower's blocks, bottom to top.
BLOCKS = ("block_0", "block_1", "block_2", "block_3")


@dataclasses.dataclass(frozen=True)
class KnockParams:
    """Knock: a horizontal swing about world z; at impact the handle lies along world +x, the face along +y."""

    steps: int = 64
    impact_speed: float = 1.0  # m/s
    wind_up: float = 0.8  # rad
    t_wind: float = 0.7  # s
    follow_through: float = 0.25  # rad
    rest_angle: float = 0.15  # rad short of the impact pose at the start
    pivot_offset: float = 0.10  # m, pivot behind the handle butt (more for a short tool: task.swing_pivot_offset)
    target: tuple = (0.50, 0.0, 0.21)  # m, struck face of a tower's top block (world)
    target_mass: float = 0.05  # kg, one wooden block


def build(tool, prm: KnockParams):
    """The knock's `Task` for `tool` (host side)."""
    return swing_task(tool, prm, axis=np.array([0.0, 0.0, 1.0]), R_impact=R_HANDLE_X_FACE_SIDE, kind="knock")


def place(spec, task) -> None:
    """Move the tower (as one, each block at its MJCF height) so its top block's face is at c_obj."""
    c_obj = np.asarray(task.c_obj_world, float)
    n = np.asarray(task.n_world[0], float)
    blocks = [spec.body(name) for name in BLOCKS]
    top_z = float(blocks[-1].pos[2])  # the MJCF tower's top block centre height
    if abs(c_obj[0, 2] - top_z) > FACE_HEIGHT_TOL:
        raise InputError(f"knock scene: the struck face (z = {c_obj[0, 2]:.3f} m) must be within "
                         f"{FACE_HEIGHT_TOL} m of the top block's height {top_z} m")
    centre = c_obj[0] - FACE_TO_CENTRE * n  # the top block's centre, behind the struck face
    for block in blocks:
        block.pos = [centre[0], centre[1], block.pos[2]]


def outcome(scene, task, sensordata, p):
    """metric: m the top block moved during the motion; success: >= TOPPLE_SUCCESS with the tower standing
    at the start of the motion."""
    top = scene.sensor(sensordata, "top_block")
    settled = top[:, p.n_settle - 1]
    moved = np.linalg.norm(top[:, -1] - settled, axis=-1)
    standing = np.linalg.norm((settled - top[:, 0])[:, :2], axis=-1) <= TOWER_STANDING
    return moved, (moved >= TOPPLE_SUCCESS) & standing


KIND = register(TaskKind(
    name="knock", params=KnockParams, build=build, default_tool="mallet", timestep=0.0005,
    target_geoms=("block_3", "block_2"), target_bodies=BLOCKS, place=place, outcome=outcome,
    summary="knock the top block off a tower with a horizontal swing (impulse + lever arm)",
))

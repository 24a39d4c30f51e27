"""Hammer: a vertical swing that drives a nail held by wood (the impulse regime).

Trajectory: wind-up, a swing about a horizontal axis (world y) through a pivot behind the handle's butt,
the impact on the nail head at `impact_speed` with the handle horizontal (world +x) and the face down,
a short follow-through, then `t_hold` s held still so the rollout sees the blow land.

Scene (`mjcf/scenes/hammer.xml`): a nail in a 40 mm board. The wood grips the nail with 40 N (the
Forest Products Laboratory's withdrawal formula for a 1.2 mm nail started 7 mm into spruce), a stop
holds it 1 mm above the board, and it takes the blow plastically (`plastic_target`). Success: the blow
drives the nail `NAIL_DEPTH_SUCCESS` deeper during the motion.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from itup_jax.errors import InputError
from itup_jax.task import R_HANDLE_X_FACE_DOWN, swing_task
from itup_jax.tasks import TaskKind, register

#: m the nail must be driven during the motion: the blow overcame the wood's grip. A position-servoed
#: UR5e stops the hammer within its follow-through: a square blow at 0.8 m/s alone drives the nail
#: 0.2-0.6 mm (the built-in hammer held from the side anywhere along the handle, no hold), less than the
#: hammer's kinetic energy could (~3.5 mm); with the servos pressing through the hold, 0.6-7 mm.
NAIL_DEPTH_SUCCESS = 1e-4
#: m, the board's thickness (`mjcf/scenes/hammer.xml`): the nail head must stand above it.
BOARD_TOP = 0.04
#: m, the board's centre height.
BOARD_CENTRE_Z = 0.02
#: m, the nail's stop: its head comes to rest this high (1 mm above the board, under the head's 1 mm).
NAIL_STOP_Z = 0.041
#: m, the lowest nail head the scene accepts (a nail left above the board).
MIN_HEAD_Z = 0.045


@dataclasses.dataclass(frozen=True)
class HammerParams:
    """Hammer: wind-up, swing, impact on a nail head, short follow-through (a vertical swing).

    The tool swings about a horizontal axis (world y) through a pivot `pivot_offset` behind the
    handle's butt; at impact the handle is horizontal (along world +x) and the face points down.
    The swing and follow-through last 2 x angle / impact rate each (`task.swing_task`), which keeps
    the angular speed monotonic up to the impact (no overshoot of the impact rate).
    """

    steps: int = 64
    impact_speed: float = 0.8  # m/s, speed of the contact point at impact
    wind_up: float = 0.9  # rad, swing angle raised before the strike
    t_wind: float = 0.8  # s (a rest-to-rest quintic peaks at 1.875 x its mean rate)
    # rad past the impact pose: the reference ends ~6 mm past the nail head's top (lever ~0.4 m), inside
    # the nail's 9 mm travel. A deeper reference makes the position servos press the stopped nail: at
    # 0.05 rad 11 of 27 reachable grasps of the built-in hammer lost their grip.
    follow_through: float = 0.015
    t_hold: float = 0.2  # s held after the follow-through: the arm lags its reference by ~30 ms, and without
    # a hold the 0.015 rad follow-through would land the blow in the rollout's last 2 ms
    rest_angle: float = 0.15  # rad short of the impact pose at the start (the face clear of the nail)
    pivot_offset: float = 0.10  # m, pivot behind the handle butt along the handle (more for a short tool: task.swing_pivot_offset)
    target: tuple = (0.55, 0.0, 0.05)  # m, nail head (world)
    target_mass: float = math.inf  # kg: the nail is held by the wood


def build(tool, prm: HammerParams):
    """The hammer's `Task` for `tool` (host side)."""
    return swing_task(tool, prm, axis=np.array([0.0, 1.0, 0.0]), R_impact=R_HANDLE_X_FACE_DOWN, kind="hammer",
                      t_hold=prm.t_hold)


def place(spec, task) -> None:
    """Put the nail's head at the task's c_obj, the board under it, the stop 1 mm above the board."""
    head_top = np.asarray(task.c_obj_world, float)[0]
    if head_top[2] < MIN_HEAD_Z:
        raise InputError(f"hammer scene: nail head at z = {head_top[2]:.3f} m leaves no nail above the "
                         f"{BOARD_TOP * 1e3:.0f} mm board")
    spec.body("nail").pos = head_top
    spec.body("board").pos = [head_top[0], head_top[1], BOARD_CENTRE_Z]
    spec.joint("nail_depth").range = [-(head_top[2] - NAIL_STOP_Z), 0.0]


def outcome(scene, task, sensordata, p):
    """metric: m the nail was driven during the motion (from the end of the settle); success: >= NAIL_DEPTH_SUCCESS."""
    depth_sensor = scene.sensor(sensordata, "nail_depth")
    depth = depth_sensor[:, p.n_settle - 1, 0] - depth_sensor[:, -1, 0]
    return depth, depth >= NAIL_DEPTH_SUCCESS


KIND = register(TaskKind(
    name="hammer", params=HammerParams, build=build, default_tool="hammer", timestep=0.0005,
    target_geoms=("nail_head",), target_bodies=("nail",), place=place, outcome=outcome,
    plastic_target=True, summary="drive a nail with a vertical swing (impulse)",
))

"""Rollout settings and label thresholds, one frozen dataclass (`SimConfig`)."""

from __future__ import annotations

import dataclasses
import math

from itup_jax import robot


@dataclasses.dataclass(frozen=True)
class SimConfig:
    """Rollout settings and label thresholds (SI units)."""

    settle_time: float = 0.3  # s, still, gripped, before the motion
    grip_force: float = robot.GRIP_FORCE  # N per pad (Robotiq 2F-85 range 20-235 N)
    slip_threshold: float = 0.01  # m, failure when the tool slides this far in the pads (at the grasp centre)
    rotation_threshold: float = math.radians(10.0)  # rad, failure when it turns this far
    lost_distance: float = 0.05  # m, tool lost (slid this far at the grasp centre)
    impact_window: float = 0.05  # s after an impact still counted as contact (alignment drift)
    diverged_qvel: float = 500.0  # rad/s or m/s: any |qvel| above is a blow-up (and any grasp-point jump faster)
    diverged_slip: float = 2.0  # m, a grasp point this far from the pads is a blow-up (a dropped tool lands nearer)
    static_window: float = 0.05  # s at the end of the settle phase averaged for the static wrench

"""Named physical constants and hardware limits, each with its unit and source.

Everything in itup-jax is SI: metres, kilograms, seconds, newtons, newton-metres, radians.
"""

from __future__ import annotations

# --- Physics -------------------------------------------------------------------------------------
#: Standard gravity, m/s^2 (CGPM 1901 conventional value).
STANDARD_GRAVITY = 9.80665

# The robot's own constants (UR5e, gripper) live in `itup_jax/robot.py`.

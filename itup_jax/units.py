"""Named physical constants and hardware limits, each with its unit and source.

Everything in itup-jax is SI: metres, kilograms, seconds, newtons, newton-metres, radians.
"""

from __future__ import annotations

import math

# --- Physics -------------------------------------------------------------------------------------
#: Standard gravity, m/s^2 (CGPM 1901 conventional value).
STANDARD_GRAVITY = 9.80665

# --- Universal Robots UR5e (e-Series technical specifications, Universal Robots A/S) -------------
#: Maximum joint speed of every UR5e joint (base, shoulder, elbow, wrist 1-3): 180 deg/s, in rad/s.
UR5E_MAX_JOINT_SPEED = math.pi
#: Typical maximum tool (TCP) speed of the UR5e, m/s.
UR5E_MAX_TCP_SPEED = 1.0

# --- Robotiq 2F-85 class parallel-jaw gripper -----------------------------------------------------
# Stroke and force range: Robotiq 2F-85 product specifications (85 mm stroke, 20-235 N grip force,
# 0.925 kg). Pad size: MuJoCo Menagerie's robotiq_2f85 model, whose two stacked pad boxes per finger
# are 22 mm x 2 x 18.75 mm. Finger length and palm size are approximations of the real gripper's
# outline (stated as such; they only enter the collision check of the grasp sampler).
GRIPPER_MAX_OPENING = 0.085  # m, full stroke
GRIPPER_MIN_GRIP_FORCE = 20.0  # N
GRIPPER_MAX_GRIP_FORCE = 235.0  # N
GRIPPER_MASS = 0.925  # kg
PAD_WIDTH = 0.022  # m, pad extent along the grasp x axis
PAD_LENGTH = 0.0375  # m, pad extent along the approach (z) axis
FINGER_THICKNESS = 0.008  # m, finger extent behind the pad surface (along the closure axis)
FINGER_LENGTH = 0.055  # m, from the palm face to the pad centre (approximation)
PALM_DEPTH = 0.03  # m, palm box along the approach axis (approximation)
PALM_WIDTH_X = 0.04  # m, palm box along the grasp x axis (approximation)
PALM_WIDTH_Y = 0.11  # m, palm box along the closure axis: spans the open fingers (approximation)

"""The robot: UR5e arm and Robotiq-2F-85-class parallel gripper, every constant in one place.

Each value has its unit and its source. The MJCF in `mjcf/` (see `mjcf/README.md`) is built from the
same numbers; `tests/test_ik.py` and `tests/test_scene.py` check that the compiled model agrees.
"""

from __future__ import annotations

import math

import numpy as np

# --- UR5e kinematics: Universal Robots, "DH Parameters for calculations of kinematics and dynamics" ------
#: m, DH link lengths a.
DH_A = np.array([0.0, -0.425, -0.3922, 0.0, 0.0, 0.0])
#: m, DH link offsets d.
DH_D = np.array([0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996])
#: rad, DH link twists alpha.
DH_ALPHA = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])
#: The arm's joint names in the MJCF (prefixed `ur5e/` in a composed scene).
ARM_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
#: rad, the joint ranges of the MJCF: +-2 pi, elbow +-pi (UR5e technical specifications).
JOINT_LIMITS = np.array([2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi])
#: rad, the posture the first IK solution is chosen near (elbow up, wrist down): 'home'.
HOME_Q = np.array([0.0, -math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0])
#: m, elbow and wrist joints stay this high above the table (the arm has no collision geometry).
ARM_CLEARANCE = 0.03

# --- UR5e speed limits: e-Series technical specifications, Universal Robots A/S ----------------------
#: rad/s, maximum speed of every joint (base, shoulder, elbow, wrist 1-3): 180 deg/s.
UR5E_MAX_JOINT_SPEED = math.pi
#: m/s, typical maximum tool (TCP) speed.
UR5E_MAX_TCP_SPEED = 1.0

# --- UR5e joint torques: Universal Robots' joint sizes (size 3: base, shoulder, elbow; size 1: wrists) ---
#: N m, the most torque each joint's actuators exert in all (servos and gravity compensation together;
#: `actuatorfrcrange` in the MJCF).
JOINT_TORQUE_LIMITS = np.array([150.0, 150.0, 150.0, 28.0, 28.0, 28.0])

# --- Robotiq 2F-85 class parallel-jaw gripper ---------------------------------------------------------
# Stroke and force range: Robotiq 2F-85 product specifications (85 mm stroke, 20-235 N grip force,
# 0.925 kg). Pad size: MuJoCo Menagerie's robotiq_2f85 model, whose two stacked pad boxes per finger
# are 22 mm x 2 x 18.75 mm. Finger length and palm size are approximations of the real gripper's
# outline (stated as such; they only enter the collision check of the grasp sampler).
GRIPPER_MAX_OPENING = 0.085  # m, full stroke
GRIPPER_MIN_GRIP_FORCE = 20.0  # N
GRIPPER_MAX_GRIP_FORCE = 235.0  # N
#: N per pad, the grip every rollout, pick and analytic wrist load uses unless told otherwise (randomised
#: +-20 % with the physics draws), within the 2F-85's range.
GRIP_FORCE = 100.0
#: N per pad, the weak grip (a little above the 2F-85's least setting of 20 N): every dataset candidate is
#: rolled out a second time at it (`dataset.weak_rollouts`, the network's weak-grip head), the planner's
#: verification repeats each rollout at it (`planning.plan_grasp(verify_weak_grip=)`), and the evaluations'
#: grip stress counts failures at it.
WEAK_GRIP = 25.0
GRIPPER_MASS = 0.925  # kg
PAD_WIDTH = 0.022  # m, pad extent along the grasp x axis
PAD_LENGTH = 0.0375  # m, pad extent along the approach (z) axis
FINGER_THICKNESS = 0.008  # m, finger extent behind the pad surface (along the closure axis)
FINGER_LENGTH = 0.055  # m, from the palm face to the pad centre (approximation)
PALM_DEPTH = 0.03  # m, palm box along the approach axis (approximation)
PALM_WIDTH_X = 0.04  # m, palm box along the grasp x axis (approximation)
PALM_WIDTH_Y = 0.11  # m, palm box along the closure axis: spans the open fingers (approximation)
#: m, from the flange to the grasp frame along the approach axis (`mjcf/parallel_gripper/gripper.xml`).
FLANGE_TO_GRASP = 0.085
#: m, torsional friction length of the pads (an assumed contact patch radius).
PAD_TORSION = 0.005
#: MuJoCo solref (time constant s, damping ratio) and solimp of the pad-tool contacts: stiff (4 ms) and
#: critically damped, impedance 0.95-0.99 over 1 mm (`sim/scene.py`; `transmission.py` models them).
PAD_SOLREF = (0.004, 1.0)
PAD_SOLIMP = (0.95, 0.99, 0.001, 0.5, 2.0)

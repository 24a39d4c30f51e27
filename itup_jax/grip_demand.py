"""Grip demand: the normal force each pad must press with to hold a wrench at the grasp by friction.

A parallel jaw holds a tool with two flat pads pressing with normal force N each along the closure
axis y, at y = +-w/2 (w the jaw opening), friction coefficient mu, torsional friction length c_t
(MuJoCo's torsional coefficient of the pad contact, `robot.PAD_TORSION`). Per unit N, the grip
resists, in the grasp frame's axes (x third, y closure, z approach):

  force in the pad plane (x, z)   2 mu          both pads' sliding friction
  force along the closure y       2             a pad may unload to zero before the tool leaves it
  torque about the closure y      2 c_t         the pads' torsional friction alone: the weakest axis
  torque about the approach z     mu w + a_x    a friction couple across the jaw, plus the pads'
                                                centres of pressure shifting along x (a_x the pad's
                                                width, `robot.PAD_WIDTH`)
  torque about the third axis x   mu w          a friction couple across the jaw (a round handle
                                                touches the pads along x, so no pressure arm)

Combined as an ellipsoidal limit surface (the usual approximation of a soft finger's, e.g. Howe and
Cutkosky, "Practical force-motion models for sliding manipulation", IJRR 1996), the normal force a
wrench (F, tau) needs is

  N = sqrt( (F_x^2 + F_z^2) / (2 mu)^2 + F_y^2 / 4 + tau_y^2 / (2 c_t)^2 + tau_z^2 / (mu w + a_x)^2
            + tau_x^2 / (mu w)^2 ).

Each component counts by how hard it loads the grip: 1 N m about the closure axis needs 100 N per pad,
about the third axis of a 3 cm handle at mu = 0.7 about 48 N. The functions take numpy or JAX arrays
(`xp`), so the labels (measured wrist wrench) and the analytic cost (modelled wrench) use one form.
"""

from __future__ import annotations

import numpy as np

from itup_jax.robot import FLANGE_TO_GRASP, PAD_TORSION, PAD_WIDTH

#: m, the least jaw opening the friction couple is computed with (a thinner grip has no couple arm)
MIN_COUPLE_WIDTH = 0.002


def torque_about_grasp(force, torque, xp=np):
    """The torque (N m) about the grasp centre of a wrench read at the wrist sensor, [..., 3] x [..., 3]
    -> [..., 3], all in the gripper's axes: tau_g = tau_s - r x F, r = (0, 0, FLANGE_TO_GRASP) the
    grasp centre from the sensor (the sensor sits at the flange)."""
    fx, fy = force[..., 0], force[..., 1]
    # r x F with r = (0, 0, d): (-d F_y, d F_x, 0)
    return xp.stack([torque[..., 0] + FLANGE_TO_GRASP * fy, torque[..., 1] - FLANGE_TO_GRASP * fx,
                     torque[..., 2]], axis=-1)


def grip_demand_sq(force, torque, mu, width, xp=np):
    """The square of `grip_demand` (N^2): what a peak over time should maximise before one square
    root, so that a gradient through it stays finite where the wrench is zero."""
    mu = xp.asarray(mu)
    couple = mu * xp.maximum(xp.asarray(width), MIN_COUPLE_WIDTH)
    return ((force[..., 0] ** 2 + force[..., 2] ** 2) / (2.0 * mu) ** 2
            + force[..., 1] ** 2 / 4.0
            + torque[..., 1] ** 2 / (2.0 * PAD_TORSION) ** 2
            + torque[..., 2] ** 2 / (couple + PAD_WIDTH) ** 2
            + torque[..., 0] ** 2 / couple ** 2)


def grip_demand(force, torque, mu, width, xp=np):
    """Normal force per pad (N) that holds the wrench (force [..., 3] N, torque about the grasp centre
    [..., 3] N m, grasp-frame axes) by friction, for pad friction `mu` [...] and jaw opening `width`
    [...] m (broadcast against the leading axes): the ellipsoidal limit surface of the module's
    docstring."""
    return xp.sqrt(grip_demand_sq(force, torque, mu, width, xp))

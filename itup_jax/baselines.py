"""Baseline grasp scorers, behind the same interface as SDG-Net (`itup.score(..., model=NAME)`).

Lower `Scores.total` is better for every method.

  force_closure  Ferrari-Canny epsilon (the GQ-CNN / Dex-Net analogue: quality from geometry alone).
                 Two soft-finger contacts where the pads meet the surface; each Coulomb cone (the
                 tool's pad friction mu) linearised by `CONE_EDGES` unit-normal-force edges, plus
                 torsional friction +-gamma n with gamma = (2/3) mu a (a uniform disc patch of radius
                 a = half the pad width). Wrenches [f; (c - c_com) x f / L], L = the tool's largest
                 distance from its centre of mass, so epsilon is dimensionless. epsilon = radius of the
                 largest origin-centred ball inside the convex hull (qhull), 0 when the hull misses the
                 origin. total = -epsilon.
  geometric      a GraspNet-style ranking: antipodality (angle of each contact's surface normal from
                 the jaw-closure axis), approach (|cos| of the approach axis against the handle axis:
                 approaching across the handle is preferred) and distance of the grasp to the centre
                 of mass over L; total = antipodal angle (rad) + approach + distance.
  static         the static force-closure ablation (iTuP without SDG-Net and without the task): the
                 wrench of the tool's weight held at the trajectory's first pose, scored by the same
                 C_tau / C_s / C_alpha definitions (C_alpha is 0: no task normal).
  random         uniform random scores (seeded): a random pick.

These are host-side (NumPy, trimesh, scipy's qhull), per candidate; they are references, not the
fast path.
"""

from __future__ import annotations

import math

import numpy as np
import trimesh
from scipy.spatial import ConvexHull, QhullError

from itup_jax.grasp import Grasps
from itup_jax.rotations import quat_to_matrix
from itup_jax.task import Task
from itup_jax.tools import Tool

BASELINES = ("force_closure", "geometric", "static", "random")
#: Edges of each linearised friction cone.
CONE_EDGES = 8
#: Pad half-width (m): Robotiq-2F-85-class pads are 22 mm wide (mjcf/parallel_gripper).
PAD_HALF_WIDTH = 0.011


def tool_length(tool: Tool) -> float:
    """L (m): the tool's largest distance from its centre of mass, the scale of torques and offsets."""
    com = np.asarray(tool.params.com, float)
    return float(np.max(np.linalg.norm(np.asarray(tool.mesh.vertices) - com, axis=1)))


def pad_contacts(tool: Tool, grasps: Grasps) -> tuple[np.ndarray, np.ndarray]:
    """Where the two pads meet the tool: surface points [N, 2, 3] and inward surface normals [N, 2, 3]
    (tool frame), the points of the surface nearest each pad centre."""
    R = np.asarray(quat_to_matrix(grasps.q_tool_grasp), float)  # [N, 3, 3]
    p = np.asarray(grasps.p_tool_grasp, float)
    w = np.asarray(grasps.width, float)
    y = R[:, :, 1]
    pads = np.stack([p - 0.5 * w[:, None] * y, p + 0.5 * w[:, None] * y], axis=1)  # [N, 2, 3]
    closest, _, tri = trimesh.proximity.closest_point(tool.mesh, pads.reshape(-1, 3))
    normals = -np.asarray(tool.mesh.face_normals[tri], float)  # outward -> inward
    return np.asarray(closest, float).reshape(-1, 2, 3), normals.reshape(-1, 2, 3)


def _tangents(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(n, a)
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def ferrari_canny(points: np.ndarray, normals: np.ndarray, com: np.ndarray, mu: float, length: float,
                  *, edges: int = CONE_EDGES, torsion: float | None = None) -> float:
    """Ferrari-Canny epsilon of contacts `points` [C, 3] with inward normals [C, 3] (soft fingers)."""
    gamma = (2.0 / 3.0) * mu * PAD_HALF_WIDTH if torsion is None else torsion
    phi = [2 * math.pi * k / edges for k in range(edges)]
    cos_phi = np.array([[math.cos(a)] for a in phi])  # [E, 1]
    sin_phi = np.array([[math.sin(a)] for a in phi])
    W = []
    for c, n in zip(points, normals):  # per contact: its E cone edges, then its two torsion wrenches
        n = n / np.linalg.norm(n)
        t1, t2 = _tangents(n)
        f = n + mu * (cos_phi * t1 + sin_phi * t2)  # [E, 3]
        W += [np.concatenate([f, np.cross(c - com, f) / length], axis=1)]
        W += [np.r_[np.zeros(3), s * gamma * n / length][None] for s in (-1.0, 1.0)]
    W = np.concatenate(W)
    try:
        hull = ConvexHull(W)
    except QhullError:  # degenerate (e.g. coplanar wrenches): no 6-D force closure
        return 0.0
    # facets: normal . x + offset <= 0 inside; the origin's distance to facet i is -offset_i
    return float(max(0.0, np.min(-hull.equations[:, -1])))


def force_closure_scores(tool: Tool, grasps: Grasps) -> np.ndarray:
    """Ferrari-Canny epsilon [N] of each grasp (higher is better)."""
    pts, nrm = pad_contacts(tool, grasps)
    com = np.asarray(tool.params.com, float)
    length = tool_length(tool)
    mu = float(tool.params.mu)
    return np.array([ferrari_canny(pts[i], nrm[i], com, mu, length) for i in range(len(grasps))])


def geometric_scores(tool: Tool, grasps: Grasps) -> dict[str, np.ndarray]:
    """GraspNet-style terms [N] each (lower is better) and their sum."""
    R = np.asarray(quat_to_matrix(grasps.q_tool_grasp), float)
    _, nrm = pad_contacts(tool, grasps)
    y = R[:, :, 1]
    # pad 0 (at -y) pushes along +y: its inward normal should be +y; pad 1's should be -y
    cos0 = np.clip(np.sum(nrm[:, 0] * y, -1), -1, 1)
    cos1 = np.clip(np.sum(nrm[:, 1] * -y, -1), -1, 1)
    antipodal = 0.5 * (np.arccos(cos0) + np.arccos(cos1))
    approach = np.abs(R[:, 2, 2])  # |approach . tool z| (tool z: the handle axis of every built-in tool)
    com = np.asarray(tool.params.com, float)
    dist = np.linalg.norm(np.asarray(grasps.p_tool_grasp, float) - com, axis=1) / tool_length(tool)
    return {"antipodal": antipodal, "approach": approach, "com_distance": dist,
            "total": antipodal + approach + dist}


def static_scores(tool: Tool, task: Task, grasps: Grasps) -> dict[str, np.ndarray]:
    """C_tau (N m) and C_s (N) of the tool's weight held at the trajectory's first pose."""
    R = np.asarray(quat_to_matrix(grasps.q_tool_grasp), float)  # grasp axes in the tool frame
    p = np.asarray(grasps.p_tool_grasp, float)
    R_wt = np.asarray(task.traj.R_world_tool[0], float)
    m = float(tool.params.mass)
    F_tool = m * (R_wt.T @ np.asarray(task.gravity_world, float))  # weight in the tool frame
    com = np.asarray(tool.params.com, float)
    tau_tool = np.cross(com - p, F_tool)  # [N, 3] about the grasp origin
    tau_g = np.einsum("nij,ni->nj", R, tau_tool)  # grasp-frame components
    F_g = np.einsum("nij,i->nj", R, F_tool)
    c_tau = np.linalg.norm(tau_g[:, [0, 2]], axis=1)  # perpendicular to jaw closure (y)
    c_s = np.maximum(0.0, np.linalg.norm(F_g[:, [0, 2]], axis=1) - float(tool.params.mu) * np.abs(F_g[:, 1]))
    return {"tau": c_tau, "slip": c_s, "align": np.zeros(len(p)), "total": c_tau + c_s}

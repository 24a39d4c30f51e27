"""UR5e kinematics from its DH table: forward kinematics and the closed-form inverse (8 branches).

Vectorised NumPy over any batch shape (host side: it runs once per rollout batch, before stepping).
The MJCF in `mjcf/universal_robots_ur5e/ur5e.xml` is built from the same table, so FK here equals
MuJoCo's flange pose (tested). The inverse follows the standard geometric solution for arms with a
spherical-offset wrist (shoulder: 2 branches, wrist: 2, elbow: 2).

DH table (Universal Robots, "DH Parameters for calculations of kinematics and dynamics"):
  a = [0, -0.425, -0.3922, 0, 0, 0] m, d = [0.1625, 0, 0, 0.1333, 0.0997, 0.0996] m,
  alpha = [pi/2, 0, 0, pi/2, -pi/2, 0] rad.
"""

from __future__ import annotations

import numpy as np

DH_A = np.array([0.0, -0.425, -0.3922, 0.0, 0.0, 0.0])
DH_D = np.array([0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996])
DH_ALPHA = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])


def dh_transform(theta: np.ndarray, j: int) -> np.ndarray:
    """[..., 4, 4] DH transform of joint j (0-based) at angles theta [...]."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(DH_ALPHA[j]), np.sin(DH_ALPHA[j])
    T = np.zeros(np.shape(theta) + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, DH_A[j] * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, DH_A[j] * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, DH_D[j]
    T[..., 3, 3] = 1.0
    return T


def forward_kinematics(q: np.ndarray) -> np.ndarray:
    """[..., 6] joint angles (rad) -> [..., 4, 4] flange pose in the base frame."""
    q = np.asarray(q, float)
    T = dh_transform(q[..., 0], 0)
    for j in range(1, 6):
        T = T @ dh_transform(q[..., j], j)
    return T


def _inv(T: np.ndarray) -> np.ndarray:
    R, p = T[..., :3, :3], T[..., :3, 3]
    out = np.zeros_like(T)
    Rt = np.swapaxes(R, -1, -2)
    out[..., :3, :3] = Rt
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", Rt, p)
    out[..., 3, 3] = 1.0
    return out


def inverse_kinematics(T06: np.ndarray) -> np.ndarray:
    """[..., 4, 4] flange poses -> [..., 8, 6] joint solutions (NaN where a branch is unreachable)."""
    T06 = np.asarray(T06, float)
    batch = T06.shape[:-2]
    a2, a3, d4, d6 = DH_A[1], DH_A[2], DH_D[3], DH_D[5]
    out = np.full(batch + (8, 6), np.nan)
    p05 = T06[..., :3, 3] - d6 * T06[..., :3, 2]  # wrist centre (origin of frame 5)
    r = np.hypot(p05[..., 0], p05[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.arccos(np.clip(d4 / r, -2, 2)) * np.where(np.abs(d4 / r) <= 1, 1.0, np.nan)
        base = np.arctan2(p05[..., 1], p05[..., 0]) + np.pi / 2
        T60 = _inv(T06)
        k = 0
        for s1 in (1.0, -1.0):
            t1 = base + s1 * phi
            c1, sn1 = np.cos(t1), np.sin(t1)
            c5 = (T06[..., 0, 3] * sn1 - T06[..., 1, 3] * c1 - d4) / d6
            valid5 = np.abs(c5) <= 1 + 1e-12
            t5_base = np.arccos(np.clip(c5, -1, 1))
            for s5 in (1.0, -1.0):
                t5 = s5 * t5_base
                s5v = np.sin(t5)
                # theta6 from the rotation of frame 0 seen from frame 6 (arbitrary when sin(t5) = 0)
                y6 = (-T60[..., 1, 0] * sn1 + T60[..., 1, 1] * c1)
                x6 = (T60[..., 0, 0] * sn1 - T60[..., 0, 1] * c1)
                t6 = np.where(np.abs(s5v) > 1e-9, np.arctan2(y6 / np.where(s5v == 0, 1, s5v), x6 / np.where(s5v == 0, 1, s5v)), 0.0)
                T01 = dh_transform(t1, 0)
                T45 = dh_transform(t5, 4)
                T56 = dh_transform(t6, 5)
                T14 = _inv(T01) @ T06 @ _inv(T45 @ T56)
                px, py = T14[..., 0, 3], T14[..., 1, 3]  # joints 2-3 act in frame 1's x-y plane
                rr = px**2 + py**2
                c3 = (rr - a2**2 - a3**2) / (2 * a2 * a3)
                valid3 = np.abs(c3) <= 1 + 1e-12
                t3_base = np.arccos(np.clip(c3, -1, 1))
                # joints 2-4 have parallel axes (alpha_1 = alpha_2 = 0): R14 = Rz(t2 + t3 + t4) Rx(alpha_3),
                # whose first column is (cos, sin, 0) of the sum, so t4 follows without forming T34
                t234 = np.arctan2(T14[..., 1, 0], T14[..., 0, 0])
                for s3 in (1.0, -1.0):
                    t3 = s3 * t3_base
                    # (px, py) = Rz(t2) (a2 + a3 cos t3, a3 sin t3)
                    t2 = np.arctan2(py, px) - np.arctan2(a3 * np.sin(t3), a2 + a3 * np.cos(t3))
                    t4 = t234 - t2 - t3
                    sol = np.stack([t1, t2, t3, t4, t5, t6], axis=-1)
                    ok = valid5 & valid3 & np.isfinite(phi)
                    out[..., k, :] = np.where(ok[..., None], _wrap(sol), np.nan)
                    k += 1
    return out


def _wrap(q: np.ndarray) -> np.ndarray:
    return (q + np.pi) % (2 * np.pi) - np.pi


def nearest_branch(solutions: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """[..., 8, 6] solutions -> [..., 6] the branch nearest to q_ref [..., 6] (2 pi-unwrapped to it)."""
    diff = _wrap(solutions - q_ref[..., None, :])
    dist = np.abs(diff).sum(-1)  # NaN where the branch is unreachable
    dist[np.isnan(dist)] = np.inf
    best = np.argmin(dist, axis=-1)
    chosen = np.take_along_axis(diff, best[..., None, None], axis=-2)[..., 0, :] + q_ref
    chosen[np.isinf(np.take_along_axis(dist, best[..., None], -1)[..., 0])] = np.nan
    return chosen


def joint_heights(q: np.ndarray) -> np.ndarray:
    """[..., 6] -> [..., 5] z (m) of the origins of DH frames 1-5 (shoulder to wrist 3)."""
    q = np.asarray(q, float)
    T = dh_transform(q[..., 0], 0)
    z = [T[..., 2, 3]]
    for j in range(1, 5):
        T = T @ dh_transform(q[..., j], j)
        z.append(T[..., 2, 3])
    return np.stack(z, axis=-1)


def track(T06: np.ndarray, q_start_ref: np.ndarray, min_height: float | None = None) -> np.ndarray:
    """Joint trajectory [..., T, 6] for flange poses [..., T, 4, 4], continuous in time.

    The first step takes the branch nearest `q_start_ref` [6] (a posture such as 'home') among those
    whose elbow and wrist stay above `min_height` (m; None: any branch); each later step the branch
    nearest the previous step, unwrapped by multiples of 2 pi. NaN where unreachable (or, with
    `min_height`, where the chosen branch dips below it).
    """
    sols = inverse_kinematics(T06)  # [..., T, 8, 6]
    if min_height is not None:
        low = (joint_heights(np.nan_to_num(sols[..., 0, :, :]))[..., 1:] < min_height).any(-1)
        sols[..., 0, :, :] = np.where(low[..., None], np.nan, sols[..., 0, :, :])
    T = sols.shape[-3]
    q = np.empty(sols.shape[:-2] + (6,))
    prev = np.broadcast_to(np.asarray(q_start_ref, float), sols.shape[:-3] + (6,))
    for t in range(T):
        q[..., t, :] = nearest_branch(sols[..., t, :, :], prev)
        prev = np.where(np.isnan(q[..., t, :]), prev, q[..., t, :])
    if min_height is not None:
        below = (joint_heights(np.nan_to_num(q))[..., 1:] < min_height).any(-1)
        q = np.where(below[..., None], np.nan, q)
    return q

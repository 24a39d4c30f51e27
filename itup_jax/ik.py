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

from itup_jax.robot import DH_A, DH_ALPHA, DH_D


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
    """[..., 4, 4] flange poses -> [..., 8, 6] joint solutions (NaN where a branch is unreachable).

    Branch k = 4 i1 + 2 i5 + i3 with signs (+, -) of the shoulder (i1), wrist (i5) and elbow (i3)
    choices. The branches are array axes, not Python loops, and T14 = T01^-1 T06 (T45 T56)^-1 is formed
    only in the four entries the elbow needs, written out from the DH table:
      (T45 T56)^-1 has first column (c5 c6, -c5 s6, -s5, 0) and last (d5 s6, d5 c6, -d6, 1);
      T01^-1 has rows (c1, s1, 0, 0) and (0, 0, 1, -d1).
    """
    T06 = np.asarray(T06, float)
    batch = T06.shape[:-2]
    d1, a2, a3, d4, d5, d6 = DH_D[0], DH_A[1], DH_A[2], DH_D[3], DH_D[4], DH_D[5]
    R, p = T06[..., :3, :3], T06[..., :3, 3]
    sign = np.array([1.0, -1.0])
    with np.errstate(invalid="ignore", divide="ignore"):
        p05 = p - d6 * R[..., :, 2]  # wrist centre (origin of frame 5)
        r = np.hypot(p05[..., 0], p05[..., 1])
        phi = np.arccos(np.clip(d4 / r, -2, 2)) * np.where(np.abs(d4 / r) <= 1, 1.0, np.nan)
        base = np.arctan2(p05[..., 1], p05[..., 0]) + np.pi / 2
        t1 = base[..., None] + sign * phi[..., None]  # [..., 2]  (i1)
        c1, s1 = np.cos(t1), np.sin(t1)
        c5 = (p[..., 0, None] * s1 - p[..., 1, None] * c1 - d4) / d6
        valid5 = np.abs(c5) <= 1 + 1e-12
        t5 = np.arccos(np.clip(c5, -1, 1))[..., None] * sign  # [..., 2, 2]  (i1, i5)
        sn5 = np.sin(t5)
        cs5 = np.cos(t5)
        # theta6 from the rotation of frame 0 seen from frame 6 (R60 = R^T; arbitrary when sin(t5) = 0)
        y6 = (-R[..., 0, 1, None] * s1 + R[..., 1, 1, None] * c1)[..., None]
        x6 = (R[..., 0, 0, None] * s1 - R[..., 1, 0, None] * c1)[..., None]
        safe = np.where(sn5 == 0, 1.0, sn5)
        t6 = np.where(np.abs(sn5) > 1e-9, np.arctan2(y6 / safe, x6 / safe), 0.0)
        c6, sn6 = np.cos(t6), np.sin(t6)
        # M = T06 (T45 T56)^-1, columns 0 and 3 (rows 0-2)
        v0 = (cs5 * c6, -cs5 * sn6, -sn5)
        v3 = (d5 * sn6, d5 * c6, np.full_like(sn6, -d6))
        m0 = [sum(R[..., i, j, None, None] * v0[j] for j in range(3)) for i in range(3)]
        m3 = [sum(R[..., i, j, None, None] * v3[j] for j in range(3)) + p[..., i, None, None] for i in range(3)]
        c1b, s1b = c1[..., None], s1[..., None]
        px, py = c1b * m3[0] + s1b * m3[1], m3[2] - d1  # T14[0, 3], T14[1, 3]: joints 2-3 act in frame 1's x-y plane
        # joints 2-4 have parallel axes (alpha_1 = alpha_2 = 0): R14 = Rz(t2 + t3 + t4) Rx(alpha_3), whose
        # first column is (cos, sin, 0) of the sum, so t4 follows without forming T34
        t234 = np.arctan2(m0[2], c1b * m0[0] + s1b * m0[1])
        c3 = (px**2 + py**2 - a2**2 - a3**2) / (2 * a2 * a3)
        valid3 = np.abs(c3) <= 1 + 1e-12
        t3 = np.arccos(np.clip(c3, -1, 1))[..., None] * sign  # [..., 2, 2, 2]  (i1, i5, i3)
        # (px, py) = Rz(t2) (a2 + a3 cos t3, a3 sin t3)
        t2 = np.arctan2(py, px)[..., None] - np.arctan2(a3 * np.sin(t3), a2 + a3 * np.cos(t3))
        t4 = t234[..., None] - t2 - t3
        shape = batch + (2, 2, 2)
        sol = np.stack([np.broadcast_to(t1[..., :, None, None], shape), t2, t3, t4,
                        np.broadcast_to(t5[..., None], shape), np.broadcast_to(t6[..., None], shape)], axis=-1)
        ok = (valid5[..., None, None] & valid3[..., None] & np.isfinite(phi)[..., None, None, None])
        return np.where(ok[..., None], _wrap(sol), np.nan).reshape(batch + (8, 6))


def _wrap(q: np.ndarray) -> np.ndarray:
    """Angles to [-pi, pi] (rint, not %: np.remainder costs ~4x more on these arrays)."""
    return q - (2 * np.pi) * np.rint(q * (0.5 / np.pi))


def _nearest(solutions: np.ndarray, q_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(the branch nearest to q_ref [..., 6] among solutions [..., 8, 6], 2 pi-unwrapped to it [..., 6];
    its index [...]). L1 distance of the wrapped differences; the lowest index wins a tie; NaN where
    every branch is unreachable."""
    diff = _wrap(solutions - q_ref[..., None, :])
    dist = np.abs(diff).sum(-1)  # NaN where the branch is unreachable
    dist[np.isnan(dist)] = np.inf
    best = np.argmin(dist, axis=-1)
    chosen = np.take_along_axis(diff, best[..., None, None], axis=-2)[..., 0, :] + q_ref
    chosen[np.isinf(np.take_along_axis(dist, best[..., None], -1)[..., 0])] = np.nan
    return chosen, best


def nearest_branch(solutions: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """[..., 8, 6] solutions -> [..., 6] the branch nearest to q_ref [..., 6] (2 pi-unwrapped to it)."""
    return _nearest(solutions, q_ref)[0]


def joint_heights(q: np.ndarray) -> np.ndarray:
    """[..., 6] -> [..., 5] z (m) of the origins of DH frames 1-5 (shoulder to wrist 3).

    Only the third row of the running product T01 T12 ... is needed: it is carried as a row vector
    (r T_j, with T_j's entries written out from the DH table)."""
    q = np.asarray(q, float)
    r = [np.zeros(q.shape[:-1]), np.full(q.shape[:-1], np.sin(DH_ALPHA[0])), np.full(q.shape[:-1], np.cos(DH_ALPHA[0])),
         np.full(q.shape[:-1], DH_D[0])]  # row 2 of T01 (independent of q1)
    z = [r[3]]
    for j in range(1, 5):
        ct, st = np.cos(q[..., j]), np.sin(q[..., j])
        ca, sa = np.cos(DH_ALPHA[j]), np.sin(DH_ALPHA[j])
        r = [r[0] * ct + r[1] * st,
             (r[1] * ct - r[0] * st) * ca + r[2] * sa,
             (r[0] * st - r[1] * ct) * sa + r[2] * ca,
             (r[0] * ct + r[1] * st) * DH_A[j] + r[2] * DH_D[j] + r[3]]
        z.append(r[3])
    return np.stack(z, axis=-1)


def track(T06: np.ndarray, q_start_ref: np.ndarray, min_height: float | None = None, *,
          solutions: np.ndarray | None = None) -> np.ndarray:
    """Joint trajectory [..., T, 6] for flange poses [..., T, 4, 4], continuous in time.

    The first step takes the branch nearest `q_start_ref` [6] (a posture such as 'home') among those
    whose elbow and wrist stay above `min_height` (m; None: any branch); each later step the branch
    nearest the previous step, unwrapped by multiples of 2 pi. NaN where unreachable (or, with
    `min_height`, where the chosen branch dips below it).

    That rule is sequential, but a trajectory almost always keeps its first branch: so the first
    branch is followed for all steps at once (`_follow`), the rule is checked at every step in one
    pass, and only the trajectories where it picks another branch (or meets an unreachable step) are
    stepped one step at a time, together, from the earliest such step (`_sequential`).

    `solutions`: `inverse_kinematics(T06)` [..., T, 8, 6] when the caller has it already (not modified).
    """
    T06 = np.asarray(T06, float)
    batch, T = T06.shape[:-3], T06.shape[-3]
    sols = (inverse_kinematics(T06) if solutions is None else np.array(solutions, float)).reshape((-1, T, 8, 6))
    if min_height is not None:
        low = (joint_heights(np.nan_to_num(sols[:, 0]))[..., 1:] < min_height).any(-1)
        sols[:, 0] = np.where(low[..., None], np.nan, sols[:, 0])
    ref = np.broadcast_to(np.asarray(q_start_ref, float), (len(sols), 6))
    q0, b0 = _nearest(sols[:, 0], ref)
    q, first = _follow(sols, q0, b0)
    redo = np.nonzero(first < T)[0]
    if len(redo):
        _sequential(sols[redo], q, redo, int(first[redo].min()), ref[redo])
    if min_height is not None:
        below = (joint_heights(np.nan_to_num(q))[..., 1:] < min_height).any(-1)
        q = np.where(below[..., None], np.nan, q)
    return q.reshape(batch + (T, 6))


def _follow(sols: np.ndarray, q0: np.ndarray, b0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Branch b0 [B] of sols [B, T, 8, 6] followed from q0 [B, 6], unwrapped: ([B, T, 6], first [B]: the
    first step where the nearest-branch rule would leave b0 or b0 is unreachable, T if none; up to it the
    result is the sequential one; 1 where q0 itself is unreachable)."""
    T = sols.shape[1]
    path = np.take_along_axis(sols, b0[:, None, None, None], axis=2)[:, :, 0]  # [B, T, 6]
    q = q0[:, None] + np.concatenate([np.zeros_like(q0[:, None]), np.cumsum(_wrap(np.diff(path, axis=1)), axis=1)], 1)
    dist = np.abs(_wrap(sols[:, 1:] - q[:, :-1, None])).sum(-1)  # [B, T - 1, 8]
    dist[np.isnan(dist)] = np.inf
    bad = (np.argmin(dist, axis=-1) != b0[:, None]) | ~np.isfinite(q[:, 1:]).all(-1)
    first = np.where(bad.any(1), bad.argmax(1) + 1, T)
    return q, np.where(np.isnan(q0).any(-1), 1, first)


def _sequential(sols: np.ndarray, q: np.ndarray, rows: np.ndarray, start: int, ref: np.ndarray) -> None:
    """The nearest-branch rule one step at a time for `rows` of q [B, T, 6] (in place) from step `start`
    on; sols [R, T, 8, 6] are those rows' solutions, ref [R, 6] their start reference (used while no
    step so far was reachable)."""
    prev = q[rows, start - 1]
    prev = np.where(np.isnan(prev), ref, prev)
    for t in range(start, sols.shape[1]):
        qt = nearest_branch(sols[:, t], prev)
        q[rows, t] = qt
        prev = np.where(np.isnan(qt), prev, qt)

"""Labels: what a rollout measured, from its recorded sensors (the same code for both backends).

    labels = compute_labels(scene, task, plan, qvel_peak, sensordata)   # Labels: arrays [N]

The headline is the full induced peak wrist torque (`peak_torque_induced`: the wrist sensor's torque
minus its static value at the end of the settle, all three axes), with the raw peak, the projected and
closure-axis parts and the grasp-frame components beside it; then the grip demand, slip, turn,
alignment drift, failure and the task's own success (`tasks.<kind>.outcome`). A rollout that diverged
or was infeasible is not a label (`Labels.valid` False).
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from itup_jax import tasks
from itup_jax.grip_demand import grip_demand, torque_about_grasp
from itup_jax.rotations import quat_angle, quat_z_axis
from itup_jax.sim.arm import Plan
from itup_jax.sim.config import SimConfig
from itup_jax.sim.scene import Scene
from itup_jax.task import Task

LABEL_FIELDS = (
    "peak_torque", "peak_torque_induced", "peak_torque_projected", "peak_torque_closure",
    "peak_induced_third", "peak_induced_closure", "peak_induced_approach", "grip_demand", "static_torque",
    "peak_force_induced", "peak_pad_force", "slip_translation", "slip_rotation", "alignment_drift", "failed", "success",
    "task_metric", "diverged", "infeasible", "over_speed", "valid",
)


#: The boolean ones.
LABEL_FLAGS = ("failed", "success", "diverged", "infeasible", "over_speed", "valid")


@dataclasses.dataclass(frozen=True)
class Labels:
    """Per-rollout labels, each [N] (SI units; torques in N m about the wrist sensor site).

    peak_torque: max |tau| over the motion.  peak_torque_induced: max |tau - tau_static|.
    peak_torque_projected: max |(I - y y^T)(tau - tau_static)|, y the jaw-closure axis (the cost's
    projection).  peak_torque_closure: max |(tau - tau_static) . y|.  peak_induced_third,
    peak_induced_closure, peak_induced_approach: the induced torque's components in the grasp frame's
    axes (x, y the jaw's closure, z the approach), absolute, at the step of its peak norm: they
    recompose peak_torque_induced.  grip_demand (N per pad): max over the motion of the normal force
    each pad needs to hold the induced wrench by friction (`grip_demand.grip_demand`: the wrist's
    induced force and its torque moved to the grasp centre, the rollout's pad friction, the grasp's
    jaw opening; the hold at rest is not in it; the gripper's own inertia is, as in every wrist
    label).  static_torque: |tau_static|.
    peak_force_induced: max |F - F_static| (N).  peak_pad_force: max normal force of either pad's
    strongest contact during the motion (N).  slip_translation (m): max distance over the motion by
    which the tool's material point at the grasp centre (midway between the pads at the end of the
    settle) moved away from it, in the grasp frame (`grasp_point_slip`; independent of where the tool's
    frame has its origin).  slip_rotation (rad): max angle the tool turned in the grasp frame over the
    motion, from its pose at the end of the settle.  alignment_drift (rad): max angle
    of the tool's z axis from the trajectory's during contact.  failed: slip or rotation over the
    thresholds, or tool lost.  task_metric: nail depth (m) | debris past the line (count) | top-block
    displacement (m) | block displacement along the task direction (m).  success: task_metric beyond
    the task's threshold.  diverged, infeasible, over_speed: flags.  valid: neither diverged nor
    infeasible (only valid rollouts are labels). diverged: a non-finite state or sensor, a joint faster
    than `SimConfig.diverged_qvel`, or a slip no physical rollout makes (`implausible_slip`).
    """

    peak_torque: np.ndarray
    peak_torque_induced: np.ndarray
    peak_torque_projected: np.ndarray
    peak_torque_closure: np.ndarray
    peak_induced_third: np.ndarray
    peak_induced_closure: np.ndarray
    peak_induced_approach: np.ndarray
    grip_demand: np.ndarray
    static_torque: np.ndarray
    peak_force_induced: np.ndarray
    peak_pad_force: np.ndarray
    slip_translation: np.ndarray
    slip_rotation: np.ndarray
    alignment_drift: np.ndarray
    failed: np.ndarray
    success: np.ndarray
    task_metric: np.ndarray
    diverged: np.ndarray
    infeasible: np.ndarray
    over_speed: np.ndarray
    valid: np.ndarray

    def as_dict(self) -> dict[str, np.ndarray]:
        return {f: getattr(self, f) for f in LABEL_FIELDS}

    @classmethod
    def unmeasured(cls, n: int) -> Labels:
        """[n] rows with nothing measured: NaN measurements, every flag False."""
        full = {f: np.full(n, np.nan) for f in LABEL_FIELDS}
        full.update({f: np.zeros(n, bool) for f in LABEL_FLAGS})
        return cls(**full)

    @classmethod
    def concatenate(cls, parts) -> Labels:
        """The rows of `parts` (a sequence of `Labels`) one after the other; no rows for no parts."""
        parts = list(parts)
        if not parts:
            return cls.unmeasured(0)
        return cls(**{f: np.concatenate([np.asarray(getattr(L, f)) for L in parts]) for f in LABEL_FIELDS})


#: The grasp frame's axes as the wrist sensor reads them (its frame is the gripper base's, whose axes are
#: the grasp frame's): x the third axis, y the jaw's closure, z the approach.
GRASP_AXES = ("third", "closure", "approach")


def induced_components_at_peak(d_tau: np.ndarray) -> dict[str, np.ndarray]:
    """d_tau [N, S, 3] N m, the induced torque in the grasp frame's axes over the motion ->
    {"peak_induced_<axis>": [N]}: the absolute components at the step where its norm peaks, so
    sqrt(third^2 + closure^2 + approach^2) is the peak induced torque."""
    sq = np.einsum("...i,...i->...", d_tau, d_tau)
    k = np.argmax(np.nan_to_num(sq, nan=-np.inf), axis=1)
    at = np.take_along_axis(d_tau, k[:, None, None], axis=1)[:, 0]
    return {f"peak_induced_{name}": np.abs(at[:, i]) for i, name in enumerate(GRASP_AXES)}


def _peak_norm(x: np.ndarray) -> np.ndarray:
    """max over axis 1 of the Euclidean norm over the last axis: [N, S, k] -> [N] (NaN if any NaN).
    einsum on the sensor slices (strided views) runs ~6x faster here than np.linalg.norm."""
    return np.sqrt(np.einsum("...i,...i->...", x, x).max(1))


def initial_pad_overlap(scene: Scene, qpos0: np.ndarray) -> np.ndarray:
    """[N] m: how deep the deeper pad sits in the tool at each initial state qpos0 [N, nq] (MuJoCo's
    contact distance, positive = overlap; NaN where a pad touches nothing). A rollout starts with the pads
    `INITIAL_SQUEEZE` inside the jaw opening; grasps whose pads lie flat on the tool start that deep
    (`SamplerConfig(contact="flat")`), point-contact grasps deeper (experiments/initial_grip.py)."""
    m = scene.model
    d = mujoco.MjData(m)
    pads = (m.geom("gripper/pad_neg").id, m.geom("gripper/pad_pos").id)
    out = np.full(len(qpos0), np.nan)
    for i, q in enumerate(qpos0):
        mujoco.mj_resetData(m, d)
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        depth = {pad: -np.inf for pad in pads}
        for c in d.contact[:d.ncon]:
            for pad in pads:
                if pad in (c.geom1, c.geom2):
                    depth[pad] = max(depth[pad], -c.dist)
        if all(np.isfinite(v) for v in depth.values()):
            out[i] = max(depth.values())
    return out


def grasp_point_slip(pos_g: np.ndarray, quat_g: np.ndarray, ref: int) -> np.ndarray:
    """How far the tool's material point at the grasp centre slid, [N, S, 3] x [N, S, 4] -> [N, S] (m).

    pos_g [N, S, 3] (m) and quat_g [N, S, 4] (w, x, y, z) are the pose of the tool frame in the grasp
    frame at each step. The grasp centre (the grasp frame's origin, midway between the pads) sits in
    tool coordinates at c = -R^T p. The point of the tool that was there at step `ref` is, at step t,
    at R(t) c(ref) + p(t) = R(t) (c(ref) - c(t)) in the grasp frame, a distance |c(t) - c(ref)| from
    the centre. Unlike the displacement of the tool frame's origin (the label until code 0.4.0), it
    does not depend on where the tool's mesh has its origin: a tool turning about the grasp centre does
    not slide there however far its origin swings.
    """
    w, u = quat_g[..., :1], quat_g[..., 1:]
    uxp = np.cross(u, pos_g)
    # R^T p: p rotated by the conjugate quaternion (w, -u) = p - 2w (u x p) + 2 u x (u x p)
    centre = -(pos_g - 2.0 * w * uxp + 2.0 * np.cross(u, uxp))
    d = centre - centre[:, ref:ref + 1]
    return np.sqrt(np.einsum("...i,...i->...", d, d))


def implausible_slip(slip_path: np.ndarray, dt: float, config: SimConfig = SimConfig()) -> np.ndarray:
    """[N] bool: a grasp point's slip [N, S] (m, per step) that no physical rollout makes: farther from the
    pads than `config.diverged_slip` (a tool that falls out of the hand lands within it), or a jump
    between two steps faster than `config.diverged_qvel` m/s (a state MuJoCo reset after an
    instability, or an integration that blew up without a non-finite value). NaN counts as implausible."""
    path = np.nan_to_num(slip_path, nan=np.inf)
    jump = np.abs(np.diff(path, axis=1)).max(1, initial=0.0) if path.shape[1] > 1 else np.zeros(len(path))
    return (path.max(1, initial=0.0) > config.diverged_slip) | (jump > config.diverged_qvel * dt)


def induced(scene: Scene, p: Plan, x: np.ndarray, config: SimConfig = SimConfig()) -> tuple[np.ndarray, np.ndarray]:
    """What the motion induces at a wrist sensor: (x over the motion minus its static value
    [N, nstep - n_settle, 3], the static value [N, 3]). x: [N, nstep, 3], the trace of the wrist torque
    (N m) or force (N) sensor over the whole rollout, in the sensor (gripper base) frame, whose y is the
    jaw-closure axis; the static value is its mean over the settle's last `config.static_window` s. The
    labels' projected torque (the measured C_tau) is the norm of the induced torque's (x, z) part."""
    n_static = max(1, int(round(config.static_window / scene.model.opt.timestep)))
    static = x[:, p.n_settle - n_static:p.n_settle].mean(1)
    return x[:, p.n_settle:p.nstep] - static[:, None], static


def compute_labels(scene: Scene, task: Task, p: Plan, qvel_peak: np.ndarray, sensordata: np.ndarray,
                   config: SimConfig = SimConfig()) -> Labels:
    """Labels from recorded sensors (the same code for both backends). qvel_peak: peak |qvel| per
    rollout [N] (native) or per step [N, nstep] (MJX); NaN marks a blow-up."""
    s = lambda name: scene.sensor(sensordata, name)  # noqa: E731
    dt = scene.model.opt.timestep
    tau, force = s("gripper/wrist_torque"), s("gripper/wrist_force")
    motion = slice(p.n_settle, p.nstep)
    d_tau, tau_static = induced(scene, p, tau, config)
    d_force, _ = induced(scene, p, force, config)
    # closure axis: y of the sensor (gripper base) frame; the projected torque is the rest, (x, z)
    closure = d_tau[..., 1]
    d_tau_sq = np.einsum("...i,...i->...", d_tau, d_tau)
    perp_sq = d_tau[..., 0] * d_tau[..., 0] + d_tau[..., 2] * d_tau[..., 2]
    pos_g, quat_g = s("tool_pos_grasp"), s("tool_quat_grasp")
    # slip and rotation in the pads over the motion, from the grip as it stands at the end of the settle
    ref = p.n_settle - 1
    slip_path = grasp_point_slip(pos_g[:, ref:], quat_g[:, ref:], 0)[:, 1:]  # [N, S]
    slip_t = slip_path.max(1)
    slip_r = quat_angle(quat_g[:, motion], quat_g[:, ref, None]).max(1)
    # alignment drift: the tool's z axis against the trajectory's, while in contact
    # (the task's arrays are JAX arrays: converted once, host indexing of a JAX array dispatches an op)
    impact, drag = np.asarray(task.impact), np.asarray(task.drag)
    active = np.maximum(impact, drag).max(1) > 0
    idx = p.traj_index[motion]
    in_contact = np.where(idx >= 0, active[np.clip(idx, 0, None)], False)
    t_traj = np.asarray(task.traj.t, float)
    t_m = p.sim_t[motion]
    for k in np.nonzero(impact.max(1) > 0)[0]:
        in_contact |= (t_m >= t_traj[k] - dt) & (t_m <= t_traj[k] + config.impact_window)
    # the angle is only needed while in contact: the tool's z axis at those steps against the trajectory's
    z_ref = np.asarray(task.traj.R_world_tool, float)[np.clip(idx[in_contact], 0, None), :, 2]  # [C, 3]
    cos_angle = np.einsum("nci,ci->nc", quat_z_axis(s("tool_quat")[:, motion][:, in_contact]), z_ref)
    drift = np.arccos(np.clip(cos_angle, -1.0, 1.0)).max(1) if in_contact.any() else np.zeros(len(sensordata))
    # pads: peak normal force of either pad over the motion, counted where a contact is found
    pad_peak = np.max([np.where(pad[..., 0] > 0, np.abs(pad[..., 1]), 0.0).max(1)
                       for pad in (s(f"pad_{side}_contact")[:, motion] for side in ("neg", "pos"))], axis=0)
    lost = slip_t > config.lost_distance
    qvel_peak = np.nan_to_num(np.asarray(qvel_peak), nan=np.inf).reshape(len(sensordata), -1).max(1)
    diverged = (~np.isfinite(sensordata).all(axis=(1, 2)) | (qvel_peak > config.diverged_qvel)
                | implausible_slip(slip_path, dt, config))
    metric, success = _task_outcome(scene, task, sensordata, p)
    failed = (slip_t > config.slip_threshold) | (slip_r > config.rotation_threshold) | lost
    nan0 = lambda a: np.nan_to_num(a, nan=np.inf)  # noqa: E731
    return Labels(
        peak_torque=nan0(_peak_norm(tau[:, motion])),
        peak_torque_induced=nan0(np.sqrt(d_tau_sq.max(1))),
        peak_torque_projected=nan0(np.sqrt(perp_sq.max(1))),
        peak_torque_closure=nan0(np.abs(closure).max(1)),
        **{k: nan0(v) for k, v in induced_components_at_peak(d_tau).items()},
        grip_demand=nan0(grip_demand(d_force, torque_about_grasp(d_force, d_tau), p.mu[:, None],
                                     p.width[:, None]).max(1)),
        static_torque=np.linalg.norm(tau_static, axis=-1),
        peak_force_induced=nan0(_peak_norm(d_force)),
        peak_pad_force=nan0(pad_peak),
        slip_translation=nan0(slip_t), slip_rotation=nan0(slip_r), alignment_drift=nan0(drift),
        failed=failed | diverged, success=success & ~diverged, task_metric=metric,
        diverged=diverged, infeasible=p.infeasible.copy(), over_speed=p.over_speed.copy(),
        valid=~(diverged | p.infeasible),
    )


def _task_outcome(scene: Scene, task: Task, sensordata: np.ndarray, p: Plan) -> tuple[np.ndarray, np.ndarray]:
    """The task kind's metric and success (`TaskKind.outcome`, in `itup_jax/tasks/<kind>.py`)."""
    return tasks.get(task.kind).outcome(scene, task, sensordata, p)


def feasible_labels(scene: Scene, task: Task, p: Plan, run: np.ndarray, run_plan: Plan, qvel_peak: np.ndarray | None,
                     sensordata: np.ndarray | None, config: SimConfig) -> Labels:
    """Labels [N] of a plan whose rollouts `run` (the feasible ones; `run_plan` = their plan) were stepped,
    with their qvel peaks and sensors (leading axis len(run)); the others (infeasible, not stepped) get NaN
    measurements, flags False."""
    n = len(p.infeasible)
    full = Labels.unmeasured(n).as_dict()
    full.update(infeasible=p.infeasible.copy(), over_speed=p.over_speed.copy())
    if len(run):
        sub = compute_labels(scene, task, run_plan, qvel_peak, sensordata, config)
        for f in LABEL_FIELDS:
            full[f][run] = getattr(sub, f)
    return Labels(**full)


def traces_of_rows(scene: Scene, n: int, nstep: int, run: np.ndarray, sensordata: np.ndarray | None) -> np.ndarray:
    """Sensor traces [n, nstep, nsensordata]: rows `run` from `sensordata` (the stepped rollouts), NaN in the
    others (infeasible, not stepped)."""
    full = np.full((n, nstep, scene.model.nsensordata), np.nan)
    if len(run):
        full[run] = sensordata
    return full

"""Executing grasps in MuJoCo: batched rollouts with two backends and one label schema.

    result = simulate(tool, task, grasps, backend=None, seed=0)   # result.labels.<name>: arrays [N]

Per rollout: the tool starts in the gripper at grasp g with the pads closed on it at the grip force;
the arm holds still for `settle_time` (the static holding wrench is measured at its end), then its
flange follows the task trajectory xi(t) through closed-form UR5e inverse kinematics (`ik.py`), as
position targets of the joint servos. Recorded per step (sensors, so both backends record the same):
wrist force/torque at the flange/gripper interface, each pad's contact (found, force of its strongest
contact), the tool's pose in the grasp frame and in the world, and the task objects' state.

Backends (same inputs, same outputs):
  * 'native': `mujoco.rollout` with one MjData per thread and one MjModel per rollout (so mass,
    friction, restitution and grip force vary per rollout). The CPU default and the ground truth.
  * 'mjx': `jax.jit(jax.vmap(lax.scan(mjx.step)))` with the varying model fields batched. The default
    when JAX's backend is an accelerator. On a CPU, MJX is 240-430x slower (docs/design.md, "Simulation"), `rollout_mjx` runs
    chunks of at most 64 per CPU device, and MJX's Cholesky is `mjx_cholesky`'s (jaxlib's LAPACK kernel
    deadlocked there: the knock at a batch of 16, the hammer at 128). Capsule-box
    contacts go through `mjx_collision.capsule_box_collider` (MJX's own reverses a pad's contact on long
    tilted handles). It runs in float64 (`MJX_FLOAT64`), where its reach labels match native MuJoCo's; in
    float32 the pads' stiff contacts spike (docs/benchmarks.md, "MJX against native").

Rollouts whose IK fails (unreachable pose, joint limit, or elbow/wrist below the table) are flagged `infeasible`:
the native path does not step them at all, and for both backends their measured labels are NaN (flags False,
their traces NaN). Rollouts that blow up are flagged `diverged`. Neither is a label: `Labels.valid` is False.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import math
import os
import weakref

import jax
import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from itup_jax import ik, robot, tasks
from itup_jax.errors import InputError, check_seed, is_integer
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.grip_demand import grip_demand, torque_about_grasp
from itup_jax.mjx_cholesky import jax_cholesky
from itup_jax.mjx_collision import native_capsule_box
from itup_jax.precision import full_precision
from itup_jax.robot import ARM_CLEARANCE, FLANGE_TO_GRASP, HOME_Q, JOINT_LIMITS
from itup_jax.scene import Scene, build_scene, target_solref
from itup_jax.task import Task
from itup_jax.tool import Tool

#: Pads start this much inside the tool's surface so contact exists at step 0 (m).
INITIAL_SQUEEZE = 3e-4
#: The largest MJX batch per CPU device. MJX on a CPU hung at a device batch of 128, a
#: deadlock in jaxlib's LAPACK Cholesky that `mjx_cholesky` now avoids (a hammer batch of 128 has
#: run); the cap stays until larger batches have run more than once.
MJX_CPU_MAX_BATCH = 64
#: MJX rollouts run in float64 by default. In float32 the pads' stiff contacts spike while a tool is held
#: still: on the reach, float32 MJX's torques rank at 0.52 against native MuJoCo's and float64 MJX's at
#: 0.995 (CPU; docs/benchmarks.md "MJX against native"). On a GPU float64 may cost speed (not measured).
MJX_FLOAT64 = True


def _mjx_float64(float64: bool | None) -> bool:
    """An MJX float-type choice: True (float64), False (float32), None (`MJX_FLOAT64`, read at the call)."""
    return MJX_FLOAT64 if float64 is None else bool(float64)


@dataclasses.dataclass(frozen=True)
class SimConfig:
    """Rollout settings and label thresholds (SI units)."""

    settle_time: float = 0.3  # s, still, gripped, before the motion
    grip_force: float = 100.0  # N per pad (Robotiq 2F-85 range 20-235 N)
    slip_threshold: float = 0.01  # m, failure when the tool slides this far in the pads (at the grasp centre)
    rotation_threshold: float = math.radians(10.0)  # rad, failure when it turns this far
    lost_distance: float = 0.05  # m, tool lost (slid this far at the grasp centre)
    impact_window: float = 0.05  # s after an impact still counted as contact (alignment drift)
    diverged_qvel: float = 500.0  # rad/s or m/s: any |qvel| above is a blow-up
    static_window: float = 0.05  # s at the end of the settle phase averaged for the static wrench


@dataclasses.dataclass(frozen=True)
class Randomization:
    """Relative spreads of the domain randomisation (uniform, +- the value); 0 switches one off."""

    mass: float = 0.1
    mu: float = 0.2
    restitution: float = 0.1  # absolute, clipped to [0.05, 0.95]
    contact_duration: float = 0.3
    grip_force: float = 0.2


@dataclasses.dataclass(frozen=True)
class Physics:
    """Physical parameters of each rollout, arrays [N]."""

    mass_scale: np.ndarray
    mu: np.ndarray
    restitution: np.ndarray
    contact_duration: np.ndarray
    grip_force: np.ndarray


def sample_physics(tool: Tool, n: int, seed: int = 0, *, spread: Randomization | None = Randomization(),
                   grip_force: float = SimConfig.grip_force) -> Physics:
    """Per-rollout physics around the tool's priors; `spread=None` gives the nominal values."""
    p = tool.params
    nominal = Physics(np.ones(n), np.full(n, float(p.mu)), np.full(n, float(p.restitution)),
                      np.full(n, float(p.contact_duration)), np.full(n, float(grip_force)))
    check_seed(seed, "sample_physics")
    if spread is None:
        return nominal
    rng = np.random.default_rng(seed)
    u = lambda: rng.uniform(-1.0, 1.0, n)  # noqa: E731
    return Physics(
        mass_scale=1.0 + spread.mass * u(),
        mu=nominal.mu * (1.0 + spread.mu * u()),
        restitution=np.clip(nominal.restitution + spread.restitution * u(), 0.05, 0.95),
        contact_duration=nominal.contact_duration * (1.0 + spread.contact_duration * u()),
        # a randomised grip stays in the gripper's range; a nominal grip outside it (a stress probe,
        # `stress.py`) is kept as given
        grip_force=np.clip(nominal.grip_force * (1.0 + spread.grip_force * u()),
                           min(robot.GRIPPER_MIN_GRIP_FORCE, float(grip_force)),
                           max(robot.GRIPPER_MAX_GRIP_FORCE, float(grip_force))),
    )


@dataclasses.dataclass(frozen=True)
class Plan:
    """Everything a backend needs, arrays with leading [N]."""

    qpos0: np.ndarray  # [N, nq]
    ctrl: np.ndarray  # [N, nstep, nu]
    q_traj: np.ndarray  # [N, T, 6] IK solution at the trajectory samples
    infeasible: np.ndarray  # [N] bool
    over_speed: np.ndarray  # [N] bool, a joint faster than 180 deg/s
    nstep: int
    n_settle: int
    sim_t: np.ndarray  # [nstep] s, time of each recorded step from the start of the motion
    traj_index: np.ndarray  # [nstep] nearest trajectory sample of each step (-1 during settling)
    width: np.ndarray  # [N] m, the grasp's jaw opening
    mu: np.ndarray  # [N] -, the rollout's pad friction


def _concat_plans(plans: list[Plan]) -> Plan:
    first = plans[0]
    cat = lambda f: np.concatenate([getattr(q, f) for q in plans])  # noqa: E731
    return dataclasses.replace(first, qpos0=cat("qpos0"), ctrl=cat("ctrl"), q_traj=cat("q_traj"),
                               infeasible=cat("infeasible"), over_speed=cat("over_speed"), width=cat("width"),
                               mu=cat("mu"))


def _slice_physics(physics: Physics, sl: slice) -> Physics:
    return Physics(*(getattr(physics, f.name)[sl] for f in dataclasses.fields(Physics)))


def _pose_matrix(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3], T[..., :3, 3], T[..., 3, 3] = R, p, 1.0
    return T


def _quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """[..., 4] quaternions (w, x, y, z; normalised here) -> [..., 3, 3], host side in float64
    (`grasp.rotation_matrix` is the jittable one; as a host call its dispatch costs more than this)."""
    w, x, y, z = np.moveaxis(q / np.linalg.norm(q, axis=-1, keepdims=True), -1, 0)
    return np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(q.shape[:-1] + (3, 3))


def _quat_from_matrix(R: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R).ravel())
    return q


def _as_slice(idx: np.ndarray):
    """A run of consecutive indices as a slice (a view, faster to assign through); others unchanged."""
    idx = np.asarray(idx)
    if idx.ndim == 1 and len(idx) and np.all(np.diff(idx) == 1):
        return slice(int(idx[0]), int(idx[-1]) + 1)
    return idx


def _tool_grasp_poses(grasps: Grasps) -> np.ndarray:
    """[N, 4, 4] the grasp frames in the tool frame."""
    return _pose_matrix(_quat_to_matrix(np.asarray(grasps.q_tool_grasp, float)), np.asarray(grasps.p_tool_grasp, float))


def _grasp_flange_pose() -> np.ndarray:
    """[4, 4] the flange in the grasp frame."""
    return _pose_matrix(np.eye(3), np.array([0.0, 0.0, -FLANGE_TO_GRASP]))


def arm_trajectory(task: Task, grasps: Grasps) -> tuple[np.ndarray, np.ndarray]:
    """The arm's joint trajectory that carries each grasp along the task: q_traj [N, T, 6] (rad, closed-form
    IK at the trajectory's samples; NaN where IK fails) and infeasible [N] (IK failed somewhere or a joint
    leaves its limits). Kinematics only: no scene, no physics."""
    tr = task.traj
    T_world_tool = _pose_matrix(np.asarray(tr.R_world_tool, float), np.asarray(tr.p_world_tool, float))  # [T]
    T06 = T_world_tool[None] @ _tool_grasp_poses(grasps)[:, None] @ _grasp_flange_pose()  # [N, T, 4, 4]
    q_traj = ik.track(T06, HOME_Q, min_height=ARM_CLEARANCE)
    infeasible = np.isnan(q_traj).any(axis=(1, 2)) | (np.abs(np.nan_to_num(q_traj)) > JOINT_LIMITS).any(axis=(1, 2))
    return q_traj, infeasible


#: Candidates per `arm_trajectory` call in `reachable`: the IK's temporaries of 128 candidates x 64 samples
#: x 8 branches stay below the allocator's mmap threshold and are reused; one call on 2,000 candidates
#: costs ~3x the same work in chunks of 128 (each ~50 MB temporary is mapped and zeroed afresh).
REACHABLE_CHUNK = 128


def reachable(task: Task, grasps: Grasps) -> np.ndarray:
    """[N] bool: whether the arm can follow the task's trajectory holding each grasp (`arm_trajectory`;
    the complement of `plan(...).infeasible`, without building controls), in chunks of REACHABLE_CHUNK."""
    g = Grasps(*(np.asarray(a, float) for a in (grasps.p_tool_grasp, grasps.q_tool_grasp, grasps.width)))
    n = len(g)
    if n <= REACHABLE_CHUNK:
        return ~arm_trajectory(task, g)[1]
    return np.concatenate([~arm_trajectory(task, g[s: s + REACHABLE_CHUNK])[1] for s in range(0, n, REACHABLE_CHUNK)])


def reachability_in_order(task: Task, grasps: Grasps, order, chunk: int = 16):
    """Yield (index, reachable) for the candidates `order` [M] (indices into grasps), in that order,
    checking `reachable` `chunk` candidates at a time (closed-form IK, ~0.2 ms a grasp warm): a caller
    that stops at the first reachable grasps of a ranking checks only as many chunks as it needs."""
    order = np.asarray(order, np.int64)
    if not is_integer(chunk) or chunk < 1:
        raise InputError(f"reachability_in_order: chunk must be an integer >= 1, got {chunk!r}")

    def walk():
        for s in range(0, len(order), chunk):
            idx = order[s: s + chunk]
            yield from zip(idx.tolist(), reachable(task, grasps[idx]).tolist())

    return walk()


def plan(scene: Scene, task: Task, grasps: Grasps, physics: Physics, config: SimConfig = SimConfig()) -> Plan:
    """Initial states and control sequences (IK of the grasp-frame trajectory), host side."""
    m = scene.model
    dt = m.opt.timestep
    n = len(grasps)
    tr = task.traj
    T_tool_grasp = _tool_grasp_poses(grasps)  # [N]
    T_grasp_flange = _grasp_flange_pose()
    q_traj, infeasible = arm_trajectory(task, grasps)
    t_traj = np.asarray(tr.t, float)
    q_safe = np.where(infeasible[:, None, None], HOME_Q, q_traj)
    over_speed = (np.abs(np.diff(q_safe, axis=1)) / np.diff(t_traj)[None, :, None] > robot.UR5E_MAX_JOINT_SPEED * 1.001).any(axis=(1, 2))

    n_settle = int(round(config.settle_time / dt))
    n_motion = int(round(t_traj[-1] / dt))
    nstep = n_settle + n_motion
    sim_t = (np.arange(nstep) + 1 - n_settle) * dt  # time after the motion started, at the end of each step
    t_clip = np.clip(sim_t, 0.0, t_traj[-1])
    traj_index = np.where(sim_t > 0, np.abs(t_traj[None, :] - t_clip[:, None]).argmin(1), -1)
    ctrl = np.zeros((n, nstep, m.nu))
    qd_safe = np.gradient(q_safe, t_traj, axis=1)  # joint velocities at the samples (rad/s)
    moving = (sim_t > 0) & (sim_t < t_traj[-1])
    # linear interpolation of the IK samples at each step's end (one time grid for every rollout)
    hi = np.clip(np.searchsorted(t_traj, t_clip, side="right"), 1, len(t_traj) - 1)
    w = ((t_clip - t_traj[hi - 1]) / (t_traj[hi] - t_traj[hi - 1]))[None, :, None]
    # (gathers of the samples and of their differences: two temporaries fewer than q[hi - 1] + w (q[hi] - q[hi - 1]),
    # the same numbers)
    seg = hi - 1
    ctrl[:, :, _as_slice(scene.arm_actuators)] = np.take(q_safe, seg, axis=1) + w * np.take(np.diff(q_safe, axis=1), seg, axis=1)
    ctrl[:, :, _as_slice(scene.arm_vel_actuators)] = moving[None, :, None] * (
        np.take(qd_safe, seg, axis=1) + w * np.take(np.diff(qd_safe, axis=1), seg, axis=1))
    ctrl[:, :, scene.grip_actuator] = physics.grip_force[:, None]

    # initial state: arm at the first IK sample, tool where the (actual) grasp frame holds it
    qpos0 = np.tile(m.qpos0, (n, 1))
    qpos0[:, scene.arm_qpos] = q_safe[:, 0]
    T_world_grasp0 = ik.forward_kinematics(q_safe[:, 0]) @ np.linalg.inv(T_grasp_flange)
    T_world_tool0 = T_world_grasp0 @ np.linalg.inv(T_tool_grasp)
    half = np.maximum(np.asarray(grasps.width, float) / 2 - INITIAL_SQUEEZE, 0.0)
    qpos0[:, scene.finger_qpos[0]] = half
    qpos0[:, scene.finger_qpos[1]] = half
    qpos0[:, scene.tool_qpos:scene.tool_qpos + 3] = T_world_tool0[:, :3, 3]
    qpos0[:, scene.tool_qpos + 3:scene.tool_qpos + 7] = [_quat_from_matrix(T[:3, :3]) for T in T_world_tool0]
    return Plan(qpos0=qpos0, ctrl=ctrl, q_traj=q_traj, infeasible=infeasible, over_speed=over_speed, nstep=nstep,
                n_settle=n_settle, sim_t=sim_t, traj_index=traj_index,
                width=np.asarray(grasps.width, float).copy(), mu=np.asarray(physics.mu, float).copy())


def randomized_model(scene: Scene, physics: Physics, i: int) -> mujoco.MjModel:
    """A copy of the scene's model with rollout i's physics."""
    return _set_physics(copy.copy(scene.model), scene, physics, i)


_MODEL_POOL: "weakref.WeakKeyDictionary[Scene, list]" = weakref.WeakKeyDictionary()


def _pooled_models(scene: Scene, physics: Physics, idx) -> list[mujoco.MjModel]:
    """Models for rollouts `idx` (a sequence of indices into `physics`), from a per-scene pool of copies
    (slot j serves idx[j]), with each rollout's physics written in place: copying a model per rollout
    costs more than setting 5 fields."""
    pool = _MODEL_POOL.setdefault(scene, [])
    while len(pool) < len(idx):
        pool.append(copy.copy(scene.model))
    return [_set_physics(pool[j], scene, physics, int(i)) for j, i in enumerate(idx)]


def _set_physics(m: mujoco.MjModel, scene: Scene, physics: Physics, i: int) -> mujoco.MjModel:
    b = m.body("tool").id
    m.body_mass[b] = scene.model.body_mass[b] * physics.mass_scale[i]
    m.body_inertia[b] = scene.model.body_inertia[b] * physics.mass_scale[i]
    for p in scene.pad_tool_pairs:
        m.pair_friction[p, :2] = physics.mu[i]
    solref = target_solref(scene.kind, physics.restitution[i], physics.contact_duration[i], scene.model.opt.timestep)
    for p in scene.tool_target_pairs:
        m.pair_solref[p] = solref
    return m


def _initial_states(model: mujoco.MjModel, qpos0: np.ndarray) -> np.ndarray:
    d = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    out = np.empty((len(qpos0), mujoco.mj_stateSize(model, spec)))
    for i, q in enumerate(qpos0):
        mujoco.mj_resetData(model, d)
        d.qpos[:] = q
        mujoco.mj_getState(model, d, out[i], spec)
    return out


def rollout_native(scene: Scene, p: Plan, physics: Physics, nthread: int | None = None,
                   models: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(peak |qvel| over the rollout [N], sensordata [N, nstep, nsensordata]) with `mujoco.rollout`.

    Releases the GIL while stepping (so host work can overlap it: see `simulate`).
    """
    nthread = nthread or os.cpu_count() or 1
    if models is None:
        models = [randomized_model(scene, physics, i) for i in range(len(p.qpos0))]
    return _step(scene, p.qpos0, p.ctrl, p.nstep, models, nthread)


def _step(scene: Scene, qpos0: np.ndarray, ctrl: np.ndarray, nstep: int, models: list,
          nthread: int = 1) -> tuple[np.ndarray, np.ndarray]:
    datas = [mujoco.MjData(scene.model) for _ in range(nthread)]
    state0 = _initial_states(scene.model, qpos0)
    state, sensordata = mj_rollout.rollout(models, datas, state0, ctrl, nstep=nstep)
    nq = scene.model.nq
    qvel = state[:, :, 1 + nq:1 + nq + scene.model.nv]
    # peak |qvel| per rollout, NaN if any NaN: max and -min, no |.| temporary (2x faster than abs().max())
    return np.maximum(qvel.max(axis=(1, 2)), -qvel.min(axis=(1, 2))), sensordata


def rollout_mjx(scene: Scene, p: Plan, physics: Physics, *, devices: list | None = None,
                float64: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Same outputs as `rollout_native`, from MJX: one jit of vmap(scan(step)) (built per scene).

    `float64`: run MJX in float64 (`jax.enable_x64` for this call only, whatever the process's setting) or,
    False, in float32; None: `MJX_FLOAT64` (True).

    With several devices (default: this process's devices of JAX's default backend, `jax.local_devices()`:
    a GPU machine's GPUs, or host devices from XLA_FLAGS=--xla_force_host_platform_device_count=2; under
    `jax.distributed` each process rolls its own batch out on its own devices) the batch is sharded over them
    with `jax.sharding` (padded to a multiple of the device count by repeating the last rollout;
    the padding is dropped from the outputs). `devices=[d]` runs unsharded on d. The batch per device
    is padded up to a power of two (one compiled program serves every batch up to it). On a CPU the batch
    runs in chunks of at most 64 rollouts per device.
    """
    devices = list(jax.local_devices()) if devices is None else list(devices)
    if not devices:
        raise InputError("rollout_mjx: devices is empty")
    float64 = _mjx_float64(float64)
    with jax.enable_x64(float64):  # device_put and the call too: under float32, float64 inputs would be cast
        return _rollout_mjx(scene, p, physics, devices, float64)


def _rollout_mjx(scene: Scene, p: Plan, physics: Physics, devices: list, float64: bool) -> tuple[np.ndarray, np.ndarray]:
    n, nd = len(p.qpos0), len(devices)
    fn = _mjx_rollout_fn(scene, float64)
    dt = fn.dtype  # the model's float type
    arrays = [a.astype(dt) for a in mjx_model_fields(scene, physics)] + [p.qpos0.astype(dt), p.ctrl.astype(dt)]
    # one compile per batch shape (45-100 s on an H100): the per-device batch is rounded up to a power of
    # two, so batches of 65-128 rollouts share one program, 129-256 the next, ... (padding <= 2x)
    per_device = 1 << max(0, -(-n // nd) - 1).bit_length()
    # on a CPU a device batch of 128 or more hangs MJX: run chunks of <= 64 per device,
    # every chunk padded to the same shape (one compile)
    if devices[0].platform == "cpu":
        per_device = min(per_device, MJX_CPU_MAX_BATCH)
    chunk = per_device * nd
    mesh = jax.sharding.Mesh(np.array(devices), ("batch",)) if nd > 1 else None
    place = devices[0] if mesh is None else jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec("batch"))
    qv_out, sens_out = [], []
    for lo in range(0, n, chunk):
        part = [a[lo:lo + chunk] for a in arrays]
        pad = chunk - len(part[0])
        if pad:
            part = [np.concatenate([a, np.repeat(a[-1:], pad, axis=0)]) for a in part]
        qv, sens = fn(*[jax.device_put(a, place) for a in part], mesh=mesh)
        keep = chunk - pad
        qv_out.append(np.asarray(qv, float)[:keep])
        sens_out.append(np.asarray(sens, float)[:keep])
    return np.concatenate(qv_out), np.concatenate(sens_out)


def mjx_model_fields(scene: Scene, physics: Physics) -> tuple[np.ndarray, ...]:
    """The model fields MJX batches, one row per rollout: (body_mass, body_inertia, pair_friction,
    pair_solref) with each rollout's physics, as `_set_physics` writes them into a native model."""
    m = scene.model
    n = len(physics.mass_scale)
    b = m.body("tool").id
    pad, tt = scene.pad_tool_pairs, scene.tool_target_pairs
    mass = np.tile(m.body_mass, (n, 1))
    mass[:, b] *= physics.mass_scale
    inertia = np.tile(m.body_inertia, (n, 1, 1))
    inertia[:, b] *= physics.mass_scale[:, None]
    friction = np.tile(m.pair_friction, (n, 1, 1))
    friction[:, pad, 0] = physics.mu[:, None]
    friction[:, pad, 1] = physics.mu[:, None]
    solref = np.tile(m.pair_solref, (n, 1, 1))
    for i in range(n):
        solref[i, tt] = target_solref(scene.kind, physics.restitution[i], physics.contact_duration[i], m.opt.timestep)
    return mass, inertia, friction, solref


_MJX_CACHE: "weakref.WeakKeyDictionary[Scene, dict]" = weakref.WeakKeyDictionary()  # scene -> {float64: fn}

#: XLA's switch for deterministic scatters on a GPU. Without it two MJX calls on the same inputs return
#: different labels there (an H100, 512 hammer rollouts: the peak torques differed between two calls; with
#: it they were bit for bit equal; docs/benchmarks.md, "GPU"), so a dataset would not be reproducible. XLA
#: reads XLA_FLAGS once, when JAX starts its backend: set it before (`request_deterministic_gpu`).
DETERMINISTIC_GPU_FLAG = "--xla_gpu_deterministic_ops=true"
_DETERMINISM_FLAGS = ("--xla_gpu_deterministic_ops", "--xla_gpu_exclude_nondeterministic_ops")


def gpu_determinism(environ=None) -> bool | None:
    """What XLA_FLAGS says of deterministic GPU scatters: True (on), False (off), None (nothing; XLA's
    default, non-deterministic)."""
    setting = None
    for token in (os.environ if environ is None else environ).get("XLA_FLAGS", "").split():
        name, _, value = token.partition("=")
        if name in _DETERMINISM_FLAGS:
            setting = value.lower() in ("", "true", "1")  # a bare boolean flag means true; the last one wins
    return setting


def request_deterministic_gpu(environ=None) -> bool:
    """Add `DETERMINISTIC_GPU_FLAG` to XLA_FLAGS unless it already chooses (the user's choice stands).
    Takes effect only if JAX has not started its backend yet; the CLI calls it first. Returns whether
    it added the flag. No effect on a CPU, where the scatters are deterministic anyway."""
    env = os.environ if environ is None else environ
    if gpu_determinism(env) is not None:
        return False
    env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " " + DETERMINISTIC_GPU_FLAG).strip()
    return True


def import_mjx():
    """`mujoco.mjx`, imported with its stdout sent to stderr: without the optional Warp backend the import
    prints "Failed to import warp" to stdout, which would corrupt `--json` outputs."""
    import contextlib
    import sys

    with contextlib.redirect_stdout(sys.stderr):
        from mujoco import mjx
    return mjx


def _mjx_rollout_fn(scene: Scene, float64: bool | None = None):
    """The jitted batched rollout for a scene's model in float64 or float32 (None: `MJX_FLOAT64`); compiled
    once per scene, float type and batch shape; the model is put and the program traced and called under
    `jax.enable_x64(float64)`."""
    float64 = _mjx_float64(float64)
    cached = _MJX_CACHE.setdefault(scene, {})
    if float64 in cached:
        return cached[float64]
    mjx = import_mjx()

    with jax.enable_x64(float64):
        mx = mjx.put_model(scene.model)

    def one(mass, inertia, friction, solref, qpos0, ctrl):
        mi = mx.tree_replace({"body_mass": mass, "body_inertia": inertia, "pair_friction": friction,
                              "pair_solref": solref})
        d = mjx.make_data(mi).replace(qpos=qpos0)

        def step(d, u):
            d = mjx.step(mi, d.replace(ctrl=u))
            return d, (jax.numpy.abs(d.qvel).max(), d.sensordata)

        _, (qv, sens) = jax.lax.scan(step, d, ctrl)
        return qv, sens

    batched = full_precision(jax.vmap(one))  # float32 products on a GPU too (precision.py)
    jits: dict = {}

    def program(mesh, platform):
        """Unsharded: jit(vmap(one)). With a mesh: jit(shard_map(vmap(one))), each device running
        vmap(one) on its slice. XLA compiles the partitioned program differently, so in float32 its
        rounding differs from an unsharded call (labels agree to ~1e-7 relative in float64). One program
        per platform: JAX caches a trace per function object and cannot see the blocks of `tracing`, so
        each platform's jit wraps its own function (otherwise a GPU call after a CPU call of the same
        shape would reuse the CPU's trace, plain-JAX Cholesky included, and a CPU call after a GPU call
        would get LAPACK's Cholesky back, which can deadlock)."""
        key = (platform, None if mesh is None else tuple(d.id for d in mesh.devices.flat))
        if key not in jits:  # the outer call: one jit for the whole batch

            def run(*a):
                return batched(*a)

            if mesh is None:
                jits[key] = jax.jit(run)
            else:
                spec = jax.sharding.PartitionSpec("batch")
                # check_vma off: MJX's solver mixes batch-varying and replicated values in lax.cond
                jits[key] = jax.jit(jax.shard_map(run, mesh=mesh, in_specs=spec, out_specs=spec, check_vma=False))
        return jits[key]

    def platform_of(args) -> str:
        devices = getattr(args[0], "devices", None)  # host arrays go to the default device
        return next(iter(devices())).platform if devices is not None else jax.default_backend()

    @contextlib.contextmanager
    def tracing(platform):
        """The blocks a program is traced in. MJX's stock capsule-box collider picks the wrong face for long
        capsules (mjx_collision.py), and on a CPU jaxlib's LAPACK Cholesky can deadlock XLA's thread pool
        (mjx_cholesky.py). A program is traced on the first call of a shape, inside these blocks, and
        keeps both replacements."""
        with contextlib.ExitStack() as stack:
            stack.enter_context(native_capsule_box())
            if platform == "cpu":
                stack.enter_context(jax_cholesky())
            stack.enter_context(jax.enable_x64(float64))
            yield

    def fn(*args, mesh: jax.sharding.Mesh | None = None):
        """(qvel_max [N, T], sensordata [N, T, nsensordata]) of the batch; args are device arrays."""
        platform = platform_of(args)
        with tracing(platform):
            return program(mesh, platform)(*args)

    def lower(*args, mesh: jax.sharding.Mesh | None = None, platform: str | None = None):
        """The program `fn(*args, mesh=mesh)` runs, lowered (not compiled), for inspection (tests).
        `platform` (default: the args') picks the tracing blocks of another platform, lowered for the
        args' devices: `platform="gpu"` on a CPU shows MJX's stock solver, LAPACK's Cholesky included."""
        platform = platform_of(args) if platform is None else platform
        with tracing(platform):
            return program(mesh, platform).lower(*args)

    fn.lower = lower
    fn.dtype = np.asarray(mx.body_mass).dtype
    fn.batched = batched  # what every platform's jit runs, wrapped (tests lower it to read its matmul precision)
    cached[float64] = fn
    return fn


# ---------------------------------------------------------------------------------------------------
# Labels
# ---------------------------------------------------------------------------------------------------
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
    infeasible (only valid rollouts are labels).
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


def quat_angle(q: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
    """Rotation angle (rad) between unit quaternions [..., 4] (either sign): the measure of `slip_rotation`."""
    return 2.0 * np.arccos(np.clip(np.abs(np.einsum("...i,...i->...", q, q_ref)), 0.0, 1.0))


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


def _quat_z_axis(q: np.ndarray) -> np.ndarray:
    w, x, y, z = np.moveaxis(q, -1, 0)
    return np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], axis=-1)


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
    slip_t = grasp_point_slip(pos_g[:, ref:], quat_g[:, ref:], 0)[:, 1:].max(1)
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
    cos_angle = np.einsum("nci,ci->nc", _quat_z_axis(s("tool_quat")[:, motion][:, in_contact]), z_ref)
    drift = np.arccos(np.clip(cos_angle, -1.0, 1.0)).max(1) if in_contact.any() else np.zeros(len(sensordata))
    # pads: peak normal force of either pad over the motion, counted where a contact is found
    pad_peak = np.max([np.where(pad[..., 0] > 0, np.abs(pad[..., 1]), 0.0).max(1)
                       for pad in (s(f"pad_{side}_contact")[:, motion] for side in ("neg", "pos"))], axis=0)
    lost = slip_t > config.lost_distance
    qvel_peak = np.nan_to_num(np.asarray(qvel_peak), nan=np.inf).reshape(len(sensordata), -1).max(1)
    diverged = ~np.isfinite(sensordata).all(axis=(1, 2)) | (qvel_peak > config.diverged_qvel)
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


# ---------------------------------------------------------------------------------------------------
# Public entry point
# ---------------------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class SimResult:
    """Labels [N], the physics each rollout ran with, the plan, and optional per-step traces."""

    labels: Labels
    physics: Physics
    plan: Plan
    backend: str
    traces: dict | None = None


#: Rollouts per block of the native path: plan (IK) the block on the host, step it with `mujoco.rollout`
#: on `nthread` threads, label it. Measured on the 2-core CPU (hammer, 64 rollouts, ratio to raw
#: stepping): overlapping the host work with the stepping threads (a pipeline of small chunks) kept 0.83-0.85
#: with 2 threads, because the host's NumPy work then competes with both stepping threads for 2 cores;
#: doing it between the steps keeps 0.90 and, with 1 thread, the same 0.94 as the pipeline. Blocks bound
#: the memory the recorded sensors take (256 rollouts of the hammer: ~85 MB).
NATIVE_BLOCK = 256


def _take_plan(p: Plan, idx: np.ndarray) -> Plan:
    """The plan of rollouts `idx` only."""
    return dataclasses.replace(p, qpos0=p.qpos0[idx], ctrl=p.ctrl[idx], q_traj=p.q_traj[idx],
                               infeasible=p.infeasible[idx], over_speed=p.over_speed[idx], width=p.width[idx],
                               mu=p.mu[idx])


def _feasible_labels(scene: Scene, task: Task, p: Plan, run: np.ndarray, run_plan: Plan, qvel_peak: np.ndarray | None,
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


def _traces_of_rows(scene: Scene, n: int, nstep: int, run: np.ndarray, sensordata: np.ndarray | None) -> np.ndarray:
    """Sensor traces [n, nstep, nsensordata]: rows `run` from `sensordata` (the stepped rollouts), NaN in the
    others (infeasible, not stepped)."""
    full = np.full((n, nstep, scene.model.nsensordata), np.nan)
    if len(run):
        full[run] = sensordata
    return full


def _simulate_native(scene: Scene, task: Task, grasps: Grasps, physics: Physics, config: SimConfig,
                     nthread: int | None, keep_sensordata: bool = False) -> tuple[Plan, Labels, np.ndarray | None]:
    """Plan, step (feasible rollouts only) and label block by block (`NATIVE_BLOCK`)."""
    n = len(grasps)
    nthread = max(1, min(nthread or os.cpu_count() or 1, n))
    plans, labels, sens = [], [], []
    for lo in range(0, n, NATIVE_BLOCK):
        hi = min(n, lo + NATIVE_BLOCK)
        ph = _slice_physics(physics, slice(lo, hi))
        p = plan(scene, task, grasps[lo:hi], ph, config)
        run = np.nonzero(~p.infeasible)[0]
        run_plan = p if len(run) == hi - lo else _take_plan(p, run)  # one copy of the controls, or none
        qvel_peak = sensordata = None
        if len(run):
            qvel_peak, sensordata = _step(scene, run_plan.qpos0, run_plan.ctrl, p.nstep,
                                          _pooled_models(scene, physics, lo + run), min(nthread, len(run)))
        labels.append(_feasible_labels(scene, task, p, run, run_plan, qvel_peak, sensordata, config))
        plans.append(p)
        if keep_sensordata:
            sens.append(_traces_of_rows(scene, hi - lo, p.nstep, run, sensordata))
    merged = Labels(**{f: np.concatenate([getattr(lab, f) for lab in labels]) for f in LABEL_FIELDS})
    return _concat_plans(plans), merged, (np.concatenate(sens) if keep_sensordata else None)


def default_backend() -> str:
    """'mjx' on an accelerator, 'native' on a CPU (docs/design.md: MJX is 240-430x slower on this CPU)."""
    return "native" if jax.default_backend() == "cpu" else "mjx"


def simulate(tool: Tool, task: Task, grasps: Grasps, *, backend: str | None = None, seed: int = 0,
             randomize: Randomization | None = Randomization(), config: SimConfig = SimConfig(),
             traces: bool = False, nthread: int | None = None, scene: Scene | None = None,
             devices: list | None = None, mjx_float64: bool | None = None) -> SimResult:
    """Roll out every grasp along the task in MuJoCo and return its labels (arrays [N]).

    Args:
      tool, task, grasps: as for `wrench_costs`.
      backend: 'native' | 'mjx' | None (follows `jax.default_backend()`).
      seed: seeds the domain randomisation.  randomize: spreads, or None for nominal physics.
      config: `SimConfig`.  traces: also return per-step sensor traces.  nthread: native threads.
      scene: a prebuilt `build_scene(tool, task)` to reuse.
      devices: MJX only: the devices the batch is sharded over (default: all of JAX's default backend).
      mjx_float64: MJX only: float64 (None: `MJX_FLOAT64`, True) or float32 (`rollout_mjx`).
    """
    backend = backend or default_backend()
    if backend not in ("native", "mjx"):
        raise InputError(f"simulate: backend must be 'native' or 'mjx', got {backend!r}")
    validate_grasps(grasps)
    if scene is None:
        scene = build_scene(tool, task)
    physics = sample_physics(tool, len(grasps), seed, spread=randomize, grip_force=config.grip_force)
    if backend == "mjx":
        pl = plan(scene, task, grasps, physics, config)
        run = np.nonzero(~pl.infeasible)[0]  # like the native path, step the feasible rollouts only
        run_plan = _take_plan(pl, run)
        qvel_peak = sensordata = None
        if len(run):
            qvel_peak, sensordata = rollout_mjx(scene, run_plan, _slice_physics(physics, run), devices=devices,
                                                float64=mjx_float64)
        labels = _feasible_labels(scene, task, pl, run, run_plan, qvel_peak, sensordata, config)
        if traces:
            sensordata = _traces_of_rows(scene, len(grasps), pl.nstep, run, sensordata)
    else:
        pl, labels, sensordata = _simulate_native(scene, task, grasps, physics, config, nthread, traces)
    tr = None
    if traces:
        tr = {name: scene.sensor(sensordata, name) for name in scene.sensors}
        tr["t"] = pl.sim_t
    return SimResult(labels=labels, physics=physics, plan=pl, backend=backend, traces=tr)

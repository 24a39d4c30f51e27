"""MJX rollouts: `jax.jit(jax.vmap(lax.scan(mjx.step)))` with the varying model fields batched.

The default when JAX's backend is an accelerator. On a CPU, MJX is 240-430x slower than native MuJoCo
(docs/design.md, "Simulation"), `rollout_mjx` runs chunks of at most 64 per CPU device, and MJX's
Cholesky is `mjx_cholesky`'s (jaxlib's LAPACK kernel deadlocked there: the knock at a batch of 16, the
hammer at 128). Capsule-box contacts go through `mjx_collision.capsule_box_collider` (MJX's own
reverses a pad's contact on long tilted handles). It runs in float64 (`MJX_FLOAT64`), where its reach
labels match native MuJoCo's; in float32 the pads' stiff contacts spike (docs/benchmarks.md, "MJX
against native"). On a GPU, `DETERMINISTIC_GPU_FLAG` makes its labels reproducible.
"""

from __future__ import annotations

import contextlib
import os
import weakref

import jax
import numpy as np

from itup_jax.errors import InputError
from itup_jax.precision import full_precision
from itup_jax.sim.arm import Plan
from itup_jax.sim.mjx_cholesky import jax_cholesky
from itup_jax.sim.mjx_collision import native_capsule_box
from itup_jax.sim.physics import Physics, mjx_model_fields
from itup_jax.sim.scene import Scene

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
    fn = mjx_rollout_fn(scene, float64)
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


def mjx_rollout_fn(scene: Scene, float64: bool | None = None):
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

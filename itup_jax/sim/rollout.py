"""Executing grasps in MuJoCo: the one rollout interface, two backends, one label schema.

    result = simulate(tool, task, grasps, backend=None, seed=0)   # result.labels.<name>: arrays [N]

Per rollout: the tool starts in the gripper at grasp g with the pads closed on it at the grip force;
the arm holds still for `settle_time` (the static holding wrench is measured at its end), then its
flange follows the task trajectory xi(t) through closed-form UR5e inverse kinematics (`arm.py`), as
position targets of the joint servos. Recorded per step (sensors, so both backends record the same):
wrist force/torque at the flange/gripper interface, each pad's contact (found, force of its strongest
contact), the tool's pose in the grasp frame and in the world, and the task objects' state.

Backends (same inputs, same outputs): 'native' (`native.py`: `mujoco.rollout` on threads; the CPU
default and the ground truth) and 'mjx' (`mjx.py`: jit + vmap + scan; the default on an accelerator).

Rollouts whose IK fails (unreachable pose, joint limit, or elbow/wrist below the table) are flagged
`infeasible`: neither backend steps them, and their measured labels are NaN (flags False, traces NaN).
Rollouts that blow up are flagged `diverged`. Neither is a label: `Labels.valid` is False.
"""

from __future__ import annotations

import dataclasses

import jax
import numpy as np

from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.sim.arm import Plan, plan, take_plan
from itup_jax.sim.config import SimConfig
from itup_jax.sim.labels import Labels, feasible_labels, traces_of_rows
from itup_jax.sim.mjx import rollout_mjx
from itup_jax.sim.native import simulate_native
from itup_jax.sim.physics import Physics, Randomization, sample_physics, slice_physics
from itup_jax.sim.scene import Scene, build_scene
from itup_jax.task import Task
from itup_jax.tools import Tool


@dataclasses.dataclass(frozen=True)
class SimResult:
    """Labels [N], the physics each rollout ran with, the plan, and optional per-step traces."""

    labels: Labels
    physics: Physics
    plan: Plan
    backend: str
    traces: dict | None = None


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
        run_plan = take_plan(pl, run)
        qvel_peak = sensordata = None
        if len(run):
            qvel_peak, sensordata = rollout_mjx(scene, run_plan, slice_physics(physics, run), devices=devices,
                                                float64=mjx_float64)
        labels = feasible_labels(scene, task, pl, run, run_plan, qvel_peak, sensordata, config)
        if traces:
            sensordata = traces_of_rows(scene, len(grasps), pl.nstep, run, sensordata)
    else:
        pl, labels, sensordata = simulate_native(scene, task, grasps, physics, config, nthread, traces)
    tr = None
    if traces:
        tr = {name: scene.sensor(sensordata, name) for name in scene.sensors}
        tr["t"] = pl.sim_t
    return SimResult(labels=labels, physics=physics, plan=pl, backend=backend, traces=tr)

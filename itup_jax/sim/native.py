"""Native MuJoCo rollouts: `mujoco.rollout` on threads, one `MjModel` per rollout (its physics draw).

The CPU default and the ground truth. `simulate_native` plans, steps (the feasible rollouts only) and
labels block by block (`NATIVE_BLOCK`); `rollout_native` steps a whole plan.
"""

from __future__ import annotations

import os

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from itup_jax.grasp import Grasps
from itup_jax.sim.arm import Plan, concat_plans, plan, take_plan
from itup_jax.sim.config import SimConfig
from itup_jax.sim.labels import Labels, feasible_labels, traces_of_rows
from itup_jax.sim.physics import Physics, pooled_models, randomized_model, slice_physics
from itup_jax.sim.scene import Scene
from itup_jax.task import Task


def initial_states(model: mujoco.MjModel, qpos0: np.ndarray) -> np.ndarray:
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
    return step_native(scene, p.qpos0, p.ctrl, p.nstep, models, nthread)


def step_native(scene: Scene, qpos0: np.ndarray, ctrl: np.ndarray, nstep: int, models: list,
          nthread: int = 1) -> tuple[np.ndarray, np.ndarray]:
    datas = [mujoco.MjData(scene.model) for _ in range(nthread)]
    state0 = initial_states(scene.model, qpos0)
    state, sensordata = mj_rollout.rollout(models, datas, state0, ctrl, nstep=nstep)
    nq = scene.model.nq
    qvel = state[:, :, 1 + nq:1 + nq + scene.model.nv]
    # peak |qvel| per rollout, NaN if any NaN: max and -min, no |.| temporary (2x faster than abs().max())
    return np.maximum(qvel.max(axis=(1, 2)), -qvel.min(axis=(1, 2))), sensordata


#: Rollouts per block of the native path: plan (IK) the block on the host, step it with `mujoco.rollout`
#: on `nthread` threads, label it. Measured on the 2-core CPU (hammer, 64 rollouts, ratio to raw
#: stepping): overlapping the host work with the stepping threads (a pipeline of small chunks) kept 0.83-0.85
#: with 2 threads, because the host's NumPy work then competes with both stepping threads for 2 cores;
#: doing it between the steps keeps 0.90 and, with 1 thread, the same 0.94 as the pipeline. Blocks bound
#: the memory the recorded sensors take (256 rollouts of the hammer: ~85 MB).
NATIVE_BLOCK = 256


def simulate_native(scene: Scene, task: Task, grasps: Grasps, physics: Physics, config: SimConfig,
                     nthread: int | None, keep_sensordata: bool = False) -> tuple[Plan, Labels, np.ndarray | None]:
    """Plan, step (feasible rollouts only) and label block by block (`NATIVE_BLOCK`)."""
    n = len(grasps)
    nthread = max(1, min(nthread or os.cpu_count() or 1, n))
    plans, labels, sens = [], [], []
    for lo in range(0, n, NATIVE_BLOCK):
        hi = min(n, lo + NATIVE_BLOCK)
        ph = slice_physics(physics, slice(lo, hi))
        p = plan(scene, task, grasps[lo:hi], ph, config)
        run = np.nonzero(~p.infeasible)[0]
        run_plan = p if len(run) == hi - lo else take_plan(p, run)  # one copy of the controls, or none
        qvel_peak = sensordata = None
        if len(run):
            qvel_peak, sensordata = step_native(scene, run_plan.qpos0, run_plan.ctrl, p.nstep,
                                          pooled_models(scene, physics, lo + run), min(nthread, len(run)))
        labels.append(feasible_labels(scene, task, p, run, run_plan, qvel_peak, sensordata, config))
        plans.append(p)
        if keep_sensordata:
            sens.append(traces_of_rows(scene, hi - lo, p.nstep, run, sensordata))
    return concat_plans(plans), Labels.concatenate(labels), (np.concatenate(sens) if keep_sensordata else None)

"""Physics draws: each rollout's tool mass, pad friction, restitution, contact duration and grip.

    physics = sample_physics(tool, n, seed)        # Physics: arrays [n], drawn around the tool's priors
    model = randomized_model(scene, physics, i)    # a copy of the scene's MjModel with rollout i's physics

`set_physics` writes one rollout's draw into a native `MjModel`; `mjx_model_fields` gives the same
fields batched for MJX. Both backends therefore run every rollout with the same physics.
"""

from __future__ import annotations

import copy
import dataclasses
import weakref

import mujoco
import numpy as np

from itup_jax import robot
from itup_jax.errors import check_seed
from itup_jax.sim.scene import Scene, target_solref
from itup_jax.tools import Tool


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
                   grip_force: float = robot.GRIP_FORCE) -> Physics:
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


def slice_physics(physics: Physics, sl: slice) -> Physics:
    return Physics(*(getattr(physics, f.name)[sl] for f in dataclasses.fields(Physics)))


def randomized_model(scene: Scene, physics: Physics, i: int) -> mujoco.MjModel:
    """A copy of the scene's model with rollout i's physics."""
    return set_physics(copy.copy(scene.model), scene, physics, i)


_MODEL_POOL: "weakref.WeakKeyDictionary[Scene, list]" = weakref.WeakKeyDictionary()


def pooled_models(scene: Scene, physics: Physics, idx) -> list[mujoco.MjModel]:
    """Models for rollouts `idx` (a sequence of indices into `physics`), from a per-scene pool of copies
    (slot j serves idx[j]), with each rollout's physics written in place: copying a model per rollout
    costs more than setting 5 fields."""
    pool = _MODEL_POOL.setdefault(scene, [])
    while len(pool) < len(idx):
        pool.append(copy.copy(scene.model))
    return [set_physics(pool[j], scene, physics, int(i)) for j, i in enumerate(idx)]


def set_physics(m: mujoco.MjModel, scene: Scene, physics: Physics, i: int) -> mujoco.MjModel:
    b = m.body("tool").id
    m.body_mass[b] = scene.model.body_mass[b] * physics.mass_scale[i]
    m.body_inertia[b] = scene.model.body_inertia[b] * physics.mass_scale[i]
    for p in scene.pad_tool_pairs:
        m.pair_friction[p, :2] = physics.mu[i]
    solref = target_solref(scene.kind, physics.restitution[i], physics.contact_duration[i], scene.model.opt.timestep)
    for p in scene.tool_target_pairs:
        m.pair_solref[p] = solref
    return m


def mjx_model_fields(scene: Scene, physics: Physics) -> tuple[np.ndarray, ...]:
    """The model fields MJX batches, one row per rollout: (body_mass, body_inertia, pair_friction,
    pair_solref) with each rollout's physics, as `set_physics` writes them into a native model."""
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

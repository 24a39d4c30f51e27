"""Stress: whether a grasp holds and does the task as the grip weakens, and the least grip that holds it.

At the default 100 N per pad almost no pick fails in the grip, so whether a grasp carries the task's
wrench shows only when the grip is weaker. Two measures, both per pick and on the same physics draws for
every method:

  * `rollouts_at_grip`: a pick rolled out R times at one grip force per pad (every other prior
    randomised as usual, the grip fixed);
  * `min_holding_grip`: the smallest grip force per pad at which the pick holds (no grip failure) and
    does the task in all R draws, found by bisection; the points it tried are kept, and a pick whose
    outcome is not monotone in the grip (holds at a force, fails at a larger one) is reported as such.

The Robotiq 2F-85 grips with 20-235 N per pad (`robot.GRIPPER_MIN_GRIP_FORCE`). Below 20 N the
scene's grip actuator is opened to 0 N (`probe_scene`) and the results are a robustness probe of the
grasp, not something the gripper can be set to; `is_probe` says which.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable

import numpy as np

from itup_jax import robot
from itup_jax.errors import InputError
from itup_jax.grasp import Grasps
from itup_jax.sim.config import SimConfig
from itup_jax.sim.labels import Labels
from itup_jax.sim.physics import Randomization
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import Scene, build_scene

#: N per pad: the bisection's range (the lower end a probe below the gripper's 20 N).
GRIP_RANGE = (5.0, robot.GRIPPER_MAX_GRIP_FORCE)
#: N: the bisection stops when the bracket is this narrow.
GRIP_TOLERANCE = 1.0


def is_probe(grip_force: float) -> bool:
    """Whether a grip force per pad lies below what the 2F-85 can be set to (a robustness probe)."""
    return float(grip_force) < robot.GRIPPER_MIN_GRIP_FORCE


def probe_scene(scene: Scene) -> Scene:
    """A copy of `scene` whose grip actuator accepts 0 N up to the gripper's maximum (for probes)."""
    model = copy.deepcopy(scene.model)
    model.actuator_ctrlrange[scene.grip_actuator] = [0.0, robot.GRIPPER_MAX_GRIP_FORCE]
    return dataclasses.replace(scene, model=model)


def fixed_grip(scene: Scene, randomize: Randomization | None, grip_force: float) -> tuple[Scene, Randomization | None]:
    """(scene, spread) to roll out at a fixed grip of `grip_force` N per pad: the scene's grip actuator
    opened below the gripper's 20 N for a probe (`probe_scene`, else the actuator's range would clamp the
    force), and `randomize` with the grip not randomised (the other priors' draws unchanged)."""
    scene = probe_scene(scene) if is_probe(grip_force) else scene
    return scene, None if randomize is None else dataclasses.replace(randomize, grip_force=0.0)


def simulate_at_grip(tool, task, grasps: Grasps, grip_force: float, *, seed: int, randomize: Randomization | None,
                     scene: Scene, backend: str | None = None, nthread: int | None = None) -> Labels:
    """`grasps` rolled out at a fixed `grip_force` N per pad, row r on the physics draw `simulate` gives
    row r under `randomize` from `seed` (the same mass, friction, restitution and contact duration as a
    default-grip rollout of the same rows and seed; the grip not randomised, `fixed_grip`): the weak-grip
    rollout of the datasets (`dataset.weak_rollouts`) and of the planner's check (`verify`). Host side."""
    weak_scene, spread = fixed_grip(scene, randomize, grip_force)
    return simulate(tool, task, grasps, seed=seed, randomize=spread, scene=weak_scene, backend=backend,
                    config=SimConfig(grip_force=grip_force), nthread=nthread).labels


def check_grip(grip_force: float, where: str) -> float:
    """`grip_force` (N per pad) as a float if it lies in (0, the gripper's maximum], else InputError naming `where`."""
    g = float(grip_force)
    if not 0.0 < g <= robot.GRIPPER_MAX_GRIP_FORCE:
        raise InputError(f"{where}: grip force must be in (0, {robot.GRIPPER_MAX_GRIP_FORCE}] N per pad, got {grip_force!r}")
    return g


def rollouts_at_grip(tool, task, grasps: Grasps, grip_force: float, *, draws: int = 3, seed: int = 0,
                     scene: Scene | None = None, randomize: Randomization | None = Randomization()) -> Labels:
    """Each grasp rolled out `draws` times at `grip_force` N per pad: labels [len(grasps) * draws], grasp
    i's draws at rows i * draws ... i * draws + draws - 1. Draw d of every grasp is the same physics draw
    (the priors randomised by `randomize` from `seed`, the grip fixed). Native MuJoCo; host side."""
    g = check_grip(grip_force, "rollouts_at_grip")
    if not isinstance(draws, (int, np.integer)) or draws < 1:
        raise InputError(f"rollouts_at_grip: draws must be an integer >= 1, got {draws!r}")
    scene, spread = fixed_grip(scene or build_scene(tool, task), randomize, g)
    parts = []
    for i in range(len(grasps)):  # each grasp its own call: row d is physics draw d for every grasp
        reps = Grasps(*(np.repeat(np.asarray(a)[i:i + 1], draws, axis=0)
                        for a in (grasps.p_tool_grasp, grasps.q_tool_grasp, grasps.width)))
        parts.append(simulate(tool, task, reps, scene=scene, seed=seed, randomize=spread,
                              config=SimConfig(grip_force=g), backend="native").labels)
    return Labels.concatenate(parts)


def holds(labels: Labels, draws: int) -> np.ndarray:
    """[N] bool from labels [N * draws] (`rollouts_at_grip`): every draw valid, done and not failed."""
    ok = np.asarray(labels.valid) & np.asarray(labels.success) & ~np.asarray(labels.failed)
    return ok.reshape(-1, draws).all(axis=1)


@dataclasses.dataclass(frozen=True)
class MinGrip:
    """The least grip force per pad at which a pick holds (`min_holding_grip`).

    force: N per pad, or None when it does not hold even at the range's top.  monotone: False when the
    forces tried show it holding at one force and not at a larger one (then `force` is the bisection's
    answer on a non-monotone outcome, to be read with care).  tried: {N: holds}.  probe: whether `force`
    lies below the gripper's 20 N.
    """

    force: float | None
    monotone: bool
    tried: dict
    probe: bool


def min_holding_grip(holds_at: Callable[[float], bool], *, lo: float = GRIP_RANGE[0], hi: float = GRIP_RANGE[1],
                     tol: float = GRIP_TOLERANCE, grid=(), known: dict | None = None) -> MinGrip:
    """The smallest grip force in [lo, hi] (N per pad) at which `holds_at(force)` is true, to within `tol`.

    `holds_at` is asked at hi, at lo and at the forces of `grid` first; then bisection between the lowest
    force that held and the largest force below it that did not. Every answer is kept: one that breaks
    monotonicity (true at a force, false at a larger one) marks the result not monotone, and a denser
    `grid` finds more of those."""
    if not 0 < lo < hi or not tol > 0:
        raise InputError(f"min_holding_grip: need 0 < lo < hi and tol > 0, got lo={lo}, hi={hi}, tol={tol}")
    tried: dict[float, bool] = {} if known is None else known

    def ask(f: float) -> bool:
        f = float(f)
        if f not in tried:
            tried[f] = bool(holds_at(f))
        return tried[f]

    def monotone() -> bool:
        seq = [tried[f] for f in sorted(tried)]
        return all(not x or y for x, y in zip(seq, seq[1:]))  # once it holds, it holds at every larger force

    for f in (hi, lo, *sorted(float(g) for g in grid if lo < g < hi)):
        ask(f)
    held = [f for f, ok in tried.items() if ok]
    if not held:
        return MinGrip(None, monotone(), tried, False)
    b = min(held)
    below = [f for f, ok in tried.items() if not ok and f < b]
    if not below:  # it held at the lowest force tried
        return MinGrip(b, monotone(), tried, is_probe(b))
    a = max(below)
    while b - a > tol:
        mid = 0.5 * (a + b)
        if ask(mid):
            b = mid
        else:
            a = mid
    return MinGrip(b, monotone(), tried, is_probe(b))


def pick_min_holding_grip(tool, task, grasp: Grasps, *, draws: int = 3, seed: int = 0, scene: Scene | None = None,
                          lo: float = GRIP_RANGE[0], hi: float = GRIP_RANGE[1], tol: float = GRIP_TOLERANCE,
                          grid=(), known: dict | None = None,
                          randomize: Randomization | None = Randomization()) -> MinGrip:
    """`min_holding_grip` of one grasp (one `Grasps` row, or a batch whose first row is taken), each force
    tried with `draws` rollouts on the same physics draws (`rollouts_at_grip`); `known` as there."""
    scene = scene or build_scene(tool, task)
    if np.ndim(grasp.width) == 0:  # a single grasp: a batch of one
        grasp = Grasps(*(np.asarray(a)[None] for a in (grasp.p_tool_grasp, grasp.q_tool_grasp, grasp.width)))
    one = grasp[:1]
    return min_holding_grip(
        lambda f: bool(holds(rollouts_at_grip(tool, task, one, f, draws=draws, seed=seed, scene=scene,
                                              randomize=randomize), draws)[0]), lo=lo, hi=hi, tol=tol,
        grid=grid, known=known)

"""The task registry: one module per task kind, each a `TaskKind` that says everything about the kind.

    from itup_jax import tasks
    tasks.get("hammer").params()        # the kind's defaults (a frozen dataclass)
    tasks.names()                       # ('hammer', 'sweep', 'knock', 'reach')

A task kind is its parameters and trajectory (`build`, used by `itup_jax.task.make_task`), its scene
(the environment's MJCF under `mjcf/scenes/`, the target geoms the tool may touch, where the targets are
placed: `sim.scene.build_scene`), its integration step, and its success measure (`outcome`, used by
`sim.labels.compute_labels`). To add a fifth task, write one module here that defines a `TaskKind` and
calls `register`, add its MJCF to `mjcf/scenes/`, and import the module at the end of this file: the
CLI, datasets, scenes and labels read the registry, not a list of names.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any, Callable

from itup_jax.errors import InputError

if TYPE_CHECKING:  # types only: the kind modules import `task` (the registry's one circle)
    import mujoco
    import numpy as np

    from itup_jax.task import Task
    from itup_jax.tools import Tool


@dataclasses.dataclass(frozen=True)
class TaskKind:
    """Everything the code needs to know about one kind of task.

    Attributes:
      name: the kind's name (`Task.kind`, the CLI's `--task`).
      params: frozen dataclass of the kind's parameters with their defaults (SI units).
      build: (tool, params) -> Task: the contacts, schedules and trajectory (host side).
      default_tool: the built-in tool the kind uses when none is given (`tools.BUILTIN_TOOLS`).
      timestep: s, the scene's default integration step.
      target_geoms: the environment's geoms the tool may touch (explicit contact pairs).
      target_bodies: the task objects whose world pose is recorded (sensors `target/<body>_pos`, `_quat`).
      place: (spec, task) -> None: moves the environment's bodies so the targets sit where the task
        expects them (raises InputError when they cannot).
      outcome: (scene, task, sensordata [N, S, nsensordata], plan) -> (metric [N], success [N] bool), from
        a `sim.scene.Scene` and a `sim.arm.Plan` (not imported here: the simulator reads this registry).
      plastic_target: the target gives way under the blow: the tool-target contact is critically damped
        whatever the tool's restitution (`sim.scene.target_solref`).
      works_on_table: the tool touches the table while working (a tool-table contact pair).
      validate: optional (params) -> None for checks beyond the generic ones of `make_task`.
      summary: one line for `itup --help` and the docs.
      scene: the environment's MJCF relative to `mjcf/` (default `scenes/<name>.xml`).
    """

    name: str
    params: type
    build: Callable[["Tool", Any], "Task"]
    default_tool: str
    timestep: float
    target_geoms: tuple[str, ...]
    target_bodies: tuple[str, ...]
    place: Callable[["mujoco.MjSpec", "Task"], None]
    outcome: Callable[[Any, "Task", "np.ndarray", Any], tuple["np.ndarray", "np.ndarray"]]
    plastic_target: bool = False
    works_on_table: bool = False
    validate: Callable[[Any], None] | None = None
    summary: str = ""
    scene: str | None = None

    @property
    def scene_file(self) -> str:
        """The environment's MJCF, relative to `mjcf/`: `scene` if given, else `scenes/<name>.xml`."""
        return self.scene or f"scenes/{self.name}.xml"


_REGISTRY: dict[str, TaskKind] = {}


def register(kind: TaskKind) -> TaskKind:
    """Add `kind` to the registry (once per name) and return it."""
    if kind.name in _REGISTRY:
        raise InputError(f"tasks.register: a task kind {kind.name!r} is registered already")
    if not dataclasses.is_dataclass(kind.params):
        raise InputError(f"tasks.register({kind.name!r}): params must be a dataclass of defaults")
    _REGISTRY[kind.name] = kind
    return kind


def unregister(name: str) -> None:
    """Remove a kind (for tests that register a temporary one)."""
    _REGISTRY.pop(name, None)


def get(name: str) -> TaskKind:
    """The registered kind `name`, or InputError naming the known ones."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise InputError(f"task kind {name!r}: unknown; known: {', '.join(_REGISTRY)}") from None


def names() -> tuple[str, ...]:
    """The registered kinds, in registration order."""
    return tuple(_REGISTRY)


def default_tools() -> dict[str, str]:
    """kind -> the built-in tool it uses by default."""
    return {k.name: k.default_tool for k in _REGISTRY.values()}


def timesteps() -> dict[str, float]:
    """kind -> its scene's default integration step (s)."""
    return {k.name: k.timestep for k in _REGISTRY.values()}


# The built-in kinds, in the order the CLI lists them (the import order is the registration order).
# A new kind: one module, one name here.
# isort: off
from itup_jax.tasks import hammer, sweep, knock, reach  # noqa: E402,F401
# isort: on

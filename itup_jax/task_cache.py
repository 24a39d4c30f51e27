"""Built tasks kept between runs of the command line, next to its compiled kernels.

Building a task (`task.make_task`) samples the trajectory's pose and its first and second derivatives
by forward-mode AD op by op (one jit would round them differently in float32 and change every label).
In a fresh process each of those ops is dispatched for the first time, which costs ~0.5 s of a repeated
`itup plan` on a 2-core CPU, for arrays that depend only on the task kind, its parameters, the tool and
this package's code. `make_task` here returns the same `Task`, bit for bit, from a file written the
first time it was built.

Key: SHA-256 of the task kind, its parameter overrides, every field of the tool (mesh vertices and faces,
physical parameters, contact points and normal, grasp region, parts, primitives, mesh frame), the source
of every module of this package, the JAX and NumPy versions, the backend and whether float64 is on. Any change to one of them is a new
entry; a stale entry is never read. An entry that cannot be read is rebuilt and rewritten. Entries are
written atomically. The warnings the build raised (the UR5e's speed limits) are stored with the arrays
and raised again when the entry is read.

Folder: `$ITUP_TASK_CACHE_DIR`, else `$XDG_CACHE_HOME/itup-jax/tasks`, else `~/.cache/itup-jax/tasks`.
An entry is ~12 kB (64 steps); entries of other code versions are never read again, and the folder may
be deleted at any time (the next run builds its task again).
The CLI uses it whenever it uses the compile cache (`compile_cache.wanted`: off with
`--no-compile-cache` or `ITUP_COMPILE_CACHE=0`); a notebook keeps its tasks in memory and has no need.
Its subfolder `restitution/` (`restitution_dir`) keeps the contact calibration tables of the tasks'
scenes (`sim.restitution.keep_tables`), ~1 kB each.
"""

from __future__ import annotations

import dataclasses
import hashlib
import io
import json
import os
import warnings
from pathlib import Path
from typing import Any

import jax
import numpy as np

from itup_jax.atomic import atomic_write
from itup_jax.kernel_cache import code_digest
from itup_jax.shapes import to_device
from itup_jax.task import Task
from itup_jax.task import make_task as build_task
from itup_jax.tools import Tool
from itup_jax.trajectory import Trajectory

#: Environment variable naming the folder.
ENV_DIR = "ITUP_TASK_CACHE_DIR"
#: File format of an entry (a change here is a new key).
FORMAT = 1


def cache_dir() -> Path:
    """The folder the task cache uses (not created)."""
    if os.environ.get(ENV_DIR):
        return Path(os.environ[ENV_DIR]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "itup-jax" / "tasks"


def restitution_dir() -> Path:
    """The folder the CLI keeps MuJoCo's contact calibration tables in (`sim.restitution.keep_tables`)."""
    return cache_dir() / "restitution"


def _update(h, value: Any) -> None:
    """Feed `value` (arrays, numbers, strings, nested tuples) into the hash `h`, with its type and shape."""
    if isinstance(value, (np.ndarray, jax.Array)):
        a = np.ascontiguousarray(np.asarray(value))
        h.update(f"array{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    elif isinstance(value, (tuple, list)):
        h.update(f"seq{len(value)}".encode())
        for v in value:
            _update(h, v)
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(type(value).__name__.encode())
        for f in dataclasses.fields(value):
            h.update(f.name.encode())
            _update(h, getattr(value, f.name))
    else:
        h.update(repr(value).encode())


def key(kind: str, tool: Tool, overrides: dict) -> str:
    """The entry's name for a task of `kind` for `tool` with parameter `overrides`."""
    h = hashlib.sha256()
    h.update(f"format {FORMAT} jax {jax.__version__} numpy {np.__version__} code {code_digest()} "
             f"x64 {jax.config.jax_enable_x64} backend {jax.default_backend()}".encode())
    h.update(kind.encode())
    for name in sorted(overrides):
        h.update(name.encode())
        _update(h, overrides[name])
    _update(h, (tool.name, tool.category, np.asarray(tool.mesh.vertices), np.asarray(tool.mesh.faces)))
    for f in dataclasses.fields(tool):
        if f.name != "mesh":
            h.update(f.name.encode())
            _update(h, getattr(tool, f.name))
    return h.hexdigest()


#: The arrays of a `Task` (all its fields but the trajectory and the kind) and of its `Trajectory`.
_TASK_FIELDS = tuple(f.name for f in dataclasses.fields(Task) if f.name not in ("traj", "kind"))
_TRAJ_FIELDS = tuple(f.name for f in dataclasses.fields(Trajectory))


def _encode(task, caught: list[str]) -> bytes:
    arrays = {f"task.{n}": np.asarray(getattr(task, n)) for n in _TASK_FIELDS}
    arrays.update({f"traj.{n}": np.asarray(getattr(task.traj, n)) for n in _TRAJ_FIELDS})
    meta = json.dumps({"kind": task.kind, "warnings": caught})
    buf = io.BytesIO()
    np.savez(buf, meta=np.frombuffer(meta.encode(), np.uint8), **arrays)
    return buf.getvalue()


def _decode(data: bytes):
    with np.load(io.BytesIO(data), allow_pickle=False) as z:
        meta = json.loads(bytes(z["meta"]).decode())
        traj = Trajectory(**{n: to_device(z[f"traj.{n}"]) for n in _TRAJ_FIELDS})
        task = Task(**{n: to_device(z[f"task.{n}"]) for n in _TASK_FIELDS}, traj=traj, kind=meta["kind"])
    return task, list(meta["warnings"])


def make_task(kind: str, tool: Tool, *, folder: str | os.PathLike | None = None, **overrides: Any):
    """`task.make_task(kind, tool, **overrides)`, read from the cache in `folder` (default `cache_dir()`)
    when an entry exists, else built and written there. Returns the same `Task` either way, and raises
    the same warnings; the same errors before anything is read or written. A folder that cannot be
    created or written leaves the build as it is (no cache)."""
    path = Path(folder) if folder is not None else cache_dir()
    entry = path / f"{key(kind, tool, overrides)}.npz"
    try:
        data = entry.read_bytes()
    except OSError:
        data = None
    if data is not None:
        try:
            task, caught = _decode(data)
        except Exception:  # noqa: BLE001 - an unreadable entry (truncated, foreign) is rebuilt
            task = None
        if task is not None:
            for message in caught:
                warnings.warn(message, UserWarning, stacklevel=2)
            return task
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        task = build_task(kind, tool, **overrides)
    caught = [str(w.message) for w in record if issubclass(w.category, UserWarning)]
    for w in record:  # raised again outside the recorder, as make_task would have
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    try:
        path.mkdir(parents=True, exist_ok=True)
        atomic_write(str(entry), _encode(task, caught))
    except OSError:
        pass
    return task

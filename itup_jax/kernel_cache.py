"""The planner's jitted kernels kept between runs as exported modules, so a repeated command skips tracing them.

JAX's persistent compilation cache (`compile_cache`) saves a kernel's compile, but to find its entry JAX
first traces the Python function and lowers it: 0.05-0.4 s per kernel in a fresh process, ~0.7 s of a
repeated `itup plan` on a 2-core CPU (SDG-Net's scorer alone 0.3 s). `kept(fun, name)` is
`jax.jit(fun)` that, once `enable(folder)` has been called, exports each (kernel, argument structure)
it is called with (`jax.export`: the jitted function's StableHLO), writes it to `folder`, and in later
processes calls the module read from there instead of tracing. The module is the one the jit lowers
and the same XLA compiles it, so the outputs are bit for bit the jit's (tests/test_kernel_cache.py);
its compile is read from the compilation cache as before.

Key: SHA-256 of the kernel's name, its static arguments, the arguments' tree structure and each leaf's
shape, dtype and weak type, the source of every module of this package, the JAX and jaxlib versions,
the backend, whether float64 is on and the default matmul precision. Any change to one of them is a
new entry; a stale entry is never read. An entry that cannot be read is exported and written again;
entries are written atomically; a folder that cannot be written leaves the plain jit.

Static arguments are given by keyword (a call that gives one by position, or any other keyword, is a
plain jit). Only the arguments are flattened into the exported function (a `Task` or `Grasps` stays on
this side); a kernel's outputs must be arrays in tuples, lists, dicts or None, which the export format
stores itself. A kernel whose export fails is called as a plain jit for the rest of the process.

An entry is 5-35 kB (the scorer's is the largest); entries of other code versions are never read
again, and the folder may be deleted at any time (the next run exports again).

Off until `enable` is called: notebooks and tests trace as usual unless they ask. The CLI turns it on
with the compilation cache (`compile_cache.enable`, the subfolder `exported/`).
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
from pathlib import Path
from typing import Any, Callable

import jax
import jaxlib

from itup_jax.atomic import atomic_write

#: File format of an entry (a change here is a new key).
FORMAT = 1

#: Folder the kept kernels are read from and written to (None: off, every kernel is a plain jit).
_folder: Path | None = None
#: Every kernel made by `kept` (for `forget`).
_kernels: list[KeptKernel] = []


def enable(folder: str | os.PathLike | None) -> None:
    """Keep the exported kernels in `folder` (made when the first is written), or turn keeping off (None)."""
    global _folder
    _folder = None if folder is None else Path(folder)


def folder() -> Path | None:
    """The folder kernels are kept in, or None when keeping is off."""
    return _folder


def forget() -> None:
    """Drop the modules this process has read or exported, so the next calls read the folder again, as a
    fresh process would (tests)."""
    for kernel in _kernels:
        kernel._calls.clear()
        kernel._broken = False


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """SHA-256 of every module of this package (its source as installed): a code change is a new key."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        h.update(str(path.relative_to(root)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()


class KeptKernel:
    """`jax.jit(fun, static_argnames=static_argnames)`, called through its exported module when keeping is
    on (`enable`). Every other attribute (`lower`, `_cache_size`, ...) is the jit's."""

    def __init__(self, fun: Callable, name: str, static_argnames: tuple[str, ...] = ()):
        self.name = name
        self.static_argnames = tuple(static_argnames)
        self.jit = jax.jit(fun, static_argnames=self.static_argnames)
        self._fun = fun
        self._calls: dict[str, Callable] = {}  # key -> the jitted call of its exported module
        self._broken = False  # the export failed once: a plain jit from then on
        params = list(inspect.signature(fun).parameters) if self.static_argnames else []
        #: positional arguments from this many on would hold a static one: such calls are a plain jit
        self._positional = min((params.index(n) for n in self.static_argnames if n in params), default=1 << 30)
        functools.update_wrapper(self, fun)
        _kernels.append(self)

    def __getattr__(self, attr: str) -> Any:
        return getattr(self.__dict__["jit"], attr)

    def _key(self, static: dict, treedef, leaves: list) -> str:
        h = hashlib.sha256()
        h.update(f"format {FORMAT} jax {jax.__version__} jaxlib {jaxlib.__version__} code {code_digest()} "
                 f"x64 {jax.config.jax_enable_x64} backend {jax.default_backend()} "
                 f"matmul {jax.config.jax_default_matmul_precision}".encode())
        h.update(f"kernel {self.name} static {sorted(static.items())!r} tree {treedef}".encode())
        for leaf in leaves:
            aval = jax.typeof(leaf)
            h.update(f"{aval.shape}{aval.dtype}{getattr(aval, 'weak_type', False)};".encode())
        return h.hexdigest()

    def __call__(self, *args, **kwargs):
        if (_folder is None or self._broken or set(kwargs) - set(self.static_argnames)
                or len(args) > self._positional):
            return self.jit(*args, **kwargs)
        leaves, treedef = jax.tree_util.tree_flatten(args)
        key = self._key(kwargs, treedef, leaves)
        call = self._calls.get(key)
        if call is None:
            call = self._read(key)
        if call is None:
            call = self._export(key, kwargs, treedef, leaves)
        if call is None:  # the export failed (its tracing errors are raised here again, as the jit's)
            return self.jit(*args, **kwargs)
        return call(*leaves)

    def _read(self, key: str) -> Callable | None:
        try:
            data = (_folder / f"{key}.bin").read_bytes()
        except OSError:
            return None
        try:
            exported = jax.export.deserialize(bytearray(data))
        except Exception:  # noqa: BLE001 - truncated or foreign: exported and written again
            return None
        self._calls[key] = call = jax.jit(exported.call)
        return call

    def _export(self, key: str, static: dict, treedef, leaves: list) -> Callable | None:
        """Export the kernel for these arguments, write it, and return its call; None when it cannot be
        exported. The first run calls the exported module too, so its compile is the one later runs read
        from the compilation cache."""
        fun = self._fun

        def flat(*flat_args):
            return fun(*jax.tree_util.tree_unflatten(treedef, flat_args), **static)

        try:
            exported = jax.export.export(jax.jit(flat))(*leaves)
            data = exported.serialize()
        except Exception:  # noqa: BLE001 - outputs the format cannot store, effects, bad arguments, ...
            self._broken = True
            return None
        try:
            _folder.mkdir(parents=True, exist_ok=True)
            atomic_write(str(_folder / f"{key}.bin"), bytes(data))
        except OSError:
            pass
        self._calls[key] = call = jax.jit(exported.call)
        return call


def kept(fun: Callable, name: str, static_argnames: tuple[str, ...] | str = ()) -> KeptKernel:
    """`jax.jit(fun, static_argnames=...)` kept between runs as an exported module once `enable` is called;
    `name` (unique in the package) goes into its key."""
    return KeptKernel(fun, name, (static_argnames,) if isinstance(static_argnames, str) else static_argnames)

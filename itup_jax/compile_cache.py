"""JAX's persistent compilation cache for the command line: compiled kernels kept between runs.

A repeated `itup plan` or `itup demo` spends most of its time compiling the same kernels again (the
costs, the sampler's collision check, SDG-Net's scorer). `enable()` points JAX's persistent cache at a
per-user folder, so the second run loads them instead, and keeps the planner's kernels exported in
its subfolder `exported/` (`kernel_cache`), so the second run does not trace them either. The CLI
calls it before any JAX work unless `--no-compile-cache` is given or `ITUP_COMPILE_CACHE=0`; in a
notebook, call it yourself.

Folder: `$ITUP_COMPILE_CACHE_DIR`, else `$XDG_CACHE_HOME/itup-jax/jax`, else `~/.cache/itup-jax/jax`.
A cache entry is keyed by the computation, the JAX and XLA versions and the device, so a stale entry
is never used; deleting the folder only costs the next run its compile time.
"""

from __future__ import annotations

import os
from pathlib import Path

#: Environment variable that turns the CLI's cache off when set to 0, false or no.
ENV_SWITCH = "ITUP_COMPILE_CACHE"
#: Environment variable naming the cache folder.
ENV_DIR = "ITUP_COMPILE_CACHE_DIR"


def cache_dir() -> Path:
    """The folder the cache uses (not created)."""
    if os.environ.get(ENV_DIR):
        return Path(os.environ[ENV_DIR]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "itup-jax" / "jax"


def wanted(flag_off: bool = False) -> bool:
    """Whether the CLI should use the cache: not when `flag_off` or `$ITUP_COMPILE_CACHE` is 0/false/no."""
    return not flag_off and os.environ.get(ENV_SWITCH, "1").strip().lower() not in ("0", "false", "no", "off")


def enable(folder: str | os.PathLike | None = None) -> Path | None:
    """Turn JAX's persistent compilation cache on, in `folder` (default `cache_dir()`), for every kernel
    however short its compile, and `kernel_cache` in its subfolder `exported/`. Returns the folder, or
    None when it cannot be created (the run goes on without a cache)."""
    import jax

    path = Path(folder) if folder is not None else cache_dir()
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    from itup_jax import kernel_cache

    kernel_cache.enable(path / "exported")
    return path

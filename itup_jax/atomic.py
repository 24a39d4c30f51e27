"""Atomic file writes: a temporary file in the same folder, fsync, then rename — never half-written."""

from __future__ import annotations

import json
import math
import os
import tempfile


def atomic_write(path: str, data: bytes) -> None:
    """Write `data` to `path` atomically (the folder must exist)."""
    umask = os.umask(0)
    os.umask(umask)
    fd, tmp = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)) or ".", prefix=".tmp-")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600: give the file the mode open() would
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _json_safe(obj):
    """NaN and +-inf become null (strict JSON has no such numbers); NumPy scalars become Python ones."""
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if hasattr(obj, "item") and getattr(obj, "ndim", 1) == 0:
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def atomic_write_json(path: str, obj, indent: int | None = 1) -> None:
    """`obj` as strict JSON (non-finite numbers written as null), atomically."""
    atomic_write(path, (json.dumps(_json_safe(obj), indent=indent, allow_nan=False) + "\n").encode())

"""Checkpoints: arrays only (NumPy .npz, loaded with pickle refused), written atomically.

A checkpoint holds the MLP's (W, b) layers plus a JSON spec (feature spec, normalisation, config)
stored as a uint8 array, so nothing in it needs pickle to read.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
from typing import Any

import numpy as np

from itup_jax.atomic import atomic_write
from itup_jax.errors import InputError

FORMAT = "itup.checkpoint/1"


def save(path: str, layers: list, spec: dict[str, Any]) -> None:
    """Write layers [(W, b), ...] and a JSON-able spec to `path` (.npz) atomically."""
    arrays = {}
    for i, (W, b) in enumerate(layers):
        arrays[f"W{i}"] = np.asarray(W)
        arrays[f"b{i}"] = np.asarray(b)
    meta = {"format": FORMAT, "num_layers": len(layers), "spec": spec}
    arrays["meta_json"] = np.frombuffer(json.dumps(meta, sort_keys=True).encode(), dtype=np.uint8)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    atomic_write(path, buf.getvalue())


def load(path: str) -> tuple[list, dict[str, Any]]:
    """(layers [(W, b), ...] as NumPy arrays, spec). Refuses pickles, truncated or foreign files."""
    if not os.path.exists(path):
        raise InputError(f"checkpoint {path!r}: file not found")
    if not zipfile.is_zipfile(path):  # before np.load, which would try a pickle and blame that
        with open(path, "rb") as fh:
            if fh.read(4) == b"PK\x03\x04":
                raise InputError(f"checkpoint {path!r}: unreadable or truncated (an .npz archive's start without "
                                 "its end)")
        raise InputError(f"checkpoint {path!r}: not a checkpoint (not an .npz archive: no zip header)")
    try:
        with np.load(path, allow_pickle=False) as z:
            if "meta_json" not in z.files:
                raise InputError(f"checkpoint {path!r}: not an itup checkpoint (no meta_json)")
            meta = json.loads(bytes(z["meta_json"]).decode())
            if meta.get("format") != FORMAT:
                raise InputError(f"checkpoint {path!r}: format {meta.get('format')!r}, expected {FORMAT!r}")
            layers = [(z[f"W{i}"], z[f"b{i}"]) for i in range(int(meta["num_layers"]))]
    except InputError:
        raise
    except ValueError as exc:  # np.load's refusal of object arrays / pickles
        raise InputError(f"checkpoint {path!r}: refused ({exc}); checkpoints hold plain arrays only") from None
    except (zipfile.BadZipFile, EOFError, OSError, KeyError) as exc:
        raise InputError(f"checkpoint {path!r}: unreadable or truncated ({type(exc).__name__}: {exc})") from None
    for i, (W, b) in enumerate(layers):
        for name, a in ((f"W{i}", W), (f"b{i}", b)):
            if not np.issubdtype(a.dtype, np.floating) or not np.all(np.isfinite(a)):
                raise InputError(f"checkpoint {path!r}: layer array {name} holds NaN, infinity or non-float values; "
                                 "the file is corrupt or came from a diverged training run")
    return layers, meta["spec"]

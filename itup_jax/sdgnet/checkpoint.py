"""SDG-Net checkpoints: arrays only (NumPy .npz, loaded with pickle refused), written atomically.

A checkpoint holds the MLP's (W, b) layers plus a JSON spec (feature spec, normalisation, config)
stored as a uint8 array, so nothing in it needs pickle to read.

    save_model("model.npz", model); model = load_model("model.npz")   # None: the shipped checkpoint
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
from itup_jax.sdgnet import objective
from itup_jax.sdgnet.config import CLASS_TARGETS, DEFAULT_MODEL
from itup_jax.sdgnet.model import Model

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


def save_model(path: str, model: Model) -> None:
    save(path, model.params, model.spec)


def load_model(path: str | None = None) -> Model:
    """A saved model; None: the default checkpoint shipped in the package."""
    layers, spec = load(path or DEFAULT_MODEL)
    if not isinstance(spec.get("objective", "paper"), str) or spec.get("objective", "paper") not in objective.OBJECTIVES:
        raise InputError(f"model {path!r}: unknown objective {spec.get('objective')!r}; known: "
                         f"{', '.join(objective.OBJECTIVES)}")
    targets = list(objective.get(spec.get("objective", "paper")).targets)
    if spec.get("targets") != targets:
        raise InputError(f"model {path!r}: trained for targets {spec.get('targets')}, expected {targets} "
                         f"(objective {spec.get('objective', 'paper')!r})")
    scales = spec.get("target_scales")
    if not (isinstance(scales, list) and len(scales) == len(targets) and all(isinstance(v, (int, float)) and v > 0 for v in scales)):
        raise InputError(f"model {path!r}: target_scales must be {len(targets)} positive numbers (the log1p(y / scale) "
                         f"of training), got {scales!r}")
    model = Model(params=layers, spec=spec)
    heads = model.class_heads
    if not set(heads) <= set(CLASS_TARGETS) or len(set(heads)) != len(heads):
        raise InputError(f"model {path!r}: class_heads must be distinct labels among {list(CLASS_TARGETS)}, got {heads}")
    n_out = len(targets) + len(heads)
    outs = [layers[hi - 1][0].shape[-1] for hi in
            ([e["layers"][1] for e in spec["by_task"].values()] if "by_task" in spec else [len(layers)])]
    if any(o != n_out for o in outs):
        raise InputError(f"model {path!r}: its network has {outs} outputs, but its spec ({len(targets)} costs + binary heads "
                         f"{heads}) says {n_out}")
    m = model.ensemble_size
    if any(W.ndim != (2 if m == 1 else 3) or (m > 1 and (W.shape[0] != m or b.shape[0] != m)) for W, b in layers):
        raise InputError(f"model {path!r}: its spec says an ensemble of {m}, but its layers have shapes "
                         f"{[W.shape for W, _ in layers]}")
    return model

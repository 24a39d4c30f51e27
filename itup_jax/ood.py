"""The out-of-distribution guard: how far a tool's grasps lie from SDG-Net's training data.

SDG-Net has seen the tools of its training families only; on a tool unlike them its predictions are
extrapolations (on five held-out families its ranking of candidates by torque falls from Spearman ~0.85
to ~0.2: docs/results.md, "Tool families the network never saw"). The guard measures how far each
candidate's features lie from the training rows, in the network's own normalisation (the checkpoint's
per-feature mean and standard deviation):

    d(x)  = mean Euclidean distance from the standardised x to its K nearest rows of a reference sample
            of the training features (`Reference`: up to REFERENCE_ROWS rows per task)
    score = median over the tool's candidates of d(x) / s, with s the reference's own median d
            (leave-one-out), so a tool like the training tools scores ~1

Above GUARD_THRESHOLD the planner warns and rolls its best candidates out in MuJoCo instead of trusting
the learned score (`planning.plan_grasp`). The threshold is calibrated by `experiments/ood_guard.py`
against SDG-Net's measured ranking quality on tools of families it never saw (the training families of
`tools.families`, on which no shipped checkpoint was trained), and judged on other such families (the
held-out ones). The reading also names
the feature group farthest from the training mean (`FEATURE_GROUPS`), to say why.

The reference ships beside the checkpoints (`models/training_reference.npz`, the features of the shipped
checkpoints' training inputs, `experiments/ood_reference.py`); `itup train` writes one beside every
checkpoint it makes (`<checkpoint>.reference.npz`, `save_reference`). A checkpoint with neither has no
guard (`check` returns None).

    g = ood.check(tool, task, grasps)         # the shipped checkpoint
    g.score, g.fired, g.groups                # the score, above the threshold?, distance per feature group

Host-side wrapper around one jit (`guard_distances_jit`: features and distances, the outer call).
"""

from __future__ import annotations

import dataclasses
import functools
import importlib.resources
import os
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.errors import InputError
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.kernel_cache import kept
from itup_jax.precision import full_precision
from itup_jax.sdgnet.features import FeatureSpec, batched, cached_tool_field
from itup_jax.shapes import pad_batch, to_device, unpad_batch
from itup_jax.wrench import task_loads

#: The feature groups, in feature order (`sdgnet.features.grasp_features`): geometry [G^3], loads [12],
#: contact [9], physics [4].
FEATURE_GROUPS = ("geometry", "loads", "contact", "physics")
#: Nearest reference rows averaged per candidate.
K_NEAREST = 10
#: Reference rows kept per task (a uniform sample of the training rows).
REFERENCE_ROWS = 2048
#: The guard's threshold on a tool's score (its candidates' median nearest-neighbour distance over the
#: training rows' own), calibrated for the shipped default checkpoint by `experiments/ood_guard.py` on the
#: calibration families (`tools.families.calibration()`), which no training set holds, and judged on the
#: held-out families (docs/results.md, "The guard calibrated on other families").
GUARD_THRESHOLD = 1.34
#: The reference of the shipped checkpoints: the inputs of both (the default one's training tools hold
#: the paper one's and the training families'; `experiments/ood_reference.py`).
SHIPPED_REFERENCE = str(importlib.resources.files("itup_jax") / "models" / "training_reference.npz")


def group_slices(spec: FeatureSpec) -> dict[str, slice]:
    """Feature index ranges of `FEATURE_GROUPS` for a feature spec."""
    g = spec.grid**3
    bounds = (0, g, g + 12, g + 21, g + 25)
    return {name: slice(bounds[i], bounds[i + 1]) for i, name in enumerate(FEATURE_GROUPS)}


def knn_distance(z: jax.Array, ref: jax.Array, k: int) -> jax.Array:
    """[N] mean Euclidean distance of each row of z [N, F] to its k nearest rows of ref [R, F]. Pure."""
    d2 = jnp.sum(z * z, -1)[:, None] + jnp.sum(ref * ref, -1)[None, :] - 2.0 * z @ ref.T
    nearest = -jax.lax.top_k(-d2, k)[0]
    return jnp.mean(jnp.sqrt(jnp.maximum(nearest, 0.0)), axis=-1)


def group_distances(z: jax.Array, spec: FeatureSpec) -> jax.Array:
    """[N, 4] RMS of the standardised features z [N, F] per group (`FEATURE_GROUPS`; ~1 on training
    data). Pure."""
    return jnp.stack([jnp.sqrt(jnp.mean(z[:, s] ** 2, axis=-1)) for s in group_slices(spec).values()], axis=-1)


def _distances(field, tool_params, task, grasps, x_mean, x_std, ref, spec, k):
    feats = batched(field, task_loads(tool_params, task), tool_params, grasps, spec)
    z = (feats.astype(x_mean.dtype) - x_mean) / x_std
    return knn_distance(z, ref, k), group_distances(z, spec)


#: The outer call: a batch of grasps' features, their nearest-neighbour distances to the standardised
#: reference and their group distances, one jit (`spec`, `k` static).
guard_distances_jit = kept(full_precision(_distances), "ood.guard_distances", static_argnames=("spec", "k"))


@dataclasses.dataclass(frozen=True)
class Reference:
    """Raw features of training rows, per task: {task: [R, F] float32}."""

    features: dict

    def for_task(self, kind: str) -> np.ndarray:
        if kind not in self.features:
            raise InputError(f"guard reference: no training rows of task {kind!r}; has {sorted(self.features)}")
        return self.features[kind]


def sample_reference(features: np.ndarray, tasks: np.ndarray, *, rows: int = REFERENCE_ROWS, seed: int = 0) -> Reference:
    """A `Reference` of up to `rows` rows per task, drawn uniformly from training features [N, F] with
    their tasks [N]."""
    features, tasks = np.asarray(features, np.float32), np.asarray(tasks)
    if features.ndim != 2 or len(features) != len(tasks) or len(features) == 0:
        raise InputError(f"sample_reference: need features [N, F] and tasks [N], N >= 1; got {features.shape}, "
                         f"{tasks.shape}")
    rng = np.random.default_rng(seed)
    out = {}
    for kind in sorted(set(tasks.tolist())):
        idx = np.nonzero(tasks == kind)[0]
        out[str(kind)] = features[np.sort(rng.permutation(idx)[:rows])]
    return Reference(out)


def save_reference(path: str, ref: Reference) -> None:
    """Write a reference (.npz of float16 arrays, one per task) atomically."""
    import io

    from itup_jax.atomic import atomic_write

    buf = io.BytesIO()
    np.savez_compressed(buf, **{k: v.astype(np.float16) for k, v in ref.features.items()})
    atomic_write(path, buf.getvalue())


def reference_path(checkpoint: str) -> str:
    """Where `itup train` puts a checkpoint's reference: beside it, `<stem>.reference.npz`."""
    stem, _ = os.path.splitext(os.fspath(checkpoint))
    return stem + ".reference.npz"


@functools.lru_cache(maxsize=8)
def load_reference(path: str) -> Reference:
    """A saved reference (arrays only, no pickle)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return Reference({k: np.asarray(z[k], np.float32) for k in z.files})
    except (OSError, ValueError) as exc:
        raise InputError(f"guard reference {path!r}: unreadable ({exc})") from None


@functools.lru_cache(maxsize=1)
def _shipped_first_layers() -> tuple[np.ndarray, ...]:
    """The first-layer weights of the shipped checkpoints (read once per process)."""
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.config import DEFAULT_MODEL, PAPER_MODEL

    return tuple(np.asarray(load_model(p).params[0][0]) for p in (DEFAULT_MODEL, PAPER_MODEL))


def reference_path_of(model: Any) -> str | None:
    """The reference file of a checkpoint: the shipped one's for the shipped checkpoints (a path, None,
    or a loaded `Model` with their weights), `<stem>.reference.npz` beside any other path, else None."""
    from itup_jax.sdgnet.config import DEFAULT_MODEL, PAPER_MODEL
    from itup_jax.sdgnet.model import Model

    if isinstance(model, Model):
        w = np.asarray(model.params[0][0])
        shipped = any(w.shape == s.shape and np.array_equal(w, s) for s in _shipped_first_layers())
        return SHIPPED_REFERENCE if shipped else None
    if model is None or os.path.abspath(model) in (os.path.abspath(DEFAULT_MODEL), os.path.abspath(PAPER_MODEL)):
        return SHIPPED_REFERENCE
    p = reference_path(model)
    return p if os.path.exists(p) else None


@functools.lru_cache(maxsize=32)
def _standardised(path: str, kind: str, x_mean: bytes, x_std: bytes, k: int) -> tuple[np.ndarray, float]:
    """(the reference's rows of task `kind` standardised [R, F], their own median leave-one-out
    k-nearest distance, on up to 512 of them)."""
    mu, sd = np.frombuffer(x_mean, np.float32), np.frombuffer(x_std, np.float32)
    z = np.ascontiguousarray((load_reference(path).for_task(kind) - mu) / sd, np.float32)
    q = z[: min(512, len(z))]
    d2 = (q * q).sum(-1)[:, None] + (z * z).sum(-1)[None] - 2.0 * q @ z.T
    d2[np.arange(len(q)), np.arange(len(q))] = np.inf  # leave each row out
    nearest = np.sort(d2, axis=1)[:, :k]
    return z, float(np.median(np.sqrt(np.maximum(nearest, 0.0)).mean(1)))


@dataclasses.dataclass(frozen=True)
class Guard:
    """The guard's reading for one tool and task.

    Attributes:
      score: median over the candidates of their K-nearest distance to the training rows over the
        training rows' own (~1 for a tool like the training tools).
      threshold: the threshold it was compared with.  fired: score > threshold.
      groups: {group: median RMS standardised feature} (which part of the input is unlike the training
        data).
      per_candidate: [N] each candidate's distance ratio.
    """

    score: float
    threshold: float
    fired: bool
    groups: dict
    per_candidate: np.ndarray

    @property
    def farthest(self) -> str:
        """The feature group farthest from the training mean."""
        return max(self.groups, key=self.groups.get)

    def to_json(self) -> dict:
        return {"score": round(self.score, 4), "threshold": self.threshold, "fired": self.fired,
                "groups": {k: round(v, 4) for k, v in self.groups.items()}}

    def message(self, tool_name: str, task_kind: str) -> str:
        """One line for the user when the guard fired."""
        return (f"tool {tool_name!r} lies outside SDG-Net's training data for the {task_kind} task (guard score "
                f"{self.score:.2f} > {self.threshold:g}: its grasps' features lie {self.score:.1f}x as far from the "
                f"training rows as those rows lie from each other; farthest: its {self.farthest} features)")


def check(tool, task, grasps: Grasps, model: Any = None, *, threshold: float | None = None) -> Guard | None:
    """The guard's reading for `grasps` [N >= 1] of `tool` in `task` under SDG-Net checkpoint `model`
    (None: the shipped one; a path; a loaded `sdgnet.model.Model`), against `threshold` (None:
    GUARD_THRESHOLD). None when the checkpoint has no reference (`reference_path_of`)."""
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.model import Model

    validate_grasps(grasps)
    path = reference_path_of(model)
    if path is None:
        return None
    m = (model if isinstance(model, Model) else load_model(model)).for_task(task.kind)
    spec = m.feature_spec
    x_mean, x_std = np.asarray(m.spec["x_mean"], np.float32), np.asarray(m.spec["x_std"], np.float32)
    if x_mean.ndim == 2:  # an ensemble: its members' normalisations, averaged
        x_mean, x_std = x_mean.mean(0), x_std.mean(0)
    rows = len(load_reference(path).for_task(task.kind))
    k = min(K_NEAREST, rows - 1)
    if k < 1:
        return None
    z_ref, scale = _standardised(path, task.kind, x_mean.tobytes(), x_std.tobytes(), k)
    dt = jnp.float32
    padded, n = pad_batch(grasps)  # one compile per bucket of candidate counts (shapes.py)
    d, groups = unpad_batch(guard_distances_jit(cached_tool_field(tool, spec, dt), tool.params, task, padded,
                                                to_device(x_mean), to_device(x_std), to_device(z_ref), spec=spec,
                                                k=k), n)
    ratio = np.asarray(d, float) / scale
    score = float(np.median(ratio))
    threshold = GUARD_THRESHOLD if threshold is None else float(threshold)
    groups = np.asarray(groups, float)
    return Guard(score=score, threshold=threshold, fired=bool(score > threshold),
                 groups={g: float(np.median(groups[:, i])) for i, g in enumerate(FEATURE_GROUPS)}, per_candidate=ratio)

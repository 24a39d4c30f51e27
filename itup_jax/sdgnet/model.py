"""A trained SDG-Net (`Model`): its layers and spec, prediction from features, and deep ensembles.

    model = load_model()                              # the shipped checkpoint (`checkpoint.py`)
    costs = predict_costs(model, feats, "hammer")     # {name: [N]} costs and head probabilities
    ens = ensemble([m0, m1, m2])                      # one Model that averages three

The network (`mlp.py`) maps a grasp's features (`features.py`) to log1p(y / scale) of its objective's
targets and to the logits of its binary heads; `predict_from_features` is the pure function the scorer's
one jit wraps (`scoring.score`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.errors import InputError
from itup_jax.precision import full_precision
from itup_jax.sdgnet import mlp, objective
from itup_jax.sdgnet.config import CLASS_NAMES, CLASS_TARGETS, SUCCESS_TARGET, WEAK_TARGET, TrainConfig
from itup_jax.sdgnet.features import RESIDUAL_SIZE, FeatureSpec


@dataclasses.dataclass(frozen=True)
class Model:
    """Trained SDG-Net: MLP layers plus everything needed to rebuild its inputs and outputs."""

    params: list
    spec: dict  # feature_spec, x_mean, x_std, y_mean, y_std, targets, train config, metrics

    @property
    def feature_spec(self) -> FeatureSpec:
        return FeatureSpec(**self.spec["feature_spec"])

    @property
    def residual(self) -> bool:
        """Whether its torque and grip outputs are residuals on the rigid-body model's prediction
        (`FeatureSpec.residual`)."""
        return self.feature_spec.residual

    @property
    def objective(self) -> str:
        """The objective it was trained on (`objective.OBJECTIVES`; checkpoints that predate the choice:
        'paper')."""
        return str(self.spec.get("objective", "paper"))

    @property
    def output_names(self) -> list[str]:
        """The names of its regression outputs, in order (`objective.Objective.outputs`)."""
        return list(objective.get(self.objective).outputs)

    @property
    def class_heads(self) -> list[str]:
        """Labels of the binary heads, in output order after the three costs (the oldest
        checkpoints say `success_head` instead)."""
        if "class_heads" in self.spec:
            return list(self.spec["class_heads"])
        return [SUCCESS_TARGET] if self.spec.get("success_head") else []

    @property
    def head_names(self) -> list[str]:
        """The probability names of the binary heads (`CLASS_NAMES`: p_success, p_failed, p_failed_weak), in
        output order."""
        return [CLASS_NAMES[CLASS_TARGETS.index(t)] for t in self.class_heads]

    @property
    def has_success_head(self) -> bool:
        """Whether the network also predicts the probability of task success."""
        return SUCCESS_TARGET in self.class_heads

    @property
    def train_config(self) -> TrainConfig:
        """The recipe this model was trained with (`spec["config"]`; fields a checkpoint predates take
        TrainConfig's defaults, but a head it predates weighs 0: it has no such output): what `train`
        needs to make it again on other data, and what `adapt` continues with."""
        fields = {f.name for f in dataclasses.fields(TrainConfig)}
        cfg = {k: v for k, v in self.spec["config"].items() if k in fields}
        if WEAK_TARGET not in self.class_heads:
            cfg["weak_failure_weight"] = 0.0
        cfg["objective"] = self.objective  # a checkpoint that predates the choice was trained on the paper's
        if "hidden" in cfg:
            cfg["hidden"] = tuple(int(h) for h in cfg["hidden"])
        return TrainConfig(**cfg)

    @property
    def ensemble_size(self) -> int:
        """How many networks' predictions are averaged (`ensemble`); 1 for a trained model."""
        return int(self.spec.get("ensemble", {}).get("size", 1))

    @property
    def tasks(self) -> list[str] | None:
        """The tasks of a per-task model (one MLP each), or None for one shared MLP."""
        return list(self.spec["by_task"]) if "by_task" in self.spec else None

    def for_task(self, kind: str | None) -> "Model":
        """The network that scores task `kind`: the model itself when one MLP serves every task, else
        that task's MLP with its own normalisation (a plain single-network Model)."""
        by_task = self.spec.get("by_task")
        if by_task is None:
            return self
        if kind not in by_task:
            raise InputError(f"SDG-Net model: trained per task for {list(by_task)}; no network for task {kind!r}")
        e = by_task[kind]
        lo, hi = e["layers"]
        spec = {k: v for k, v in self.spec.items() if k != "by_task"}
        spec.update({k: e[k] for k in ("x_mean", "x_std", "y_mean", "y_std")})
        return Model(params=self.params[lo:hi], spec=spec)


def _network_outputs(params, x_mean, x_std, y_mean, y_std, feats):
    """One network: [N, F] features -> ([N, C] log1p(y / scale) of the regression targets, [N, K] head logits)."""
    out = jax.vmap(mlp.apply, in_axes=(None, 0))(params, (feats - x_mean) / x_std)
    k = y_mean.shape[-1]
    return out[:, :k] * y_std + y_mean, out[:, k:]


def residual_base(feats, spec: FeatureSpec):
    """[N, RESIDUAL_SIZE] the rigid-body prediction a residual network's first outputs are added to (the
    features' last block, in the targets' log1p(y / scale)), or None for a spec without it."""
    return feats[..., -RESIDUAL_SIZE:] if spec.residual else None


def _add_base(z, base):
    """Regression outputs z [..., N, C] plus the residual base [N, R] on their first R columns."""
    if base is None:
        return z
    return z + jnp.pad(base.astype(z.dtype), ((0, 0), (0, z.shape[-1] - base.shape[-1])))


def predict_from_features(params, x_mean, x_std, y_mean, y_std, y_scale, feats, base=None):
    """[N, F] features -> ([N, C] regression outputs in SI units, [N, K] probabilities of the binary heads
    or None): normalise, MLP, de-normalise, undo log1p(y / scale) with the checkpoint's own scales
    `y_scale` [C] (the objective's units; `objective.costs_of` makes the scorer's costs of them); the probabilities are the sigmoids of the outputs after the costs (which label each
    is: `Model.class_heads`), None for a network without heads (decided by the last layer's static
    shape). An ensemble (`ensemble`: every array with a leading member axis M, x_mean [M, F]) runs its
    M networks as one batched MLP and averages their log1p(y / scale) and their probabilities. Outputs
    are >= 0 and probabilities in [0, 1] by construction. `base` [N, R] (`residual_base`, a residual
    network's): added to each network's first R outputs before anything else. Pure;
    `predict` and the scorer's jit wrap it."""
    if x_mean.ndim == 2:  # static: an ensemble's stacked members
        z, logits = jax.vmap(_network_outputs, in_axes=(0, 0, 0, 0, 0, None))(params, x_mean, x_std, y_mean, y_std,
                                                                               feats)
        # each member's prediction held at >= 0 (below), then their mean
        z, probs = jnp.maximum(_add_base(z, base), 0.0).mean(0), jax.nn.sigmoid(logits).mean(0)
    else:
        z, logits = _network_outputs(params, x_mean, x_std, y_mean, y_std, feats)
        z = _add_base(z, base)
        probs = jax.nn.sigmoid(logits)
    # every target is a magnitude (torque, grip force, slip, drift >= 0), learnt as log1p(y / scale) >= 0: a
    # network output below 0 (an extrapolation) is held at 0, so no prediction is negative
    return y_scale * jnp.expm1(jnp.maximum(z, 0.0)), (probs if probs.shape[-1] > 0 else None)


#: Prediction from precomputed features, one jit (`scoring.score` fuses features and network instead).
predict = jax.jit(full_precision(predict_from_features))


def predict_costs(model: Model, feats: Any, task: str | None = None) -> dict[str, jax.Array]:
    """Each regression output (`Model.output_names`), the scorer's costs tau, slip, align (and grip,
    for the wrench objective: tau is then the norm of the three torque components) and each binary
    head's probability (p_success, p_failed, p_failed_weak): each [N], from features [N, F] of grasps for `task`
    (required by a per-task model)."""
    model = model.for_task(task)
    s = model.spec
    dt = jnp.asarray(model.params[0][0]).dtype
    feats = jnp.asarray(feats, dt)
    out, p = predict([(jnp.asarray(W), jnp.asarray(b)) for W, b in model.params], jnp.asarray(s["x_mean"]),
                     jnp.asarray(s["x_std"]), jnp.asarray(s["y_mean"]), jnp.asarray(s["y_std"]),
                     jnp.asarray(s["target_scales"], dt), feats, residual_base(feats, model.feature_spec))
    costs = objective.costs_of(out, model.objective)
    derived = {name: costs[:, i] for i, name in enumerate(objective.COST_COLUMNS)
               if name != "grip" or model.objective != "paper"}
    return ({name: out[:, i] for i, name in enumerate(model.output_names)} | derived
            | {n: p[:, j] for j, n in enumerate(model.head_names)})


#: Spec entries that are one per network (normalisation): stacked along the member axis in an ensemble.
_NORMALISATION = ("x_mean", "x_std", "y_mean", "y_std")


def ensemble(models) -> Model:
    """One Model that averages the predictions of `models` (>= 2 trained models, e.g. the same recipe
    with different `TrainConfig.seed`s): a deep ensemble. Each layer's weights are stacked along a
    leading member axis ([M, n_in, n_out]) and so is each network's normalisation, so the scorer runs
    the M networks as one batched MLP in its one jit (M times the MLP's flops) and averages their
    log1p(y / scale) (a geometric mean of 1 + y / scale) and their head probabilities.

    The members must agree on everything but their weights: feature spec, targets and scales, binary
    heads, layer shapes, and tasks (per-task networks: the same tasks and layer ranges). The spec is
    the first member's with the normalisation stacked; `spec["ensemble"]` records each member's training
    config, metrics and command (`train_config` gives the first member's recipe).
    """
    models = list(models)
    if len(models) < 2 or not all(isinstance(m, Model) for m in models):
        raise InputError(f"ensemble: needs >= 2 trained Models, got {len(models)} "
                         f"({', '.join(sorted({type(m).__name__ for m in models})) or 'none'})")
    first = models[0]
    for k, m in enumerate(models):
        if m.ensemble_size != 1:
            raise InputError(f"ensemble: member {k} is itself an ensemble of {m.ensemble_size}; combine the trained "
                             "models it was made of instead")
        for key in ("feature_spec", "objective", "targets", "target_scales", "class_heads"):
            if m.spec.get(key) != first.spec.get(key):
                raise InputError(f"ensemble: member {k}'s {key} {m.spec.get(key)!r} differs from member 0's "
                                 f"{first.spec.get(key)!r}; members must take the same inputs and give the same outputs")
        shapes = [(np.shape(W), np.shape(b)) for W, b in m.params]
        if shapes != [(np.shape(W), np.shape(b)) for W, b in first.params]:
            raise InputError(f"ensemble: member {k}'s layers {shapes} differ from member 0's; members must share "
                             "an architecture")
        ranges = {t: e["layers"] for t, e in m.spec.get("by_task", {}).items()}
        if ranges != {t: e["layers"] for t, e in first.spec.get("by_task", {}).items()}:
            raise InputError(f"ensemble: member {k}'s per-task networks {ranges} differ from member 0's")
    params = [(np.stack([np.asarray(m.params[i][0]) for m in models]), np.stack([np.asarray(m.params[i][1]) for m in models]))
              for i in range(len(first.params))]
    stack = lambda specs: {k: np.stack([np.asarray(s[k], np.float64) for s in specs]).tolist()  # noqa: E731
                           for k in _NORMALISATION if k in specs[0]}
    own = ("config", "command", "datasets", "n_train", "n_val", "best_val_loss", "train_seconds", "val_metrics")
    spec = {k: v for k, v in first.spec.items() if k not in _NORMALISATION + own
            + ("by_task", "history", "shared", "best_epoch", "ensemble")}
    spec["config"] = first.spec.get("config")
    spec.update(stack([m.spec for m in models]))
    if "by_task" in first.spec:
        spec["by_task"] = {t: {"layers": e["layers"], **stack([m.spec["by_task"][t] for m in models])}
                           for t, e in first.spec["by_task"].items()}
    spec["ensemble"] = {"size": len(models), "members": [{k: m.spec[k] for k in own if k in m.spec} for m in models]}
    return Model(params=params, spec=spec)

"""The scorer interface: analytic iTuP costs or SDG-Net predictions, same call, same outputs.

    s = itup.score(tool, task, grasps)                    # SDG-Net, the shipped default checkpoint
    s = itup.score(tool, task, grasps, model="analytic")  # the foundation's wrench costs
    i, g, s_i = itup.best_grasp(tool, task, grasps)

SDG-Net scoring runs in one jit (grasp-independent loads, per-grasp features, the MLP); a second call
with the same shapes does not recompile.
"""

from __future__ import annotations

import dataclasses
import weakref
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.costs import CostParams, wrench_costs
from itup_jax.errors import InputError
from itup_jax.features import _batched, surface_sample
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.sdgnet import Model, load_model, predict_from_features
from itup_jax.task import Task
from itup_jax.tool import Tool
from itup_jax.wrench import task_loads


@dataclasses.dataclass(frozen=True)
class ScoreWeights:
    """Weights of the SDG-Net total: its costs are measured quantities (N m, m, rad), so 1 cm of slip
    weighs like 1 N m of torque and 0.1 rad of drift (a stated choice; the experiments tune it)."""

    w_tau: float = 1.0  # 1/(N m)
    w_slip: float = 100.0  # 1/m
    w_align: float = 10.0  # 1/rad


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Scores:
    """Per-grasp scores, each [N]; lower is better. `scorer` (static) says which model made them."""

    tau: jax.Array
    slip: jax.Array
    align: jax.Array
    total: jax.Array
    scorer: str = dataclasses.field(default="analytic", metadata=dict(static=True))


def _sdgnet_scores(points, tool_params, task, grasps, params, x_mean, x_std, y_mean, y_std, weights, spec):
    loads = task_loads(tool_params, task)
    feats = _batched(points, loads, tool_params, grasps, spec)
    y = predict_from_features(params, x_mean, x_std, y_mean, y_std, feats.astype(x_mean.dtype))
    tau, slip, align = y[:, 0], y[:, 1], y[:, 2]
    return tau, slip, align, weights[0] * tau + weights[1] * slip + weights[2] * align


#: The one jit of SDG-Net scoring (the outer call).
sdgnet_scores_jit = jax.jit(_sdgnet_scores, static_argnames=("spec",))
_POINTS: "weakref.WeakKeyDictionary[Tool, dict]" = weakref.WeakKeyDictionary()  # tool -> {spec: points}


def score(tool: Tool, task: Task, grasps: Grasps, model: Any = None, *,
          weights: ScoreWeights = ScoreWeights(), cost_params: CostParams | None = None) -> Scores:
    """Scores [N] of `grasps`: model None (default checkpoint), a path, a `Model`, or 'analytic'."""
    validate_grasps(grasps)
    if isinstance(model, str) and model == "analytic":
        c = wrench_costs(tool, task, grasps, cost_params)
        return Scores(tau=c.tau, slip=c.slip, align=c.align, total=c.total, scorer="analytic")
    if model is None or isinstance(model, str):
        model = load_model(model)
    if not isinstance(model, Model):
        raise InputError(f"score: model must be None, 'analytic', a checkpoint path or a Model, got {type(model).__name__}")
    spec = model.feature_spec
    per_tool = _POINTS.setdefault(tool, {})
    if spec not in per_tool:
        per_tool[spec] = surface_sample(tool, spec)
    points = per_tool[spec]
    s = model.spec
    dt = jnp.float32
    params = [(jnp.asarray(W, dt), jnp.asarray(b, dt)) for W, b in model.params]
    out = sdgnet_scores_jit(jnp.asarray(points, dt), tool.params, task, grasps, params,
                            jnp.asarray(s["x_mean"], dt), jnp.asarray(s["x_std"], dt), jnp.asarray(s["y_mean"], dt),
                            jnp.asarray(s["y_std"], dt), jnp.asarray([weights.w_tau, weights.w_slip, weights.w_align], dt),
                            spec=spec)
    return Scores(*out, scorer="sdgnet")


def best_grasp(tool: Tool, task: Task, grasps: Grasps, model: Any = None, **kw) -> tuple[int, Grasps, Scores]:
    """(index, that grasp, all scores) of the lowest total score."""
    s = score(tool, task, grasps, model, **kw)
    i = int(np.argmin(np.asarray(s.total)))
    return i, grasps[i], s


"""The scorer interface: analytic iTuP costs or SDG-Net predictions, same call, same outputs.

    s = itup.score(tool, task, grasps)                    # SDG-Net, the shipped default checkpoint
    s = itup.score(tool, task, grasps, model="analytic")  # the foundation's wrench costs
    i, g, s_i = itup.best_grasp(tool, task, grasps)
    i, g, s_i = itup.best_grasp(tool, task, grasps, reachable_only=True)  # one the arm can carry along the task

SDG-Net scoring runs in one jit (grasp-independent loads, per-grasp features, the MLP); a second call
with the same shapes does not recompile.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.baselines import BASELINES
from itup_jax.costs import CostParams, wrench_costs
from itup_jax.errors import InputError, check_seed
from itup_jax.grasp import Grasps, validate_grasps
from itup_jax.kernel_cache import kept
from itup_jax.precision import full_precision
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sdgnet.config import PAPER_MODEL
from itup_jax.sdgnet.features import batched, cached_tool_field
from itup_jax.sdgnet.model import Model, predict_from_features, residual_base
from itup_jax.sdgnet.objective import WRENCH, costs_of
from itup_jax.shapes import pad_batch, to_device, unpad_batch
from itup_jax.task import Task
from itup_jax.tools import Tool
from itup_jax.wrench import task_loads

#: Weights of SDG-Net's predicted probabilities in the total (N m of torque per unit): that the grasp
#: misses the task (1 - p_success) and that it fails in the grip (p_failed).
W_TASK = 10.0
W_FAIL = 10.0
#: Weight of the predicted grip demand (N per pad) in the total, N m per N (objective.WRENCH's models).
#: 0: without it the planner's picks failed at 25 N per pad no more often than the better baseline's
#: (none did) on the validation tools, and with it (0.05) they carried a quarter more full induced torque
#: (`experiments/score_weights.py`'s rule; docs/results.md, "The planner's weights"). A nonzero weight
#: prefers grasps the pads hold with less force (`itup plan --w-grip`).
W_GRIP = 0.0
#: Weight of the predicted alignment drift (rad) in the total, 1/rad. A grasp that lets the tool turn
#: between the pads caps the wrench the pads pass on, so the wrist reads a low torque where the grip is
#: weakest; the weak-grip failure head (`W_WEAK`) keeps such grasps out of the pick (none of the picks
#: failed at 25 N per pad on the validation tools with this weight at 0), while a weight on the drift
#: itself costs a third more wrist torque. Without it the picks drift from the trajectory during contact
#: as much as the baselines' on the validation tools, about twice force closure's on Table I's sweep.
#: Chosen with W_GRIP by `experiments/score_weights.py`'s rule (docs/results.md, "The planner's weights").
W_ALIGN = 0.0
#: Weight of SDG-Net's predicted probability that the grasp fails in the grip at a weak grip
#: (`dataset.WEAK_GRIP`, 25 N per pad; the network's `label_weak_failed` head), N m per unit: a sure
#: failure at the weak grip weighs like this many N m of torque. Grasps that fail at a weak grip hold
#: by force rather than by where they sit on the tool; nothing else the network predicts ranks them on
#: the sweep. Chosen on validation tools by the rule fixed in `experiments/weight_by_stress.py`.
W_WEAK = 30.0


@dataclasses.dataclass(frozen=True)
class ScoreWeights:
    """Weights of the SDG-Net total: its costs are measured quantities (N m, m, rad, N), so 1 cm of slip
    weighs like 1 N m of torque. With a success head, the predicted probability that the grasp misses the
    task adds w_task x (1 - p_success): a sure miss weighs like W_TASK N m of torque; with a failure head,
    w_fail x p_failed (slip over 1 cm or a turn over 10 degrees in the grip); with a weak-grip failure
    head, w_weak x p_failed_weak (the same failure at 25 N per pad). The drift and the grip demand weigh
    nothing by default (`W_ALIGN`, `W_GRIP`).
    The defaults are the setting `experiments/score_weights.py` chose on validation tools by its rule (the
    least full induced torque among settings whose picks miss the task and fail in the grip, at the
    default grip and at 25 N per pad, no more often than the better of force closure's and geometric
    ranking's picks; docs/results.md, "The planner's weights"). The same weights score the
    paper-objective network (the paper publishes no weights)."""

    w_tau: float = 1.0  # 1/(N m)
    w_slip: float = 100.0  # 1/m
    w_align: float = W_ALIGN  # 1/rad
    w_task: float = W_TASK  # per unit of probability of missing the task
    w_fail: float = W_FAIL  # per unit of probability of failing in the grip
    # per unit of probability of failing in the grip at the weak grip (a network with that head)
    w_weak: float = W_WEAK
    # N m per N of grip demand (a model of the wrench objective; the paper's predicts none)
    w_grip: float = W_GRIP

    def __post_init__(self):
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v >= 0):
                raise InputError(f"ScoreWeights: {f.name} must be a finite number >= 0 (every term is a cost "
                                 f"to minimise), got {v!r}")

    @classmethod
    def torque_first(cls, w_task: float = W_TASK, w_fail: float = W_FAIL) -> "ScoreWeights":
        """Wrist torque alone (slip, drift and the grip demand weigh nothing) with the task and grip
        penalties kept (w_weak at its default): the default weights without the slip term. On the
        validation tools its picks carry 3 % more full induced torque than the default's, with no more
        failures (docs/results.md, "The planner's weights")."""
        return cls(w_tau=1.0, w_slip=0.0, w_align=0.0, w_grip=0.0, w_task=w_task, w_fail=w_fail)

    def costs(self, dtype=jnp.float32) -> jax.Array:
        """[4] weights of the cost columns (tau, slip, align, grip: `sdgnet.objective.COST_COLUMNS`)."""
        return to_device([self.w_tau, self.w_slip, self.w_align, self.w_grip], dtype)

    def heads(self, class_heads, dtype=jnp.float32) -> jax.Array:
        """[K, 2] (a, b) per binary head of a model (`Model.class_heads`): its term is a + b p. Success:
        w_task (1 - p); failure: w_fail p; weak-grip failure: w_weak p."""
        coef = {"label_success": (self.w_task, -self.w_task), "label_failed": (0.0, self.w_fail),
                "label_weak_failed": (0.0, self.w_weak)}
        return to_device(np.reshape([coef[h] for h in class_heads], (len(class_heads), 2)), dtype)


def sdgnet_total(costs, probs, w_costs, head_coef):
    """[N] total of SDG-Net's predictions: costs [N, 4] (N m, m, rad, N) . w_costs [4], plus, per binary
    head k, head_coef[k, 0] + head_coef[k, 1] x probs[:, k] (probs [N, K]; None: no heads). Pure."""
    total = costs @ w_costs
    if probs is None:
        return total
    return total + jnp.sum(head_coef[:, 0] + head_coef[:, 1] * probs, axis=-1)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class Scores:
    """Per-grasp scores, each [N]; lower is better. `scorer` (static) says which model made them.
    p_success / p_failed / p_failed_weak: SDG-Net's predicted probability that the grasp achieves the
    task / fails in the grip / fails in the grip at the weak grip of 25 N per pad (None where the scorer
    does not predict it)."""

    tau: jax.Array
    slip: jax.Array
    align: jax.Array
    total: jax.Array
    scorer: str = dataclasses.field(default="analytic", metadata=dict(static=True))
    p_success: jax.Array | None = None
    p_failed: jax.Array | None = None
    p_failed_weak: jax.Array | None = None
    grip: jax.Array | None = None  # predicted grip demand, N per pad (a wrench-objective SDG-Net)


def _sdgnet_scores(field, tool_params, task, grasps, params, x_mean, x_std, y_mean, y_std, y_scale, w_costs,
                   head_coef, spec, objective):
    loads = task_loads(tool_params, task)
    feats = batched(field, loads, tool_params, grasps, spec)
    feats = feats.astype(x_mean.dtype)
    y, p = predict_from_features(params, x_mean, x_std, y_mean, y_std, y_scale, feats, residual_base(feats, spec))
    c = costs_of(y, objective)
    return c[:, 0], c[:, 1], c[:, 2], c[:, 3], sdgnet_total(c, p, w_costs, head_coef), p


#: The one jit of SDG-Net scoring (the outer call).
sdgnet_scores_jit = kept(full_precision(_sdgnet_scores), "scoring.sdgnet_scores", static_argnames=("spec", "objective"))


def sdgnet_args(tool: Tool, task: Task, grasps: Grasps, model: Model, weights: ScoreWeights) -> tuple[tuple, dict]:
    """Arguments of `sdgnet_scores_jit` (float32; the tool's density field cached per tool and spec)."""
    model = model.for_task(task.kind)
    spec = model.feature_spec
    dt = jnp.float32
    s = model.spec
    params = [(to_device(W, dt), to_device(b, dt)) for W, b in model.params]
    args = (cached_tool_field(tool, spec, dt), tool.params, task, grasps, params,
            to_device(s["x_mean"], dt), to_device(s["x_std"], dt), to_device(s["y_mean"], dt),
            to_device(s["y_std"], dt), to_device(s["target_scales"], dt), weights.costs(dt),
            weights.heads(model.class_heads, dt))
    return args, {"spec": spec, "objective": model.objective}


def score(tool: Tool, task: Task, grasps: Grasps, model: Any = None, *,
          weights: ScoreWeights = ScoreWeights(), cost_params: CostParams | None = None, seed: int = 0) -> Scores:
    """Scores [N] of `grasps` (lower is better).

    model: None or 'sdgnet' (the shipped checkpoint), 'sdgnet_paper' (the paper objective's shipped
    checkpoint), a checkpoint path, a `Model`, 'analytic' (the wrench costs, `cost_params` or the
    paper's form), 'analytic_wrench' (the same in the grip-demand form, `CostParams.wrench()`), or a
    baseline of `baselines.py`: 'force_closure' (Ferrari-Canny), 'geometric', 'static', 'random'
    (seeded by `seed`).
    """
    validate_grasps(grasps)
    if isinstance(model, str) and model in BASELINES:
        return _baseline(model, tool, task, grasps, seed)
    if isinstance(model, str) and model == "sdgnet":
        model = None
    if isinstance(model, str) and model == "sdgnet_paper":
        model = PAPER_MODEL
    if isinstance(model, str) and model == "analytic_wrench":
        c = wrench_costs(tool, task, grasps, cost_params or WRENCH.analytic)
        return Scores(tau=c.tau, slip=c.slip, align=c.align, total=c.total, scorer="analytic_wrench")
    if isinstance(model, str) and model == "analytic":
        c = wrench_costs(tool, task, grasps, cost_params)
        return Scores(tau=c.tau, slip=c.slip, align=c.align, total=c.total, scorer="analytic")
    if model is None or isinstance(model, str):
        model = load_model(model)
    if not isinstance(model, Model):
        raise InputError(f"score: model must be None, 'analytic', a checkpoint path or a Model, got {type(model).__name__}")
    padded, n = pad_batch(grasps)  # one compile per bucket of candidate counts (shapes.py)
    args, kw = sdgnet_args(tool, task, padded, model, weights)
    tau, slip, align, grip, total, p = unpad_batch(sdgnet_scores_jit(*args, **kw), n)
    probs = {name: p[:, j] for j, name in enumerate(model.for_task(task.kind).head_names)}
    return Scores(tau=tau, slip=slip, align=align, total=total, scorer="sdgnet",
                  grip=None if model.objective == "paper" else grip, **probs)


def _baseline(name: str, tool: Tool, task: Task, grasps: Grasps, seed: int) -> Scores:
    from itup_jax import baselines

    n = len(grasps)
    zero = jnp.zeros(n)
    if name == "force_closure":
        eps = baselines.force_closure_scores(tool, grasps)
        return Scores(tau=zero, slip=zero, align=zero, total=jnp.asarray(-eps), scorer=name)
    if name == "geometric":
        g = baselines.geometric_scores(tool, grasps)
        return Scores(tau=zero, slip=zero, align=jnp.asarray(g["antipodal"]), total=jnp.asarray(g["total"]), scorer=name)
    if name == "static":
        s = baselines.static_scores(tool, task, grasps)
        return Scores(tau=jnp.asarray(s["tau"]), slip=jnp.asarray(s["slip"]), align=jnp.asarray(s["align"]),
                      total=jnp.asarray(s["total"]), scorer=name)
    r = np.random.default_rng(check_seed(seed, "score (random)")).random(n)
    return Scores(tau=zero, slip=zero, align=zero, total=jnp.asarray(r), scorer=name)


#: Every name `score` accepts as `model` (besides a path or a Model).
SCORERS = ("sdgnet", "sdgnet_paper", "analytic", "analytic_wrench") + BASELINES
#: The scorers that are SDG-Net checkpoints (their weights are `ScoreWeights`).
SDGNET_SCORERS = ("sdgnet", "sdgnet_paper")
#: The analytic scorers (their weights are `CostParams` fields).
ANALYTIC_SCORERS = ("analytic", "analytic_wrench")


def best_grasp(tool: Tool, task: Task, grasps: Grasps, model: Any = None, *, reachable_only: bool = False,
               **kw) -> tuple[int, Grasps, Scores]:
    """(index, that grasp, all scores) of the lowest total score (`score`'s keywords pass through).

    reachable_only: the lowest-scored grasp with which the arm can follow the task's trajectory
    (closed-form IK, `sim.arm.reachable`, checked down the ranking 16 at a time, ~0.2 ms a grasp): the
    scorers rank grasps, not the arm's reach, and raw candidates are often unreachable (about half of a
    sample; for the reach task's L-stick SDG-Net's 20 best of 1,000). Raises InputError when none is.
    """
    s = score(tool, task, grasps, model, **kw)
    total = np.asarray(s.total)
    if not reachable_only:
        i = int(np.argmin(total))
        return i, grasps[i], s
    from itup_jax.sim.arm import first_reachable  # MuJoCo's kinematics: imported only when asked

    ranking = np.argsort(total, kind="stable")
    rank, _ = first_reachable(task, grasps, ranking)
    if rank is None:
        raise InputError(f"best_grasp: none of the {len(grasps)} grasps is reachable for the arm along the "
                         f"{task.kind} task's trajectory (closed-form IK); sample more or other grasps")
    i = int(ranking[rank])
    return i, grasps[i], s


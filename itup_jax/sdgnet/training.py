"""Training SDG-Net on label datasets: from scratch (`train`), continued (`adapt`), distilled (`teacher_targets`).

    model = train(load_dataset("data/"), TrainConfig())        # -> Model (params + spec)

The loss is the paper's: the sum of squared errors on normalised targets, plus each binary head's
cross-entropy (`TrainConfig` weights; a head whose weight is 0 is left out), and optionally
(`TrainConfig.rank_weight`, off by default) a within-tool listwise term on the torque output
(`listwise_loss`) for the top-1 pick of each tool. The split is by tool (held-out tools); the optimiser
is our own AdamW (`optim.py`); minibatches are scanned inside one jitted epoch (the outer call), with
early stopping on the validation loss.
"""

from __future__ import annotations

import dataclasses
import time

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.errors import InputError, is_integer
from itup_jax.precision import full_precision
from itup_jax.sdgnet import mlp, objective
from itup_jax.sdgnet.config import CLASS_NAMES, CLASS_TARGETS, WEAK_TARGET, TrainConfig
from itup_jax.sdgnet.features import RESIDUAL_SCALES, RESIDUAL_SIZE, FeatureSpec
from itup_jax.sdgnet.model import Model, predict_costs, residual_base
from itup_jax.sdgnet.optim import AdamConfig, adam_init, adam_update


def training_loss(params, x, y, s, class_weights):
    """SDG-Net's training loss on a minibatch, mean over examples: the sum of squared errors of the first
    three outputs against the normalised targets y [B, 3] (the paper's loss), plus, for each binary head
    k, class_weights[k] x the binary cross-entropy of output 3 + k (a logit) against its labels s[:, k]
    in {0, 1}, or in [0, 1] when they are a teacher's probabilities (`teacher_targets`; the loss is then
    least where sigmoid(logit) = s); a NaN label (not measured for that row) adds nothing. x: [B, F]
    normalised features; s: [B, K]; class_weights: [K] (K = 0: no heads)."""
    pred = jax.vmap(mlp.apply, in_axes=(None, 0))(params, x)
    out = jnp.mean(jnp.sum((pred[:, : y.shape[1]] - y) ** 2, axis=1))
    if pred.shape[1] > y.shape[1]:  # static: the heads' logits; softplus(z) - s z = -log p(s | z)
        z = pred[:, y.shape[1]:]
        measured = ~jnp.isnan(s)
        ce = jnp.where(measured, jax.nn.softplus(z) - jnp.where(measured, s, 0.0) * z, 0.0)
        out = out + jnp.mean(jnp.sum(class_weights * ce, axis=1))
    return out


def listwise_loss(pred, target, temperature, mask=None):
    """Within-tool listwise loss of one group of grasps of one tool, mean over groups: the KL divergence
    KL(q || p) between the top-1 distributions q = softmax(-target / temperature) of the labels and
    p = softmax(-pred / temperature) of the predictions (ListNet's, on the negated scores: the lowest
    torque is the most probable top-1). pred, target: [T, G] normalised log torques of T groups of G
    grasps; mask: [T, G] bool, the grasps that count (default all; each group needs one). >= 0, and 0
    exactly when pred = target + a constant per group: it ranks and spaces one tool's grasps and ignores
    the offset between tools. A smaller temperature weighs the lowest grasps more."""
    if mask is None:
        mask = jnp.ones(pred.shape, bool)
    # padded entries are -inf before the softmax and 0 after it (never inf - inf: no NaN in the gradient)
    lq = jnp.where(mask, jax.nn.log_softmax(jnp.where(mask, -target / temperature, -jnp.inf), axis=-1), 0.0)
    lp = jnp.where(mask, jax.nn.log_softmax(jnp.where(mask, -pred / temperature, -jnp.inf), axis=-1), 0.0)
    return jnp.mean(jnp.sum(jnp.where(mask, jnp.exp(lq), 0.0) * (lq - lp), axis=-1))


def _tool_groups(names: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows grouped by tool: (order [N], the rows sorted by tool; starts [T], counts [T]: each tool's
    slice of `order`)."""
    order = np.argsort(names, kind="stable")
    _, starts, counts = np.unique(names[order], return_index=True, return_counts=True)
    return order, starts, counts


def _draw_groups(key, order, starts, counts, tools: int, group: int):
    """[tools, group] row indices: `tools` tools drawn uniformly, then `group` of each one's rows drawn with
    replacement (order, starts, counts: `_tool_groups`, as arrays). Pure; runs inside the jitted epoch."""
    kt, kg = jax.random.split(key)
    t = jax.random.randint(kt, (tools,), 0, len(counts))
    u = jax.random.uniform(kg, (tools, group))
    return order[starts[t][:, None] + jnp.floor(u * counts[t][:, None]).astype(starts.dtype)]


def _padded_groups(names: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every tool's rows as one padded group: (index [T, G_max] into the rows, mask [T, G_max])."""
    order, starts, counts = _tool_groups(names)
    g = int(counts.max()) if len(counts) else 1
    col = np.arange(g)
    mask = col[None, :] < counts[:, None]
    idx = np.where(mask, order[np.minimum(starts[:, None] + col[None, :], len(order) - 1)], 0)
    return idx, mask


def _tool_names(data: dict) -> np.ndarray:
    return np.array([f"{t}/{v}" for t, v in zip(data["task"], data["tool_id"])])


def _val_tools(data: dict, fraction: float, seed: int) -> set:
    """The held-out tools ("task/tool_id") of a split: `fraction` of the tools, drawn with `seed`."""
    names = np.unique(_tool_names(data))
    rng = np.random.default_rng(seed)
    n_val = max(1, int(round(fraction * len(names)))) if len(names) > 1 else 0
    return set(rng.choice(names, size=n_val, replace=False).tolist()) if n_val else set()


def _val_tools_per_task(data: dict, fraction: float, seed: int) -> set:
    """The held-out tools drawn task by task (`_val_tools` on each task's rows): every task with more
    than one tool holds at least one out."""
    task = np.asarray(data["task"])
    out: set = set()
    for kind in sorted(set(task.tolist())):
        rows = task == kind
        out |= _val_tools({"task": task[rows], "tool_id": np.asarray(data["tool_id"])[rows]}, fraction, seed)
    return out


def _split_by_tool(data: dict, fraction: float, seed: int, val_tools: set | None = None) -> tuple[np.ndarray, np.ndarray]:
    if val_tools is None:
        val_tools = _val_tools(data, fraction, seed)
    val = np.isin(_tool_names(data), list(val_tools))
    return ~val, val


def train(data: dict, config: TrainConfig = TrainConfig(), *, feature_spec: dict | None = None,
          progress: bool = True, log=print) -> Model:
    """Fit SDG-Net on a loaded dataset (valid rows only; see `dataset_load.load_dataset`).

    Default: one MLP shared by every task. With `config.finetune_epochs` > 0, then a copy of it
    fine-tuned on each task's rows (the same held-out tools and normalisation), stored as one network
    per task (`Model.for_task` picks it; scoring one task costs one network, as before). With
    `config.per_task`, one MLP per task trained from scratch, each with its own normalisation, split
    and early stopping."""
    if config.per_task:
        return _train_per_task(data, config, feature_spec=feature_spec, progress=progress, log=log)
    shared = _train_one(data, dataclasses.replace(config, finetune_epochs=0,
                                                  rank_weight=0.0 if config.finetune_epochs else config.rank_weight),
                        feature_spec=feature_spec, progress=progress, log=log)
    if not config.finetune_epochs:
        return shared
    return _train_per_task(data, config, feature_spec=feature_spec, progress=progress, log=log, init=shared)


def adapt(model: Model, data: dict, *, epochs: int, lr: float | None = None, seed: int = 0,
          patience: int | None = None, ema: float | None = None, feature_spec: dict | None = None,
          progress: bool = True, log=print) -> Model:
    """Continue training a trained model on new data (a new tool family, say): each of its networks (the
    shared one, or each task's) starts from its weights and keeps its normalisation and targets, trains
    `epochs` epochs at peak rate `lr` (default: its recipe's fine-tuning rate; `ema`: the weight average's
    decay, default its recipe's, `TrainConfig.ema`) on the data's rows of its
    task, and is kept as it was unless an epoch beats it on the data's held-out tools (drawn by `seed`,
    as in `train`). A per-task model's networks for tasks the data lacks are carried over unchanged.
    The recipe is the model's own (`Model.train_config`); `spec["adapted_from"]` records the start.

    Raises InputError for an ensemble (adapt its members), for data whose features were made with
    another `FeatureSpec`, and for data of a task the model has no network for."""
    if model.ensemble_size > 1:
        raise InputError(f"adapt: the model is an ensemble of {model.ensemble_size}; adapt its members and "
                         f"average them again (`ensemble`)")
    if not is_integer(epochs) or epochs < 1:
        raise InputError(f"adapt: epochs must be an integer >= 1, got {epochs!r}")
    if feature_spec is not None and model.spec.get("feature_spec") and feature_spec != model.spec["feature_spec"]:
        raise InputError(f"adapt: the data's features were made with {feature_spec}, the model's with "
                         f"{model.spec['feature_spec']}")
    kinds = sorted(set(np.asarray(data["task"]).tolist()))
    if model.tasks is not None and set(kinds) - set(model.tasks):
        raise InputError(f"adapt: the data holds {sorted(set(kinds) - set(model.tasks))}, for which the model "
                         f"has no network (it has {model.tasks})")
    recipe = model.train_config
    config = dataclasses.replace(recipe, seed=seed, per_task=False, rank_weight=0.0, finetune_epochs=epochs,
                                 finetune_lr=recipe.finetune_lr if lr is None else lr,
                                 patience=recipe.patience if patience is None else patience,
                                 ema=recipe.ema if ema is None else ema)
    fs = model.spec.get("feature_spec") if feature_spec is None else feature_spec
    if model.tasks is None:
        one = dataclasses.replace(config, epochs=epochs, lr=config.finetune_lr, finetune_epochs=0)
        out = _train_one(data, one, feature_spec=fs, progress=progress, log=log, init=model)
    else:
        out = _train_per_task(data, config, feature_spec=fs, progress=progress, log=log, init=model)
        params, by_task = list(out.params), dict(out.spec["by_task"])
        for kind in model.tasks:  # the tasks the data lacks keep their networks
            if kind not in by_task:
                old = model.spec["by_task"][kind]
                lo, hi = old["layers"]
                by_task[kind] = {**old, "layers": [len(params), len(params) + hi - lo]}
                params += list(model.params[lo:hi])
        out = Model(params=params, spec={**out.spec, "by_task": dict(sorted(by_task.items()))})
    out.spec["adapted_from"] = {"command": model.spec.get("command"), "datasets": model.spec.get("datasets"),
                                "best_val_loss": model.spec.get("best_val_loss"), "epochs": epochs,
                                "lr": config.finetune_lr, "seed": seed, "ema": config.ema}
    return out


def _design(data: dict, config: TrainConfig, feature_spec: dict | None = None
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Features X [N, F], targets Y [N, C] = log1p(y / scale), keep [N] bool: the rows a network is
    trained on (finite features and targets), and the residual base B [N, R] (`model.residual_base`) or
    None. For a residual spec (`FeatureSpec.residual`) Y's first R columns are the residuals Y - B."""
    X = np.asarray(data["features"], np.float64)
    missing = [t for t in config.targets if t not in data]
    if missing:
        raise InputError(f"train: the data has no {', '.join(missing)}, which the {config.objective!r} objective "
                         "regresses (labels older than that field; make the data again, or train "
                         f"--objective {'paper' if config.objective != 'paper' else 'wrench'})")
    Y = np.log1p(np.stack([np.asarray(data[t], np.float64) for t in config.targets], axis=1)
                 / np.array(config.target_scales))
    spec = FeatureSpec(**(feature_spec or {}))
    B = residual_base(X, spec)
    if B is not None:
        scales = tuple(float(v) for v in config.target_scales[:RESIDUAL_SIZE])
        if config.objective != "wrench" or not np.allclose(scales, RESIDUAL_SCALES):
            raise InputError(f"train: a residual feature spec predicts the wrench objective's torque and grip "
                             f"targets at scales {RESIDUAL_SCALES}; this recipe regresses the {config.objective!r} "
                             f"objective's at {scales} (train with --objective wrench and torque_scale "
                             f"{RESIDUAL_SCALES[0]})")
        Y = Y.copy()
        Y[:, :RESIDUAL_SIZE] -= B
    return X, Y, np.isfinite(X).all(1) & np.isfinite(Y).all(1), B


def _train_per_task(data: dict, config: TrainConfig, *, feature_spec: dict | None, progress: bool, log,
                    init: Model | None = None) -> Model:
    """One network per task: trained from scratch (`per_task`), fine-tuned from the shared `init` on
    the shared network's held-out tools (none of them leaks into a task's training rows), or, when
    `init` is a per-task model (`adapt`), each task's network fine-tuned on held-out tools drawn task by
    task, so that every task with more than one tool is judged on one."""
    task = np.asarray(data["task"])
    if init is None:
        one, val_tools = dataclasses.replace(config, per_task=False), None
    else:
        one = dataclasses.replace(config, epochs=config.finetune_epochs, lr=config.finetune_lr, finetune_epochs=0)
        keep = _design(data, config, feature_spec)[2]
        draw = _val_tools_per_task if init.tasks is not None else _val_tools
        val_tools = draw({"task": task[keep], "tool_id": np.asarray(data["tool_id"])[keep]},
                         config.val_fraction, config.seed)
    params, by_task = [], {}
    t0 = time.perf_counter()
    for kind in sorted(set(task.tolist())):
        rows = task == kind
        sub = {k: (np.asarray(v)[rows] if np.ndim(v) and len(v) == len(rows) else v) for k, v in data.items()}
        start = init.for_task(kind) if init is not None else None  # a per-task init: that task's network
        m = _train_one(sub, one, feature_spec=feature_spec, progress=progress,
                       log=lambda msg, kind=kind: log(f"{kind}: {msg}"), val_tools=val_tools, init=start)
        by_task[kind] = {"layers": [len(params), len(params) + len(m.params)],
                         **{k: m.spec[k] for k in ("x_mean", "x_std", "y_mean", "y_std", "best_epoch",
                                                   "best_val_loss", "n_train", "n_val", "history", "val_metrics")
                            if k in m.spec}}
        params += m.params
    n_val = sum(e["n_val"] for e in by_task.values())
    spec = {
        "feature_spec": feature_spec or {}, "objective": config.objective, "targets": list(config.targets),
        "cost_names": list(objective.get(config.objective).outputs),
        "target_scales": list(config.target_scales), "config": dataclasses.asdict(config), "by_task": by_task,
        **_head_spec(config),
        # the validation rows' mean loss over all tasks (each task's best epoch), comparable to a shared model's
        "best_val_loss": (sum(e["best_val_loss"] * e["n_val"] for e in by_task.values()) / n_val if n_val
                          else float("nan")),
        "n_train": sum(e["n_train"] for e in by_task.values()), "n_val": n_val,
        "train_seconds": time.perf_counter() - t0,
    }
    if init is not None and init.tasks is None:  # what the shared network reached before fine-tuning, and the total time
        spec["shared"] = {k: init.spec[k] for k in ("best_epoch", "best_val_loss", "val_metrics", "history",
                                                    "train_seconds", "n_train", "n_val")}
        spec["train_seconds"] += init.spec["train_seconds"]
    return Model(params=params, spec=spec)


def _train_one(data: dict, config: TrainConfig, *, feature_spec: dict | None, progress: bool, log,
               val_tools: set | None = None, init: Model | None = None) -> Model:
    """One MLP on `data`'s valid rows. `val_tools`: the held-out tools (default: drawn by `config`);
    `init`: start from this network and keep its normalisation (fine-tuning) instead of a fresh one."""
    X, Y, keep, B = _design(data, config, feature_spec)
    heads = config.class_weights
    missing = [t for t in heads if t not in data]
    if missing:
        hint = ("; made with `itup generate --weak-grip 0` or before label version 0.11.0: generate it again, or "
                "train a network without that head (`itup train --weak-failure-weight 0`; a checkpoint that has "
                "the head adapts only on data with weak-grip rollouts)" if WEAK_TARGET in missing else
                " (or train with their weights at 0: success_weight / failure_weight)")
        raise InputError(f"train: the binary heads need the {missing} labels, which the data lacks{hint}")
    S = (np.stack([head_labels(data, t)[keep] for t in heads], axis=1) if heads
         else np.zeros((int(keep.sum()), 0)))
    class_w = jnp.asarray(list(heads.values()), jnp.float32)
    X, Y = X[keep], Y[keep]
    B0 = np.zeros(len(X)) if B is None else B[keep][:, 0]  # the first output's residual base (listwise term)
    sub = {k: np.asarray(v)[keep] for k, v in data.items() if k in ("task", "tool_id")}
    if len(X) < 8:
        raise InputError(f"train: need at least 8 valid examples, got {len(X)}")
    tr, va = _split_by_tool(sub, config.val_fraction, config.seed, val_tools)
    if init is None:
        x_mean, x_std = X[tr].mean(0), X[tr].std(0)
        # a feature constant over the training rows (a tool-level prior when one tool is trained on) is
        # centred, not scaled: dividing by its ~0 spread would blow up every other tool's value of it
        x_std = np.where(x_std > 1e-6 * np.maximum(1.0, np.abs(x_mean)), x_std + 1e-8, 1.0)
        y_mean, y_std = Y[tr].mean(0), Y[tr].std(0) + 1e-8
    else:
        x_mean, x_std, y_mean, y_std = (np.asarray(init.spec[k], np.float64) for k in ("x_mean", "x_std", "y_mean", "y_std"))
    Xn, Yn = (X - x_mean) / x_std, (Y - y_mean) / y_std
    f32 = lambda a: jnp.asarray(a, jnp.float32)  # noqa: E731
    Xtr, Ytr, Str, Xva, Yva, Sva = f32(Xn[tr]), f32(Yn[tr]), f32(S[tr]), f32(Xn[va]), f32(Yn[va]), f32(S[va])
    # the listwise term ranks the first output itself: a residual network's normalised output plus its base
    Bn = B0 / y_std[0]
    Btr, Bva = f32(Bn[tr]), f32(Bn[va])
    n_tr = len(Xtr)
    batch = min(config.batch, n_tr)
    steps_per_epoch = max(1, n_tr // batch)
    key = jax.random.key(config.seed)
    key, k_init = jax.random.split(key)
    params = jax.tree_util.tree_map(f32, mlp.init(k_init, [X.shape[1], *config.hidden, len(config.targets) + len(heads)])
                                    if init is None else init.params)
    adam = AdamConfig(lr=config.lr, weight_decay=config.weight_decay, warmup_steps=min(100, 5 * steps_per_epoch),
                      total_steps=config.epochs * steps_per_epoch)
    opt = adam_init(params)

    rank = config.rank_weight > 0
    if rank:  # the within-tool term: training tools' rows by tool; each held-out tool as one whole group
        names = _tool_names(sub)
        g_order, g_start, g_count = (jnp.asarray(a) for a in _tool_groups(names[tr]))
        va_idx, va_mask = _padded_groups(names[va])
        Gva, Gva_mask = (Xva[va_idx], Yva[va_idx], Bva[va_idx]), jnp.asarray(va_mask)

    def loss_fn(p, x, y, s, group=None, mask=None):
        out = training_loss(p, x, y, s, class_w)
        if group is not None:  # group = (features [T, G, F], targets [T, G, C], bases [T, G]) of T tools' grasps
            pred = jax.vmap(jax.vmap(mlp.apply, in_axes=(None, 0)), in_axes=(None, 0))(p, group[0])
            out = out + config.rank_weight * listwise_loss(pred[..., 0] + group[2], group[1][..., 0] + group[2],
                                                           config.rank_temperature, mask)
        return out

    ema = float(config.ema)

    @jax.jit  # the outer call: one jitted epoch (shuffle, then scan over minibatches)
    @full_precision
    def epoch(p, s, pa, k):
        if rank:
            k, kr = jax.random.split(k)
        perm = jax.random.permutation(k, n_tr)[: steps_per_epoch * batch].reshape(steps_per_epoch, batch)
        group_keys = jax.random.split(kr, steps_per_epoch) if rank else jnp.zeros((steps_per_epoch,))

        def step(carry, xs):
            (p, s, pa), (idx, kg) = carry, xs
            group = None
            if rank:
                gi = _draw_groups(kg, g_order, g_start, g_count, config.rank_tools, config.rank_group)
                group = (Xtr[gi], Ytr[gi], Btr[gi])
            l, g = jax.value_and_grad(loss_fn)(p, Xtr[idx], Ytr[idx], Str[idx], group)
            p, s = adam_update(g, s, p, adam)
            # the weights validated and kept: their moving average (TrainConfig.ema), or the step's own
            pa = jax.tree_util.tree_map(lambda a, w: ema * a + (1.0 - ema) * w, pa, p) if ema > 0 else p
            return (p, s, pa), l

        (p, s, pa), losses = jax.lax.scan(step, (p, s, pa), (perm, group_keys))
        return p, s, pa, losses.mean()

    val_loss = jax.jit(full_precision(loss_fn))
    val_args = (Xva, Yva, Sva) + ((Gva, Gva_mask) if rank else ())
    best = (np.inf, params, 0)
    if init is not None:  # fine-tuning keeps the network it started from unless an epoch beats it
        best = (float(val_loss(params, *val_args)) if len(Xva) else np.inf, params, -1)
        if not len(Xva):
            log(f"no held-out tool among the data's {len(np.unique(_tool_names(sub)))} tool(s): the epochs are "
                f"judged on their training loss, and the last best of them replaces the start")
    history = []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=config.epochs, desc="train", unit="epoch", dynamic_ncols=True)
    t0 = time.perf_counter()
    averaged = params  # the weights validated and kept: the last step's, or their average (config.ema)
    for e in range(config.epochs):
        key, k = jax.random.split(key)
        params, opt, averaged, tl = epoch(params, opt, averaged, k)
        vl = float(val_loss(averaged, *val_args)) if len(Xva) else float(tl)
        history.append((float(tl), vl))
        if vl < best[0]:
            best = (vl, averaged, e)
        if bar is not None:
            bar.set_postfix(train=f"{float(tl):.3f}", val=f"{vl:.3f}")
            bar.update(1)
        if e - best[2] >= config.patience:
            break
    if bar is not None:
        bar.close()
    wall = time.perf_counter() - t0
    val_metrics = _validation_metrics(best[1], Xva, Yva, S[va], list(heads), objective.get(config.objective).outputs)
    log(f"train: {len(history)} epochs in {wall:.1f} s, best val loss {best[0]:.4f} at epoch {best[2]} "
        f"({int(tr.sum())} train / {int(va.sum())} validation examples, held-out tools)"
        + ("; validation " + ", ".join(f"{k} {v:.3f}" for k, v in val_metrics.items()) if val_metrics else ""))
    spec = {
        "feature_spec": feature_spec or {}, "objective": config.objective, "targets": list(config.targets),
        "cost_names": list(objective.get(config.objective).outputs),
        "target_scales": list(config.target_scales), **_head_spec(config),
        "x_mean": x_mean.tolist(), "x_std": x_std.tolist(), "y_mean": y_mean.tolist(), "y_std": y_std.tolist(),
        "config": dataclasses.asdict(config), "best_epoch": best[2], "best_val_loss": best[0],
        "history": history, "train_seconds": wall, "n_train": int(tr.sum()), "n_val": int(va.sum()),
        "val_metrics": val_metrics,
    }
    return Model(params=[(np.asarray(W), np.asarray(b)) for W, b in best[1]], spec=spec)


def head_labels(data: dict, label: str) -> np.ndarray:
    """[N] float64 labels of binary head `label` (`CLASS_TARGETS`) in `data`: 0/1 (or a teacher's
    probabilities), NaN where the label was not measured (the weak-grip head on a row whose weak-grip
    rollout is not valid), which the loss skips."""
    v = np.asarray(data[label], np.float64)
    if label == WEAK_TARGET and "label_weak_valid" in data:
        v = np.where(np.asarray(data["label_weak_valid"], bool), v, np.nan)
    return v


def _validation_metrics(params, Xva, Yva, s_va: np.ndarray, heads: list, names: tuple) -> dict:
    """The best network on the held-out-tool rows: each target's mean squared error on the normalised
    scale (`mse_tau`, ...; 1.0 = predicting the training mean) and each binary head's AUC (`auc_success`,
    `auc_failed`, `auc_weak_failed`, on the rows where that label was measured; NaN when one class is
    missing)."""
    if len(Xva) == 0:
        return {}
    from itup_jax.stats import roc_auc

    pred = np.asarray(jax.vmap(mlp.apply, in_axes=(None, 0))(params, Xva), float)
    err = ((pred[:, : len(names)] - np.asarray(Yva, float)) ** 2).mean(0)
    out = {f"mse_{name}": float(e) for name, e in zip(names, err)}
    for k, label in enumerate(heads):
        m = ~np.isnan(s_va[:, k])
        out[f"auc_{label.removeprefix('label_')}"] = roc_auc(pred[m, len(names) + k], s_va[m, k] > 0.5)
    return out


def _head_spec(config: TrainConfig) -> dict:
    return {"class_heads": list(config.class_weights)}


def teacher_targets(data: dict, teacher: Model, outputs: tuple[str, ...] | None = None) -> dict:
    """A copy of `data` (as from `dataset_load.load_datasets`) whose regression targets (the teacher objective's, SI units) and
    binary labels (`CLASS_TARGETS` the teacher has a head for) are `teacher`'s predictions for each row,
    by task: the targets to distil a model (typically an `ensemble`, M times slower to score) into one
    network that scores at one network's cost (`itup train --teacher E.npz`). The probabilities are
    soft labels of the cross-entropy (`training_loss`); the features and every other column are `data`'s
    own (not copied). The rows' features must be of the teacher's `FeatureSpec` (the caller checks the
    datasets' manifests).

    outputs: only these of `Model.output_names` + `CLASS_NAMES` (e.g. ("tau", "align")) are the teacher's, the
    rest stay the labels: adapting a checkpoint to a changed label while holding its other outputs
    where they were (`itup train --init M.npz --keep tau,align,p_success`). None: all of them."""
    names = tuple(teacher.output_names)
    known = names + CLASS_NAMES
    if outputs is not None and (not outputs or set(outputs) - set(known)):
        raise InputError(f"teacher_targets: outputs must be some of {', '.join(known)}, got {list(outputs)}")
    tasks = np.asarray(data["task"])
    X = np.asarray(data["features"])
    n_in = np.shape(teacher.params[0][0])[-2]  # every network of a model takes the same features
    if X.ndim != 2 or X.shape[1] != n_in:
        raise InputError(f"teacher_targets: the rows have {X.shape[-1]} features, the teacher's networks take {n_in}")
    out = dict(data)
    heads = [(CLASS_NAMES[CLASS_TARGETS.index(h)], h) for h in teacher.class_heads]
    pairs = [(name, key) for name, key in list(zip(names, objective.get(teacher.objective).targets)) + heads
             if outputs is None or name in outputs]
    missing = [] if outputs is None else sorted(set(outputs) - {name for name, _ in pairs})
    if missing:
        raise InputError(f"teacher_targets: the teacher has no {', '.join(missing)} head (its heads: "
                         f"{', '.join(names + tuple(teacher.head_names))})")
    cols = {key: np.full(len(tasks), np.nan) for _, key in pairs}
    for kind in np.unique(tasks):
        rows = tasks == kind
        p = predict_costs(teacher, X[rows], str(kind))  # InputError when a per-task teacher lacks the task
        for name, key in pairs:
            cols[key][rows] = np.asarray(p[name], np.float64)
    out.update(cols)
    return out

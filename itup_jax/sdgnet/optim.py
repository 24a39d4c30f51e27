"""Our own Adam (no optax): Adam with decoupled weight decay (AdamW) and a warm-up + cosine schedule.

Pure functions over pytrees: `state = adam_init(params)`, `params, state = adam_update(grads, state,
params, config)`. The step counter lives in the state (an array), so an update is jit-able as is.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp


@dataclasses.dataclass(frozen=True)
class AdamConfig:
    """lr: peak learning rate; b1, b2, eps: Adam's; weight_decay: decoupled (AdamW), per step x lr;
    warmup_steps, total_steps: linear warm-up to lr, then cosine decay to lr * final_fraction."""

    lr: float = 1e-3
    b1: float = 0.9
    b2: float = 0.999
    eps: float = 1e-8
    weight_decay: float = 1e-4
    warmup_steps: int = 100
    total_steps: int = 10_000
    final_fraction: float = 0.05


class AdamState(NamedTuple):
    step: jax.Array  # [] int32, updates done so far
    mu: Any  # first moments, like params
    nu: Any  # second moments, like params


def adam_init(params: Any) -> AdamState:
    zeros = jax.tree_util.tree_map(jnp.zeros_like, params)
    return AdamState(step=jnp.zeros((), jnp.int32), mu=zeros, nu=jax.tree_util.tree_map(jnp.zeros_like, params))


def learning_rate(step: jax.Array, config: AdamConfig) -> jax.Array:
    """Learning rate at (0-based) `step`: linear warm-up, then cosine to lr * final_fraction."""
    s = jnp.asarray(step, jnp.float32 if not jax.config.jax_enable_x64 else jnp.float64)
    warm = config.lr * (s + 1) / max(config.warmup_steps, 1)
    span = max(config.total_steps - config.warmup_steps, 1)
    frac = jnp.clip((s - config.warmup_steps) / span, 0.0, 1.0)
    cos = config.final_fraction + (1 - config.final_fraction) * 0.5 * (1 + jnp.cos(jnp.pi * frac))
    return jnp.where(s < config.warmup_steps, warm, config.lr * cos)


def adam_update(grads: Any, state: AdamState, params: Any, config: AdamConfig) -> tuple[Any, AdamState]:
    """One AdamW step: bias-corrected moments, then p <- p - lr (m_hat / (sqrt(v_hat) + eps) + wd p)."""
    t = state.step + 1
    mu = jax.tree_util.tree_map(lambda m, g: config.b1 * m + (1 - config.b1) * g, state.mu, grads)
    nu = jax.tree_util.tree_map(lambda v, g: config.b2 * v + (1 - config.b2) * g * g, state.nu, grads)
    lr = learning_rate(state.step, config)
    c1 = 1 - config.b1 ** t.astype(lr.dtype)
    c2 = 1 - config.b2 ** t.astype(lr.dtype)
    new = jax.tree_util.tree_map(  # each parameter keeps its dtype (float32 nets under jax_enable_x64)
        lambda p, m, v: (p - lr * ((m / c1) / (jnp.sqrt(v / c2) + config.eps) + config.weight_decay * p)).astype(p.dtype),
        params, mu, nu)
    return new, AdamState(step=t, mu=mu, nu=nu)

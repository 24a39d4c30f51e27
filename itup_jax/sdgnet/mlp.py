"""SDG-Net's network: a hand-written MLP (no flax), parameters a list of (W, b) pairs.

Applied to ONE example; batch with `jax.vmap(apply, in_axes=(None, 0))`. No jit here: the training
step and the scorer jit at their outer calls.
"""

from __future__ import annotations

from collections.abc import Sequence

import jax
import jax.numpy as jnp

Params = list  # [(W [n_in, n_out], b [n_out]), ...]


def init(key: jax.Array, sizes: Sequence[int]) -> Params:
    """He-normal weights (for ReLU-family hidden layers), zero biases. `sizes` = [n_in, h1, ..., n_out]."""
    if len(sizes) < 2 or any(int(s) < 1 for s in sizes):
        raise ValueError(f"mlp.init: sizes must be >= 2 positive layer widths, got {list(sizes)}")
    params = []
    for n_in, n_out in zip(sizes[:-1], sizes[1:]):
        key, sub = jax.random.split(key)
        W = jax.random.normal(sub, (n_in, n_out)) * jnp.sqrt(2.0 / n_in)
        params.append((W, jnp.zeros(n_out)))
    return params


def apply(params: Params, x: jax.Array) -> jax.Array:
    """[n_in] -> [n_out]: affine layers with SiLU between them, linear output."""
    h = x
    for W, b in params[:-1]:
        h = jax.nn.silu(h @ W + b)
    W, b = params[-1]
    return h @ W + b


def num_params(params: Params) -> int:
    return sum(int(W.size + b.size) for W, b in params)

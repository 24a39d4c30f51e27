"""Cholesky factorisation and solves in plain JAX, for MJX on a CPU, where jaxlib's LAPACK kernels deadlock.

MJX factors its mass matrix (`smooth.factor_m`) and the Newton solver's Hessian (`solver._update_gradient`)
with `jax.scipy.linalg.cho_factor` and solves with `cho_solve`. On a CPU these lower to jaxlib's LAPACK
custom calls (`lapack_dpotrf_ffi` in float64, `spotrf` in float32). In jaxlib 0.10.2 such a kernel splits
its batch into parts, queues them on XLA's intra-op thread pool (one thread per core) and blocks until
they are done. When as many of these kernels run at once as the pool has threads, every thread blocks
waiting for parts queued behind the others, and the program never returns: all threads idle, the caller
in `block_until_ready`. On this 2-core CPU that is what happened to the knock's MJX rollout at a batch of
16 in every run (gdb: both pool threads in `BlockingCounter::Wait` under
`jax::ParallelBatchMap` in `CholeskyFactorization`), and to the hammer's at 128. Neither
`--xla_cpu_multi_thread_eigen=false`, nor `jax_cpu_enable_async_dispatch=False`, nor turning XNNPACK off
avoids it (tried).

The functions here do the same arithmetic as LAPACK's unblocked Cholesky (column by column, left-looking)
with JAX's own operations, which XLA compiles into the program: no custom call, nothing that blocks.
`jax_cholesky()` puts them in place of `jax.scipy.linalg.cho_factor` and `cho_solve` for the duration of
a `with` block; `sim.mjx.rollout_mjx` traces its program on a CPU inside one. A program traced inside the
block keeps them; code traced elsewhere is not affected. On a GPU MJX keeps jaxlib's (cuSOLVER) kernels.
The matrices are small (the scenes' nv is 20-26), so the loop over columns costs little
(`itup bench rollout`, docs/benchmarks.md).

Conventions are `jax.scipy.linalg`'s: `cho_factor(a, lower=False)` returns (c, lower) with a = c^T c
(upper) or c c^T (lower), and the other triangle of c zero; `cho_solve((c, lower), b)` reads only c's
`lower` (or upper) triangle. Leading batch dimensions are allowed. Traceable, no jit (jit at the outer call).
"""

from __future__ import annotations

import contextlib

import jax
import jax.numpy as jnp


def cholesky_lower(a: jax.Array) -> jax.Array:
    """The lower Cholesky factor L of symmetric positive-definite `a` (a = L L^T), from its lower triangle.
    Shapes: a [..., n, n] -> L [..., n, n], zero above the diagonal. A matrix that is not positive
    definite gives NaN, as LAPACK's kernel does in JAX."""
    n = a.shape[-1]
    idx = jnp.arange(n)

    def column(j, low):
        # left-looking: v = a[:, j] - L[:, :j] L[j, :j]^T; the columns >= j of `low` are still zero
        v = a[..., :, j] - jnp.einsum("...ik,...k->...i", low, low[..., j, :])
        d = jnp.sqrt(v[..., j])
        col = jnp.where(idx > j, v / d[..., None], jnp.where(idx == j, d[..., None], 0.0))
        return low.at[..., :, j].set(col)

    return jax.lax.fori_loop(0, n, column, jnp.zeros_like(a))


def solve_lower(low: jax.Array, b: jax.Array, transpose: bool = False) -> jax.Array:
    """x with L x = b (or L^T x = b when `transpose`), L lower triangular [..., n, n] (only its lower
    triangle is read); b [..., n] or [..., n, k], the same leading dimensions as L."""
    n = low.shape[-1]
    vec = b.ndim == low.ndim - 1
    rhs = b[..., None] if vec else b
    mat = jnp.tril(low)
    if transpose:
        mat = jnp.swapaxes(mat, -1, -2)  # upper: back substitution, last row first
    order = jnp.arange(n - 1, -1, -1) if transpose else jnp.arange(n)

    def row(k, x):
        i = order[k]
        # x is zero in the rows not solved yet, so row i of mat meets only the solved ones off its diagonal
        r = mat[..., i, :]
        xi = (rhs[..., i, :] - jnp.einsum("...j,...jk->...k", r, x)) / r[..., i, None]
        return x.at[..., i, :].set(xi)

    x = jax.lax.fori_loop(0, n, row, jnp.zeros_like(rhs))
    return x[..., 0] if vec else x


def cho_factor(a, lower: bool = False, overwrite_a: bool = False, check_finite: bool = True):
    """`jax.scipy.linalg.cho_factor` in plain JAX: (c, lower) with a = c c^T (lower) or c^T c (upper).
    `overwrite_a` and `check_finite` are accepted and ignored, as JAX's are."""
    del overwrite_a, check_finite
    a = jnp.asarray(a)
    low = cholesky_lower(a)
    return (low if lower else jnp.swapaxes(low, -1, -2)), lower


def cho_solve(c_and_lower, b, overwrite_b: bool = False, check_finite: bool = True):
    """`jax.scipy.linalg.cho_solve` in plain JAX: x with a x = b, for (c, lower) from a `cho_factor`."""
    del overwrite_b, check_finite
    c, lower = c_and_lower
    c, b = jnp.asarray(c), jnp.asarray(b)
    low = c if lower else jnp.swapaxes(c, -1, -2)  # solve_lower reads only the lower triangle
    return solve_lower(low, solve_lower(low, b), transpose=True)


@contextlib.contextmanager
def jax_cholesky():
    """Within the block, `jax.scipy.linalg.cho_factor` and `cho_solve` are this module's (module
    docstring). Not thread-safe: it swaps two attributes of `jax.scipy.linalg` and restores them on exit."""
    mod = jax.scipy.linalg
    old = mod.cho_factor, mod.cho_solve
    mod.cho_factor, mod.cho_solve = cho_factor, cho_solve
    try:
        yield
    finally:
        mod.cho_factor, mod.cho_solve = old

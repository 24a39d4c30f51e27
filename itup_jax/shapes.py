"""Shape buckets: array sizes rounded up so that a jitted kernel compiles once per bucket, not per tool.

Every procedural tool has its own mesh, so its surface sample and its tabulated density field have
their own sizes. A jitted kernel traced on those sizes compiles again for every tool, and XLA keeps
each executable: `itup generate` compiled three kernels for every shard and its process kept growing
(6.6 GB resident after 280 shards of a 512-shard run, docs/benchmarks.md "Dataset generation").
Padding a size up to a bucket with values that cannot change the kernel's result (a repeated point
under any / min / max, zeros under `map_coordinates`' zero `cval`) bounds the compiles to a few per
octave of size, and leaves every result bit for bit as it was.

The candidates' count is the other size that varies from call to call (the pipeline scores the 16 to
~130 grasps a table leaves, a notebook whatever it sampled): the per-candidate kernels (SDG-Net's
scores, the wrench costs, the out-of-distribution guard's distances) compiled once per count, ~2.5 s
and ~200 memory maps each on a 2-core CPU, until a process that planned a few hundred tables ran out of
the kernel's 65,530 maps (`vm.max_map_count`: "LLVM ERROR: Unable to allocate section memory").
`pad_batch` rounds the count up to a bucket (CANDIDATE_BUCKET_BITS) by repeating the first candidate on
the host, `unpad_batch` cuts the per-candidate results back; each candidate's result is its own row,
so the padding changes no result.

`to_device` keeps another compile away: `jnp.asarray` of a NumPy float32 array compiles a copy kernel
per shape (JAX's "stage"), ~5 ms each in a fresh process; a host array put on the device as it is
costs none.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.errors import InputError, is_integer


def bucket(n: int, bits: int) -> int:
    """The least size >= n with at most `bits` significant binary digits: n itself for n < 2**bits,
    else ceil(n / 2**s) * 2**s with s = bit_length(n) - bits. At most 2**(1 - bits) larger than n, and
    2**(bits - 1) buckets per octave (bits = 3: <= 25 % larger, 4 per octave)."""
    if not (is_integer(n) and n >= 0):
        raise InputError(f"bucket: n must be an integer >= 0, got {n!r}")
    if not (is_integer(bits) and bits >= 1):
        raise InputError(f"bucket: bits must be an integer >= 1, got {bits!r}")
    shift = max(int(n).bit_length() - bits, 0)
    return ((int(n) + (1 << shift) - 1) >> shift) << shift


def pad_rows_repeating(a: np.ndarray, bits: int) -> np.ndarray:
    """[bucket(S), ...]: the rows of a [S, ...] (S >= 1) followed by copies of its first row. Neutral
    for reductions over the rows that a repeated row cannot change (any, all, min, max)."""
    a = np.asarray(a)
    if a.ndim < 1 or len(a) == 0:
        raise InputError(f"pad_rows_repeating: need at least one row, got shape {a.shape}")
    extra = bucket(len(a), bits) - len(a)
    return np.concatenate([a, np.repeat(a[:1], extra, axis=0)]) if extra else a


def pad_zeros_high(a: np.ndarray, bits: int) -> np.ndarray:
    """a [n_0, n_1, ...] zero-padded at the high end of every axis to [bucket(n_0), bucket(n_1), ...]."""
    a = np.asarray(a)
    return np.pad(a, [(0, bucket(n, bits) - n) for n in a.shape])


#: Significant bits of a padded candidate count (`pad_batch`): at most 25 % more rows, four buckets per
#: octave.
CANDIDATE_BUCKET_BITS = 3


def pad_batch(batch, bits: int = CANDIDATE_BUCKET_BITS):
    """(`batch` padded to bucket(N) rows, N) for a batch of N >= 1 candidates (a pytree whose leaves are
    [N, ...] arrays, with len(): `Grasps`): its first row repeated on the host and the rows put on the
    device (`to_device`), so that a kernel compiles once per bucket. Returned unchanged when N is already
    a bucket or a leaf is traced (inside jit)."""
    n = len(batch)
    extra = bucket(n, bits) - n if n else 0
    leaves = jax.tree_util.tree_leaves(batch)
    if not extra or any(isinstance(a, jax.core.Tracer) for a in leaves):
        return batch, n
    idx = np.concatenate([np.arange(n), np.zeros(extra, np.int64)])
    return jax.tree_util.tree_map(lambda a: to_device(np.asarray(a)[idx]), batch), n


def unpad_batch(out, n: int):
    """`out` (a pytree of per-candidate results, each [bucket(n), ...] or already [n, ...]) cut back to its
    first n rows: host copies put on the device (`to_device`: no slice kernel compiled per size)."""
    def cut(a):
        return a if np.shape(a)[0] == n else to_device(np.asarray(a)[:n])
    return jax.tree_util.tree_map(cut, out)


def to_device(a, dtype=None) -> jax.Array:
    """`jnp.asarray(a, dtype)` for host data (NumPy arrays, Python numbers and lists) without a compile:
    converted to JAX's canonical dtype on the host (float64 -> float32 unless x64 is on), copied, and
    put on the default device. Values bit for bit those of `jnp.asarray`. A JAX array (or a tracer)
    goes through `jnp.asarray` unchanged."""
    if isinstance(a, jax.Array):
        return jnp.asarray(a, dtype)
    x = np.asarray(a) if dtype is None else np.asarray(a, dtype=dtype)
    return jax.device_put(np.array(x, dtype=jax.dtypes.canonicalize_dtype(x.dtype), copy=True))

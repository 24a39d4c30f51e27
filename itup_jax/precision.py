"""Float32 matrix products on every backend.

JAX's default precision for a float32 `dot` is the fastest the hardware offers: true float32 on a CPU,
TensorFloat32 (10-bit mantissa) on recent NVIDIA GPUs, bfloat16 passes on a TPU. For physics that is not
rounding: on an H100 the analytic costs of 100,000 grasps differed from the float64 NumPy reference by up
to 1.2e-2 relative under the default, and by 7.6e-6 under "highest", in the same time (0.90 ms;
docs/benchmarks.md, "GPU"). So every outer jit of this package (costs, features, scoring, SDG-Net prediction
and training, the MJX rollout) traces its body under `full_precision`, and its products are float32
wherever it runs. On a CPU nothing changes.
"""

from __future__ import annotations

import functools

import jax

#: The matmul precision of the package's jitted functions ("highest": float32 products).
MATMUL_PRECISION = "highest"


def full_precision(fn):
    """`fn` traced with float32 matrix products (`jax.default_matmul_precision("highest")`).

    The setting is read when `jax.jit` traces the body, so wrap the function that is jitted:
    `jax.jit(full_precision(f))`. Keeps `fn`'s signature (for `static_argnames`).
    """
    @functools.wraps(fn)
    def wrapped(*args, **kwargs):
        with jax.default_matmul_precision(MATMUL_PRECISION):
            return fn(*args, **kwargs)

    return wrapped

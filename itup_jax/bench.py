"""Benchmarks (`itup bench ...`). Each prints the machine, the sizes, compile time apart from
steady-state time, and a ratio to a reference measured in the same run.
"""

from __future__ import annotations

import os
import platform
import statistics
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.costs import CostParams, wrench_costs_jit
from itup_jax.grasp import Grasps
from itup_jax.numpy_reference import numpy_wrench_costs, to_numpy_inputs
from itup_jax.task import DEFAULT_TOOL, make_task
from itup_jax.tool import load_tool


def machine_info() -> dict[str, Any]:
    """What the numbers were measured on."""
    cpu = platform.processor() or ""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    dev = jax.devices()[0]
    return {
        "platform": platform.platform(),
        "cpu": cpu,
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "jax": jax.__version__,
        "numpy": np.__version__,
        "jax_backend": jax.default_backend(),
        "device": getattr(dev, "device_kind", str(dev)),
        "x64": bool(jax.config.jax_enable_x64),
    }


def random_grasps(tool, n: int, seed: int = 0) -> Grasps:
    """n grasps with positions uniform in the grasp region, uniform rotations and widths in the stroke.

    Valid poses for timing (the cost code has no data-dependent branches); not antipodal grasps.
    """
    rng = np.random.default_rng(seed)
    lo, hi = tool.grasp_region.lo, tool.grasp_region.hi
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return Grasps(p_tool_grasp=jnp.asarray(lo + rng.random((n, 3)) * (hi - lo)), q_tool_grasp=jnp.asarray(q),
                  width=jnp.asarray(rng.random(n) * 0.08))


def _timed(fn, repeats: int) -> list[float]:
    out = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return out


def bench_costs(n: int = 100_000, t: int = 64, repeats: int = 10, numpy_repeats: int = 3,
                task_kind: str = "hammer") -> dict[str, Any]:
    """Time `wrench_costs` (one jit: loads + vmapped per-grasp costs) against plain NumPy."""
    tool = load_tool(DEFAULT_TOOL[task_kind])
    task = make_task(task_kind, tool, steps=t)
    grasps = random_grasps(tool, n)
    params = CostParams()
    args = (tool.params, task, grasps, params)

    t0 = time.perf_counter()
    compiled = wrench_costs_jit.lower(*args).compile()
    compile_s = time.perf_counter() - t0
    run = lambda: jax.block_until_ready(compiled(*args))  # noqa: E731
    run()  # first execution (allocations) is not steady state
    warm = _timed(run, repeats)

    np_tool, np_task, np_grasps = to_numpy_inputs(*args[:3])
    np_run = lambda: numpy_wrench_costs(np_tool, np_task, np_grasps)  # noqa: E731
    ref = np_run()
    numpy_times = _timed(np_run, numpy_repeats)
    out = run()
    rel_err = float(np.max(np.abs(np.asarray(out.total) - ref["total"]) / (np.abs(ref["total"]) + 1e-6)))

    warm_ms = 1e3 * statistics.median(warm)
    numpy_ms = 1e3 * statistics.median(numpy_times)
    return {
        "benchmark": "costs",
        "task": task_kind,
        "n": n,
        "t": t,
        "contacts": task.num_contacts,
        "dtype": str(np.asarray(grasps.p_tool_grasp).dtype),
        "compile_s": round(compile_s, 3),
        "warm_ms": round(warm_ms, 3),
        "warm_ms_min": round(1e3 * min(warm), 3),
        "repeats": repeats,
        "numpy_ms": round(numpy_ms, 3),
        "numpy_repeats": numpy_repeats,
        "speedup_vs_numpy": round(numpy_ms / warm_ms, 2),
        "grasp_steps_per_s": round(n * t / (warm_ms / 1e3)),
        "max_rel_diff_vs_numpy": rel_err,
        "target_warm_ms": 200.0,
        "machine": machine_info(),
    }

"""Benchmarks (`itup bench ...`). Each prints the machine, the sizes, compile time apart from
steady-state time, and a ratio to a reference measured in the same run.
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax import robot
from itup_jax.costs import CostParams, wrench_costs_jit
from itup_jax.grasp import Grasps
from itup_jax.numpy_reference import numpy_wrench_costs, to_numpy_inputs
from itup_jax.precision import full_precision
from itup_jax.task import DEFAULT_TOOL, make_task
from itup_jax.tools import load_tool


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


def _progress(msg: str) -> None:
    """A long benchmark's stages, on stderr (stdout carries the one JSON object of --json)."""
    print(f"[bench] {msg}", file=sys.stderr, flush=True)


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


def bench_rollout(n: int = 64, threads: tuple = (1, 2), mjx_batches: tuple = (1, 16, 64), mjx_steps: int = 50,
                  repeats: int = 9, seed: int = 0) -> dict[str, Any]:
    """Hammer scene: raw `mujoco.rollout` stepping vs full label generation (`simulate`), and MJX.

    raw: only `mujoco.rollout` on prepared models, states and controls. labels: `simulate` end to end
    (IK planning, per-rollout models, rollout, labels), with the scene prebuilt and the grasps given.
    MJX: `rollout_mjx`'s jitted vmap(scan(step)) on the first `mjx_steps` steps, compile timed apart, in
    the float type it rolls out in (`sim.mjx.MJX_FLOAT64`; each row's `dtype`).
    """
    import mujoco
    from mujoco import rollout as mj_rollout

    from itup_jax.grasp_sampler import sample_grasps
    from itup_jax.sim.arm import plan, reachable
    from itup_jax.sim.mjx import MJX_CPU_MAX_BATCH, mjx_rollout_fn
    from itup_jax.sim.native import initial_states
    from itup_jax.sim.physics import mjx_model_fields, randomized_model, sample_physics, slice_physics
    from itup_jax.sim.rollout import simulate
    from itup_jax.sim.scene import build_scene

    tool = load_tool("hammer")
    task = make_task("hammer", tool)
    scene = build_scene(tool, task)
    grasps = sample_grasps(tool, 4 * n, seed=seed)
    feasible = np.nonzero(reachable(task, grasps))[0][:n]
    grasps = grasps[feasible]
    n = len(feasible)
    physics = sample_physics(tool, n, seed)
    p = plan(scene, task, grasps, physics)
    models = [randomized_model(scene, physics, i) for i in range(n)]
    state0 = initial_states(scene.model, p.qpos0)
    env_steps = n * p.nstep
    out: dict[str, Any] = {"benchmark": "rollout", "scene": "hammer", "n_rollouts": n, "nstep": p.nstep,
                           "timestep_s": scene.model.opt.timestep, "nq": scene.model.nq, "nv": scene.model.nv,
                           "npair": scene.model.npair}
    for nt in threads:
        datas = [mujoco.MjData(scene.model) for _ in range(nt)]
        # interleaved pairs: this machine's speed drifts by tens of percent between seconds, so the
        # ratio is the median of per-pair ratios, each pair timed back to back
        raw, full = [], []
        for _ in range(repeats):
            raw += _timed(lambda: mj_rollout.rollout(models, datas, state0, p.ctrl, nstep=p.nstep), 1)
            full += _timed(lambda: simulate(tool, task, grasps, scene=scene, seed=seed, nthread=nt,
                                              backend="native"), 1)
        out[f"raw_steps_per_s_threads{nt}"] = round(env_steps / statistics.median(raw))
        out[f"label_steps_per_s_threads{nt}"] = round(env_steps / statistics.median(full))
        out[f"label_over_raw_threads{nt}"] = round(statistics.median(r / f for r, f in zip(raw, full)), 3)
        _progress(f"native, {nt} threads: raw {out[f'raw_steps_per_s_threads{nt}']} env-steps/s")
    out["mjx"] = []
    for b in mjx_batches:
        if jax.default_backend() == "cpu" and b > MJX_CPU_MAX_BATCH:
            continue
        idx = np.arange(b) % n  # an index array: _slice_physics and the plan arrays take it alike
        fn = mjx_rollout_fn(scene)
        dt = fn.dtype
        fields = mjx_model_fields(scene, slice_physics(physics, idx))
        args = tuple(a.astype(dt) for a in fields) + (p.qpos0[idx].astype(dt), p.ctrl[idx, :mjx_steps].astype(dt))
        t0 = time.perf_counter()
        jax.block_until_ready(fn(*args))
        first = time.perf_counter() - t0
        warm = min(_timed(lambda: jax.block_until_ready(fn(*args)), max(1, repeats - 1)))
        out["mjx"].append({"batch": b, "steps": mjx_steps, "dtype": str(np.dtype(dt)), "compile_s": round(first - warm, 2),
                           "steps_per_s": round(b * mjx_steps / warm, 1)})
        _progress(f"mjx batch {b}: compile {out['mjx'][-1]['compile_s']} s, {out['mjx'][-1]['steps_per_s']} env-steps/s")
    for nt in sorted({1, max(threads)} & set(threads)):  # the MJX rows against 1 thread and all threads timed
        for row in out["mjx"]:
            row[f"native_threads{nt}_over_mjx"] = round(out[f"raw_steps_per_s_threads{nt}"] / row["steps_per_s"], 2)
    out["repeats"] = repeats
    out["target_label_over_raw"] = 0.9
    out["machine"] = machine_info()
    return out


def _flops(compiled) -> float | None:
    """XLA's own flop count of a compiled computation (None if the backend does not say)."""
    try:
        ca = compiled.cost_analysis()
    except Exception:  # noqa: BLE001 - some backends have no cost model
        return None
    if isinstance(ca, (list, tuple)):
        ca = ca[0] if ca else None
    if not ca or "flops" not in ca:
        return None
    return float(ca["flops"])


def matmul_rate(size: int = 2048, repeats: int = 5, dtype=jnp.float32) -> dict[str, Any]:
    """The reference of the same run: a large `jnp.dot` (2 size^3 flops), jitted, median of `repeats`."""
    key = jax.random.PRNGKey(0)
    a = jax.random.normal(key, (size, size), dtype)
    b = jax.random.normal(jax.random.fold_in(key, 1), (size, size), dtype)
    f = jax.jit(full_precision(jnp.dot)).lower(a, b).compile()  # the scorer's precision (precision.py)
    jax.block_until_ready(f(a, b))
    t = statistics.median(_timed(lambda: jax.block_until_ready(f(a, b)), repeats))
    return {"size": size, "ms": round(1e3 * t, 3), "flops_per_s": 2.0 * size**3 / t}


def bench_score(n: int = 10_000, repeats: int = 20, task_kind: str = "hammer", model: Any = None) -> dict[str, Any]:
    """Time SDG-Net scoring (`scoring.sdgnet_scores_jit`: loads + features + MLP, one jit) of n candidates.
    `model`: a `Model`, a checkpoint path, or None (the shipped checkpoint).

    Reports XLA's flop count of the compiled scorer divided by the warm time (`flops_per_s`), a large
    `jnp.dot` in the same run (`matmul_flops_per_s`, what this device does at best), and the analytic
    cost path on the same candidates as a second reference.
    """
    from itup_jax import scoring
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.model import Model

    tool = load_tool(DEFAULT_TOOL[task_kind])
    task = make_task(task_kind, tool)
    grasps = random_grasps(tool, n)
    m = model if isinstance(model, Model) else load_model(model)  # None: the shipped checkpoint; str: a path
    args, kw = scoring.sdgnet_args(tool, task, grasps, m, scoring.ScoreWeights())
    t0 = time.perf_counter()
    compiled = scoring.sdgnet_scores_jit.lower(*args, **kw).compile()
    compile_s = time.perf_counter() - t0
    run = lambda: jax.block_until_ready(compiled(*args))  # noqa: E731
    run()
    warm = _timed(run, repeats)
    warm_s = statistics.median(warm)
    flops = _flops(compiled)
    mm = matmul_rate()
    # second reference: the analytic costs (no features, no MLP) on the same candidates
    a_args = (tool.params, task, grasps, CostParams())
    a_compiled = wrench_costs_jit.lower(*a_args).compile()
    jax.block_until_ready(a_compiled(*a_args))
    analytic_s = statistics.median(_timed(lambda: jax.block_until_ready(a_compiled(*a_args)), repeats))
    spec = m.feature_spec
    return {
        "benchmark": "score",
        "task": task_kind,
        "n": n,
        "t": task.num_steps,
        "features": spec.size,
        "hidden": [int(W.shape[-1]) for W, _ in m.for_task(task_kind).params[:-1]],  # the network scoring this task
        "ensemble_size": m.ensemble_size,  # networks run and averaged per candidate (`sdgnet.model.ensemble`)
        "class_heads": m.class_heads,
        "dtype": "float32",
        "compile_s": round(compile_s, 3),
        "warm_ms": round(1e3 * warm_s, 3),
        "warm_ms_min": round(1e3 * min(warm), 3),
        "repeats": repeats,
        "candidates_per_s": round(n / warm_s),
        "flops": flops,
        "flops_per_s": None if flops is None else flops / warm_s,
        "matmul": mm,
        "matmul_flops_per_s": mm["flops_per_s"],
        "fraction_of_matmul_rate": None if flops is None else round(flops / warm_s / mm["flops_per_s"], 4),
        "analytic_warm_ms": round(1e3 * analytic_s, 3),
        "sdgnet_over_analytic_time": round(warm_s / analytic_s, 2),
        "target_warm_ms": 20.0,
        "machine": machine_info(),
    }


def bench_verify(n: int = 1000, k: int = 5, repeats: int = 5, model: Any = None, draws: int = 1,
                 torque_first: bool = False, weak_grip: float | None = robot.WEAK_GRIP) -> dict[str, Any]:
    """Per task (its built-in tool, its own time step): the cost of a verified pick
    (`verify.best_grasp_verified`, SDG-Net's k best rolled out under nominal physics; with `draws` r > 1,
    each r times under random physics; each rollout again at `weak_grip` N per pad, as `itup plan`
    verifies, None: not; `torque_first`: `ScoreWeights.torque_first`) against SDG-Net's
    scoring of the n sampled candidates (`score`, warm), measured in the same run. The scene is built once
    per task and reused, as a planner would; its build time is reported apart, like the scorer's compile."""
    from itup_jax.grasp_sampler import sample_grasps
    from itup_jax.scoring import ScoreWeights, score
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.model import Model
    from itup_jax.sim.physics import Randomization
    from itup_jax.sim.scene import build_scene
    from itup_jax.task import TASK_KINDS
    from itup_jax.verify import best_grasp_verified

    m = model if isinstance(model, Model) else load_model(model)
    kw = {"weights": ScoreWeights.torque_first() if torque_first else ScoreWeights(), "weak_grip": weak_grip}
    if draws > 1:
        kw.update(draws=draws, randomize=Randomization())
    rows = []
    for kind in TASK_KINDS:
        tool = load_tool(DEFAULT_TOOL[kind])
        task = make_task(kind, tool)
        grasps = sample_grasps(tool, n, seed=0)
        t0 = time.perf_counter()
        scene = build_scene(tool, task)
        scene_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        s = score(tool, task, grasps, m, weights=kw["weights"])
        jax.block_until_ready(s.total)
        first_s = time.perf_counter() - t0
        score_s = statistics.median(_timed(lambda: jax.block_until_ready(score(tool, task, grasps, m, weights=kw["weights"]).total),
                                           repeats))
        v = best_grasp_verified(tool, task, grasps, k=k, scores=s, scene=scene, **kw)
        verify_s = statistics.median(_timed(lambda: best_grasp_verified(tool, task, grasps, k=k, scores=s, scene=scene,
                                                                        **kw), repeats))
        rows.append({"task": kind, "tool": tool.name, "timestep_s": scene.model.opt.timestep,
                     "scene_build_s": round(scene_s, 3), "score_first_s": round(first_s, 3),
                     "score_warm_ms": round(1e3 * score_s, 2), "verify_ms": round(1e3 * verify_s, 1),
                     "rollouts": int(len(v.labels.valid)), "valid_rollouts": int(v.labels.valid.sum()),
                     "verify_over_score": round(verify_s / score_s, 1),
                     "pick_changed": bool(v.index != int(np.argmin(np.asarray(s.total))))})
    return {"benchmark": "verify", "n": n, "k": k, "draws": draws, "torque_first": torque_first, "weak_grip": weak_grip,
            "repeats": repeats,
            "physics": "nominal" if draws == 1 else "random", "tasks": rows,
            "machine": machine_info()}


def bench_sample(n: int = 4096, repeats: int = 3, seed: int = 0) -> dict[str, Any]:
    """Per task's built-in tool: `sample_grasps(tool, n)` warm (the collision kernel's compile for the
    tool's point count reported apart), and its collision kernel on one chunk of 256 candidates against the
    same kernel with the grasp-frame transform written as a batched `d @ R` (the form it replaced), both
    in this run, with a check that the two agree on the chunk."""
    import functools

    from itup_jax.grasp_sampler import CHUNK, SamplerConfig, collision_points, gripper_hits, sample_grasps
    from itup_jax.grasp_sampler import gripper_hits_batch as kernel
    from itup_jax.rotations import quat_to_matrix
    from itup_jax.task import TASK_KINDS

    config = SamplerConfig()
    dot_kernel = jax.jit(full_precision(jax.vmap(functools.partial(gripper_hits, to_grasp_frame=lambda d, R: d @ R),
                                                 in_axes=(None, 0, 0, 0, None))))
    rows = []
    for kind in TASK_KINDS:
        tool = load_tool(DEFAULT_TOOL[kind])
        t0 = time.perf_counter()
        g = sample_grasps(tool, n, seed=seed)
        first_s = time.perf_counter() - t0
        warm_s = statistics.median(_timed(lambda: sample_grasps(tool, n, seed=seed), repeats))
        # one chunk of the sampled candidates (repeated if fewer), as the sampler feeds its kernel
        idx = np.arange(CHUNK) % len(g)
        pts = jnp.asarray(collision_points(tool, config.surface_spacing), jnp.float32)
        args = (pts, jnp.asarray(quat_to_matrix(g.q_tool_grasp)[idx], jnp.float32),
                jnp.asarray(g.p_tool_grasp[idx], jnp.float32),
                jnp.asarray(g.width[idx] + 2 * config.clearance, jnp.float32), jnp.float32(config.collision_margin))
        times = {}
        for name, k in (("kernel", kernel), ("dot_kernel", dot_kernel)):
            jax.block_until_ready(k(*args))
            times[name] = statistics.median(_timed(lambda k=k: jax.block_until_ready(k(*args)), 5))
        agree = bool(np.array_equal(np.asarray(kernel(*args)), np.asarray(dot_kernel(*args))))
        rows.append({"task": kind, "tool": tool.name, "surface_points": int(pts.shape[0]),
                     "first_call_s": round(first_s, 3), "warm_s": round(warm_s, 3),
                     "grasps_per_s": round(n / warm_s), "kernel_chunk_ms": round(1e3 * times["kernel"], 2),
                     "dot_kernel_chunk_ms": round(1e3 * times["dot_kernel"], 2),
                     "kernel_speedup": round(times["dot_kernel"] / times["kernel"], 1), "kernels_agree": agree})
    return {"benchmark": "sample", "n": n, "chunk": CHUNK, "repeats": repeats, "tasks": rows,
            "machine": machine_info()}


def bench_reachable(n: int = 256, repeats: int = 3, seed: int = 0, families: tuple | None = None) -> dict[str, Any]:
    """Per tool family (`families`, default all) and task it can do (the family's default tool): the wall time of
    `sample_reachable(tool, task, n)` warm (median of `repeats`; the first call, which compiles the
    sampler's kernels, apart), the candidates it drew and the reachable share, beside plain
    `sample_grasps` of as many candidates as it drew (the reference: the IK's share of the cost)."""
    from itup_jax.grasp_sampler import sample_grasps, sample_reachable
    from itup_jax.tools import families as fams

    rows = []
    for name in families or fams.names():
        for kind in fams.get(name).tasks:
            tool = load_tool(name)
            task = make_task(kind, tool)
            t0 = time.perf_counter()
            r = sample_reachable(tool, task, n, seed=seed)
            first_s = time.perf_counter() - t0
            warm_s = statistics.median(_timed(lambda: sample_reachable(tool, task, n, seed=seed), repeats))
            plain_s = statistics.median(_timed(lambda: sample_grasps(tool, r.drawn, seed=seed), repeats))
            rows.append({"family": name, "task": kind, "reachable": len(r.grasps), "drawn": r.drawn,
                         "reachable_share": round(len(r.grasps) / r.drawn, 3), "first_call_s": round(first_s, 3),
                         "warm_s": round(warm_s, 3), "sample_only_s": round(plain_s, 3),
                         "ik_share": round(max(0.0, 1.0 - plain_s / warm_s), 2)})
    return {"benchmark": "reachable", "n": n, "repeats": repeats, "families": rows, "machine": machine_info()}


#: The wall-time goals of a repeated command (s, on a 2-core laptop-class CPU): printed beside the
#: measurements, not enforced.
STARTUP_GOALS_S = {"plan": 3.0, "demo": 6.0}


def bench_startup(repeats: int = 5, task_kind: str = "hammer") -> dict[str, Any]:
    """Wall time of the command line from a shell, each run a fresh Python process: `itup --help` (Python
    and the command line's parser, no library import: the floor of every command, the reference), then `itup plan
    --task T` and `itup demo --task T --out <tmp>` without the caches kept between runs
    (`--no-compile-cache`), once with empty caches (the first run: it fills them) and `repeats` times
    repeated. The caches live in a temporary folder (ITUP_COMPILE_CACHE_DIR, ITUP_TASK_CACHE_DIR), so a
    user's own are neither read nor changed. Medians, minima and maxima in s."""
    import subprocess
    import tempfile

    from itup_jax import compile_cache, task_cache

    def runs(args: list[str], count: int, env: dict) -> list[float]:
        out = []
        for _ in range(count):
            t0 = time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "itup_jax.cli", *args], env=env, capture_output=True,
                                  text=True, timeout=600)
            out.append(time.perf_counter() - t0)
            if done.returncode != 0:
                raise RuntimeError(f"bench startup: `itup {' '.join(args)}` exited {done.returncode}: "
                                   f"{done.stderr[-1000:]}")
        return out

    def summary(ts: list[float]) -> dict[str, float]:
        return {"median_s": round(statistics.median(ts), 2), "min_s": round(min(ts), 2), "max_s": round(max(ts), 2)}

    rows = {}
    with tempfile.TemporaryDirectory(prefix="itup-bench-startup-") as tmp:
        env = {k: v for k, v in os.environ.items() if k != compile_cache.ENV_SWITCH}
        env[compile_cache.ENV_DIR] = os.path.join(tmp, "jax")
        env[task_cache.ENV_DIR] = os.path.join(tmp, "tasks")
        _progress("itup --help")
        rows["help"] = summary(runs(["--help"], repeats, env))
        for name, args in (("plan", ["plan", "--task", task_kind]),
                           ("demo", ["demo", "--task", task_kind, "--out", os.path.join(tmp, "demo")])):
            _progress(f"itup {' '.join(args[:3])}")
            no_cache = runs(["--no-compile-cache", *args], 1, env)[0]
            first = runs(args, 1, env)[0]
            repeated = runs(args, repeats, env)
            rows[name] = {"no_cache_s": round(no_cache, 2), "first_s": round(first, 2), **summary(repeated),
                          "goal_s": STARTUP_GOALS_S[name], "over_import_floor_s": round(
                              statistics.median(repeated) - rows["help"]["median_s"], 2)}
    return {"benchmark": "startup", "task": task_kind, "repeats": repeats, "commands": rows,
            "machine": machine_info()}


def describe(res: dict[str, Any], *, threads: int | None = None) -> str:
    """A benchmark's result (any `bench_*`'s) in a few lines, as `itup bench` prints it without --json.
    `threads`: the rollout benchmark's thread count to quote (default: the most it timed)."""
    kind = res["benchmark"]
    if kind == "costs":
        return (f"costs: n={res['n']} t={res['t']} compile {res['compile_s']:.2f} s, warm {res['warm_ms']:.1f} ms "
                f"(numpy {res['numpy_ms']:.1f} ms, x{res['speedup_vs_numpy']}) on {res['machine']['cpu']}")
    if kind == "rollout":
        nt = threads or max(int(k.rsplit("threads", 1)[1]) for k in res if k.startswith("raw_steps_per_s_threads"))
        return (f"rollout: raw {res[f'raw_steps_per_s_threads{nt}']} steps/s, labels "
                f"{res[f'label_steps_per_s_threads{nt}']} steps/s (x{res[f'label_over_raw_threads{nt}']}) on {nt} "
                f"threads; mjx {res['mjx']}")
    if kind == "score":
        return (f"score: n={res['n']} compile {res['compile_s']:.2f} s, warm {res['warm_ms']:.2f} ms "
                f"({res['candidates_per_s']} candidates/s; {res['flops_per_s'] or 0:.3g} flop/s vs matmul "
                f"{res['matmul_flops_per_s']:.3g}) on {res['machine']['cpu']}")
    if kind == "verify":
        return "\n".join(
            f"verify {r['task']:6s}: {r['rollouts']} rollouts ({r['valid_rollouts']} valid) {r['verify_ms']:.0f} ms vs "
            f"scoring {res['n']} candidates {r['score_warm_ms']:.1f} ms (x{r['verify_over_score']}); scene built in "
            f"{r['scene_build_s']:.2f} s" for r in res["tasks"])
    if kind == "sample":
        return "\n".join(
            f"sample {r['task']:6s}: {res['n']} grasps in {r['warm_s']:.2f} s warm ({r['grasps_per_s']} grasps/s; first "
            f"call {r['first_call_s']:.2f} s); collision kernel {r['kernel_chunk_ms']:.1f} ms per {res['chunk']} "
            f"candidates x {r['surface_points']} points vs {r['dot_kernel_chunk_ms']:.1f} ms as a batched dot "
            f"(x{r['kernel_speedup']}, {'same' if r['kernels_agree'] else 'DIFFERENT'} hits)" for r in res["tasks"])
    if kind == "reachable":
        return "\n".join(
            f"reachable {r['family']:11s} {r['task']:6s}: {r['reachable']} reachable of {r['drawn']} drawn "
            f"({r['reachable_share']:.0%}) in {r['warm_s']:.2f} s warm (first call {r['first_call_s']:.2f} s; sampling "
            f"alone {r['sample_only_s']:.2f} s, IK {r['ik_share']:.0%})" for r in res["families"])
    if kind == "startup":
        c = res["commands"]
        lines = [f"startup itup --help: {c['help']['median_s']:.2f} s (Python and the command line's parser: the floor)"]
        for name in ("plan", "demo"):
            r = c[name]
            lines.append(f"startup itup {name} --task {res['task']}: repeated {r['median_s']:.2f} s (median of "
                         f"{res['repeats']}, {r['min_s']:.2f}-{r['max_s']:.2f}; goal {r['goal_s']:g} s), first run "
                         f"{r['first_s']:.2f} s, without the caches {r['no_cache_s']:.2f} s; {r['over_import_floor_s']:.2f} "
                         "s over the floor")
        return "\n".join(lines)
    raise ValueError(f"describe: unknown benchmark {kind!r}")

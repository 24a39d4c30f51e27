"""Same labels either way? MJX against native MuJoCo on the same grasps and the same physics draws.

    python experiments/mjx_vs_native.py --out results/mjx_vs_native                 # all tasks, 256 grasps each
    python experiments/mjx_vs_native.py --tasks hammer --grasps 1024 --out results/mvn_quick  # one task, larger batch
    python experiments/mjx_vs_native.py --quick --out results/mvn_quick                       # tests (CPU: 3 grasps)

Dataset generation runs MJX on an accelerator and native MuJoCo on a CPU (`sim.rollout.default_backend`), and
a dataset mixes neither: this script measures how far the two label sets differ when they could be mixed.
Per task (its built-in tool), `sample_grasps(tool, N, seed)` is simulated with both backends under the
same randomised physics (`simulate(..., seed=)`: the draws depend on the seed only), MJX in float64 as
`simulate` runs it (`MJX_FLOAT64`; `--mjx-float32` for float32). On the rows both call valid:
  - peak wrist torque: Spearman rank correlation, median and 90th-percentile relative difference;
  - slip (m) and alignment drift (rad): median and 90th-percentile absolute difference;
  - the task metric: Spearman; the failed and success flags: fraction of rows where the two agree;
and the rows that only one backend calls valid (diverged on one side); `per_row` keeps both backends' peak and static
torques, slip, alignment drift and flags row by row. MJX collides capsules with boxes by
`itup_jax.sim.mjx_collision`, as `simulate` does. The quick run's test checks the firm-grasp tolerances
on its rows; the full run is the same comparison over a whole batch. The control
(`native_control`): native MuJoCo against itself with every grasp moved by 1 micrometre, which shows how
much of a difference a perturbation of float32's size makes by itself (the labels' own conditioning).

With `--traces K`, the whole batch is simulated again with per-step traces and the same seed, so the
traced rollouts are the compared ones (the same physics draws; MJX reuses its compiled program), and
the first K grasps valid in both are reported (`row`: the grasp's index). Each traced row records both
backends' peak wrist torque during the motion, its time, and the time from which the two torque traces
differ by more than 5 % of the native peak: where in the motion the labels part.

Timing, per task: the native path on all of this machine's cores (end to end: IK plan, stepping, labels)
and MJX's first call (compile included) and a second, warm call on the same inputs (`--once`: the first
only, for a CPU, where MJX is slow); env-steps/s counts the feasible rollouts' steps, the only ones either
backend steps (MJX pads its batch to a power of two). The two MJX calls' labels are compared too: equal
on a CPU, and on a GPU only with deterministic scatters (`sim.mjx.DETERMINISTIC_GPU_FLAG`).
Writes mjx_vs_native.json (schema `itup.mjx_vs_native/1`) into --out.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.grasp import Grasps
from itup_jax.precision import MATMUL_PRECISION
from itup_jax.sim import mjx_collision
from itup_jax.stats import spearman
from itup_jax.task import DEFAULT_TOOL, TASK_KINDS

QUICK = {"tasks": ("hammer",), "grasps": 3, "timestep": 0.002}
#: The control's grasp shift (m): native MuJoCo against itself with every grasp moved this far.
CONTROL_SHIFT_M = 1e-6


def _quantiles(x: np.ndarray) -> tuple[float | None, float | None]:
    if not len(x):
        return None, None
    return float(np.median(x)), float(np.quantile(x, 0.9))


def compare(native, mjx) -> dict:
    """Agreement of two `Labels` of the same rollouts (arrays [N]): see the module docstring."""
    nv, mv = np.asarray(native.valid, bool), np.asarray(mjx.valid, bool)
    both = nv & mv
    out: dict = {"rows": int(len(nv)), "valid_native": int(nv.sum()), "valid_mjx": int(mv.sum()),
                 "valid_both": int(both.sum()), "valid_native_only": int((nv & ~mv).sum()),
                 "valid_mjx_only": int((mv & ~nv).sum())}
    if not both.any():
        return out
    tn, tm = np.asarray(native.peak_torque)[both], np.asarray(mjx.peak_torque)[both]
    rel = np.abs(tm - tn) / np.maximum(np.abs(tn), 1e-9)
    out["torque_spearman"] = spearman(tn, tm) if both.sum() > 2 else None
    out["torque_rel_median"], out["torque_rel_p90"] = _quantiles(rel)
    slip = np.abs(np.asarray(mjx.slip_translation)[both] - np.asarray(native.slip_translation)[both])
    out["slip_abs_median_m"], out["slip_abs_p90_m"] = _quantiles(slip)
    drift = np.abs(np.asarray(mjx.alignment_drift)[both] - np.asarray(native.alignment_drift)[both])
    out["drift_abs_median_rad"], out["drift_abs_p90_rad"] = _quantiles(drift)
    out["task_metric_spearman"] = (spearman(np.asarray(native.task_metric)[both], np.asarray(mjx.task_metric)[both])
                                   if both.sum() > 2 else None)
    for flag in ("failed", "success"):
        a, b = np.asarray(getattr(native, flag), bool)[both], np.asarray(getattr(mjx, flag), bool)[both]
        out[f"{flag}_agree"] = float((a == b).mean())
        out[f"{flag}_native"], out[f"{flag}_mjx"] = int(a.sum()), int(b.sum())
    return out


def per_row(native, mjx) -> dict:
    """Both backends' labels row by row, for a closer look: {field: {"native": [N], "mjx": [N]}} of the peak
    wrist torque and the static holding torque (N m), slip (m), alignment drift (rad) and the valid and failed
    flags; null where a label is NaN (unstepped rows)."""
    out = {}
    for f in ("peak_torque", "static_torque", "slip_translation", "alignment_drift", "valid", "failed"):
        out[f] = {}
        for name, lab in (("native", native), ("mjx", mjx)):
            x = np.asarray(getattr(lab, f))
            out[f][name] = [bool(v) for v in x] if x.dtype == bool else [None if np.isnan(v) else float(v) for v in x]
    return out


def trace_rows(tool, task, scene, grasps, rows, seed: int, nthread: int, mjx_float64: bool = True) -> list[dict]:
    """Per row of `rows` (indices into `grasps`, all valid in both backends): when and how high each
    backend's wrist torque peaks during the motion, and when their two torque traces first part by more
    than 5 % of the native peak. The whole batch is simulated again with traces, with the comparison's
    seed, so each traced rollout is the compared one (same physics draw) and MJX reuses its compiled
    program (same batch shape)."""
    import itup_jax as itup

    nat = itup.simulate(tool, task, grasps, scene=scene, backend="native", seed=seed, nthread=nthread, traces=True)
    mjx = itup.simulate(tool, task, grasps, scene=scene, backend="mjx", seed=seed, traces=True, mjx_float64=mjx_float64)
    t = nat.traces["t"]
    motion = t >= 0  # the settle phase runs at t < 0
    out = []
    for i in (int(r) for r in rows):
        a = np.linalg.norm(nat.traces["gripper/wrist_torque"][i], axis=-1)
        b = np.linalg.norm(mjx.traces["gripper/wrist_torque"][i], axis=-1)
        ia, ib = (int(np.argmax(np.where(motion, x, -np.inf))) for x in (a, b))
        apart = motion & (np.abs(a - b) > 0.05 * a[ia])
        out.append({"row": i, "native_peak_nm": float(a[ia]), "native_peak_t_s": float(t[ia]), "mjx_peak_nm": float(b[ib]),
                    "mjx_peak_t_s": float(t[ib]), "apart_from_t_s": float(t[np.argmax(apart)]) if apart.any() else None,
                    "native_label_nm": float(nat.labels.peak_torque[i]), "mjx_label_nm": float(mjx.labels.peak_torque[i])})
    return out


def run_task(kind: str, n: int, seed: int, timestep: float | None, nthread: int, repeat: bool = True,
             traces: int = 0, mjx_float64: bool = True) -> dict:
    """Both backends on `n` sampled grasps of the task's built-in tool; agreement and timing."""
    import itup_jax as itup
    from itup_jax.sim.scene import build_scene

    tool = itup.load_tool(DEFAULT_TOOL[kind])
    task = itup.make_task(kind, tool)
    scene = build_scene(tool, task) if timestep is None else build_scene(tool, task, timestep=timestep)
    grasps = itup.sample_grasps(tool, n, seed=seed)
    t0 = time.perf_counter()
    nat = itup.simulate(tool, task, grasps, scene=scene, backend="native", seed=seed, nthread=nthread)
    t_native = time.perf_counter() - t0
    print(f"  {kind}: native {t_native:.1f} s on {nthread} threads", flush=True)
    # the control: native MuJoCo against itself with every grasp moved CONTROL_SHIFT_M along the tool's z
    # (float32 rounding of a pose is ~1e-7 m): how far the labels move for a perturbation of that size
    moved = Grasps(p_tool_grasp=np.asarray(grasps.p_tool_grasp) + CONTROL_SHIFT_M * np.array([0.0, 0.0, 1.0]),
                   q_tool_grasp=grasps.q_tool_grasp, width=grasps.width)
    control = itup.simulate(tool, task, moved, scene=scene, backend="native", seed=seed, nthread=nthread)
    t0 = time.perf_counter()
    first = itup.simulate(tool, task, grasps, scene=scene, backend="mjx", seed=seed, mjx_float64=mjx_float64)
    t_first = time.perf_counter() - t0
    print(f"  {kind}: mjx first call {t_first:.1f} s", flush=True)
    mjx, t_warm = first, None
    if repeat:  # the same inputs twice: equal on a CPU; on a GPU only with deterministic scatters (XLA_FLAGS)
        t0 = time.perf_counter()
        mjx = itup.simulate(tool, task, grasps, scene=scene, backend="mjx", seed=seed, mjx_float64=mjx_float64)
        t_warm = time.perf_counter() - t0
    feasible = int((~nat.plan.infeasible).sum())
    steps = feasible * nat.plan.nstep
    row = {"task": kind, "tool": tool.name, "grasps": n, "feasible": feasible,
           "nstep": int(nat.plan.nstep), "timestep_s": float(scene.model.opt.timestep),
           "native_threads": nthread, "native_s": round(t_native, 2), "mjx_first_s": round(t_first, 2),
           "native_steps_per_s": round(steps / t_native)}
    if t_warm is not None:
        row.update(mjx_warm_s=round(t_warm, 2), mjx_compile_s=round(t_first - t_warm, 2),
                   mjx_steps_per_s=round(steps / t_warm), mjx_over_native=round(t_native / t_warm, 2))
    row.update(compare(nat.labels, mjx.labels))
    row["native_control"] = compare(nat.labels, control.labels)
    row["per_row"] = per_row(nat.labels, mjx.labels)
    if traces:  # the first `traces` grasps valid in both: the compared rollouts, simulated again with traces
        both = np.nonzero(np.asarray(nat.labels.valid) & np.asarray(mjx.labels.valid))[0][:traces]
        if len(both):
            row["traces"] = trace_rows(tool, task, scene, grasps, both, seed, nthread, mjx_float64)
    if repeat:
        rep = compare(first.labels, mjx.labels)
        a, b = np.asarray(first.labels.peak_torque), np.asarray(mjx.labels.peak_torque)
        row["mjx_repeat_bitwise_equal"] = bool(np.array_equal(a, b, equal_nan=True))
        row["mjx_repeat_torque_rel_p90"] = rep.get("torque_rel_p90")
        row["mjx_repeat_valid_differs"] = rep["valid_native_only"] + rep["valid_mjx_only"]
    return row


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="folder for mjx_vs_native.json")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS), help="comma-separated task kinds")
    ap.add_argument("--grasps", type=int, default=256, help="sampled grasps per task (both backends)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=None, help="native stepping threads (default: all cores)")
    ap.add_argument("--once", action="store_true", help="one MJX call (no warm timing, no repeat check; for CPUs)")
    ap.add_argument("--traces", type=int, default=0, metavar="K",
                    help="also trace K grasps valid in both: each backend's torque peak and its time, and when the "
                    "two torque traces part (one more MJX compile)")
    ap.add_argument("--mjx-float32", action="store_true", help="MJX in float32 (default: float64, as simulate runs it)")
    ap.add_argument("--quick", action="store_true", help="hammer, 3 grasps, 2 ms steps (for tests)")
    a = ap.parse_args(argv)
    tasks = QUICK["tasks"] if a.quick else tuple(t for t in a.tasks.split(",") if t)
    bad = [t for t in tasks if t not in TASK_KINDS]
    if bad or not tasks:
        ap.error(f"--tasks: unknown task kind(s) {bad}; choose from {', '.join(TASK_KINDS)}")
    n = QUICK["grasps"] if a.quick else a.grasps
    if n < 1:
        ap.error(f"--grasps must be >= 1, got {n}")
    if a.traces < 0:
        ap.error(f"--traces must be >= 0, got {a.traces}")
    if a.threads is not None and a.threads < 1:
        ap.error(f"--threads must be >= 1, got {a.threads}")
    nthread = a.threads or os.cpu_count() or 1
    from itup_jax.bench import machine_info

    t0 = time.perf_counter()
    rows = []
    for kind in tasks:
        rows.append(run_task(kind, n, a.seed, QUICK["timestep"] if a.quick else None, nthread, repeat=not a.once,
                             traces=2 if a.quick else a.traces, mjx_float64=not a.mjx_float32))
        r = rows[-1]
        print(f"{kind}: {r['valid_both']}/{r['rows']} valid in both (native only {r['valid_native_only']}, mjx only "
              f"{r['valid_mjx_only']}); torque Spearman {r.get('torque_spearman')}, rel. diff median "
              f"{r.get('torque_rel_median')}; native {r['native_s']} s, mjx {r['mjx_first_s']} s first / "
              f"{r.get('mjx_warm_s')} s warm; repeat bitwise equal {r.get('mjx_repeat_bitwise_equal')}", flush=True)
    out = {"schema": "itup.mjx_vs_native/1", "experiment": "mjx_vs_native", "seed": a.seed, "quick": a.quick,
           "precision": "float32" if a.mjx_float32 else "float64",  # MJX's; native MuJoCo is float64
           "matmul_precision": MATMUL_PRECISION,  # every jit of the package traces float32 products (precision.py)
           "xla_flags": os.environ.get("XLA_FLAGS", ""),
           "mjx_capsule_box": mjx_collision.__name__, "rows": rows,  # MJX's capsule-box collider
           "wall_s": round(time.perf_counter() - t0, 1), "machine": machine_info()}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "mjx_vs_native.json"), out, indent=1)
    print(f"wrote {a.out}/mjx_vs_native.json ({out['wall_s']} s)")
    return out


if __name__ == "__main__":
    main()

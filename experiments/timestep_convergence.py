"""Are the labels converged in the simulator's timestep? The same grasps, the same contact model and
nominal physics, integrated at several timesteps: if the labels at a step rank the grasps differently
from the labels at a finer step, part of what they measure is the integration. This study chose each
task's default step (`sim.scene.TASK_TIMESTEP`).

    python experiments/timestep_convergence.py --data data/test --tools-per-task 3 --out results/timestep
    python experiments/timestep_convergence.py --quick --out results/timestep_quick     # a tiny dataset made here (tests)

For the first `--tools-per-task` procedural tools of every task in --data, the valid grasps of the shard
are rolled out under nominal physics in scenes built at each of `--timesteps` (s). Only the
integration changes: every contact keeps the same parameters at every step <= 2 ms (the tool-target
spring's time constant keeps its 4 ms floor, `sim.scene.CONTACT_MIN_TIMECONST`; the pads 4 ms).
Per tool and timestep, over the grasps valid at both that step and the finest:

  rho_vs_finest     Spearman of the full induced peak wrist torque (the paper's measure, no projection)
                    against the finest step's;
  rho_vs_finest_projected  the same of the projected part (the paper objective's target), beside it;
  ratio_vs_finest   the median over grasps of label / finest label (full induced);
  success_agree     the share of grasps whose task success is the same as at the finest step;
  rho_moved         the labels of the grasps moved by 2 mm and 2 degrees (`label_smoothness.moved`)
                    against the grasps' own, at that step: roughness in the grasp;
  rho_sdgnet        the model's predicted torque (`--model`, default the shipped checkpoint: its full
                    induced torque) against that step's labels.

Reported per tool and as the mean over each task's tools. Writes timestep.json (`itup.timestep/2`).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import GenerateConfig, generate, unit_tool
from itup_jax.dataset_load import MANIFEST, load_shard
from itup_jax.heldout import mean_or_none, rho, with_moved_copies
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sdgnet.model import predict_costs
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import MAX_TIMESTEP, build_scene
from itup_jax.task import TASK_KINDS

FIELDS = ("rho_vs_finest", "rho_vs_finest_projected", "ratio_vs_finest", "success_agree", "rho_moved", "rho_sdgnet")
MOVE, TURN = 0.002, np.radians(2.0)


def tool_rows(tool, task, a: dict, timesteps: list[float], pred: np.ndarray, grasps) -> list[dict]:
    """One row per timestep for one shard's valid grasps `a`; `grasps` [2N]: them and their moved copies
    (`label_smoothness.with_moved_copies`), rolled out in one batch per timestep."""
    n = len(a["grasp_width"])
    runs = {}
    for dt in timesteps:
        t0 = time.perf_counter()
        L = simulate(tool, task, grasps, scene=build_scene(tool, task, timestep=dt), randomize=None,
                     backend="native").labels
        runs[dt] = (np.asarray(L.valid), np.asarray(L.peak_torque_induced, float), np.asarray(L.success),
                    time.perf_counter() - t0, np.asarray(L.peak_torque_projected, float))
    v_f, y_f, s_f, _, p_f = runs[min(timesteps)]
    rows = []
    for dt in timesteps:
        v, y, s, wall, yp = runs[dt]
        both = v[:n] & v_f[:n]
        moved_ok = v[:n] & v[n:]
        rows.append({"timestep_s": dt, "n": int(both.sum()), "wall_s": round(wall, 2),
                     "rho_vs_finest": rho(y[:n][both], y_f[:n][both]),
                     "rho_vs_finest_projected": rho(yp[:n][both], p_f[:n][both]),
                     "ratio_vs_finest": float(np.median(y[:n][both] / y_f[:n][both])) if both.any() else None,
                     "success_agree": float((s[:n][both] == s_f[:n][both]).mean()) if both.any() else None,
                     "rho_moved": rho(y[n:][moved_ok], y[:n][moved_ok]),
                     "rho_sdgnet": rho(pred[v[:n]], y[:n][v[:n]])})
    return rows


def summarise(per_tool: list[dict], timesteps: list[float]) -> dict:
    out = {}
    for t in sorted({r["task"] for r in per_tool}):
        sel = [r for r in per_tool if r["task"] == t]
        out[t] = {"tools": len(sel), "by_timestep": []}
        for i, dt in enumerate(timesteps):
            row = {"timestep_s": dt}
            row.update({f: mean_or_none(r["timesteps"][i][f] for r in sel) for f in FIELDS})
            out[t]["by_timestep"].append(row)
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=None, help="an `itup generate` folder")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--tools-per-task", type=int, default=3, help="procedural tools per task (the first ones)")
    ap.add_argument("--timesteps", default="0.002,0.001,0.0005,0.00025", help="s, comma-separated")
    ap.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    ap.add_argument("--seed", type=int, default=0, help="seeds the moves (with the tool's task and variant)")
    ap.add_argument("--quick", action="store_true", help="hammer, 1 tool, 10 grasps, 2 and 1 ms, made in --out (tests)")
    ap.add_argument("--out", default="results/timestep")
    a = ap.parse_args(argv)
    tasks = tuple(t for t in a.tasks.split(",") if t)
    try:
        timesteps = sorted({float(x) for x in a.timesteps.split(",") if x.strip()}, reverse=True)
    except ValueError:
        timesteps = []
    if (not tasks or any(t not in TASK_KINDS for t in tasks) or len(timesteps) < 2
            or not all(0 < dt <= MAX_TIMESTEP for dt in timesteps) or a.tools_per_task < 1 or a.seed < 0):
        print(f"timestep_convergence: need --tasks from {', '.join(TASK_KINDS)}, two or more --timesteps in "
              f"(0, {MAX_TIMESTEP}] s, "
              f"--tools-per-task >= 1 and --seed >= 0; got --tasks {a.tasks!r} --timesteps {a.timesteps!r} "
              f"--tools-per-task {a.tools_per_task} --seed {a.seed}", file=sys.stderr)
        raise SystemExit(2)
    t0 = time.perf_counter()
    if a.quick:
        a.data, tasks, a.tools_per_task, timesteps = os.path.join(a.out, "data"), ("hammer",), 1, [0.002, 0.001]
        generate(a.data, GenerateConfig(tasks=tasks, tools_per_task=2, grasps=10, seed=1), progress=False)
    elif not a.data or not os.path.exists(os.path.join(a.data, MANIFEST)):
        print(f"timestep_convergence: --data {a.data!r} holds no dataset manifest", file=sys.stderr)
        raise SystemExit(2)
    with open(os.path.join(a.data, MANIFEST)) as fh:
        manifest = json.load(fh)
    config = GenerateConfig.from_json(manifest["config"])
    model = load_model(a.model)
    per_tool = []
    for task_kind in tasks:
        entries = [e for e in manifest["shards"] if e["task"] == task_kind and e["variant"] > 0][: a.tools_per_task]
        for entry in entries:
            shard = load_shard(a.data, entry, valid_only=True)
            if len(shard["grasp_width"]) < 3:
                continue
            tool, task = unit_tool(config, task_kind, entry["variant"])
            pred = np.asarray(predict_costs(model, shard["features"], task_kind)["tau"], float)
            grasps = with_moved_copies(shard, task_kind, entry["variant"], MOVE, TURN, a.seed)
            per_tool.append({"task": task_kind, "variant": entry["variant"],
                             "timesteps": tool_rows(tool, task, shard, timesteps, pred, grasps)})
            r = per_tool[-1]["timesteps"]
            print(f"{task_kind} {entry['variant']}: " + "  ".join(
                f"{1000 * x['timestep_s']:g} ms rho {x['rho_vs_finest'] if x['rho_vs_finest'] is None else round(x['rho_vs_finest'], 2)}"
                for x in r), flush=True)
    if not per_tool:
        print(f"timestep_convergence: no shard of {a.data!r} for {', '.join(tasks)} has 3 or more valid rollouts",
              file=sys.stderr)
        raise SystemExit(2)
    summary = summarise(per_tool, timesteps)
    from itup_jax.bench import machine_info

    out = {"schema": "itup.timestep/2", "experiment": "timestep_convergence", "quick": a.quick,
           "data": os.path.abspath(a.data), "timesteps_s": timesteps, "move_m": MOVE, "turn_deg": float(np.degrees(TURN)),
           "seed": a.seed, "model": os.path.abspath(a.model) if a.model else "shipped", "summary": summary,
           "per_tool": per_tool, "wall_s": round(time.perf_counter() - t0, 1), "machine": machine_info()}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "timestep.json"), out, indent=1)
    print(f"mean over tools; 'finest' is {1000 * timesteps[-1]:g} ms")
    print(f"{'task':8s} {'dt ms':>6s} {'rho vs finest':>13s} {'projected':>9s} {'ratio':>6s} {'success =':>9s} {'moved':>6s} {'SDG-Net':>8s}")
    for t, s in summary.items():
        for r in s["by_timestep"]:
            print(f"{t:8s} {1000 * r['timestep_s']:6g} " + " ".join(
                f"{r[f]:>{w}.3f}" if r[f] is not None else f"{'n/a':>{w}s}" for f, w in zip(FIELDS, (13, 9, 6, 9, 6, 8))))
    return out


if __name__ == "__main__":
    main()

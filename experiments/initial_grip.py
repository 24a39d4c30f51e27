"""How the grip starts: how deep the pads sit in the tool at step 0, and how far the tool turns and slides
in the pads during the settle, before the motion.

    python experiments/initial_grip.py --data data/test --out results/initial_grip   # ~40 s
    python experiments/initial_grip.py --quick --out results/initial_grip_quick   # a tiny dataset made here (tests)

A rollout starts with the pads closed `sim.arm.INITIAL_SQUEEZE` (0.3 mm) inside the jaw opening of the
grasp, the chord between the two antipodal surface points that the sampler found. Flat pads on a handle
whose closure axis is tilted off its cross-section (the sampler accepts up to atan(mu)) touch it at their
ends, deeper than that. The contacts push the tool out, and it turns until it lies flat between the pads.
The labels measure the grasp as it stands at the end of the settle; the features and the analytic costs
describe the grasp as sampled.

For every valid row of the first --tools-per-task shards of each task in --data (0: all), with the row's
own physics (the shard's `physics` array) and the shard's timestep:

  overlap_mm        the deeper pad's penetration into the tool at step 0 (MuJoCo's contact distance,
                    positive = overlap; NaN if a pad touches nothing);
  turn_50ms_deg     the angle the tool turned in the grasp frame over the first 50 ms;
  turn_settle_deg   ... from 50 ms to the end of the settle;
  slide_settle_mm   the slide of the tool at the grasp centre (`sim.labels.grasp_point_slip`) over the
                    whole settle.

Reported per task as percentiles, and the first 50 ms turn by overlap bin. Writes initial_grip.json
(`itup.initial_grip/1`).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.dataset import GenerateConfig, unit_tool
from itup_jax.dataset_load import load_shard
from itup_jax.grasp import Grasps
from itup_jax.heldout import held_out_dataset
from itup_jax.rotations import quat_angle
from itup_jax.sim.arm import INITIAL_SQUEEZE, plan
from itup_jax.sim.config import SimConfig
from itup_jax.sim.labels import grasp_point_slip, initial_pad_overlap
from itup_jax.sim.native import rollout_native
from itup_jax.sim.physics import Physics
from itup_jax.sim.scene import build_scene
from itup_jax.task import TASK_KINDS

EARLY = 0.05  # s: the first part of the settle, where the contacts push the tool out
BINS_MM = (0.0, 0.5, 1.0, 2.0, np.inf)  # overlap bins for the turn
PERCENTILES = (10, 50, 90)


def shard_rows(data: str, config: GenerateConfig, entry: dict, timestep: float) -> dict[str, np.ndarray]:
    """The four measures (module docstring) for the valid rows of one shard, SI units."""
    a = load_shard(data, entry)
    rows = np.flatnonzero(a["label_valid"].astype(bool))
    tool, task = unit_tool(config, entry["task"], entry["variant"])
    scene = build_scene(tool, task, timestep=timestep)
    physics = Physics(*(a["physics"][rows, i] for i in range(a["physics"].shape[1])))
    grasps = Grasps(a["grasp_p"][rows], a["grasp_q"][rows], a["grasp_width"][rows])
    p = plan(scene, task, grasps, physics, SimConfig())
    settle = dataclasses.replace(p, ctrl=p.ctrl[:, :p.n_settle], nstep=p.n_settle)
    _, sd = rollout_native(scene, settle, physics)
    q, x = scene.sensor(sd, "tool_quat_grasp"), scene.sensor(sd, "tool_pos_grasp")
    k = int(round(EARLY / timestep)) - 1
    return {"overlap": initial_pad_overlap(scene, p.qpos0),
            "turn_50ms": quat_angle(q[:, k], q[:, 0]),
            "turn_settle": quat_angle(q[:, k:], q[:, k:k + 1]).max(1),
            "slide_settle": grasp_point_slip(x, q, 0).max(1)}


def _pct(x: np.ndarray, scale: float) -> dict | None:
    x = x[np.isfinite(x)]
    if not len(x):
        return None
    return {f"p{p}": round(float(np.percentile(x, p)) * scale, 3) for p in PERCENTILES} | {"n": int(len(x))}


def summarise(rows: dict[str, np.ndarray]) -> dict:
    deg, mm = float(np.degrees(1.0)), 1e3
    overlap_mm = rows["overlap"] * mm
    by_bin = []
    for lo, hi in zip(BINS_MM[:-1], BINS_MM[1:]):
        sel = (overlap_mm >= lo) & (overlap_mm < hi)
        by_bin.append({"overlap_mm": [lo, None if np.isinf(hi) else hi], "rows": int(sel.sum()),
                       "turn_50ms_deg": _pct(rows["turn_50ms"][sel], deg)})
    return {"rows": int(len(overlap_mm)), "no_pad_contact": int(np.isnan(overlap_mm).sum()),
            "overlap_mm": _pct(overlap_mm, 1.0), "turn_50ms_deg": _pct(rows["turn_50ms"], deg),
            "turn_settle_deg": _pct(rows["turn_settle"], deg), "slide_settle_mm": _pct(rows["slide_settle"], mm),
            "turn_50ms_by_overlap": by_bin}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=None, help="an `itup generate` folder")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--tools-per-task", type=int, default=0, help="the first shards of each task; 0: all")
    ap.add_argument("--quick", action="store_true", help="hammer, 2 tools, 12 grasps each, made in --out (tests)")
    ap.add_argument("--out", default="results/initial_grip")
    a = ap.parse_args(argv)
    tasks = tuple(t for t in a.tasks.split(",") if t)
    if not tasks or any(t not in TASK_KINDS for t in tasks) or a.tools_per_task < 0:
        print(f"initial_grip: need --tasks from {', '.join(TASK_KINDS)} and --tools-per-task >= 0; got --tasks "
              f"{a.tasks!r} --tools-per-task {a.tools_per_task}", file=sys.stderr)
        raise SystemExit(2)
    t0 = time.perf_counter()
    if a.quick:
        tasks = ("hammer",)
    quick_dir = os.path.join(a.out, "data") if a.quick else None
    data, manifest, config, steps = held_out_dataset(a.data, quick_dir, error=ap.error)
    per_task = {}
    for kind in tasks:
        entries = [e for e in manifest["shards"] if e["task"] == kind]
        if a.tools_per_task:
            entries = entries[: a.tools_per_task]
        parts = [shard_rows(data, config, e, steps[kind]) for e in entries]
        parts = [r for r in parts if len(r["overlap"])]
        if parts:
            per_task[kind] = summarise({f: np.concatenate([r[f] for r in parts]) for f in parts[0]})
    if not per_task:
        print(f"initial_grip: no valid rollout in {data!r} for {', '.join(tasks)}", file=sys.stderr)
        raise SystemExit(2)
    from itup_jax.bench import machine_info

    out = {"schema": "itup.initial_grip/1", "experiment": "initial_grip", "quick": a.quick,
           "data": os.path.abspath(data), "initial_squeeze_mm": INITIAL_SQUEEZE * 1e3, "early_s": EARLY, "per_task": per_task,
           "wall_s": round(time.perf_counter() - t0, 1), "machine": machine_info()}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "initial_grip.json"), out, indent=1)
    f = lambda d, k="p50": "n/a" if d is None else f"{d[k]:.2f}"  # noqa: E731
    print(f"{'task':8s} {'rows':>5s} {'overlap mm p10/50/90':>22s} {'turn 50 ms deg p50/90':>22s} "
          f"{'turn after p50/90':>18s} {'slide mm p50/90':>16s}")
    for kind, s in per_task.items():
        print(f"{kind:8s} {s['rows']:5d} {f(s['overlap_mm'], 'p10'):>8s}/{f(s['overlap_mm'])}/{f(s['overlap_mm'], 'p90')} "
              f"{f(s['turn_50ms_deg']):>13s}/{f(s['turn_50ms_deg'], 'p90')} {f(s['turn_settle_deg']):>11s}/"
              f"{f(s['turn_settle_deg'], 'p90')} {f(s['slide_settle_mm']):>10s}/{f(s['slide_settle_mm'], 'p90')}")
        print("         turn in the first 50 ms by overlap: " + ", ".join(
            f"{b['overlap_mm'][0]}-{b['overlap_mm'][1] or ''} mm: {f(b['turn_50ms_deg'])} deg ({b['rows']} rows)"
            for b in s["turn_50ms_by_overlap"]))
    print(f"wrote {os.path.join(a.out, 'initial_grip.json')} ({out['wall_s']} s)")
    return out


if __name__ == "__main__":
    main()

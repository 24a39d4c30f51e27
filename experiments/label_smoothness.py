"""Is the measured torque smooth in the grasp? If a grasp moved by a few millimetres and degrees ranks
differently from where it was, no scorer of the grasp's pose can rank it better than that.

    python experiments/label_smoothness.py --data data/test --tasks hammer,knock --out results/smoothness
    python experiments/label_smoothness.py --quick --out results/smooth_quick      # a tiny dataset made here (tests)

Per tool (a dataset shard; the built-in tool, variant 0, is skipped unless `--with-builtin`), every
grasp is rolled out under nominal physics twice: as it is, and moved by `--move` metres in a random
direction across the jaw axis (in the grasp's x-z plane, so the pads stay on the handle) and turned by
`--turn` degrees, either way at random, about the jaw axis; same width. Spearman, over the grasps valid
in both rollouts, of the full induced peak wrist torque (the paper's measure, no projection):

  rho_moved    nominal label of the moved grasps against the grasps' own: smoothness in the pose;
  rho_draw     the shard's stored label (its randomised physics draw) against the nominal one: what a
               new physics draw changes, for comparison;
  rho_sdgnet   the model's predicted torque (`--model`, default the shipped checkpoint: its full induced
               torque; a paper-objective checkpoint's C_tau) against the nominal label;
  rho_moved_projected  rho_moved of the projected part (the paper objective's target), beside it.

Reported per tool and as the mean over each task's tools. Writes smoothness.json (`itup.smoothness/2`).
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
from itup_jax.dataset_load import MANIFEST, dataset_timesteps, load_shard
from itup_jax.heldout import mean_or_none, rho, with_moved_copies
from itup_jax.sdgnet.checkpoint import load_model
from itup_jax.sdgnet.model import predict_costs
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import build_scene
from itup_jax.task import TASK_KINDS

#: The measured label the rankings are judged on: the full induced peak wrist torque.
HEADLINE = "peak_torque_induced"
FIELDS = ("rho_moved", "rho_draw", "rho_sdgnet", "rho_moved_projected")


def per_tool(data_dir: str, tasks: tuple[str, ...], move: float, turn: float, model, seed: int,
             with_builtin: bool = False) -> list[dict]:
    with open(os.path.join(data_dir, MANIFEST)) as fh:
        manifest = json.load(fh)
    config = GenerateConfig.from_json(manifest["config"])
    steps = dataset_timesteps(manifest)  # rolled out again at the dataset's step
    rows = []
    for entry in manifest["shards"]:
        if entry["task"] not in tasks or (entry["variant"] == 0 and not with_builtin):
            continue
        a = load_shard(data_dir, entry, valid_only=True)
        n = len(a["grasp_width"])
        if n < 3:
            continue
        tool, task = unit_tool(config, entry["task"], entry["variant"])
        both = with_moved_copies(a, entry["task"], entry["variant"], move, turn, seed)
        L = simulate(tool, task, both, randomize=None, backend="native",
                     scene=build_scene(tool, task, timestep=steps[entry["task"]])).labels
        valid = np.asarray(L.valid)
        ok = valid[:n] & valid[n:]
        y = np.asarray(getattr(L, HEADLINE), float)
        y0, y1 = y[:n][ok], y[n:][ok]
        yp = np.asarray(L.peak_torque_projected, float)
        pred = np.asarray(predict_costs(model, a["features"], entry["task"])["tau"], float)[ok]
        rows.append({"task": entry["task"], "variant": entry["variant"], "n": int(ok.sum()),
                     "rho_moved": rho(y1, y0), "rho_draw": rho(a[f"label_{HEADLINE}"][ok], y0),
                     "rho_sdgnet": rho(pred, y0), "rho_moved_projected": rho(yp[n:][ok], yp[:n][ok])})
    return rows


def summarise(rows: list[dict]) -> dict:
    out = {}
    for t in sorted({r["task"] for r in rows}):
        sel = [r for r in rows if r["task"] == t]
        out[t] = {"tools": len(sel), **{f: mean_or_none(r[f] for r in sel) for f in FIELDS}}
    return out


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=None, help="an `itup generate` folder")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--move", type=float, default=0.002, help="m, step across the jaw axis (default 2 mm)")
    ap.add_argument("--turn", type=float, default=2.0, help="degrees about the jaw axis (default 2)")
    ap.add_argument("--model", default=None, help="SDG-Net checkpoint (default: the shipped one)")
    ap.add_argument("--with-builtin", action="store_true", help="include each task's built-in tool (variant 0)")
    ap.add_argument("--seed", type=int, default=0, help="seeds the moves (with the tool's task and variant)")
    ap.add_argument("--quick", action="store_true", help="hammer, 2 tools, 16 grasps made in --out (tests)")
    ap.add_argument("--out", default="results/smoothness")
    a = ap.parse_args(argv)
    tasks = tuple(t for t in a.tasks.split(",") if t)
    bad = [t for t in tasks if t not in TASK_KINDS]
    if bad or not tasks:
        print(f"label_smoothness: --tasks {a.tasks!r}: each must be one of {', '.join(TASK_KINDS)}", file=sys.stderr)
        raise SystemExit(2)
    if not (np.isfinite(a.move) and a.move >= 0 and np.isfinite(a.turn) and a.turn >= 0) or a.seed < 0:
        print(f"label_smoothness: --move and --turn must be finite and >= 0 and --seed >= 0, got --move {a.move} "
              f"--turn {a.turn} --seed {a.seed}", file=sys.stderr)
        raise SystemExit(2)
    t0 = time.perf_counter()
    if a.quick:
        a.data, tasks = os.path.join(a.out, "data"), ("hammer",)
        generate(a.data, GenerateConfig(tasks=tasks, tools_per_task=3, grasps=16, seed=1), progress=False)
    elif not a.data or not os.path.exists(os.path.join(a.data, MANIFEST)):
        print(f"label_smoothness: --data {a.data!r} holds no dataset manifest", file=sys.stderr)
        raise SystemExit(2)
    model = load_model(a.model)
    rows = per_tool(a.data, tasks, a.move, np.radians(a.turn), model, a.seed, a.with_builtin)
    if not rows:
        print(f"label_smoothness: no shard of {a.data!r} for {', '.join(tasks)} has 3 or more valid rollouts",
              file=sys.stderr)
        raise SystemExit(2)
    summary = summarise(rows)
    from itup_jax.bench import machine_info

    out = {"schema": "itup.smoothness/2", "experiment": "label_smoothness", "quick": a.quick,
           "data": os.path.abspath(a.data), "move_m": a.move, "turn_deg": a.turn, "seed": a.seed,
           "model": os.path.abspath(a.model) if a.model else "shipped", "summary": summary, "per_tool": rows,
           "wall_s": round(time.perf_counter() - t0, 1), "machine": machine_info()}
    os.makedirs(a.out, exist_ok=True)
    atomic_write_json(os.path.join(a.out, "smoothness.json"), out, indent=1)
    print(f"moved {1000 * a.move:g} mm and {a.turn:g} deg, nominal physics; mean over tools of Spearman against "
          "the nominal full induced peak torque (the projected part's beside it):")
    print(f"{'task':8s} {'tools':>5s} {'moved':>7s} {'new draw':>9s} {'SDG-Net':>8s} {'moved, projected':>17s}")
    for t, s in summary.items():
        print(f"{t:8s} {s['tools']:5d} " + " ".join(f"{s[f]:>{w}.3f}" if s[f] is not None else f"{'n/a':>{w}s}"
                                                   for f, w in zip(FIELDS, (7, 9, 8, 17))))
    return out


if __name__ == "__main__":
    main()

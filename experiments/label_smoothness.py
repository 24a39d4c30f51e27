"""Is the measured torque smooth in the grasp? If a grasp moved by a few millimetres and degrees ranks
differently from where it was, no scorer of the grasp's pose can rank it better than that.

    python experiments/label_smoothness.py --data /tmp/sdg_test8 --tasks hammer,knock --out results/smoothness
    python experiments/label_smoothness.py --quick --out /tmp/smooth      # a tiny dataset made here (tests)

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
from itup_jax.dataset import MANIFEST, GenerateConfig, dataset_timesteps, generate, load_shard, unit_tool
from itup_jax.grasp import Grasps, make_grasps, rotation_matrix
from itup_jax.scene import build_scene
from itup_jax.sdgnet import load_model, predict_costs
from itup_jax.simulate import simulate
from itup_jax.stats import spearman
from itup_jax.task import TASK_KINDS

#: The measured label the rankings are judged on: the full induced peak wrist torque.
HEADLINE = "peak_torque_induced"
FIELDS = ("rho_moved", "rho_draw", "rho_sdgnet", "rho_moved_projected")


def moved(p: np.ndarray, R: np.ndarray, move: float, turn: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Positions [N, 3] and rotations [N, 3, 3] (tool frame) of N grasps moved by `move` m along a random
    unit direction in each grasp's x-z plane and turned by +-`turn` rad about its y (jaw) axis."""
    n = len(p)
    phi = rng.uniform(0.0, 2 * np.pi, n)
    step = move * (np.cos(phi)[:, None] * R[:, :, 0] + np.sin(phi)[:, None] * R[:, :, 2])
    a = turn * rng.choice([-1.0, 1.0], n)
    c, s = np.cos(a), np.sin(a)
    Ry = np.zeros((n, 3, 3))
    Ry[:, 0, 0], Ry[:, 0, 2], Ry[:, 1, 1], Ry[:, 2, 0], Ry[:, 2, 2] = c, s, 1.0, -s, c
    return p + step, R @ Ry


def with_moved_copies(a: dict, task_kind: str, variant: int, move: float, turn: float, seed: int) -> Grasps:
    """[2N] grasps: a shard's N grasps `a`, then each of them `moved`. The moves are drawn from `seed`,
    the task and the variant alone, so a tool's moves do not depend on which other tools are run."""
    rng = np.random.default_rng([seed, TASK_KINDS.index(task_kind), variant])
    R = np.stack([np.asarray(rotation_matrix(q), float) for q in a["grasp_q"]])
    p1, R1 = moved(a["grasp_p"], R, move, turn, rng)
    return make_grasps(np.concatenate([a["grasp_p"], p1]), np.concatenate([R, R1]),
                       np.concatenate([a["grasp_width"]] * 2))


def rho(a: np.ndarray, b: np.ndarray) -> float | None:
    """Spearman of a and b, or None (null in the JSON) with fewer than 3 pairs."""
    return spearman(a, b) if len(a) >= 3 else None


def mean_or_none(values) -> float | None:
    """The mean of the values that are not None, or None if there is none."""
    v = np.array([x for x in values if x is not None], float)
    return float(v.mean()) if len(v) else None


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

"""Analytic costs against MuJoCo: which lever arm and which torque projection of docs/design.md predict the
measured wrist torque, and does the slip cost predict measured slip?

    python experiments/analytic_vs_measured.py --out results/analytic_vs_measured        # generates its data
    python experiments/analytic_vs_measured.py --data data/test --out results/avm_rand  # an `itup generate` set
    python experiments/analytic_vs_measured.py --quick --out results/avm_quick                     # tests

Variants of C_tau (`costs.CostParams`): lever arm about the grasp (`grasp`, the default: r = c_contact -
p_grasp), about the tool's centre of mass (`com`, the seed's formula) or about the wrist's force/torque
site 85 mm behind the grasp along its approach axis (`wrist`, where the labels measure), each with the
torque projected off the jaw-closure axis (`perp`, the seed's choice) or in full (`full`); and at the wrist
the torque the pads pass on at the simulator's 100 N per pad (`wrist/passed`: the closure-axis part
capped by the pads' torsional friction). Slip: the seed's form
(grip_force 0) and the form that adds the pads' squeeze (grip_force = the simulator's nominal 100 N).

Per tool (a dataset shard: one tool, one task, its sampled grasps; valid rollouts only) the Spearman rank
correlation between each variant and each measured label; reported as the median over tools, per task
and pooled. A variant that gives every grasp of a tool the same cost (the `com` lever arm with the full
torque does not depend on the grasp) has no ranking: its rho is NaN and it is reported as such.

Beside the costs, three plain descriptors of the grasp are ranked against the measured torques the same
way (`geom[...]`), to show what the measurement follows: `along_handle` (the grasp origin's height along
the tool's +z, the handle axis of every tool here), `com_distance` (|p_grasp - com|, the lever-arm
argument), and `closure_along_swing` (|closure axis . w|, w the unit axis of the tool's peak angular
velocity in the tool frame: a swing about the jaw axis loads the pads in torsion, one across it loads
them in bending; undefined, hence NaN, for tasks that do not turn the tool).

With `--model sdgnet` (or a checkpoint's path) the network's predicted peak torque (`itup.score`'s
`tau`, the full induced peak for the shipped objective) is ranked the same way beside them
(`net[...]`), and so is an equal-weight mix of its ranks and the `wrist/passed` cost's ranks
(`mix[...]`): does the physics add what the network misses on a family it never saw?

By default the data is generated here with nominal physics (no randomisation: the analytic cost uses the
nominal priors, so this isolates the model from the prior's spread); `--data` takes any dataset, e.g. a
randomised one. Writes analytic_vs_measured.json and analytic_vs_measured.png into --out.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.costs import CostParams, wrench_costs
from itup_jax.dataset import GenerateConfig, generate, unit_tool
from itup_jax.dataset_load import MANIFEST, load_shard
from itup_jax.grasp import Grasps
from itup_jax.sim.config import SimConfig
from itup_jax.stats import spearman
from itup_jax.task import TASK_KINDS

TORQUE_VARIANTS = {f"{lever}/{proj}": CostParams(lever_arm=lever, torque_projection=proj)
                   for lever in ("grasp", "com", "wrist") for proj in ("perp", "full")}
TORQUE_VARIANTS["wrist/passed"] = CostParams(lever_arm="wrist", torque_projection="passed",
                                             grip_force=SimConfig().grip_force)
SLIP_VARIANTS = {"seed": CostParams(grip_force=0.0), "squeeze": CostParams(grip_force=SimConfig().grip_force)}
TORQUE_LABELS = ("peak_torque", "peak_torque_induced", "peak_torque_projected")
GEOMETRY = ("along_handle", "com_distance", "closure_along_swing")
SLIP_LABELS = ("slip_translation", "slip_rotation")


def per_tool(data_dir: str, model: str | None = None) -> tuple[list[dict], dict]:
    """One row per shard: Spearman of every (variant, label) pair (and, with `model`, of the network's
    prediction and of its rank mix with `wrist/passed`)."""
    with open(os.path.join(data_dir, MANIFEST)) as fh:
        manifest = json.load(fh)
    config = GenerateConfig.from_json(manifest["config"])
    rows = []
    for entry in manifest["shards"]:
        a = load_shard(data_dir, entry)  # every row: one batch shape per dataset, one compile per variant
        ok = a["label_valid"]
        if ok.sum() < 3:
            continue
        tool, task = unit_tool(config, entry["task"], entry["variant"])
        grasps = Grasps(a["grasp_p"], a["grasp_q"], a["grasp_width"])
        row = {"task": entry["task"], "variant": entry["variant"], "tool": tool.name, "n": int(ok.sum())}
        # each distinct parameter set once (a torque variant and a slip variant may share theirs)
        costs = {params: wrench_costs(tool, task, grasps, params)
                 for params in {*TORQUE_VARIANTS.values(), *SLIP_VARIANTS.values()}}
        for name, params in TORQUE_VARIANTS.items():
            c = np.asarray(costs[params].tau, float)[ok]
            for lab in TORQUE_LABELS:
                row[f"tau[{name}]~{lab}"] = spearman(c, a[f"label_{lab}"][ok])
        for name, params in SLIP_VARIANTS.items():
            c = np.asarray(costs[params].slip, float)[ok]
            for lab in SLIP_LABELS:
                row[f"slip[{name}]~{lab}"] = spearman(c, a[f"label_{lab}"][ok])
        if model is not None:
            from scipy.stats import rankdata

            import itup_jax as itup

            net = np.asarray(itup.score(tool, task, grasps, model=model).tau, float)[ok]
            phys = np.asarray(costs[TORQUE_VARIANTS["wrist/passed"]].tau, float)[ok]
            mix = rankdata(net) + rankdata(phys)
            name = os.path.basename(str(model).rstrip("/"))
            for lab in TORQUE_LABELS:
                row[f"net[{name}]~{lab}"] = spearman(net, a[f"label_{lab}"][ok])
                row[f"mix[{name}+wrist/passed]~{lab}"] = spearman(mix, a[f"label_{lab}"][ok])
        for name, d in grasp_descriptors(tool, task, a).items():
            for lab in TORQUE_LABELS:
                row[f"geom[{name}]~{lab}"] = spearman(d[ok], a[f"label_{lab}"][ok])
        rows.append(row)
    return rows, manifest["config"]


def grasp_descriptors(tool, task, a: dict) -> dict[str, np.ndarray]:
    """`GEOMETRY` descriptors [N] of a shard's grasps (tool frame; see the module docstring)."""
    from itup_jax.rotations import quat_to_matrix

    R = np.asarray(quat_to_matrix(np.asarray(a["grasp_q"], float)), float)  # [N, 3, 3] tool <- grasp
    p = np.asarray(a["grasp_p"], float)
    R_wt = np.asarray(task.traj.R_world_tool, float)
    w_body = np.einsum("tji,tj->ti", R_wt, np.asarray(task.traj.w_world, float))  # [T, 3] tool frame
    k = int(np.argmax(np.linalg.norm(w_body, axis=-1)))
    speed = float(np.linalg.norm(w_body[k]))
    swing = np.abs(R[:, :, 1] @ (w_body[k] / speed)) if speed > 1e-6 else np.full(len(p), np.nan)
    return {"along_handle": p[:, 2], "com_distance": np.linalg.norm(p - np.asarray(tool.params.com, float), axis=-1),
            "closure_along_swing": swing}


def summarise(rows: list[dict]) -> dict:
    """Median rho over tools (and how many tools had a defined rho), per task and pooled."""
    keys = [k for k in rows[0] if "~" in k]
    out = {}
    for task in sorted({r["task"] for r in rows}) + ["all"]:
        sel = [r for r in rows if task == "all" or r["task"] == task]
        out[task] = {}
        for k in keys:
            v = np.array([r[k] for r in sel], float)
            ok = np.isfinite(v)
            out[task][k] = {"median": float(np.median(v[ok])) if ok.any() else None, "tools": int(ok.sum())}
    return out


def verdict(summary: dict, n_tools: int) -> dict:
    """For each measured label, the variant with the highest pooled median rho (`positive` says whether it
    is above 0 at all) among the variants that
    rank the grasps of at least half of the tools (a variant constant on most tools is no predictor;
    its median over the few others would not compare like with like). None if no variant qualifies."""
    out = {}
    for lab in TORQUE_LABELS + SLIP_LABELS:
        fam = "tau" if lab in TORQUE_LABELS else "slip"
        cands = {k: v["median"] for k, v in summary["all"].items() if k.startswith(fam) and k.endswith("~" + lab)
                 and v["median"] is not None and 2 * v["tools"] >= n_tools}
        if cands:
            best = max(cands, key=cands.get)
            out[lab] = {"variant": best[best.index("[") + 1:best.index("]")], "median_rho": cands[best],
                        "tools": summary["all"][best]["tools"], "positive": cands[best] > 0}
        else:
            out[lab] = None
    return out


def plot(summary: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from itup_jax.plotting import save_figure

    tasks = [t for t in summary if t != "all"] + ["all"]
    panels = (("tau", TORQUE_VARIANTS, TORQUE_LABELS), ("slip", SLIP_VARIANTS, SLIP_LABELS))
    fig, axes = plt.subplots(2, 1, figsize=(8.5, 8.5), gridspec_kw={"height_ratios": [12, 4]})
    for ax, (fam, variants, labels) in zip(axes, panels):
        rowsk = [f"{fam}[{v}]~{lab}" for lab in labels for v in variants]
        m = np.array([[summary[t][k]["median"] if summary[t][k]["median"] is not None else np.nan for t in tasks]
                      for k in rowsk], float)
        im = ax.imshow(m, vmin=-1, vmax=1, cmap="RdBu_r", aspect="auto")
        for i in range(m.shape[0]):
            for j in range(m.shape[1]):
                ax.text(j, i, "n/a" if np.isnan(m[i, j]) else f"{m[i, j]:+.2f}", ha="center", va="center", fontsize=7)
        ax.set_xticks(range(len(tasks)), tasks)
        ax.set_yticks(range(len(rowsk)), [k.replace("~", "  vs  ") for k in rowsk], fontsize=7)
    axes[0].set_title("C_tau variant (lever/projection) vs measured torque")
    axes[1].set_title("C_s variant vs measured slip")
    fig.colorbar(im, ax=axes, shrink=0.8, label="Spearman rho (median over tools)")
    save_figure(fig, path, dpi=110, bbox_inches="tight")


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=None, help="an `itup generate` folder (default: generate one in OUT/data)")
    ap.add_argument("--tasks", default=",".join(TASK_KINDS))
    ap.add_argument("--tools-per-task", type=int, default=3)
    ap.add_argument("--grasps", type=int, default=128)
    ap.add_argument("--randomize", action="store_true", help="generate with randomised physics (default: nominal)")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="hammer, 2 tools, 16 grasps (tests)")
    ap.add_argument("--model", default=None,
                    help="also rank an SDG-Net's predicted torque ('sdgnet': the shipped checkpoint, or a path) and "
                    "its rank mix with the wrist/passed cost")
    ap.add_argument("--out", default="results/analytic_vs_measured")
    a = ap.parse_args(argv)
    if a.quick:
        a.tasks, a.tools_per_task, a.grasps = "hammer", 2, 16
    os.makedirs(a.out, exist_ok=True)
    t0 = time.perf_counter()
    if a.data is None:
        a.data = os.path.join(a.out, "data")
        tasks = tuple(t for t in a.tasks.split(",") if t)
        generate(a.data, GenerateConfig(tasks=tasks, tools_per_task=a.tools_per_task, grasps=a.grasps, seed=a.seed,
                                        randomize=a.randomize), progress=not a.quick)
    elif not os.path.exists(os.path.join(a.data, MANIFEST)):
        print(f"analytic_vs_measured: --data {a.data!r} holds no dataset manifest", file=sys.stderr)
        raise SystemExit(2)
    rows, config = per_tool(a.data, a.model)
    if not rows:
        print(f"analytic_vs_measured: no shard of {a.data!r} has 3 or more valid rollouts", file=sys.stderr)
        raise SystemExit(2)
    summary = summarise(rows)
    best = verdict(summary, len(rows))
    from itup_jax.bench import machine_info

    out = {"schema": "itup.analytic_vs_measured/1", "experiment": "analytic_vs_measured", "quick": a.quick, "data": a.data, "data_config": config,
           "summary": summary, "verdict": best, "per_tool": rows, "wall_s": round(time.perf_counter() - t0, 1),
           "machine": machine_info()}
    atomic_write_json(os.path.join(a.out, "analytic_vs_measured.json"), out, indent=1)
    plot(summary, os.path.join(a.out, "analytic_vs_measured.png"))
    tasks = [t for t in summary if t != "all"] + ["all"]
    print(f"{'variant vs measured':48s}" + "".join(f"{t:>8s}" for t in tasks))
    for k in summary["all"]:
        print(f"{k:48s}" + "".join(
            f"{summary[t][k]['median']:+8.2f}" if summary[t][k]["median"] is not None else f"{'n/a':>8s}" for t in tasks))
    for lab, v in best.items():
        print(f"best for {lab}: " + ("none defined" if v is None else f"{v['variant']} (median rho {v['median_rho']:+.2f})"
                                     + ("" if v["positive"] else ": no variant ranks positively, none predicts it")))
    print(f"wrote {a.out}/analytic_vs_measured.json, analytic_vs_measured.png ({out['wall_s']} s)")
    return out


if __name__ == "__main__":
    main()

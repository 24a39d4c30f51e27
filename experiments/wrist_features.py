"""Does SDG-Net rank new tool families better when it is given the wrist's rigid-body torque, as input or
as the prediction it learns the residual of?
The analytic torque at the wrist, with the closure-axis part capped by the pads' torsional friction
('wrist/passed', docs/results.md "Why the ranking does not carry to new families"), ranks the measured
full induced peak torque at 0.30-0.64 on held-out families where the network, which never saw them, ranks
at 0.10-0.31; mixing the two rankings after the fact does not help. Here the physics goes into the
network, in two ways:
  * as input: `sdgnet.features.FeatureSpec(wrist=True)` appends six features (the wrist torque's peak per
    grasp-frame axis, its peak norm, the peak the pads pass on, the peak grip demand about the grasp;
    each log1p(x / scale), the targets' own transform);
  * as the residual's base: `FeatureSpec(wrist=True, residual=True)` also appends the rigid-body model's
    prediction of the torque components and grip demand the network regresses, and the network learns
    only what it adds to them (`sdgnet.model.residual_base`): where it has learnt nothing, it predicts
    the physics.
Every arm is trained with the shipped checkpoint's recipe on the same rows, so the inputs and the
residual are the only differences; each also without the tool's shape near the grasp (the 64 occupancy
features). The datasets' features are made again from their tools, tasks and grasps (no rollout is
repeated; the base features so made are checked against the stored ones).

    python experiments/wrist_features.py --train data/train_a data/train_b data/train_c data/train_d \\
        --eval builtin=data/test screwdriver=data/families/screwdriver spanner=data/families/spanner \\
               pry_bar=data/families/pry_bar hatchet=data/families/hatchet squeegee=data/families/squeegee \\
        --out results/wrist_features
    python experiments/wrist_features.py --quick --out results/wf_quick       # tiny datasets made in --out (tests)

Per evaluation dataset and task, the median over its tools of the Spearman rho between each network's
predicted full induced peak torque (the norm of its three torque outputs) and the measured one, the same
for grip demand, and the analytic 'wrist/passed' torque's rho beside them (the block's own feature, no
training). No evaluation tool is in the training data (the family datasets hold families the training
rows do not; `data/test` holds unseen stretched tools of the built-in families and the built-in tools,
which the training rows hold too: its `builtin` row reads variants >= 1 only). Writes wrist_features.json.

The reading, written before the residual arms' first run (`reading` in the JSON): an arm carries the
physics if its median over the held-out family rows (mean over seeds) exceeds both `base`'s and the
analytic wrist/passed torque's alone by more than twice the larger spread between seeds (the arm's or
`base`'s; a seed's figure is the median over the rows of that seed's medians), while no built-in row
loses more than 0.05 against `base`. Of the arms that carry, the one with the highest held-out median
is chosen (input or residual, with or without the shape); if none carries, the shipped input stays.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from itup_jax.atomic import atomic_write_json

#: The networks compared: (name, the wrist block in the input, the occupancy grid in the input, the
#: residual block: the network learns the residual on the rigid-body prediction). The `_no_shape` arms keep
#: everything but the tool's shape near the grasp.
ARMS = (("base", False, True, False), ("wrist", True, True, False), ("wrist_no_shape", True, False, False),
        ("residual", True, True, True), ("residual_no_shape", True, False, True))


def arm_spec(arm: tuple):
    """The arm's `FeatureSpec`."""
    from itup_jax.sdgnet.features import FeatureSpec

    return FeatureSpec(wrist=arm[1], residual=arm[3])


def _tools(manifests: list[dict]) -> dict:
    """(task, tool name) -> (Tool, Task) of every shard of the datasets, each built once."""
    from itup_jax.dataset import GenerateConfig, unit_tool

    out = {}
    for m in manifests:
        config = GenerateConfig.from_json(m["config"])
        for entry in m["shards"]:
            tool, task = unit_tool(config, entry["task"], entry["variant"])
            out.setdefault((entry["task"], tool.name), (tool, task, entry["variant"]))
    return out


def refeature(data: dict, manifests: list[dict], specs: list) -> tuple[list[np.ndarray], np.ndarray]:
    """[N, spec.size] features of every row of `data` (`dataset_load.load_datasets`) under each of `specs`,
    made again from the rows' tools, tasks and grasps (each tool built and its loads computed once), and
    [N] the variant of each row's tool."""
    from itup_jax.grasp import Grasps
    from itup_jax.sdgnet.features import batched_features, tool_field
    from itup_jax.wrench import task_loads

    tools = _tools(manifests)
    out = [np.zeros((len(data["task"]), spec.size), np.float32) for spec in specs]
    variant = np.zeros(len(data["task"]), int)
    for key in dict.fromkeys(zip(data["task"].tolist(), data["tool"].tolist())):
        rows = np.flatnonzero((data["task"] == key[0]) & (data["tool"] == key[1]))
        tool, task, variant[rows] = tools[key]
        g = Grasps(data["grasp_p"][rows], data["grasp_q"][rows], data["grasp_width"][rows])
        loads = task_loads(tool.params, task)
        for x, spec in zip(out, specs):
            x[rows] = np.asarray(batched_features(tool_field(tool, spec), loads, tool.params, g, spec=spec), np.float32)
    return out, variant


def load(paths: list[str], spec) -> tuple[dict, dict, np.ndarray]:
    """The datasets' rows with their features made again under the base spec and under `spec`, and
    each row's variant; refuses a base remake that differs from the stored features (a wrong tool)."""
    from itup_jax.dataset_load import load_datasets
    from itup_jax.sdgnet.features import FeatureSpec

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data, manifests = load_datasets(paths)
    (made, wrist), variant = refeature(data, manifests, [FeatureSpec(**manifests[0]["config"]["feature_spec"]), spec])
    err = float(np.abs(made - data["features"]).max())
    if err > 1e-4:
        raise RuntimeError(f"datasets {paths}: features made again differ from the stored ones by {err:g}")
    return {**data, "features": made}, {**data, "features": wrist}, variant


def arm_features(arm: tuple, base: np.ndarray, full: np.ndarray) -> np.ndarray:
    """The rows' features as the arm sees them, from the base spec's and the full spec's (wrist and
    residual blocks) features: the base's, or the full's up to the arm's size (its occupancy columns
    zero when it does without them: a constant column is normalised to zero and carries nothing)."""
    from itup_jax.sdgnet.features import RESIDUAL_SIZE, FeatureSpec

    _, with_wrist, with_shape, with_residual = arm
    if not with_wrist:
        x = base.copy()
    elif with_residual:
        x = full.copy()
    else:
        x = full[:, : full.shape[1] - RESIDUAL_SIZE].copy()
    if not with_shape:
        x[:, :FeatureSpec().grid ** 3] = 0.0
    assert x.shape[1] == arm_spec(arm).size
    return x


def evaluate(models: dict, data: dict, variant: np.ndarray, feats: dict, only_new: bool) -> dict:
    """Per task: the median over tools of each model's Spearman (full induced torque, grip demand) and
    the analytic wrist/passed torque's (the wrist block's feature 4). `models` and `feats` (the rows'
    features as each model sees them) share their keys."""
    from itup_jax.sdgnet.features import WRIST_TORQUE_SCALE, FeatureSpec
    from itup_jax.sdgnet.model import predict_costs
    from itup_jax.stats import spearman

    out = {}
    for kind in sorted(set(data["task"].tolist())):
        per = {f"{a}_{q}": [] for a in models for q in ("induced", "grip")} | {"passed_induced": []}
        for tool in dict.fromkeys(data["tool"][data["task"] == kind].tolist()):
            rows = (data["task"] == kind) & (data["tool"] == tool)
            if only_new and variant[rows][0] == 0:
                continue
            if rows.sum() < 3:
                continue
            y = data["label_peak_torque_induced"][rows]
            for a, model in models.items():
                p = predict_costs(model, feats[a][rows], kind)
                per[f"{a}_induced"].append(spearman(np.asarray(p["tau"], float), y))
                per[f"{a}_grip"].append(spearman(np.asarray(p["grip"], float), data["label_grip_demand"][rows]))
            passed = WRIST_TORQUE_SCALE * np.expm1(data["wrist_features"][rows][:, FeatureSpec().size + 4])
            per["passed_induced"].append(spearman(passed, y))
        out[kind] = {k: float(np.nanmedian(v)) if v else None for k, v in per.items()}
        out[kind]["tools"] = len(per["passed_induced"])
    return out


def _quick_data(out: str) -> tuple[list[str], list[str]]:
    """Two tiny datasets (training: the built-in hammer and one variant; evaluation: one spanner)."""
    from itup_jax.dataset import GenerateConfig, generate

    train_dir, eval_dir = os.path.join(out, "data", "train"), os.path.join(out, "data", "spanner")
    if not os.path.exists(os.path.join(train_dir, "manifest.json")):
        generate(train_dir, GenerateConfig(tasks=("hammer",), tools_per_task=2, grasps=24, seed=3), progress=False)
    if not os.path.exists(os.path.join(eval_dir, "manifest.json")):
        generate(eval_dir, GenerateConfig(tasks=("hammer",), tools_per_task=1, grasps=24, seed=4, family="spanner"),
                 progress=False)
    return [train_dir], [f"spanner={eval_dir}"]


def main(argv=None) -> dict:
    from itup_jax.bench import machine_info
    from itup_jax.sdgnet.checkpoint import load_model, save_model
    from itup_jax.sdgnet.config import DEFAULT_MODEL, TrainConfig
    from itup_jax.sdgnet.features import FeatureSpec
    from itup_jax.sdgnet.training import train

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", nargs="+", default=[], metavar="DIR", help="training datasets (itup generate)")
    ap.add_argument("--eval", nargs="+", default=[], metavar="NAME=DIR", help="evaluation datasets")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2],
                    help="training seeds; every arm is trained once per seed (default %(default)s)")
    ap.add_argument("--epochs", type=int, default=None, help="training epochs (default: the shipped recipe's)")
    ap.add_argument("--quick", action="store_true", help="tiny datasets made in --out, 5 epochs (for the tests)")
    ap.add_argument("--out", default="results/wrist_features")
    args = ap.parse_args(argv)
    if args.quick:
        args.train, args.eval = _quick_data(args.out)
        args.epochs = 5
    if not args.train or not args.eval:
        ap.error("give --train DIR ... and --eval NAME=DIR ... (or --quick)")
    evals = []
    for e in args.eval:
        name, sep, d = e.partition("=")
        if not sep or not os.path.exists(os.path.join(d, "manifest.json")):
            ap.error(f"--eval {e!r}: give NAME=DIR with DIR an itup generate folder")
        evals.append((name, d))
    for d in args.train:
        if not os.path.exists(os.path.join(d, "manifest.json")):
            ap.error(f"--train {d!r}: not an itup generate folder (no manifest.json)")

    t0 = time.perf_counter()
    wspec = FeatureSpec(wrist=True, residual=True)  # every block; each arm takes its columns
    base_rows, wrist_rows, _ = load(args.train, wspec)
    recipe = load_model(DEFAULT_MODEL).train_config
    os.makedirs(args.out, exist_ok=True)
    models, seconds, arm_of = {}, {}, {}
    for seed in args.seeds:
        config = TrainConfig(**{**recipe.__dict__, "seed": seed,
                                **({} if args.epochs is None else {"epochs": args.epochs, "finetune_epochs": 0})})
        for arm in ARMS:
            key = f"{arm[0]}@{seed}"
            arm_of[key] = arm
            rows = {**base_rows, "features": arm_features(arm, base_rows["features"], wrist_rows["features"])}
            fs = arm_spec(arm).to_dict()
            t = time.perf_counter()
            models[key] = train(rows, config, feature_spec=fs, progress=False)
            seconds[key] = time.perf_counter() - t
            save_model(os.path.join(args.out, f"sdgnet_{arm[0]}_seed{seed}.npz"), models[key])
    results = {}
    for name, d in evals:
        b, w, variant = load([d], wspec)
        b["wrist_features"] = w["features"]
        feats = {k: arm_features(arm_of[k], b["features"], w["features"]) for k in models}
        results[name] = evaluate(models, b, variant, feats, only_new=name == "builtin")
    table = summarise(results, args.seeds)
    verdict = reading(results, table, args.seeds)
    summary = {"schema": "itup.wrist_features/2", "machine": machine_info(), "seconds": time.perf_counter() - t0,
               "train_seconds": seconds, "train": args.train, "eval": dict(evals), "recipe": recipe.__dict__,
               "seeds": args.seeds, "arms": {a[0]: {"wrist": a[1], "shape": a[2], "residual": a[3],
                                                    "features": arm_spec(a).size} for a in ARMS},
               "results": results, "table": table, "reading": verdict}
    atomic_write_json(os.path.join(args.out, "wrist_features.json"), summary, indent=2)
    print_table(table)
    print(f"reading: {verdict['choice']} ({verdict['why']})")
    return summary


def reading(results: dict, table: dict, seeds: list[int]) -> dict:
    """The rule of the module docstring: per arm, its held-out median, spread between seeds, margin over
    `base`, whether the built-in rows hold, whether it carries the physics; and the choice."""
    held_sets = [n for n in results if n != "builtin"]
    rows = [(n, k) for n in held_sets for k in results[n]]

    def per_seed(arm):
        out = []
        for s_ in seeds:
            v = [results[n][k][f"{arm}@{s_}_induced"] for n, k in rows]
            v = [x for x in v if x is not None]
            if v:
                out.append(float(np.median(v)))
        return out

    key = "held-out families (median of rows)"
    if key not in table:
        return {"choice": "base", "why": "no held-out family among the evaluation sets", "arms": {}}
    spread = {a: (max(v) - min(v) if v else 0.0) for a in (arm[0] for arm in ARMS) for v in [per_seed(a)]}
    base_mean, passed = table[key]["base"]["mean"], table[key]["passed"]
    builtin = {k: r for k, r in table.items() if k.startswith("builtin")}
    arms = {}
    for a, *_ in ARMS[1:]:
        mean = table[key][a]["mean"]
        margin = 2.0 * max(spread[a], spread["base"])
        losses = {k: r["base"]["mean"] - r[a]["mean"] for k, r in builtin.items()
                  if r[a]["mean"] is not None and r["base"]["mean"] is not None}
        holds = all(v <= 0.05 for v in losses.values())
        arms[a] = {"held_out": mean, "spread": spread[a], "margin": margin, "over_base": mean - base_mean,
                   "over_passed": mean - passed, "builtin_loss": max(losses.values(), default=0.0),
                   "carries": bool(mean - base_mean > margin and mean - passed > margin and holds)}
    carrying = [a for a, r in arms.items() if r["carries"]]
    if not carrying:
        return {"choice": "base", "arms": arms, "why": "no arm beats both the shipped input and the physics alone "
                "on the held-out families by its margin without a built-in loss over 0.05"}
    best = max(carrying, key=lambda a: arms[a]["held_out"])
    return {"choice": best, "arms": arms, "why": f"{best}: held-out {arms[best]['held_out']:.2f} against base "
            f"{base_mean:.2f} and the physics alone {passed:.2f} (margin {arms[best]['margin']:.2f})"}


def summarise(results: dict, seeds: list[int]) -> dict:
    """Per evaluation set and task, and for the held-out families together: each arm's Spearman (full
    induced torque) as the mean over seeds of the median over tools, its range over seeds, and the
    analytic wrist/passed torque's."""
    rows = {}
    for name, per in results.items():
        for kind, r in per.items():
            row = {"tools": r["tools"], "passed": r["passed_induced"]}
            for arm, *_ in ARMS:
                v = [r[f"{arm}@{s}_induced"] for s in seeds if r[f"{arm}@{s}_induced"] is not None]
                g = [r[f"{arm}@{s}_grip"] for s in seeds if r[f"{arm}@{s}_grip"] is not None]
                row[arm] = {"mean": float(np.mean(v)) if v else None, "min": min(v, default=None),
                            "max": max(v, default=None), "grip": float(np.mean(g)) if g else None}
            rows[f"{name}, {kind}"] = row
    held = [r for k, r in rows.items() if not k.startswith("builtin")]
    if held:
        rows["held-out families (median of rows)"] = {
            "tools": sum(r["tools"] for r in held),
            "passed": float(np.median([r["passed"] for r in held])),
            **{arm: {"mean": float(np.median([r[arm]["mean"] for r in held])),
                     "grip": float(np.median([r[arm]["grip"] for r in held]))} for arm, *_ in ARMS}}
    return rows


def print_table(table: dict) -> None:
    def f(x):
        return "n/a" if x is None else f"{x:.2f}"

    head = " | ".join(f"{a}: induced [seeds] / grip" for a, *_ in ARMS)
    print(f"| set, task | tools | {head} | wrist/passed alone |")
    print("|---|---|" + "---|" * len(ARMS) + "---|")
    for k, r in table.items():
        cells = " | ".join(f"{f(r[a]['mean'])}" + (f" [{f(r[a]['min'])}, {f(r[a]['max'])}]" if "min" in r[a] else "")
                           + f" / {f(r[a]['grip'])}" for a, *_ in ARMS)
        print(f"| {k} | {r['tools']} | {cells} | {f(r['passed'])} |")


if __name__ == "__main__":
    main()

"""Do training families that span the categories' shapes teach SDG-Net the held-out families?

    # the training families' data (`itup_jax/tools/families.py`, `Family.training`) and rehearsal rows
    itup generate --out data/span/baton --family baton --tasks hammer,knock --tools-per-task 16 --grasps 192 --seed 40
    itup generate --out data/span/headed_stick --family headed_stick --tasks hammer,knock --tools-per-task 16 --grasps 192 --seed 40
    itup generate --out data/span/hook --family hook --tasks reach --tools-per-task 24 --grasps 192 --seed 40
    itup generate --out data/span/pusher --family pusher --tasks sweep --tools-per-task 24 --grasps 192 --seed 40
    itup generate --out data/families/builtin --tasks hammer,sweep,knock,reach --tools-per-task 8 --grasps 192 \\
        --seed 31 --variants parts
    python experiments/training_families.py --train data/span/baton data/span/headed_stick data/span/hook \\
        data/span/pusher --rehearse data/families/builtin --out results/training_families
    python experiments/training_families.py --train ... --rehearse ... --from-scratch --out results/training_families_scratch
    # at full scale: the shipped network's own training sets as the rehearsal rows (docs/results.md "Data")
    python experiments/training_families.py --train data/span/baton data/span/headed_stick data/span/hook \\
        data/span/pusher --rehearse data/train_a data/train_b data/train_c data/train_d --from-scratch \\
        --out results/training_families_full
    python experiments/training_families.py --quick --out results/tf_quick          # tiny (tests)

The four training families span what users bring to each category: headless two-segment sticks (thin or
thick, light or heavy tips), handles with light to heavy, centred or lopsided box heads, hooks whose
grasp region reaches the bend, short and wide T-heads on short and long handles. None of them is one of
the five held-out families (screwdriver, spanner, pry bar, hatchet, squeegee), whose tools they bracket.

Models, per adaptation seed (`--seeds`): the shipped checkpoint adapted (`recipes.adapt_on_datasets`,
its recipe's fine-tuning epochs, each kept epoch judged on the data's own held-out tools) on
  * `rehearsed`: the rehearsal rows alone: what adapting does by itself (the control);
  * `trained`: the training families' rows and the rehearsal rows;
and `shipped` itself. Each adapted model's guard reference holds the shipped one's rows and its new rows.
With `--from-scratch`, two more per seed, trained from scratch by the shipped checkpoint's own recipe
(`Model.train_config`, the seed replaced): `scratch_rehearsed` on the rehearsal rows alone and
`scratch_trained` on both (whether the families teach a network that learns them from the start;
with the shipped network's own training sets as the rehearsal rows, ~27,000 rows of the built-in
families, `scratch_rehearsed` is the shipped network made again).
Evaluation (`itup_jax.family_eval`): `--tools` draws per held-out family and task and per built-in
family (seeds 200..; no dataset holds them), `--grasps` candidates the arm can carry, rolled out once
under nominal physics; the same rollouts judge every model. Per model, family and task: the median
Spearman against the measured full induced peak wrist torque and grip demand, how often the guard
fires, the learned and verified picks' outcomes. `--judge-also FAMILY ...` judges more families on the same
terms beside them (e.g. the calibration families, which no arm trains on), reported outside the reading.

The reading, fixed before the first run: the training families teach the held-out ones if `trained`'s
median over the held-out family-task rows (mean over seeds) exceeds `rehearsed`'s by more than twice
the larger spread between its seeds, while no built-in family loses more than 0.05 against `rehearsed`.
`--from-scratch` reads the scratch pair by the same rule (`reading["scratch"]`), written before its
first run. Writes training_families.json.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time

import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.family_eval import family_rollouts, judge, summarise


def _check_dirs(flag: str, dirs: list[str]) -> None:
    from itup_jax.dataset_load import MANIFEST

    for d in dirs:
        if not os.path.isfile(os.path.join(d, MANIFEST)):
            print(f"training_families: {flag} {d!r}: not a dataset folder (no {MANIFEST}; made by itup generate)",
                  file=sys.stderr)
            raise SystemExit(2)


def _quick_data(out: str) -> tuple[list[str], list[str]]:
    """Two tiny datasets in `out`: a training family's and the built-in families' (for the tests)."""
    from itup_jax.dataset import GenerateConfig, generate

    train, rehearse = os.path.join(out, "data", "baton"), os.path.join(out, "data", "builtin")
    generate(train, GenerateConfig(tasks=("knock",), tools_per_task=3, grasps=12, seed=40, family="baton"),
             progress=False)
    generate(rehearse, GenerateConfig(tasks=("knock",), tools_per_task=3, grasps=12, seed=31, variants="parts"),
             progress=False)
    return [train], [rehearse]


def held_out_median(table: dict, rows: list[tuple[str, str]]) -> float | None:
    """The median over the (family, task) rows of a model's per-row median Spearman (full induced torque)."""
    v = [table[f"{f}/{k}"]["median_rho_induced"] for f, k in rows]
    v = [x for x in v if x is not None]
    return float(np.median(v)) if v else None


def _mean(values: list) -> float | None:
    """The mean of the values that are not None (None when none is)."""
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def _reading(table: dict, seeds: list[int], held: list, builtin: list, pair: tuple[str, str],
             also: list | tuple = ()) -> dict:
    """The module's reading of a (control, trained) pair of model kinds: per kind the held-out median per
    seed, its mean and spread, each built-in row's mean, and the same median over the `also` rows
    (--judge-also, outside the rule); `teaches`, `margin`, `largest_builtin_loss`."""
    reading = {}
    for kind in pair:
        per_seed = [held_out_median(table[f"{kind}_s{s}"], held) for s in seeds]
        per_seed = [v for v in per_seed if v is not None]
        also_seed = [held_out_median(table[f"{kind}_s{s}"], list(also)) for s in seeds] if also else []
        reading[kind] = {"held_out_per_seed": per_seed,
                         "also_per_seed": also_seed, "also_mean": _mean(also_seed),
                         "held_out_mean": float(np.mean(per_seed)) if per_seed else None,
                         "held_out_spread": float(np.ptp(per_seed)) if per_seed else None,
                         "builtin_mean": {f"{f}/{k}": _mean([table[f"{kind}_s{s}"][f"{f}/{k}"]["median_rho_induced"]
                                                             for s in seeds])
                                          for f, k in builtin}}
    r, t = reading[pair[0]], reading[pair[1]]
    if r["held_out_mean"] is not None and t["held_out_mean"] is not None:
        margin = 2 * max(r["held_out_spread"], t["held_out_spread"])
        losses = [r["builtin_mean"][b] - t["builtin_mean"][b] for b in r["builtin_mean"]
                  if r["builtin_mean"][b] is not None and t["builtin_mean"][b] is not None]
        loss = max(losses) if losses else 0.0
        reading["teaches"] = bool(t["held_out_mean"] - r["held_out_mean"] > margin and loss <= 0.05)
        reading["margin"], reading["largest_builtin_loss"] = margin, float(loss)
    return reading


def main(argv=None) -> dict:
    from itup_jax.bench import machine_info
    from itup_jax.ood import reference_path
    from itup_jax.sdgnet.checkpoint import load_model, save_model
    from itup_jax.sdgnet.config import DEFAULT_MODEL
    from itup_jax.sdgnet.recipes import adapt_on_datasets, train_on_datasets
    from itup_jax.tools import families

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", nargs="*", default=[], metavar="DIR", help="datasets of the training families")
    ap.add_argument("--rehearse", nargs="*", default=[], metavar="DIR",
                    help="datasets of the checkpoint's own families, in every adaptation")
    ap.add_argument("--seeds", default="0,1,2", help="adaptation seeds, comma-separated (default %(default)s)")
    ap.add_argument("--tools", type=int, default=4, help="evaluation draws per family and task (default %(default)s)")
    ap.add_argument("--grasps", type=int, default=64, help="reachable candidates per evaluation tool (default %(default)s)")
    ap.add_argument("--verify", type=int, default=5, metavar="K", help="the verified pick's shortlist (default %(default)s)")
    ap.add_argument("--epochs", type=int, default=None, help="adaptation epochs (default: the checkpoint's recipe)")
    ap.add_argument("--from-scratch", action="store_true",
                    help="also train the pair from scratch by the shipped checkpoint's recipe (module docstring)")
    ap.add_argument("--judge-also", nargs="*", default=[], metavar="FAMILY",
                    help="families judged beside the held-out ones, outside the reading (e.g. the calibration "
                         "families, which no arm trains on)")
    ap.add_argument("--quick", action="store_true", help="tiny datasets made in --out, one evaluation tool (tests)")
    ap.add_argument("--out", default="results/training_families")
    args = ap.parse_args(argv)
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        print(f"training_families: --seeds {args.seeds!r}: expected comma-separated integers", file=sys.stderr)
        raise SystemExit(2) from None
    if not args.quick:
        if not args.train or not args.rehearse:
            print("training_families: --train and --rehearse each need at least one dataset (or --quick)",
                  file=sys.stderr)
            raise SystemExit(2)
        _check_dirs("--train", args.train)
        _check_dirs("--rehearse", args.rehearse)
    unknown = [f for f in args.judge_also if f not in families.names()]
    if unknown:
        print(f"training_families: --judge-also {' '.join(unknown)}: no such family (itup tools lists them)",
              file=sys.stderr)
        raise SystemExit(2)
    also = [(f, k) for f in args.judge_also for k in families.get(f).tasks]
    os.makedirs(os.path.join(args.out, "models"), exist_ok=True)
    t0 = time.time()
    if args.quick:
        args.train, args.rehearse = _quick_data(args.out)
        seeds, args.tools, args.grasps, args.verify, args.epochs = seeds[:1], 1, 8, 2, 2
        held = [("screwdriver", "knock")]
        builtin = [("mallet", "knock")]
        also = [(f, k) for f, k in also if k == "knock"]  # the tiny models know the knock alone
    else:
        held = [(f, k) for f in families.held_out() for k in families.get(f).tasks]
        builtin = [(f, k) for f in families.names() if families.get(f).builtin for k in families.get(f).tasks]
    models = {"shipped": DEFAULT_MODEL}
    recipe = load_model(DEFAULT_MODEL).train_config
    if args.epochs is not None:
        recipe = dataclasses.replace(recipe, epochs=args.epochs, patience=min(recipe.patience, args.epochs))

    def make(label: str, how: str, dirs: list[str], fit) -> None:
        """Fit one model (`fit(dirs, guard_reference)`), save it beside its guard reference, record it."""
        path = os.path.join(args.out, "models", f"{label}.npz")
        t1 = time.time()
        save_model(path, fit(dirs, reference_path(path)))
        models[label] = path
        print(f"model {label}: {how} on {len(dirs)} datasets in {time.time() - t1:.0f} s", flush=True)

    for seed in seeds:
        for name, dirs in (("rehearsed", list(args.rehearse)), ("trained", list(args.train) + list(args.rehearse))):
            make(f"{name}_s{seed}", "adapted", dirs, lambda d, ref, seed=seed: adapt_on_datasets(
                DEFAULT_MODEL, d, epochs=args.epochs, seed=seed, guard_reference=ref))
            if args.from_scratch:
                config = dataclasses.replace(recipe, seed=seed)
                make(f"scratch_{name}_s{seed}", "trained", dirs,
                     lambda d, ref, config=config: train_on_datasets(d, config, guard_reference=ref))
    evals = []
    for fam, kind in held + builtin + also:
        evals += family_rollouts(fam, (kind,), args.tools, args.grasps)
    print(f"{len(evals)} evaluation tools rolled out ({time.time() - t0:.0f} s)", flush=True)
    rows = {name: [dict(judge(path, ev, args.verify), family=ev["family"]) for ev in evals]
            for name, path in models.items()}
    table = {name: {f"{f}/{k}": summarise([r for r in rs if r["family"] == f and r["task"] == k])
                    for f, k in held + builtin + also} for name, rs in rows.items()}
    reading = _reading(table, seeds, held, builtin, ("rehearsed", "trained"), also)
    reading["shipped"] = {"held_out": held_out_median(table["shipped"], held),
                          "also": held_out_median(table["shipped"], also) if also else None}
    if args.from_scratch:
        reading["scratch"] = _reading(table, seeds, held, builtin, ("scratch_rehearsed", "scratch_trained"), also)
    doc = {"schema": "itup.training_families/1", "train": [os.path.abspath(d) for d in args.train],
           "rehearse": [os.path.abspath(d) for d in args.rehearse], "seeds": seeds, "tools": args.tools,
           "grasps": args.grasps, "verify": args.verify, "epochs": args.epochs, "from_scratch": args.from_scratch,
           "held_out": [f"{f}/{k}" for f, k in held], "builtin": [f"{f}/{k}" for f, k in builtin],
           "judged_also": [f"{f}/{k}" for f, k in also],
           "reading": reading, "table": table, "rows": rows, "wall_s": round(time.time() - t0, 1),
           "machine": machine_info()}
    atomic_write_json(os.path.join(args.out, "training_families.json"), doc)
    names = list(models)
    w = max(13, *map(len, names))
    print(f"{'family/task':22s} " + " ".join(f"{n:>{w}s}" for n in names))
    for f, k in held + builtin + also:
        cells = [table[n][f"{f}/{k}"] for n in names]
        print(f"{f + '/' + k:22s} " + " ".join(
            f"{c['median_rho_induced']:+.2f} g{c['guard_fired']:.2f}".rjust(w) if c["median_rho_induced"] is not None
            else "-".rjust(w) for c in cells))
    print({k: v for k, v in reading.items() if k != "shipped"} | {"shipped": reading["shipped"]})
    return doc


if __name__ == "__main__":
    main()

"""Leave one tool family out: does SDG-Net rank a family's grasps when it was trained on the others, and
does the guard fire where it does not?

    # data: one dataset per held-out-able family (itup generate --family F --tasks <its tasks>)
    itup generate --out results/fam_quick/screwdriver --family screwdriver --tasks knock --tools-per-task 8 --grasps 192 --seed 30
    ...
    python experiments/leave_family_out.py --data screwdriver=results/fam_quick/screwdriver spanner=results/fam_quick/spanner \\
        pry_bar=results/fam_quick/pry_bar hatchet=results/fam_quick/hatchet squeegee=results/fam_quick/squeegee --out results/lofo
    python experiments/leave_family_out.py --quick --out results/lofo_quick          # two tiny families (tests)

Models, each the shipped checkpoint adapted (`training.adapt_on_datasets`: every task's network continues
from its weights on the new rows, kept unless an epoch beats it on held-out tools) and given a guard
reference of the shipped one's rows and the new rows (`adapt_on_datasets(guard_reference=...)`). With
`--rehearse DIR ...`, rows of the checkpoint's own families join every adaptation (without them a
network adapted on new families alone forgets the old ones; docs/results.md):
  * `shipped`: the shipped checkpoint itself (none of the families in --data);
  * `all`: adapted on every family in --data;
  * `without_<F>`: adapted on every family but F.
Evaluation tools: per family in --data and per built-in family, `--tools` draws per task it can do
(`tools.families.draw`, seeds 200..: the test draws of experiments/ood_guard.py, none of them in any dataset),
each with `--grasps` candidates the arm can carry, rolled out once in native MuJoCo under nominal
physics; the same rollouts judge every model. Per model and family: the median Spearman rho between
predicted and measured full induced peak wrist torque and grip demand, how often the guard fires, and
for the learned pick (lowest predicted total) and the verified pick (`--verify` best by predicted total,
the lowest measured total among them) how often each did the task, failed in the grip, and did the task
and held ("ok"). The leave-one-out reading of a
family F is `without_<F>` on F's tools. Writes lofo.json.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

from itup_jax.atomic import atomic_write_json
from itup_jax.family_eval import family_rollouts, judge, summarise


def main(argv=None) -> dict:
    from itup_jax.bench import machine_info
    from itup_jax.dataset import GenerateConfig, generate
    from itup_jax.ood import reference_path
    from itup_jax.sdgnet.checkpoint import save_model
    from itup_jax.sdgnet.config import DEFAULT_MODEL
    from itup_jax.sdgnet.recipes import adapt_on_datasets
    from itup_jax.tools import families

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", nargs="+", default=[], metavar="FAMILY=DIR", help="one dataset per family")
    ap.add_argument("--tools", type=int, default=4, help="evaluation draws per family and task (default %(default)s)")
    ap.add_argument("--grasps", type=int, default=64, help="reachable candidates per evaluation tool (default %(default)s)")
    ap.add_argument("--verify", type=int, default=5, metavar="K", help="the verified pick's shortlist (default %(default)s)")
    ap.add_argument("--epochs", type=int, default=None, help="adaptation epochs (default: the checkpoint's recipe)")
    ap.add_argument("--rehearse", nargs="*", default=[], metavar="DIR",
                    help="datasets of the checkpoint's own families added to every adaptation, so that it keeps "
                    "what it knew (itup generate --tasks hammer,sweep,knock,reach --variants parts ...)")
    ap.add_argument("--quick", action="store_true", help="two tiny families made in --out (for the tests)")
    ap.add_argument("--out", default="results/lofo")
    args = ap.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    if args.quick:
        args.data, args.tools, args.grasps, args.verify, args.epochs = [], 1, 8, 2, 2
        for fam in ("screwdriver", "squeegee"):
            d = os.path.join(args.out, "data", fam)
            generate(d, GenerateConfig(tasks=families.get(fam).tasks, tools_per_task=3, grasps=12, seed=30, family=fam),
                     progress=False)
            args.data.append(f"{fam}={d}")
    data = {}
    for item in args.data:
        fam, sep, d = item.partition("=")
        if not sep or fam not in families.names() or not os.path.isdir(d):
            print(f"leave_family_out: --data {item!r}: expected FAMILY=DIR with a family of {families.names()} "
                  "and an existing dataset folder", file=sys.stderr)
            raise SystemExit(2)
        data[fam] = d
    if len(data) < 2:
        print("leave_family_out: --data needs at least two families", file=sys.stderr)
        raise SystemExit(2)
    t0 = time.time()
    models = {"shipped": DEFAULT_MODEL}
    os.makedirs(os.path.join(args.out, "models"), exist_ok=True)
    for name, fams in [("all", list(data))] + [(f"without_{f}", [g for g in data if g != f]) for f in data]:
        path = os.path.join(args.out, "models", f"{name}.npz")
        dirs = [data[f] for f in fams] + list(args.rehearse)
        t1 = time.time()
        m = adapt_on_datasets(DEFAULT_MODEL, dirs, epochs=args.epochs, seed=0, guard_reference=reference_path(path))
        save_model(path, m)
        models[name] = path
        print(f"model {name}: adapted on {', '.join(fams)} in {time.time() - t1:.0f} s", flush=True)
    # the built-in families' tools measure what adapting costs on the families the checkpoint knew
    builtin = [] if args.quick else [f for f in families.names() if families.get(f).builtin]
    evals = []
    for fam in list(data) + builtin:
        evals += family_rollouts(fam, families.get(fam).tasks, args.tools, args.grasps)
    print(f"{len(evals)} evaluation tools rolled out ({time.time() - t0:.0f} s)", flush=True)
    rows = {name: [dict(judge(path, ev, args.verify), family=ev["family"]) for ev in evals]
            for name, path in models.items()}
    table = {name: {fam: summarise([r for r in rs if r["family"] == fam])
                    for fam in list(data) + builtin} for name, rs in rows.items()}
    held_out = {f: {"without": table[f"without_{f}"][f], "shipped": table["shipped"][f], "all": table["all"][f]}
                for f in data}
    doc = {"schema": "itup.lofo/1", "families": list(data), "builtin": builtin, "tools": args.tools,
           "rehearse": [os.path.abspath(d) for d in args.rehearse],
           "grasps": args.grasps, "verify": args.verify, "epochs": args.epochs, "held_out": held_out, "table": table,
           "rows": rows, "wall_s": round(time.time() - t0, 1), "machine": machine_info()}
    atomic_write_json(os.path.join(args.out, "lofo.json"), doc)
    for f, r in held_out.items():
        print(f"{f:12s} " + "  ".join(f"{k}: rho {v['median_rho_induced']:+.2f} guard {v['guard_fired']:.2f} "
                                      f"learned {v['learned_ok']:.2f} verified {v['verified_ok']:.2f}"
                                      for k, v in r.items() if v["median_rho_induced"] is not None))
    print(json.dumps({name: {f: (t["median_rho_induced"], t["guard_fired"]) for f, t in tb.items() if f in builtin}
                      for name, tb in table.items()}))
    return doc


if __name__ == "__main__":
    main()

"""The out-of-distribution guard's reference for the shipped checkpoints: the features of their training
inputs, sampled per task (`itup_jax/models/training_reference.npz`, `ood.sample_reference`).

    python experiments/ood_reference.py --out itup_jax/models/training_reference.npz

The shipped checkpoints were trained on four `itup generate` runs of the built-in tools' variants, and the
default one also on four runs of the training families (docs/results.md, "Data"); the reference holds all
eight, so it covers both checkpoints' inputs. A row's features depend on the tool, the task and the grasp
only, not on its rollout, so they are rebuilt here without simulating: each shard's tool and candidates (`dataset.shard_candidates`, as `dataset.make_shard`
draws them), the ones the arm can carry (`sim.arm.reachable`: the rows a rollout can make valid), and
their features (`dataset.shard_features`). About 2 minutes on 2 cores.
A checkpoint trained by `itup train` gets its reference from its own training rows instead.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

#: The shipped checkpoints' training runs (`itup generate` flags: tasks, tools per task, seed, variants,
#: family, grasps); the last four, the training families', are the default checkpoint's only.
SHIPPED_RUNS = ((("hammer", "sweep", "knock"), 48, 20, "stretch", None, 256),
                (("hammer", "sweep", "knock"), 8, 21, "parts", None, 256),
                (("reach",), 40, 22, "stretch", None, 256), (("reach",), 8, 23, "parts", None, 256),
                (("hammer", "knock"), 16, 40, "stretch", "baton", 192),
                (("hammer", "knock"), 16, 40, "stretch", "headed_stick", 192),
                (("reach",), 24, 40, "stretch", "hook", 192), (("sweep",), 24, 40, "stretch", "pusher", 192))


def training_features(runs=SHIPPED_RUNS) -> tuple[np.ndarray, np.ndarray]:
    """(features [N, F], tasks [N]) of the reachable candidates of every shard of `runs`."""
    from itup_jax.dataset import GenerateConfig, shard_candidates, shard_features, shard_units
    from itup_jax.sim.arm import reachable

    feats, tasks = [], []
    for kinds, tools, seed, variants, family, grasps in runs:
        c = GenerateConfig(tasks=kinds, tools_per_task=tools, grasps=grasps, seed=seed, variants=variants,
                           contact="flat", family=family)
        for kind, v in shard_units(c):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                tool, task, g = shard_candidates(c, kind, v)
            ok = np.asarray(reachable(task, g))
            feats.append(shard_features(c, tool, task, g)[ok])
            tasks += [kind] * int(ok.sum())
    return np.concatenate(feats), np.asarray(tasks)


def main(argv=None) -> None:
    from itup_jax import ood

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="itup_jax/models/training_reference.npz")
    ap.add_argument("--rows", type=int, default=ood.REFERENCE_ROWS, help="rows kept per task (default %(default)s)")
    args = ap.parse_args(argv)
    t0 = time.time()
    feats, tasks = training_features()
    ref = ood.sample_reference(feats, tasks, rows=args.rows)
    ood.save_reference(args.out, ref)
    print(f"{args.out}: " + ", ".join(f"{k} {len(v)} of {int((tasks == k).sum())} rows" for k, v in ref.features.items())
          + f" ({time.time() - t0:.0f} s)")


if __name__ == "__main__":
    main()

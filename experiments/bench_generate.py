"""Dataset generation: the shape buckets' effect on compiles, time per shard and memory.

    python experiments/bench_generate.py --tools 20 --grasps 16 --task hammer [--json]

Makes the shards of procedural tools (`dataset.make_shard`, the units of `itup generate --seed 3`) in
two fresh processes, one after the other: one with the size buckets (`shapes.py`, the code's default)
and one without them (the bucket widths set so high that every size is its own bucket). Each process first makes `--warmup` shards (tools 1..W, not counted: the one-time compiles
of the rollouts, costs and the first buckets), then the shards of `--tools` further tools, each new to
it, and reports the median time per shard, the executables those shards added to the three
tool-shaped kernels' caches, and the growth of its resident memory over them. Small `--grasps` makes the
compiles a larger share of a shard; at 256 grasps a shard's rollouts dominate.
"""

from __future__ import annotations

import argparse
import gc
import json
import subprocess
import sys
import time

import numpy as np

from itup_jax.bench import machine_info
from itup_jax.task import TASK_KINDS


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        line = next(ln for ln in fh if ln.startswith("VmRSS:"))
    return int(line.split()[1]) / 1024


def run_mode(buckets: bool, task: str, warmup: int, tools: int, grasps: int) -> dict:
    """One mode in this process: the warm-up shards, then `tools` new tools' shards, measured."""
    from itup_jax import grasp_sampler
    from itup_jax.dataset import GenerateConfig, make_shard
    from itup_jax.sdgnet import features

    if not buckets:
        features.FIELD_BUCKET_BITS = grasp_sampler.POINT_BUCKET_BITS = 64
    kernels = (features.batched_features, grasp_sampler.pad_span_batch, grasp_sampler.gripper_hits_batch)
    cfg = GenerateConfig(tools_per_task=warmup + tools + 1, grasps=grasps, seed=3, tasks=(task,))
    for v in range(1, warmup + 1):
        make_shard(cfg, task, v, nthread=1)
    gc.collect()
    cached, rss = sum(k._cache_size() for k in kernels), rss_mb()
    times = []
    for v in range(warmup + 1, warmup + tools + 1):
        t = time.perf_counter()
        make_shard(cfg, task, v, nthread=1)
        times.append(time.perf_counter() - t)
    gc.collect()
    return {"median_shard_s": round(float(np.median(times)), 3), "max_shard_s": round(max(times), 3),
            "executables_added": sum(k._cache_size() for k in kernels) - cached,
            "rss_growth_mb": round(rss_mb() - rss, 1), "rss_end_mb": round(rss_mb(), 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tools", type=int, default=20, help="new procedural tools measured per mode")
    ap.add_argument("--warmup", type=int, default=4, help="shards made first in each process, not counted")
    ap.add_argument("--grasps", type=int, default=16)
    ap.add_argument("--task", default="hammer", choices=TASK_KINDS)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--mode", choices=("buckets", "no_buckets"), help=argparse.SUPPRESS)  # the child processes
    args = ap.parse_args()
    if args.tools < 1 or args.warmup < 1 or args.grasps < 1:
        ap.error("--tools, --warmup and --grasps must be >= 1")
    if args.mode:
        print(json.dumps(run_mode(args.mode == "buckets", args.task, args.warmup, args.tools, args.grasps)))
        return
    out = {"machine": machine_info(), "task": args.task, "warmup": args.warmup, "tools_per_mode": args.tools,
           "grasps": args.grasps}
    for mode in ("buckets", "no_buckets"):
        cmd = [sys.executable, __file__, "--mode", mode, "--task", args.task, "--warmup", str(args.warmup),
               "--tools", str(args.tools), "--grasps", str(args.grasps)]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode != 0:
            sys.exit(f"bench_generate: the {mode} process failed:\n{res.stderr[-2000:]}")
        out[mode] = json.loads(res.stdout.strip().splitlines()[-1])
    out["ratio_median_shard"] = round(out["no_buckets"]["median_shard_s"] / out["buckets"]["median_shard_s"], 2)
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"machine: {out['machine']}")
    print(f"{args.task}: {args.tools} new tools per mode after {args.warmup} warm-up shards, {args.grasps} grasps "
          f"per shard, native MuJoCo, one thread, a fresh process per mode")
    for mode in ("buckets", "no_buckets"):
        r = out[mode]
        print(f"  {mode:>10}: median shard {r['median_shard_s']:.2f} s (max {r['max_shard_s']:.2f}); "
              f"{r['executables_added']} executables compiled; resident memory +{r['rss_growth_mb']:.0f} MB "
              f"(to {r['rss_end_mb']:.0f} MB)")
    print(f"  without / with buckets, median shard: {out['ratio_median_shard']:.2f}x")


if __name__ == "__main__":
    main()

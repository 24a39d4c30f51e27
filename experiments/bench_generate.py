"""Dataset generation: the shape buckets' effect on compiles, time per shard and memory.

    python experiments/bench_generate.py --tools 12 --grasps 16 --task hammer [--json]

Makes the shards of `--tools` procedural tools (`dataset.make_shard`, the same units as `itup
generate --seed 3`) twice in one process: with the size buckets (`shapes.py`, the code's default) and
without them (the bucket widths set so high that every size is its own bucket, as before session 27).
The order alternates per tool so that neither mode runs on a warmer process. Prints, per mode, the
first shard's time (after a warm-up shard, not counted, made with the buckets), the median time of the later shards, the executables its
shards added to the three tool-shaped kernels' caches, and the growth of the process's resident
memory over its shards. Small `--grasps` makes the compiles a larger share of a shard; at 256 grasps
a shard's rollouts dominate.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from itup_jax import features, grasp_sampler
from itup_jax.bench import machine_info
from itup_jax.dataset import GenerateConfig, make_shard
from itup_jax.task import TASK_KINDS

KERNELS = {"features": features.batched_features, "pad_span": grasp_sampler._pad_span_batch,
           "gripper_hits": grasp_sampler._gripper_hits_batch}


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        line = next(ln for ln in fh if ln.startswith("VmRSS:"))
    return int(line.split()[1]) / 1024


def set_buckets(on: bool) -> None:
    features.FIELD_BUCKET_BITS = 3 if on else 64
    grasp_sampler.POINT_BUCKET_BITS = 4 if on else 64


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tools", type=int, default=12, help="procedural tools (variants 1..N) per mode")
    ap.add_argument("--grasps", type=int, default=16)
    ap.add_argument("--task", default="hammer", choices=TASK_KINDS)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if args.tools < 2 or args.grasps < 1:
        ap.error("--tools must be >= 2 and --grasps >= 1")
    cfg = GenerateConfig(tools_per_task=2 * args.tools + 2, grasps=args.grasps, seed=3, tasks=(args.task,))
    stats = {on: {"times": [], "executables": 0, "rss_mb": 0.0} for on in (True, False)}
    make_shard(cfg, args.task, 2 * args.tools + 1, nthread=1)  # warm-up (not counted): the one-time compiles
    # tools 1..N with buckets, N+1..2N without, interleaved: each mode sees tools it never saw
    for k in range(args.tools):
        for on in ((True, False) if k % 2 == 0 else (False, True)):
            set_buckets(on)
            variant = 1 + k + (0 if on else args.tools)
            cached, rss = sum(f._cache_size() for f in KERNELS.values()), rss_mb()
            t = time.perf_counter()
            make_shard(cfg, args.task, variant, nthread=1)
            st = stats[on]
            st["times"].append(time.perf_counter() - t)
            st["executables"] += sum(f._cache_size() for f in KERNELS.values()) - cached
            st["rss_mb"] += rss_mb() - rss
    set_buckets(True)
    out = {"machine": machine_info(), "task": args.task, "tools_per_mode": args.tools, "grasps": args.grasps}
    for on in (True, False):
        st = stats[on]
        out["buckets" if on else "no_buckets"] = {
            "first_shard_s": round(st["times"][0], 3), "median_later_shard_s": round(float(np.median(st["times"][1:])), 3),
            "executables_added": st["executables"], "rss_growth_mb": round(st["rss_mb"], 1)}
    out["ratio_median_shard"] = round(out["no_buckets"]["median_later_shard_s"] / out["buckets"]["median_later_shard_s"], 2)
    if args.json:
        print(json.dumps(out, indent=2))
        return
    m = out["machine"]
    print(f"machine: {m}")
    print(f"{args.task}: {args.tools} tools per mode, {args.grasps} grasps per shard, native MuJoCo, one thread")
    for name in ("buckets", "no_buckets"):
        r = out[name]
        print(f"  {name:>10}: first shard {r['first_shard_s']:.2f} s (after the warm-up), later shards median "
              f"{r['median_later_shard_s']:.2f} s; {r['executables_added']} executables compiled, resident memory "
              f"+{r['rss_growth_mb']:.0f} MB")
    print(f"  without / with buckets, median later shard: {out['ratio_median_shard']:.2f}x")

if __name__ == "__main__":
    main()

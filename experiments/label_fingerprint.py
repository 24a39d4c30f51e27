"""Hashes of what the physics produces, to show that a change to the code left the labels alone.

For each task (its built-in tool and one part-wise variant): the task's arrays (contacts, schedules,
trajectory), the compiled scene (`mj_saveModel` bytes), and, for the built-in tool, every label field of
48 sampled grasps rolled out in native MuJoCo under seeded randomised physics. Run it before and after a
change and compare the two files:

    python experiments/label_fingerprint.py --out before.json      # on the old code
    python experiments/label_fingerprint.py --out after.json       # on the new code
    diff before.json after.json                                     # empty: the same bytes

About 20 s on a 2-core CPU.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import os
import tempfile

import mujoco
import numpy as np

import itup_jax as itup
from itup_jax.tools.variants import part_variant


def _h(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()[:16]


def fingerprint(grasps: int = 48) -> dict:
    out = {}
    for kind in itup.TASK_KINDS:
        name = itup.tasks.get(kind).default_tool
        for label, tool in (("builtin", itup.load_tool(name)), ("variant", part_variant(name, 3))):
            task = itup.make_task(kind, tool)
            arrays = [np.asarray(x) for x in (task.c_tool, task.c_obj_world, task.n_world, task.impact, task.drag,
                                              task.traj.p_world_tool, task.traj.R_world_tool)]
            out[f"{kind}/{label}/task"] = _h(b"".join(a.tobytes() for a in arrays))
            scene = itup.build_scene(tool, task)
            with tempfile.TemporaryDirectory() as d:
                path = os.path.join(d, "model.mjb")
                mujoco.mj_saveModel(scene.model, path, None)
                out[f"{kind}/{label}/model"] = _h(open(path, "rb").read())
            if label == "builtin":
                g = itup.sample_grasps(tool, grasps, seed=0)
                labels = itup.simulate(tool, task, g, seed=0, backend="native").labels
                out[f"{kind}/labels"] = {f.name: _h(np.ascontiguousarray(np.asarray(getattr(labels, f.name))).tobytes())
                                         for f in dataclasses.fields(labels)}
                out[f"{kind}/valid_rows"] = int(np.sum(labels.valid))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="JSON file to write")
    ap.add_argument("--grasps", type=int, default=48, help="rollouts per task (default 48)")
    args = ap.parse_args()
    result = fingerprint(args.grasps)
    with open(args.out, "w") as fh:
        json.dump(result, fh, indent=1, sort_keys=True)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

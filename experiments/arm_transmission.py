"""Does the arm belong in the analytic model? The rigid model against the arm-in-the-loop model of
`itup_jax/transmission.py`, ranked against MuJoCo's full induced peak wrist torque, tool by tool.

    python experiments/arm_transmission.py --out results/arm_transmission            # ~4 min, 2-core CPU
    python experiments/arm_transmission.py --quick --out results/arm_transmission_quick  # tests

For the impulsive tasks (hammer, knock; a sweep's or reach's contacts last long enough for the servos to
hold the tool, where the rigid model is the arm model) and tools of two kinds: the task's built-in
family (the built-in tool and part-wise variants) and families of other shapes for the same task,
plus a headless baton (a uniform beech rod, which carries the centre-of-percussion effect the arm
model is built for). Per tool: `--grasps` reachable candidates, rolled out in native MuJoCo with the
nominal physics (the analytic models use the nominal priors), and per method the Spearman correlation
of its prediction with the measured `peak_torque_induced` over the valid rollouts. Methods:

  rigid/full     the rigid model's full torque at the wrist site (`CostParams(lever_arm='wrist',
                 torque_projection='full')`)
  rigid/passed   the same with the closure-axis part capped by the pads' torsional friction at 100 N
  arm            `transmission.wrist_response`: tool, pads, hand and arm (MuJoCo's operational-space
                 inertia, servo stiffness and damping at the impact's configuration); the pads pass on
                 everything (`pads='rigid'`)
  arm/passed     the same, the closure-axis torque capped by the pads' torsion (`pads='torsion'`)
  arm/limit      the same, the pads' wrench scaled onto the grip's limit surface (`pads='limit'`)
  heavy/passed, heavy/limit   the same chains with a heavy, servo-less arm (Lambda x 1e4, K = D = 0):
                 what the arm's own dynamics add beyond the pads

Beside them, the measure's own repeatability (`ceiling`): each grasp moved by 1 mm in its x-z plane and
turned by 1 degree about its jaw axis (`heldout.moved`), rolled out again, and the Spearman correlation
of the two measurements. No model of the grasp's pose can rank the measure much better than the
measure ranks itself under a nudge that small.

Every tool here is a validation tool (the seeds are fixed in this file; nothing here is sealed).
Writes arm_transmission.json into --out and prints the per-task medians.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

from itup_jax.atomic import atomic_write_json
from itup_jax.costs import CostParams, wrench_costs
from itup_jax.grasp import make_grasps
from itup_jax.grasp_sampler import sample_reachable
from itup_jax.heldout import moved
from itup_jax.rotations import quat_to_matrix_np
from itup_jax.sim.arm_inertia import task_blows
from itup_jax.sim.config import SimConfig
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import build_scene
from itup_jax.stats import spearman
from itup_jax.task import make_task
from itup_jax.tools import Tool, families
from itup_jax.tools.builtin import assemble_tool, cylinder_part
from itup_jax.tools.variants import part_variant
from itup_jax.transmission import batched_wrist_response

#: task -> (built-in family's variants, other families); seeds of the variants and draws
TOOL_SETS = {"hammer": ("hammer", ("spanner", "hatchet")), "knock": ("mallet", ("screwdriver", "spanner", "hatchet"))}
VARIANT_SEEDS = (4101, 4102, 4103)
DRAW_SEEDS = (4201, 4202)
GRIP = SimConfig().grip_force
RIGID = {"rigid/full": CostParams(lever_arm="wrist", torque_projection="full"),
         "rigid/passed": CostParams(lever_arm="wrist", torque_projection="passed", grip_force=GRIP)}
CHAINS = {"arm": ("arm", "rigid"), "arm/passed": ("arm", "torsion"), "arm/limit": ("arm", "limit"),
          "heavy/passed": ("heavy", "torsion"), "heavy/limit": ("heavy", "limit")}
METHODS = (*RIGID, *CHAINS)
#: m and rad: the nudge of the repeatability ceiling
NUDGE = (0.001, np.radians(1.0))

_response = jax.jit(batched_wrist_response, static_argnames="pads")


def baton(length: float = 0.45, radius: float = 0.014) -> Tool:
    """A headless beech baton (category mallet): it knocks or strikes with the side of its tip."""
    return assemble_tool(name="baton", category="mallet", parts=[("rod", "beech", cylinder_part(radius, (0, 0, 0), (0, 0, length)))],
                         contact_points=[(radius, 0.0, length - 0.02)], contact_normal=(1.0, 0.0, 0.0),
                         grasp_region=((-0.02, -0.02, 0.0), (0.02, 0.02, length - 0.03)))


def tool_sets(kind: str, quick: bool) -> dict[str, list[Tool]]:
    """{'built-in family': [...], 'other families': [...]} for task `kind`."""
    base, others = TOOL_SETS[kind]
    builtin = [families.get(base).build()] + [part_variant(base, s) for s in VARIANT_SEEDS]
    other = [baton()] + [families.draw(f, s) for f in others for s in DRAW_SEEDS]
    return {"built-in family": builtin[:1] if quick else builtin, "other families": other[:1] if quick else other}


def predictions(tool: Tool, task, scene, grasps, q_traj) -> dict[str, np.ndarray]:
    """Each method's predicted peak wrist torque [N] (N m) for the grasps."""
    out = {name: np.asarray(wrench_costs(tool, task, grasps, prm).tau, float) for name, prm in RIGID.items()}
    blows, _, _ = task_blows(scene, task, grasps, q_traj, grip_force=GRIP)
    b = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), blows)
    heavy = dataclasses.replace(b, arm_inertia=b.arm_inertia * 1e4, arm_stiffness=jnp.zeros_like(b.arm_stiffness),
                                arm_damping=jnp.zeros_like(b.arm_damping))
    for name, (arm, pads) in CHAINS.items():
        out[name] = np.asarray(_response(b if arm == "arm" else heavy, pads=pads), float)
    return out


def measure_tool(tool: Tool, kind: str, grasps_n: int, seed: int) -> dict:
    task = make_task(kind, tool)
    scene = build_scene(tool, task)  # one scene for both rollouts and the arm's impedance
    g = sample_reachable(tool, task, grasps_n, seed).grasps
    res = simulate(tool, task, g, backend="native", randomize=None, scene=scene)
    ok = res.labels.valid
    y = res.labels.peak_torque_induced[ok]
    preds = predictions(tool, task, scene, g[np.nonzero(ok)[0]], res.plan.q_traj[ok])
    p1, R1 = moved(np.asarray(g.p_tool_grasp, float), quat_to_matrix_np(np.asarray(g.q_tool_grasp, float)), *NUDGE,
                   np.random.default_rng(seed))
    again = simulate(tool, task, make_grasps(p1, R1, np.asarray(g.width, float)), backend="native", randomize=None,
                     scene=scene).labels
    both = ok & again.valid
    return {"tool": tool.name, "valid": int(ok.sum()), "label_median": float(np.median(y)),
            "rho": {m: float(spearman(preds[m], y)) for m in METHODS},
            "ceiling": float(spearman(again.peak_torque_induced[both], res.labels.peak_torque_induced[both])),
            "median_prediction": {m: float(np.median(preds[m])) for m in METHODS}}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", nargs="+", default=list(TOOL_SETS), choices=list(TOOL_SETS))
    ap.add_argument("--grasps", type=int, default=48, help="reachable candidates per tool (default 48)")
    ap.add_argument("--seed", type=int, default=0, help="candidate sampling seed")
    ap.add_argument("--quick", action="store_true", help="one tool per set, 12 grasps, the hammer task (tests)")
    ap.add_argument("--out", default="results/arm_transmission")
    args = ap.parse_args(argv)
    tasks, grasps_n = (["hammer"], 12) if args.quick else (args.tasks, args.grasps)
    t0 = time.time()
    result = {"grasps": grasps_n, "seed": args.seed, "methods": list(METHODS), "tasks": {}}
    for kind in tasks:
        per_set = {}
        for set_name, tools in tool_sets(kind, args.quick).items():
            rows = [measure_tool(t, kind, grasps_n, args.seed) for t in tools]
            medians = {m: float(np.nanmedian([r["rho"][m] for r in rows])) for m in METHODS}
            medians["ceiling"] = float(np.nanmedian([r["ceiling"] for r in rows]))
            per_set[set_name] = {"tools": rows, "median_rho": medians}
            print(f"{kind:7s} {set_name:16s} ({len(rows)} tools) median rho: "
                  + "  ".join(f"{m} {v:+.2f}" for m, v in medians.items()))
        result["tasks"][kind] = per_set
    result["wall_s"] = round(time.time() - t0, 1)
    os.makedirs(args.out, exist_ok=True)
    atomic_write_json(os.path.join(args.out, "arm_transmission.json"), result)
    print(json.dumps({"wall_s": result["wall_s"], "out": args.out}))
    return result


if __name__ == "__main__":
    main()

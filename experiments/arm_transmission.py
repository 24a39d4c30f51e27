"""Does the arm belong in the analytic model? The rigid model against the arm-in-the-loop model of
`itup_jax/transmission.py`, ranked against MuJoCo's full induced peak wrist torque, tool by tool.

    python experiments/arm_transmission.py --out results/arm_transmission            # ~4 min, 2-core CPU
    python experiments/arm_transmission.py --tasks knock --grip-force 235 --out results/arm_transmission_235  # ~2 min
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

And when the peak comes (`phases`, from the rollouts' traces): the contact's onset (the first step the
target has moved 5 micrometres), whether the peak falls in the swing before it, the blow (1 ms before to
2 ms after it) or the push after it (the servos driving the tool on into the target); the peak of each
phase and each model's ranking of it; the onset's delay after the trajectory's impact time and its rank
correlation with the measure; how far the tool's contact point is behind its planned place 10 ms
before the impact, along the direction of travel, split into the arm's part (the gripper's pose) and
the pads' part (the tool's pose in the grasp), each with its rank correlation with the delay; and the
models' ranking over the rollouts that struck the target (`rho_hit`; a rollout that never moves the
target measures no blow) and where the misses stand in each model's order (`miss_rank`).

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
from itup_jax.robot import GRIPPER_MAX_GRIP_FORCE, GRIPPER_MIN_GRIP_FORCE
from itup_jax.rotations import quat_to_matrix_np
from itup_jax.sim.arm_inertia import task_blows
from itup_jax.sim.config import SimConfig
from itup_jax.sim.labels import induced
from itup_jax.sim.rollout import simulate
from itup_jax.sim.scene import build_scene, target_bodies
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
#: N per pad: the rollouts' grip and the models' (the shipped SimConfig's unless --grip-force)
GRIP = SimConfig().grip_force


def rigid_params(grip: float) -> dict[str, CostParams]:
    """The rigid model's two forms at `grip` N per pad."""
    return {"rigid/full": CostParams(lever_arm="wrist", torque_projection="full"),
            "rigid/passed": CostParams(lever_arm="wrist", torque_projection="passed", grip_force=grip)}


CHAINS = {"arm": ("arm", "rigid"), "arm/passed": ("arm", "torsion"), "arm/limit": ("arm", "limit"),
          "heavy/passed": ("heavy", "torsion"), "heavy/limit": ("heavy", "limit")}
METHODS = (*rigid_params(GRIP), *CHAINS)
#: m and rad: the nudge of the repeatability ceiling
NUDGE = (0.001, np.radians(1.0))
#: The phases of the motion, from the contact's onset (the first step the target has moved ONSET_MOVE m from
#: where it stood when the motion began; a block creeps < 1 um before it): before it (the swing), the
#: blow (from BLOW_START to BLOW_END s after the onset: the contact's first stiffness time scales, what an
#: impulse describes) and the push after it (the servos driving the tool on into the target, a rebound,
#: a second contact)
BLOW_START, BLOW_END, ONSET_MOVE = -0.001, 0.002, 5e-6
PHASES = ("swing", "blow", "push")
#: s before the trajectory's impact time at which the contact point's lag behind the plan is taken
LAG_BEFORE = 0.010
#: the models whose ranking of each phase's peak is reported
PHASE_METHODS = ("rigid/passed", "arm/passed")

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


def predictions(tool: Tool, task, scene, grasps, q_traj, grip: float = GRIP) -> dict[str, np.ndarray]:
    """Each method's predicted peak wrist torque [N] (N m) for the grasps, at `grip` N per pad."""
    out = {name: np.asarray(wrench_costs(tool, task, grasps, prm).tau, float) for name, prm in rigid_params(grip).items()}
    blows, _, _ = task_blows(scene, task, grasps, q_traj, grip_force=grip)
    b = jax.tree_util.tree_map(lambda a: jnp.asarray(a, jnp.float32), blows)
    heavy = dataclasses.replace(b, arm_inertia=b.arm_inertia * 1e4, arm_stiffness=jnp.zeros_like(b.arm_stiffness),
                                arm_damping=jnp.zeros_like(b.arm_damping))
    for name, (arm, pads) in CHAINS.items():
        out[name] = np.asarray(_response(b if arm == "arm" else heavy, pads=pads), float)
    return out


def phase_peaks(tool: Tool, scene, task, grasps, res) -> dict[str, np.ndarray]:
    """When and how the blow lands, from one `simulate(..., traces=True)` of `grasps`, per rollout [N]: the
    contact's onset less the trajectory's impact time (`delay`, s), the peak's time after the onset (s),
    the peak of each phase (N m; `PHASES`, NaN where a phase is empty), and how far the tool's contact
    point is behind its planned place `LAG_BEFORE` s before the impact time, along the planned
    direction of travel (m), split into what the gripper's pose puts there (`lag_arm`: the arm's
    tracking) and what the tool's pose in the pads does (`lag_pads`: the tool has turned or slid in the
    grasp since the plan). The onset and the phases are NaN where the target never moved."""
    p = res.plan
    d_tau, _ = induced(scene, p, res.traces["gripper/wrist_torque"])
    norm = np.linalg.norm(d_tau, axis=-1)  # [N, S]
    t = p.sim_t[p.n_settle:p.nstep]
    pos = res.traces[f"target/{target_bodies(task.kind)[0]}_pos"][:, p.n_settle:p.nstep]
    moved_far = np.linalg.norm(pos - pos[:, :1], axis=-1) > ONSET_MOVE
    hit = moved_far.any(1)
    onset = np.where(hit, t[moved_far.argmax(1)], np.nan)
    rel = t[None, :] - onset[:, None]  # NaN rows: every phase empty
    masks = {"swing": rel < BLOW_START, "blow": (rel >= BLOW_START) & (rel <= BLOW_END), "push": rel > BLOW_END}
    t_traj = np.asarray(task.traj.t, float)
    k_impact = int(np.asarray(task.impact).max(1).argmax())
    out = {"delay": onset - t_traj[k_impact], "peak_after_onset": t[np.nan_to_num(norm, nan=-1.0).argmax(1)] - onset}
    for name, m in masks.items():
        out[name] = np.where(m.any(1), np.where(m, np.nan_to_num(norm, nan=-np.inf), -np.inf).max(1), np.nan)
    # the contact point LAG_BEFORE s before the impact: planned, as the gripper carries it with the tool where
    # the grasp planned it, and where it is
    c = np.asarray(tool.contact_points, float)[0]
    c_traj = np.asarray(task.traj.point_position(c), float)  # [T, 3]
    t_probe = t_traj[k_impact] - LAG_BEFORE
    planned = np.array([np.interp(t_probe, t_traj, c_traj[:, j]) for j in range(3)])
    travel = np.asarray(task.traj.point_velocity(c), float)[k_impact]
    travel = travel / np.linalg.norm(travel)
    k = p.n_settle + int(np.argmin(np.abs(t - t_probe)))
    R_wt = quat_to_matrix_np(res.traces["tool_quat"][:, k])
    p_wt = res.traces["tool_pos"][:, k]
    R_gt = quat_to_matrix_np(res.traces["tool_quat_grasp"][:, k])
    R_wg = np.einsum("nij,nkj->nik", R_wt, R_gt)  # the grasp frame (the gripper) in the world
    p_wg = p_wt - np.einsum("nij,nj->ni", R_wg, res.traces["tool_pos_grasp"][:, k])
    R_plan = quat_to_matrix_np(np.asarray(grasps.q_tool_grasp, float))  # the grasp frame in the tool frame
    c_grasp_plan = np.einsum("nji,nj->ni", R_plan, c[None] - np.asarray(grasps.p_tool_grasp, float))
    carried = p_wg + np.einsum("nij,nj->ni", R_wg, c_grasp_plan)
    actual = p_wt + np.einsum("nij,j->ni", R_wt, c)
    out["lag_arm"] = (planned[None] - carried) @ travel
    out["lag_pads"] = (carried - actual) @ travel
    return out


def rank01(x: np.ndarray) -> np.ndarray:
    """Each value's rank in x scaled to [0, 1] (0 the least)."""
    return np.argsort(np.argsort(x)) / max(len(x) - 1, 1)


def phase_summary(ph: dict[str, np.ndarray], y: np.ndarray, preds: dict[str, np.ndarray]) -> dict:
    """Where the peaks fall, how the models rank each phase's peak, and how the measure follows the
    blow's timing and the contact point's lag behind the plan (valid rollouts that hit)."""
    hit = np.isfinite(ph["delay"])
    pct = lambda v, scale: [float(x) for x in np.percentile(v[hit], [10, 50, 90]) * scale] if hit.any() else None  # noqa: E731
    rho = lambda a, b: float(spearman(a, b)) if len(a) > 2 else None  # noqa: E731
    out = {"valid": len(y), "hit": int(hit.sum()), "share": {name: float(np.mean(np.isclose(ph[name][hit], y[hit]))) for name in PHASES},
           "peak_after_onset_ms": pct(ph["peak_after_onset"], 1e3), "delay_ms": pct(ph["delay"], 1e3),
           "lag_arm_mm": pct(ph["lag_arm"], 1e3), "lag_pads_mm": pct(ph["lag_pads"], 1e3),
           "median_peak": {name: float(np.nanmedian(ph[name][hit])) if hit.any() else None for name in PHASES},
           "rho_delay": rho(ph["delay"][hit], y[hit]), "rho_delay_lag_pads": rho(ph["lag_pads"][hit], ph["delay"][hit]),
           "rho_delay_lag_arm": rho(ph["lag_arm"][hit], ph["delay"][hit]),
           "rho_hit": {m: rho(preds[m][hit], y[hit]) for m in PHASE_METHODS},
           "median_miss": float(np.median(y[~hit])) if (~hit).any() else None,
           # where the misses stand in each model's order (0: the least predicted torque, 1: the most)
           "miss_rank": {m: float(np.mean(rank01(preds[m])[~hit])) if (~hit).any() else None for m in PHASE_METHODS},
           "rho": {}}
    for name in PHASES:
        ok = hit & np.isfinite(ph[name])
        out["rho"][name] = {m: rho(preds[m][ok], ph[name][ok]) for m in PHASE_METHODS}
    return out


def phase_medians(rows: list[dict]) -> dict:
    """Medians over a tool set's tools of `phase_summary`'s figures (NaN where no tool has one)."""
    med = lambda xs: float(np.nanmedian([np.nan if x is None else x for x in xs])) if xs else float("nan")  # noqa: E731
    mid = lambda key: med([r[key][1] if r[key] else None for r in rows])  # noqa: E731
    return {"share": {n: med([r["share"][n] for r in rows]) for n in PHASES},
            "peak_after_onset_ms": mid("peak_after_onset_ms"), "delay_ms": mid("delay_ms"),
            "delay_spread_ms": med([r["delay_ms"][2] - r["delay_ms"][0] if r["delay_ms"] else None for r in rows]),
            "median_peak": {n: med([r["median_peak"][n] for r in rows]) for n in PHASES},
            "lag_spread_mm": {part: med([r[f"lag_{part}_mm"][2] - r[f"lag_{part}_mm"][0] if r[f"lag_{part}_mm"] else None
                                         for r in rows]) for part in ("arm", "pads")},
            "rho_delay": med([r["rho_delay"] for r in rows]),
            "rho_delay_lag": {part: med([r[f"rho_delay_lag_{part}"] for r in rows]) for part in ("arm", "pads")},
            "hit_share": med([r["hit"] / r["valid"] for r in rows]),
            "rho_hit": {m: med([r["rho_hit"][m] for r in rows]) for m in PHASE_METHODS},
            "rho": {n: {m: med([r["rho"][n][m] for r in rows]) for m in PHASE_METHODS} for n in PHASES}}


def measure_tool(tool: Tool, kind: str, grasps_n: int, seed: int, grip: float = GRIP) -> dict:
    task = make_task(kind, tool)
    scene = build_scene(tool, task)  # one scene for both rollouts and the arm's impedance
    g = sample_reachable(tool, task, grasps_n, seed).grasps
    config = SimConfig(grip_force=grip)
    res = simulate(tool, task, g, backend="native", randomize=None, scene=scene, traces=True, config=config)
    ok = res.labels.valid
    y = res.labels.peak_torque_induced[ok]
    preds = predictions(tool, task, scene, g[np.nonzero(ok)[0]], res.plan.q_traj[ok], grip)
    ph = {k: v[ok] for k, v in phase_peaks(tool, scene, task, g, res).items()}
    p1, R1 = moved(np.asarray(g.p_tool_grasp, float), quat_to_matrix_np(np.asarray(g.q_tool_grasp, float)), *NUDGE,
                   np.random.default_rng(seed))
    again = simulate(tool, task, make_grasps(p1, R1, np.asarray(g.width, float)), backend="native", randomize=None,
                     scene=scene, config=config).labels
    both = ok & again.valid
    return {"tool": tool.name, "valid": int(ok.sum()), "label_median": float(np.median(y)),
            "rho": {m: float(spearman(preds[m], y)) for m in METHODS},
            "ceiling": float(spearman(again.peak_torque_induced[both], res.labels.peak_torque_induced[both])),
            "median_prediction": {m: float(np.median(preds[m])) for m in METHODS},
            "phases": phase_summary(ph, y, preds)}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tasks", nargs="+", default=list(TOOL_SETS), choices=list(TOOL_SETS))
    ap.add_argument("--grasps", type=int, default=48, help="reachable candidates per tool (default 48)")
    ap.add_argument("--seed", type=int, default=0, help="candidate sampling seed")
    ap.add_argument("--grip-force", type=float, default=GRIP,
                    help=f"N per pad, the rollouts' grip and the models' (default {GRIP:g}; within the gripper's "
                    f"{GRIPPER_MIN_GRIP_FORCE:g}-{GRIPPER_MAX_GRIP_FORCE:g})")
    ap.add_argument("--quick", action="store_true", help="one tool per set, 12 grasps, the hammer task (tests)")
    ap.add_argument("--out", default="results/arm_transmission")
    args = ap.parse_args(argv)
    if not GRIPPER_MIN_GRIP_FORCE <= args.grip_force <= GRIPPER_MAX_GRIP_FORCE:
        ap.error(f"--grip-force must be within the gripper's {GRIPPER_MIN_GRIP_FORCE:g}-{GRIPPER_MAX_GRIP_FORCE:g} N, "
                 f"got {args.grip_force:g}")
    tasks, grasps_n = (["hammer"], 12) if args.quick else (args.tasks, args.grasps)
    t0 = time.time()
    result = {"grasps": grasps_n, "seed": args.seed, "grip_force": args.grip_force, "methods": list(METHODS), "tasks": {}}
    for kind in tasks:
        per_set = {}
        for set_name, tools in tool_sets(kind, args.quick).items():
            rows = [measure_tool(t, kind, grasps_n, args.seed, args.grip_force) for t in tools]
            medians = {m: float(np.nanmedian([r["rho"][m] for r in rows])) for m in METHODS}
            medians["ceiling"] = float(np.nanmedian([r["ceiling"] for r in rows]))
            phases = phase_medians([r["phases"] for r in rows])
            per_set[set_name] = {"tools": rows, "median_rho": medians, "phases": phases}
            print(f"{kind:7s} {set_name:16s} ({len(rows)} tools) median rho: "
                  + "  ".join(f"{m} {v:+.2f}" for m, v in medians.items()))
            print(f"{'':24s} peak in phase: " + "  ".join(f"{n} {phases['share'][n]:.2f}" for n in PHASES)
                  + f"; {phases['peak_after_onset_ms']:.1f} ms after the onset; phase peaks "
                  + "  ".join(f"{n} {phases['median_peak'][n]:.2f}" for n in PHASES) + " N m")
            print(f"{'':24s} rho per phase (rigid/passed, arm/passed): "
                  + "  ".join(f"{n} {phases['rho'][n]['rigid/passed']:+.2f} {phases['rho'][n]['arm/passed']:+.2f}"
                              for n in PHASES)
                  + f"; onset delay {phases['delay_ms']:+.1f} ms (p10-p90 spread {phases['delay_spread_ms']:.1f} ms,"
                  f" rho {phases['rho_delay']:+.2f}); lag behind the plan, p10-p90 spread: arm "
                  f"{phases['lag_spread_mm']['arm']:.1f} mm, pads {phases['lag_spread_mm']['pads']:.1f} mm (rho with the "
                  f"delay {phases['rho_delay_lag']['arm']:+.2f}, {phases['rho_delay_lag']['pads']:+.2f}); "
                  f"{phases['hit_share']:.2f} hit the target, rho over them "
                  + " ".join(f"{phases['rho_hit'][m]:+.2f}" for m in PHASE_METHODS))
        result["tasks"][kind] = per_set
    result["wall_s"] = round(time.time() - t0, 1)
    os.makedirs(args.out, exist_ok=True)
    atomic_write_json(os.path.join(args.out, "arm_transmission.json"), result)
    print(json.dumps({"wall_s": result["wall_s"], "out": args.out}))
    return result


if __name__ == "__main__":
    main()

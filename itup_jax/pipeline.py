"""The whole chain: an instruction and a table of tools -> a tool picked up and the task done, in MuJoCo.

    import itup_jax as itup
    r = itup.run("drive the nail", clutter=4, seed=3)       # -> RunResult
    r.stage, r.success                                     # 'done', True
    r = itup.run("sweep the debris", method="copa")         # an ablation (METHODS)

The stages (the paper's six, in simulation):
  1-2. grounding (`grounding`): the task, its target, the tool on the table, its working part (Omega's
       c_tool and n) and the part to hold (the grasp region);
  3.   the task's trajectory for the grounded tool (`task.make_task`: the target's placement gives
       Omega's c_obj and d);
  4.   grasp sampling on the grounded tool (`grasp_sampler`), kept where the arm can pick them from the
       tool's rest pose (`pickup.pick_candidates`) and carry them through the task with a margin for the
       pick's error (`pickup.reachable_with_margin`); of those, the ones whose lift loads the pads'
       torsional grip within `pickup.LIFT_TORQUE_SHARE` of its capacity (the tool's weight and the
       other tools' loads over a simulated lift, `pickup.lift_torque`), or, when there are none, of
       the MIN_CANDIDATES that load it least those within LIFT_FALLBACK_SPREAD of the least load (the
       weight alone always within `pickup.LIFT_TORQUE_LIMIT`);
  5.   scoring (SDG-Net by default; METHODS lists the ablations' scorers) and the choice: for the SDG-Net
       methods `itup plan`'s (`planning.default_pick`: the out-of-distribution guard read, the `verify`
       best rolled out in MuJoCo under nominal physics and again at 25 N per pad, the lowest measured
       total kept; none did the task and held: the run ends at 'plan', as `itup plan` recommends none;
       `run(verify=0)`: the best-scored), for the baselines their best-scored;
  6.   execution: the pick rolled out in MuJoCo (`pickup.execute_pick`: approach, close, lift, the grasp
       it achieved measured), then the task rolled out from the achieved grasp (`sim.rollout.simulate`,
       randomised physics by default), its task success and grip failure as the labels define them.
       A pick that does not lift the tool, or lifts it into a grasp that cannot be carried through the
       task, puts the tool back down (`regrasp.put_back`, simulated on: the tools settle where they
       come to rest) and stages 4-6 run again on that table, without the grasps near those tried; where
       grasps are pickable but none can be carried through the task, the tool is picked by the one
       whose lift loads the pads least and turned over onto another face (`regrasp.turn_over`) before
       planning again; up to MAX_PICK_ATTEMPTS picks in all (`run(max_attempts=)`).
The move from the lift to the task's first pose is not simulated: the task rollout starts with the tool
held at the grasp the pick achieved.

`RunResult.stage` says where a run ended: 'grounding' (the instruction could not be grounded), 'plan'
(no task trajectory, no grasp for the grounded tool, or none of the grasps checked did the task),
'pick' (no grasp could be picked and carried, or the last pick did not bring the tool up in the pads
in a grasp the task can use), 'grip' (the tool slipped or turned in the grip during the task), 'task'
(held, but the task not done), 'done' (success).

METHODS (the paper's Table II columns, in simulation):
  itup          two-level grounding, SDG-Net scoring and `itup plan`'s check;
  no_sdgnet     two-level grounding, static force-closure scoring (Ferrari-Canny);
  object_level  object-level grounding only: the whole tool is the grasp region and the contact is a
                default one (the tool's far end along its handle, the category's contact direction);
                SDG-Net scoring and the check;
  copa          two-level grounding, geometric scoring within the grounded part (no physics);
  no_grounding  a random tool of the table, a random part to hold and a random part to strike with;
                SDG-Net scoring and the check.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from typing import Any

import numpy as np

from itup_jax import grounding as grounding_mod
from itup_jax import robot
from itup_jax.errors import InputError
from itup_jax.grasp_sampler import MAX_CANDIDATES
from itup_jax.tabletop import Tabletop, make_tabletop
from itup_jax.tools import CATEGORY_CONTACT_NORMAL, Box, Tool, parts

#: method -> (grounding level, scorer).
METHODS = {
    "itup": ("two_level", "sdgnet"),
    "no_sdgnet": ("two_level", "force_closure"),
    "object_level": ("object", "sdgnet"),
    "copa": ("two_level", "geometric"),
    "no_grounding": ("random", "sdgnet"),
}
#: Grasps sampled on the grounded tool per round, before the pick and reach filters; rounds go on until
#: MIN_CANDIDATES pass both, at most SAMPLE_ROUNDS (a rod lying flat passes ~1 in 100).
DEFAULT_SAMPLES = 2048
MIN_CANDIDATES = 16
SAMPLE_ROUNDS = 4
#: When no grasp's lift is within LIFT_TORQUE_SHARE, the fallback keeps, of the MIN_CANDIDATES that load
#: the lift least, those within this much of the least load (a share of the pads' torsional capacity):
#: past the capacity the share decides whether the tool comes up at all (measured on tables 0-9,
#: `experiments/lift_torque.py`, cluttered: held 89 % at 1-1.5, 69 % at 1.5-2, 9 % at 2-3, none past 3),
#: so the scorer chooses only among lifts about as good as the best the table allows.
LIFT_FALLBACK_SPREAD = 0.25
#: One instruction per task, in plain words the rule grounder reads (the whole chain's experiments use them).
INSTRUCTIONS = {"hammer": "drive the nail", "sweep": "sweep the debris off the table",
                "knock": "knock over the tower", "reach": "pull the block closer"}
#: Stages a run can end at (`RunResult.stage`).
STAGES = ("grounding", "plan", "pick", "grip", "task", "done")
#: Steps between the pick's recorded poses when traces are kept (every 10 ms at the pick's 2 ms step).
PICK_LOG_EVERY = 5
#: Picks a run tries at most (`run(max_attempts=)`), and how far (m, tool frame) a grasp must lie from
#: every grasp already tried to be planned again.
MAX_PICK_ATTEMPTS = 3
RETRY_EXCLUSION = 0.015
#: m, the band below a tool's far end whose points make the object-level default contact.
FAR_END_BAND = 0.005


@dataclasses.dataclass(frozen=True, eq=False)
class RunResult:
    """One run of the whole chain (module docstring).

    Attributes:
      instruction, method: as given.  stage: where it ended (STAGES).  success: stage == 'done'.
      message: one sentence on why it ended there.
      grounding: `grounding.Grounding` (None when grounding failed).
      tabletop: the `Tabletop`.  tool: the grounded tool (None before).
      counts: candidates at each filter (sampled, pickable, task-reachable, within the lift torque
        share, scored).
      choice: the chosen candidate's index among the scored ones, its score and its lift load
        (`pickup.lift_torque`); for the SDG-Net methods also the check's `checked` (the candidates
        rolled out, with their `measured_total`; empty with verify 0 and the guard quiet), `guard_score`
        and `guard_fired`; for a pick that turned the tool over, index -1, the scorer
        'turn over: the least lift load' and the lift load as its score.
      pick: `pickup.PickResult` of the last pick (None when no pick ran).
      attempts: the picks before it, each {"choice", "pick" (its JSON), "why", "action"}: 'put_back'
        (it could not go on: the tool put back down, `regrasp.put_back`) or 'turn_over' (no grasp the
        task can use was pickable: the tool turned over, `regrasp.turn_over`); the table was planned
        again after each.
      pick_tabletop: the table as the last pick found it (None when that is `tabletop`: no earlier pick).
      labels: the task rollout's labels as {name: value} (None when none ran).
      seed: the run's seed (sampling, physics).  wall_s: seconds.
      task, sim: the Task and the task rollout's SimResult (for logs; not in the JSON).
    """

    instruction: str
    method: str
    stage: str
    message: str
    grounding: Any
    tabletop: Tabletop
    tool: Tool | None
    counts: dict
    choice: dict | None
    pick: Any
    labels: dict | None
    seed: int
    wall_s: float
    attempts: list = dataclasses.field(default_factory=list)
    pick_tabletop: Tabletop | None = None
    task: Any = None
    sim: Any = None

    @property
    def success(self) -> bool:
        return self.stage == "done"

    def report(self) -> str:
        """The run as `itup run` prints it: the grounding, the candidates at each filter, every pick, the
        task's measurement and where the chain ended."""
        from itup_jax import pickup

        lines: list[str] = []
        out = lines.append
        g = self.grounding
        out(f"grounded: task {g.task} (target: the {g.target}), tool {g.tool_index + 1} {g.tool_name}, "
            f"strike with the {g.work_part}, hold the {g.grasp_part}" + "".join(f"; {n}" for n in g.notes))
        c = self.counts
        if c:
            out(f"grasps: {c['sampled']} sampled, {c.get('pick_reachable', 0)} can be picked from the rest pose, "
                f"{c.get('task_reachable', 0)} of those can be carried through the task, {c.get('lift_within_share', 0)} "
                f"of those the pads' torsional grip holds through the lift (its load at most "
                f"{pickup.LIFT_TORQUE_SHARE:.0%} of the grip's capacity)")
            if c.get("scored") and not c.get("lift_within_share"):
                out(f"  none does: scored the {c['scored']} least-loaded lifts (within {LIFT_FALLBACK_SPREAD:.0%} "
                    f"of the grip's capacity of the least; the tool may turn in the pads)")
        ch = self.choice or {}
        if ch.get("checked"):
            meas = [m["measured_total"] for m in ch["checked"]]
            best = min((m for m in meas if m is not None), default=None)
            guard = "fired: the analytic cost's best mixed in" if ch["guard_fired"] else "quiet"
            kept = (f"the lowest measured total ({best:.3g}) kept" if ch["index"] is not None and best is not None
                    else "none did the task and held")
            out(f"checked in MuJoCo: {len(meas)} grasps (guard {guard}), {kept}")
        for k, a in enumerate(self.attempts):
            out(f"pick {k + 1}: {a['why']}; " + ("turned the tool over" if a["action"] == "turn_over" else
                                                 "put the tool back down") + ", planned again")
        if self.pick is not None:
            p = self.pick
            out(f"pick{'' if not self.attempts else f' {len(self.attempts) + 1}'}: {'lifted' if p.lifted else 'failed'} (rose "
                f"{p.rise * 1000:.0f} mm); achieved grasp {p.position_error * 1000:.1f} mm and "
                f"{np.degrees(p.angle_error):.1f} deg from the planned one")
        if self.labels is not None:
            L = self.labels
            out(f"task: metric {L['task_metric']:.4g}, success {L['success']}, grip failure {L['failed']}; full "
                f"induced peak wrist torque {L['peak_torque_induced']:.2f} N·m (raw {L['peak_torque']:.2f})")
        out(f"{'done' if self.success else 'ended at ' + self.stage}: {self.message}")
        return "\n".join(lines)

    def to_json(self) -> dict:
        return {"schema": "itup.run/2", "instruction": self.instruction, "method": self.method, "stage": self.stage,
                "success": self.success, "message": self.message, "seed": self.seed,
                "grounding": None if self.grounding is None else self.grounding.to_json(),
                "tabletop": self.tabletop.to_json(), "counts": self.counts, "choice": self.choice,
                "pick": None if self.pick is None else self.pick.to_json(), "attempts": self.attempts,
                "pick_tabletop": None if self.pick_tabletop is None else self.pick_tabletop.to_json(),
                "labels": self.labels,
                "wall_s": round(self.wall_s, 3)}


def _far_end(tool: Tool) -> tuple[np.ndarray, np.ndarray]:
    """The object-level default contact: the centre of the mesh's points within FAR_END_BAND of its far
    end along the handle (+z), and the category's contact direction."""
    v = np.asarray(tool.mesh.vertices, float)
    top = v[v[:, 2] >= v[:, 2].max() - FAR_END_BAND]
    c = top.mean(0)
    c = np.asarray(tool.mesh.nearest.on_surface(c[None])[0][0], float)
    return c, np.asarray(CATEGORY_CONTACT_NORMAL.get(tool.category, tool.contact_normal), float)


def _whole_tool(tool: Tool, contact: np.ndarray, normal: np.ndarray, region: Box | None = None) -> Tool:
    if region is None:
        lo, hi = np.asarray(tool.mesh.bounds[0], float), np.asarray(tool.mesh.bounds[1], float)
        region = Box(lo - parts.GRASP_PART_MARGIN, hi + parts.GRASP_PART_MARGIN)
    return dataclasses.replace(tool, contact_point=contact, contact_points=contact[None], contact_normal=normal,
                               grasp_region=region)


def ground_for(method: str, instruction: str, top: Tabletop, grounder: Any, rng: np.random.Generator):
    """(Grounding, the grounded tool) as `method` grounds: two-level (the grounder), object-level (the
    grounder's task and tool, the whole tool and a default contact) or random (the grounder's task, a
    random tool, random parts)."""
    level = METHODS[method][0]
    g = grounding_mod.ground(instruction, top, grounder)
    if level == "two_level":
        return g, g.grounded_tool(top)
    if level == "object":
        tool = top.tools[g.tool_index]
        c, n = _far_end(tool)
        g = dataclasses.replace(g, work_part="far end (default)", grasp_part="whole tool",
                                notes=g.notes + ("object-level grounding: whole tool, default contact",))
        return g, _whole_tool(tool, c, n)
    i = int(rng.integers(len(top.tools)))
    tool = top.tools[i]
    ps = parts.tool_parts(tool)
    hold, strike = ps[int(rng.integers(len(ps)))], ps[int(rng.integers(len(ps)))]
    centre = 0.5 * (strike.region.lo + strike.region.hi)
    c = np.asarray(tool.mesh.nearest.on_surface(centre[None])[0][0], float)
    n = np.asarray(CATEGORY_CONTACT_NORMAL.get(tool.category, tool.contact_normal), float)
    region = Box(hold.region.lo - parts.GRASP_PART_MARGIN, hold.region.hi + parts.GRASP_PART_MARGIN)
    g = dataclasses.replace(g, tool_index=i, tool_name=tool.name, work_part=strike.name, grasp_part=hold.name,
                            notes=("no grounding: a random tool and random parts",))
    return g, _whole_tool(tool, c, n, region)


def _join_traces(traces: list[dict]) -> dict:
    """One trace of several picks and put-backs in turn (`pickup.PickResult.trace`, each the same bodies):
    times run on across them; the first's model."""
    t, off = [], 0.0
    for tr in traces:
        t.append(np.asarray(tr["t"], float) - tr["t"][0] + off)
        off = t[-1][-1] + PICK_LOG_EVERY * float(tr["model"].opt.timestep)
    return {"t": np.concatenate(t), "bodies": traces[0]["bodies"], "pos": np.concatenate([tr["pos"] for tr in traces]),
            "quat": np.concatenate([tr["quat"] for tr in traces]), "model": traces[0]["model"]}


def _plan(top: Tabletop, g: Any, tool: Tool, task: Any, *, seed: int, samples: int, grip_force: float,
          tried: list[np.ndarray]) -> dict:
    """Stage 4 on table `top`: rounds of `samples` grasps (seeds seed * SAMPLE_ROUNDS + r) until
    MIN_CANDIDATES can be picked within LIFT_TORQUE_SHARE and carried through the task with margin,
    leaving out grasps within RETRY_EXCLUSION of a `tried` origin. Returns {"counts", "grasps", "shifts",
    "q_paths", "lift_load"} or {"counts", "failure": why none, "stage": where the run ends, and where
    grasps could be picked but none carried: "turnable": (of the pickable grasps whose turn the arm can
    follow, `regrasp.can_turn_over`, the one [1] whose lift loads the pads least, its joint path, its lift
    load), to turn the tool over with}."""
    import itup_jax as itup
    from itup_jax.grasp_sampler import SamplingError
    from itup_jax.pickup import LIFT_TORQUE_SHARE, pick_candidates, reachable_with_margin

    counts: dict = {"sampled": 0, "rounds": 0}
    found = []  # (grasps, shift, q_path, lift_load) of each round's pickable, task-reachable candidates
    pickable = []  # (grasps, q_path, lift_load) of each round's pickable ones (to turn the tool over)
    for r in range(SAMPLE_ROUNDS):
        try:
            grasps = itup.sample_grasps(tool, int(samples), seed=int(seed) * SAMPLE_ROUNDS + r)
        except SamplingError as exc:
            return {"counts": counts, "failure": str(exc), "stage": "plan"}
        cands = pick_candidates(top, g.tool_index, tool, grasps, grip_force=grip_force,
                                lift_torque_share=math.inf)
        counts["sampled"] += int(samples)
        counts["rounds"] += 1
        for k, v in cands.counts.items():
            if k != "given":
                counts[f"pick_{k}"] = counts.get(f"pick_{k}", 0) + v
        if cands.grasps is not None:
            pickable.append((cands.grasps, cands.q_path, cands.lift_load))
        ok = reachable_with_margin(task, cands.grasps) if cands.grasps is not None else np.zeros(0, bool)
        counts["task_reachable"] = counts.get("task_reachable", 0) + int(ok.sum())
        if tried and ok.any():
            p = np.asarray(cands.grasps.p_tool_grasp, float)
            near = np.min(np.linalg.norm(p[:, None, :] - np.asarray(tried)[None], axis=-1), axis=1) < RETRY_EXCLUSION
            counts["tried_nearby"] = counts.get("tried_nearby", 0) + int((ok & near).sum())
            ok &= ~near
        if ok.any():
            keep = np.nonzero(ok)[0]
            found.append((cands.grasps[keep], cands.shift[keep], cands.q_path[keep], cands.lift_load[keep]))
            counts["lift_within_share"] = counts.get("lift_within_share", 0) + int(
                (cands.lift_load[keep] <= LIFT_TORQUE_SHARE).sum())
        if counts.get("lift_within_share", 0) >= MIN_CANDIDATES:
            break
    if not found:
        if not counts.get("pick_reachable"):
            what = f"none of {counts['sampled']} grasps on the {tool.name} can be picked from its rest pose"
        elif counts.get("tried_nearby"):
            what = (f"none of the {counts['pick_reachable']} pickable grasps can be carried through the {g.task} "
                    f"task but the {counts['tried_nearby']} near those already tried")
        else:
            what = f"none of the {counts['pick_reachable']} pickable grasps can be carried through the {g.task} task"
        out = {"counts": counts, "failure": what, "stage": "pick"}
        if pickable:
            from itup_jax.regrasp import can_turn_over

            # of the pickable grasps whose turn the arm can follow, the one whose lift loads the pads least
            best = None
            for gr, qp, load in pickable:
                turn = can_turn_over(top, g.tool_index, gr, qp)
                counts["turnable"] = counts.get("turnable", 0) + int(turn.sum())
                if turn.any():
                    j = int(np.argmin(np.where(turn, load, np.inf)))
                    if best is None or load[j] < best[2]:
                        best = (gr[j:j + 1], qp[j], float(load[j]))
            if best is not None:
                out["turnable"] = best
        return out
    grasps_k = itup.make_grasps(np.concatenate([np.asarray(f[0].p_tool_grasp) for f in found]),
                                q_tool_grasp=np.concatenate([np.asarray(f[0].q_tool_grasp) for f in found]),
                                width=np.concatenate([np.asarray(f[0].width) for f in found]))
    shifts = np.concatenate([f[1] for f in found])
    q_paths = np.concatenate([f[2] for f in found])
    lift_load = np.concatenate([f[3] for f in found])
    # plan within the lift torque share where any grasp allows it (else among the MIN_CANDIDATES that
    # load the lift least, those within LIFT_FALLBACK_SPREAD of the least)
    if counts.get("lift_within_share"):
        keep = np.nonzero(lift_load <= LIFT_TORQUE_SHARE)[0]
    else:
        keep = np.argsort(lift_load, kind="stable")[:MIN_CANDIDATES]
        keep = np.sort(keep[lift_load[keep] <= lift_load[keep[0]] + LIFT_FALLBACK_SPREAD])
    counts["scored"] = len(keep)
    return {"counts": counts, "grasps": grasps_k[keep], "shifts": shifts[keep], "q_paths": q_paths[keep],
            "lift_load": lift_load[keep]}


def run(instruction: str, *, tabletop: Tabletop | None = None, clutter: int = 0, seed: int = 0,
        method: str = "itup", grounder: Any = "rule", samples: int = DEFAULT_SAMPLES,
        grip_force: float = robot.GRIP_FORCE, randomize: bool = True, model: Any = None,
        traces: bool = False, max_attempts: int = MAX_PICK_ATTEMPTS, verify: int | None = None,
        guard_verify: int | None = None) -> RunResult:
    """Run the whole chain once (module docstring).

    Args:
      instruction: plain words, e.g. "drive the nail with the hammer".
      tabletop: the table (default: `make_tabletop(clutter=clutter, seed=seed)`).
      seed: seeds the table (when built here), the sampling, the random ablation and the physics draw.
      method: a key of METHODS.  grounder: 'rule' or a grounder object (`vlm.VLMGrounder`).
      samples: grasps sampled per round before the pick and reach filters (rounds until MIN_CANDIDATES
        pass, at most SAMPLE_ROUNDS).
      grip_force: N per pad, pick and task.  randomize: the task's physics drawn around the priors
        (`sim.physics.Randomization`), else nominal.
      model: SDG-Net checkpoint for the SDG-Net methods (default the shipped one).
      traces: keep the task rollout's per-step traces and the picks' body poses (for `mcap_log`: every
        pick and put-back in turn, in `pick.trace`).
      verify: the SDG-Net methods' check (`planning.default_pick`): the K best rolled out in MuJoCo
        (default `planning.DEFAULT_VERIFY`, 5, as `itup plan`); 0: the best-scored grasp (unless the guard
        fires). The baselines pick their best-scored grasp.
      guard_verify: where the out-of-distribution guard fires, the check covers max(verify, guard_verify)
        grasps (default `planning.GUARD_VERIFY_K`, 20, as `itup plan`).
      max_attempts: picks made at most. A pick that does not lift the tool, or lifts it into a grasp
        that cannot be carried through the task, puts it back down (`regrasp.put_back`); where no
        pickable grasp can be carried through the task, a pick turns the tool over (`regrasp.turn_over`);
        either way the table is planned again from the tools' new rest poses, without the grasps within
        RETRY_EXCLUSION of those tried. 1: one pick, as planned first.
    """
    import itup_jax as itup
    from itup_jax.pickup import execute_pick
    from itup_jax.regrasp import put_back, turn_over
    from itup_jax.sim.arm import reachable
    from itup_jax.sim.config import SimConfig
    from itup_jax.sim.physics import Randomization
    from itup_jax.sim.rollout import simulate

    if method not in METHODS:
        raise InputError(f"run: method {method!r}: unknown; choose from {', '.join(METHODS)}")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= MAX_CANDIDATES:
        raise InputError(f"run: samples must be an integer in 1..{MAX_CANDIDATES:,} (grasps sampled per round), got "
                         f"{samples!r}")
    if not (isinstance(grip_force, (int, float)) and math.isfinite(grip_force) and grip_force > 0):
        raise InputError(f"run: grip_force must be a positive number of newtons, got {grip_force!r}")
    if isinstance(max_attempts, bool) or not isinstance(max_attempts, (int, np.integer)) or max_attempts < 1:
        raise InputError(f"run: max_attempts must be an integer >= 1, got {max_attempts!r}")
    from itup_jax.planning import DEFAULT_VERIFY, GUARD_VERIFY_K, default_pick

    verify = DEFAULT_VERIFY if verify is None else verify
    guard_verify = GUARD_VERIFY_K if guard_verify is None else guard_verify
    for name, k in (("verify", verify), ("guard_verify", guard_verify)):
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
            raise InputError(f"run: {name} must be an integer >= 0 (grasps checked in MuJoCo), got {k!r}")
    t0 = time.perf_counter()
    top = tabletop if tabletop is not None else make_tabletop(clutter=clutter, seed=seed)
    rng = np.random.default_rng([int(seed), 4049])
    base = dict(instruction=instruction, method=method, tabletop=top, seed=int(seed))

    def end(stage, message, **kw):
        fields = dict(grounding=None, tool=None, counts={}, choice=None, pick=None, labels=None, attempts=[],
                      pick_tabletop=None)
        board = kw.pop("board", top)
        fields.update(kw)
        fields["attempts"] = list(fields["attempts"])
        fields["pick_tabletop"] = None if board is top else board
        return RunResult(**base, stage=stage, message=message, wall_s=time.perf_counter() - t0, **fields)

    try:
        g, tool = ground_for(method, instruction, top, grounder, rng)
    except grounding_mod.GroundingError as exc:
        return end("grounding", str(exc))
    try:
        task = itup.make_task(g.task, tool)
    except InputError as exc:
        return end("plan", str(exc), grounding=g, tool=tool)
    attempts: list[dict] = []  # the picks that could not go on: what was tried, what happened
    tried: list[np.ndarray] = []  # their planned grasp origins (tool frame)
    logged: list[dict] = []  # with traces: the earlier picks' and put-backs' recorded poses
    rec = PICK_LOG_EVERY if traces else None
    board = top

    def with_log(pick, *more):
        """`pick` carrying the whole log: the earlier picks and put-backs, then `more` (with traces)."""
        return dataclasses.replace(pick, trace=_join_traces(logged + list(more))) if logged else pick
    for attempt in range(max_attempts):
        planned = _plan(board, g, tool, task, seed=int(seed), samples=int(samples), grip_force=grip_force,
                        tried=tried)
        counts = dict(planned["counts"], picks=len(attempts))
        if "failure" in planned and "turnable" in planned and attempt + 1 < max_attempts:
            # no grasp the task can use is pickable from this rest pose: pick the tool up by the grasp
            # whose lift loads the pads least and turn it over onto another face (every method alike)
            gk, qk, load = planned["turnable"]
            choice = {"index": -1, "scorer": "turn over: the least lift load", "score": load, "shift_m": 0.0,
                      "lift_load": round(load, 4), "p_tool_grasp": np.round(np.asarray(gk.p_tool_grasp)[0], 5).tolist()}
            pick = execute_pick(board, g.tool_index, gk, qk, grip_force=grip_force, record_every=rec, keep_state=True)
            counts["picks"] += 1
            kw = dict(grounding=g, tool=tool, counts=counts, choice=choice, pick=pick, attempts=attempts, board=board)
            if pick.diverged:
                return end("pick", f"{planned['failure']}; the pick to turn it over went unstable (MuJoCo)", **kw)
            if pick.lifted:
                why, back = planned["failure"], turn_over(board, g.tool_index, pick, grip_force=grip_force,
                                                          record_every=rec)
            else:
                why, back = f"{planned['failure']}; the pick to turn it over did not lift it", put_back(
                    board, g.tool_index, pick, qk, grip_force=grip_force, record_every=rec)
            attempts.append({"choice": choice, "pick": pick.to_json(), "why": why,
                             "action": "turn_over" if pick.lifted else "put_back"})
            if traces:
                logged += [pick.trace] + ([back.trace] if back.trace is not None else [])
            if back.tabletop is None:
                return end("pick", f"{why}; {back.why}", **dict(kw, pick=with_log(pick)))
            board = back.tabletop
            continue
        if "failure" in planned:
            msg = planned["failure"]
            if attempts:
                msg = f"{msg} (after {len(attempts)} earlier pick{'s' if len(attempts) > 1 else ''}: {attempts[-1]['why']})"
            return end(planned["stage"], msg, grounding=g, tool=tool, counts=counts, attempts=attempts, board=board)
        grasps_k, q_paths = planned["grasps"], planned["q_paths"]
        scorer = METHODS[method][1]
        scores = itup.score(tool, task, grasps_k,
                            model=model if (scorer == "sdgnet" and model is not None) else scorer, seed=int(seed))
        total = np.asarray(scores.total, float)
        best, check = int(np.argmin(np.where(np.isfinite(total), total, np.inf))), {}
        if scorer == "sdgnet":
            best, info = default_pick(tool, task, grasps_k, model=model, seed=int(seed), verify=int(verify),
                                      scores=scores, guard_verify=int(guard_verify))
            check = {"checked": [{"index": i, "measured_total": None if m is None else round(m, 4)}
                                 for i, m in zip(info.get("shortlist", []), info.get("measured_total", []))],
                     "guard_score": round(info["guard_score"], 4), "guard_fired": info["guard_fired"]}
            if best is None:
                n = len(check["checked"])
                msg = (f"none of the {n} grasps checked in MuJoCo (the {n} best of {len(total)} scored) did the "
                       f"{g.task} task and held; run with verify=0 (--no-verify) to pick the best-scored anyway")
                return end("plan", msg, grounding=g, tool=tool, counts=counts, attempts=attempts, board=board,
                           choice={"index": None, "scorer": scorer, "score": None, "shift_m": None,
                                   "lift_load": None, "p_tool_grasp": None, **check})
        choice = {"index": best, "scorer": scorer, "score": float(total[best]),
                  "shift_m": float(planned["shifts"][best]), "lift_load": round(float(planned["lift_load"][best]), 4),
                  "p_tool_grasp": np.round(np.asarray(grasps_k.p_tool_grasp)[best], 5).tolist(), **check}
        last = attempt + 1 == max_attempts
        pick = execute_pick(board, g.tool_index, grasps_k[best:best + 1], q_paths[best], grip_force=grip_force,
                            record_every=rec, keep_state=not last)
        counts["picks"] += 1
        kw = dict(grounding=g, tool=tool, counts=counts, choice=choice, pick=pick, attempts=attempts, board=board)
        if pick.diverged:
            why = f"the pick's simulation went unstable (MuJoCo); the {tool.name} was not lifted"
        elif not pick.lifted:
            why = (f"the {tool.name} did not come up in the pads (rose {pick.rise * 1000:.0f} mm, "
                   f"{pick.pads_touching} pads touching)")
        elif not reachable(task, pick.achieved)[0]:
            why = "the grasp the pick achieved cannot be carried through the task"
        else:
            break
        if last or pick.diverged:
            return end("pick", why, **dict(kw, pick=with_log(pick, pick.trace)))
        attempts.append({"choice": choice, "pick": pick.to_json(), "why": why, "action": "put_back"})
        tried.append(np.asarray(grasps_k.p_tool_grasp, float)[best])
        back = put_back(board, g.tool_index, pick, q_paths[best], grip_force=grip_force, record_every=rec)
        if traces:
            logged += [pick.trace, back.trace]
        if back.tabletop is None:
            return end("pick", f"{why}; {back.why}", **dict(kw, pick=with_log(pick)))
        board = back.tabletop
    kw["pick"] = pick = with_log(pick, pick.trace)
    sim = simulate(tool, task, pick.achieved, seed=int(seed), randomize=Randomization() if randomize else None,
                   config=SimConfig(grip_force=float(grip_force)), traces=traces)
    L = sim.labels
    labels = {f: (bool(np.asarray(v)[0]) if np.asarray(v).dtype == bool else float(np.asarray(v)[0]))
              for f, v in L.as_dict().items()}
    kw.update(labels=labels, task=task, sim=sim)
    if labels["failed"]:
        return end("grip", f"the {tool.name} slipped or turned in the grip during the task "
                   f"(slip {labels['slip_translation'] * 1000:.0f} mm, turn {math.degrees(labels['slip_rotation']):.1f} deg)", **kw)
    if not labels["success"]:
        return end("task", f"the {g.task} task was not done (task metric {labels['task_metric']:.4g})", **kw)
    return end("done", f"the {g.task} task was done with the {tool.name}", **kw)


def write_outputs(r: RunResult, out: str, *, view: str = "top") -> dict[str, str]:
    """Write a run's files into folder `out` (made if missing): `pick.mcap` (every pick and put-back, when a
    pick ran), `task.mcap` (the task rollout, when one ran), `scene.png` (the table with the grounded tool
    highlighted, from `view`: 'camera' or 'top') and `run.json` (schema itup.run/2, with the files and the
    view). Returns {what: path}. `itup run` is `run`, this and a printout."""
    from itup_jax import tabletop
    from itup_jax.atomic import atomic_write, atomic_write_json
    from itup_jax.mcap_log import bodies_mcap_bytes, write_rollout_mcap
    from itup_jax.sim.scene import build_scene

    os.makedirs(out, exist_ok=True)
    files = {}
    g = r.grounding
    if r.pick is not None and r.pick.trace is not None:
        tr = r.pick.trace
        files["pick_mcap"] = os.path.join(out, "pick.mcap")
        atomic_write(files["pick_mcap"], bodies_mcap_bytes(tr["model"], tr["t"], tr["pos"], tr["quat"], tr["bodies"],
                                                           {"tool": g.tool_name, "instruction": r.instruction}))
    if r.sim is not None:
        files["mcap"] = write_rollout_mcap(os.path.join(out, "task.mcap"), build_scene(r.tool, r.task), r.task, r.sim,
                                           0, grasp=r.pick.achieved[0])
    files["png"] = os.path.join(out, "scene.png")
    tabletop.picture(r.tabletop, files["png"], highlight=g.tool_index, view=view,
                     title=f"{r.instruction!r}: tool {g.tool_index + 1} ({g.tool_name}); {r.stage}")
    files["json"] = os.path.join(out, "run.json")
    atomic_write_json(files["json"], {**r.to_json(), "files": files, "picture_view": view}, indent=2)
    return files

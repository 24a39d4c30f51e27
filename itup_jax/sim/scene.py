"""Scene composition with `mujoco.MjSpec`: UR5e + parallel gripper + any tool + a task environment.

    scene = build_scene(tool, task)        # -> Scene: compiled MjModel plus the indices the rollout needs

The composed model: the task environment from `mjcf/scenes/<kind>.xml` (moved so its target sits at
the task's c_obj), the UR5e from `mjcf/universal_robots_ur5e/ur5e.xml` at the world origin, the gripper
from `mjcf/parallel_gripper/gripper.xml` attached to the flange (the wrist force/torque sensor between
them), and the tool as a free body whose mass and inertia are the `Tool`'s. Collision is by explicit
pairs only (pads-tool, tool-target, tool-table for sweep and reach; the environment's own pairs),
elliptic cones. The arm has no collision geometry: IK keeps its elbow and wrist above the table.

Physics of the tool's contacts, from the tool's priors:
  * pads-tool friction: mu (torsional 0.005 m, an assumed pad patch);
  * tool-target: MuJoCo's soft contact as a damped spring whose half period is about the contact
    duration, timeconst = dt_c sqrt(1 - zeta_0^2) / (pi zeta_0), zeta_0 = -ln e / sqrt(pi^2 + ln^2 e),
    floored at CONTACT_MIN_TIMECONST = 4 ms at any step (the 2 timesteps MuJoCo clamps to at 2 ms; one
    contact model at every step, so that steps compare: experiments/timestep_convergence.py), and
    whose damping ratio is calibrated so that MuJoCo delivers the restitution e (`sim/restitution.py`).

Everything kind-specific (the environment's MJCF, its targets, where they are placed, the integration
step) comes from the task registry, `itup_jax.tasks`. Each kind's step is 0.5 ms, the coarsest of 2, 1
and 0.5 ms whose full induced peak torque ranks like that integrated at 0.25 ms over held-out tools
(`experiments/timestep_convergence.py`): Spearman 0.99-0.998 for the hammer, knock and reach; the
sweep's 0.96, no better than a 2 mm move of the grasp ranks against itself, and no finer step changes
how SDG-Net ranks it (docs/design.md, "Each task has its own integration step").
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import math
import os
from pathlib import Path

import mujoco
import numpy as np

from itup_jax import tasks
from itup_jax.errors import InputError
from itup_jax.robot import ARM_JOINTS, PAD_SOLIMP, PAD_SOLREF, PAD_TORSION
from itup_jax.sim.restitution import calibrated_dampratio, textbook_dampratio
from itup_jax.task import Task
from itup_jax.tools import Tool


def _mjcf_dir() -> Path:
    """The folder of the project's MJCF: `$ITUP_MJCF_DIR` if set; in an installed wheel the package's
    `itup_jax/mjcf` (the repository's top-level `mjcf/`, mapped into the package at build time); in a
    source checkout (an editable install) the repository's `mjcf/` itself."""
    if os.environ.get("ITUP_MJCF_DIR"):
        return Path(os.environ["ITUP_MJCF_DIR"])
    packaged = importlib.resources.files("itup_jax") / "mjcf"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[2] / "mjcf"


MJCF_DIR = _mjcf_dir()
UR5E_XML = MJCF_DIR / "universal_robots_ur5e" / "ur5e.xml"
GRIPPER_XML = MJCF_DIR / "parallel_gripper" / "gripper.xml"
#: s, the one step of every scene and dataset before per-task steps (a manifest recording no step was
#: made at it)
TIMESTEP = 0.002
#: s, the floor of the tool-target contact's time constant (2 x TIMESTEP, as MuJoCo clamped it there)
CONTACT_MIN_TIMECONST = 0.004
TOOL_TARGET_FRICTION = 0.5  # -, tool on nail/blocks (assumed)
TOOL_TABLE_FRICTION = 0.4  # -, bristles or aluminium on a wooden table (assumed)


#: s, the largest timestep a scene accepts (five times the reach's; the strikes need 0.5 ms to converge)
MAX_TIMESTEP = 0.01


def __getattr__(name: str):
    """`TASK_TIMESTEP`: kind -> its default integration step (s), read from the task registry."""
    if name == "TASK_TIMESTEP":
        return tasks.timesteps()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def task_timestep(kind: str) -> float:
    """The default integration step (s) of task kind `kind` (`tasks.get(kind).timestep`)."""
    return tasks.get(kind).timestep


def check_timestep(timestep, where: str) -> float:
    """`timestep` (s) as a float if it lies in (0, MAX_TIMESTEP], else InputError naming `where`."""
    if not (isinstance(timestep, (int, float, np.floating)) and not isinstance(timestep, bool)
            and 0 < timestep <= MAX_TIMESTEP):
        raise InputError(f"{where}: timestep must be in (0, {MAX_TIMESTEP}] s, got {timestep!r}")
    return float(timestep)


def scene_xml(kind: str) -> Path:
    """The environment MJCF of task kind `kind`."""
    return MJCF_DIR / tasks.get(kind).scene_file


def restitution_solref(restitution: float, contact_duration: float, timestep: float = TIMESTEP) -> tuple[float, float]:
    """MuJoCo solref (timeconst s, dampratio) of a contact that lasts about `contact_duration` seconds
    and delivers `restitution` in MuJoCo.

    The time constant is the textbook spring-damper's whose half period is the contact duration,
    timeconst = dt_c sqrt(1 - zeta_0^2) / (pi zeta_0) with zeta_0 = `restitution.textbook_dampratio`,
    rounded to two significant digits (one calibration table per value) and floored at
    CONTACT_MIN_TIMECONST (the same contact at every step up to 2 ms) and at 2 timesteps, as native
    MuJoCo would clamp it silently, so that MJX and native MuJoCo integrate the same contact at coarser
    steps too. The damping ratio is the one at which MuJoCo's drop delivers `restitution`
    (`restitution.calibrated_dampratio`): the textbook ratio delivers more (0.49 for e = 0.4 at 0.5 ms,
    more than 1 at 2 ms) because MuJoCo's contact lets go when its force, not its penetration, returns
    to zero.
    """
    e = min(max(float(restitution), 1e-3), 0.999)
    zeta0 = textbook_dampratio(e)
    floor = max(CONTACT_MIN_TIMECONST, 2 * timestep)
    timeconst = max(float(f"{contact_duration * math.sqrt(1 - zeta0**2) / (math.pi * zeta0):.2g}"), floor)
    return timeconst, calibrated_dampratio(e, timeconst, timestep)


def target_solref(kind: str, restitution: float, contact_duration: float, timestep: float = TIMESTEP) -> tuple[float, float]:
    """solref of the tool-target pairs of a `kind` scene: `restitution_solref`, with dampratio 1 for a
    kind whose target gives way under the blow (`TaskKind.plastic_target`: a nail driven into wood; a
    critically damped contact still delivers e = 0.13 in MuJoCo's drop, `restitution.py`).
    With the restitution's under-damped spring (e = 0.4), a block dropped on the nail drove it 1.1-1.5x
    as far as its kinetic energy can at the hammer's 0.5 ms step, 3-5x at 2 ms: the soft contact and the
    nail's friction constraint together add energy."""
    timeconst, zeta = restitution_solref(restitution, contact_duration, timestep)
    return (timeconst, 1.0) if tasks.get(kind).plastic_target else (timeconst, zeta)


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    """A compiled scene and the indices a rollout needs (host side)."""

    model: mujoco.MjModel
    kind: str
    tool: Tool
    arm_qpos: np.ndarray  # [6] qpos addresses of the arm joints
    arm_dof: np.ndarray  # [6] dof addresses
    finger_qpos: np.ndarray  # [2]
    tool_qpos: int  # address of the tool's free joint (7 values)
    tool_dof: int
    grip_actuator: int
    arm_actuators: np.ndarray  # [6] position servos
    arm_vel_actuators: np.ndarray  # [6] velocity servos (velocity feed-forward)
    grasp_site: int
    ft_site: int
    sensors: dict  # name -> (adr, dim)
    tool_target_pairs: np.ndarray  # pair ids
    pad_tool_pairs: np.ndarray

    def sensor(self, sensordata: np.ndarray, name: str) -> np.ndarray:
        """Slice a named sensor out of sensordata [..., nsensordata]."""
        adr, dim = self.sensors[name]
        return sensordata[..., adr:adr + dim]


def add_tool_body(spec: mujoco.MjSpec, tool: Tool, name: str = "tool", *, pos=(0.0, 0.0, 1.0), quat=None,
                  **geom_kw) -> list[str]:
    """Add `tool` as a free body `name` (free joint `name`) at `pos`, `quat` (wxyz) with the tool's mass
    properties and its collision primitives as geoms `<name>_<k>` (capsules, boxes, and a mesh tool's
    convex pieces as meshes `<name>_hull<k>`; MuJoCo and MJX collide convex meshes). `geom_kw` overrides
    the geoms' defaults (no collision by type: the scenes collide by explicit pairs). Returns the geom
    names."""
    body = spec.worldbody.add_body(name=name, pos=list(pos), **({} if quat is None else {"quat": list(quat)}))
    body.add_freejoint(name=name)
    p = tool.params
    body.mass = float(p.mass)
    body.ipos = np.asarray(p.com, float)
    I = np.asarray(p.inertia, float)
    body.fullinertia = [I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
    body.explicitinertial = True
    names = []
    kw = dict(contype=0, conaffinity=0, rgba=[0.55, 0.35, 0.2, 1.0], density=0.0)
    kw.update(geom_kw)
    for i, prim in enumerate(tool.primitives):
        gname = f"{name}_{i}"
        if prim[0] == "capsule":
            _, a, b, r = prim
            body.add_geom(name=gname, type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=np.r_[a, b], size=[r, 0, 0], **kw)
        elif prim[0] == "box":
            _, lo, hi = prim
            body.add_geom(name=gname, type=mujoco.mjtGeom.mjGEOM_BOX, pos=(lo + hi) / 2, size=(hi - lo) / 2, **kw)
        else:
            _, verts, faces = prim
            spec.add_mesh(name=f"{name}_hull{i}", uservert=np.asarray(verts, float).ravel(),
                          userface=np.asarray(faces, np.int32).ravel())
            body.add_geom(name=gname, type=mujoco.mjtGeom.mjGEOM_MESH, meshname=f"{name}_hull{i}", **kw)
        names.append(gname)
    if not names:
        raise InputError(f"tool {tool.name!r}: no collision primitives (a mesh tool gets its convex pieces when loaded)")
    return names


def attach_robot(spec: mujoco.MjSpec, timestep: float) -> None:
    """Attach the UR5e at the world origin ('ur5e/' names) and the gripper to its flange ('gripper/'), and
    set the solver options every scene with the robot uses (step `timestep` s, implicitfast, elliptic
    cones, impratio 10)."""
    arm = mujoco.MjSpec.from_file(str(UR5E_XML))
    gripper = mujoco.MjSpec.from_file(str(GRIPPER_XML))
    spec.worldbody.add_frame().attach_body(arm.body("base"), "ur5e/", "")
    spec.site("ur5e/flange").attach_body(gripper.body("gripper_base"), "gripper/", "")
    # attach keeps the parent's <option> and drops the child's (its elliptic cone and impratio: without
    # them the pads dropped a 0.8 kg hammer): set the solver options on the composed spec
    spec.option.timestep = timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    # an unstable step keeps its NaN or huge values instead of MuJoCo's silent reset to the initial state,
    # so the labels see it (`labels.compute_labels`: diverged) on both backends (MJX never resets)
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)


def target_bodies(kind: str) -> tuple[str, ...]:
    """The task objects of a `kind` scene whose world pose is recorded (sensors `target/<body>_pos`, `_quat`)."""
    return tasks.get(kind).target_bodies


def build_scene(tool: Tool, task: Task, *, timestep: float | None = None) -> Scene:
    """Compose and compile the scene for `tool` doing `task` (host side), integrated at `timestep` s
    (None: the task's default, `task_timestep(task.kind)`)."""
    kind = tasks.get(task.kind)
    timestep = kind.timestep if timestep is None else check_timestep(timestep, "build_scene")
    spec = mujoco.MjSpec.from_file(str(MJCF_DIR / kind.scene_file))
    kind.place(spec, task)
    attach_robot(spec, timestep)
    tool_geoms = add_tool_body(spec, tool)

    mu = float(tool.params.mu)
    pad_pairs, target_pairs = [], []
    for pad in ("gripper/pad_neg", "gripper/pad_pos"):
        for g in tool_geoms:
            spec.add_pair(name=f"{pad}-{g}", geomname1=pad, geomname2=g, condim=4,
                          friction=[mu, mu, PAD_TORSION, 1e-4, 1e-4], solref=list(PAD_SOLREF),
                          solimp=list(PAD_SOLIMP))
            pad_pairs.append(f"{pad}-{g}")
    solref = target_solref(task.kind, float(tool.params.restitution), float(tool.params.contact_duration), timestep)
    for target in kind.target_geoms:
        for g in tool_geoms:
            spec.add_pair(name=f"{g}-{target}", geomname1=g, geomname2=target, condim=3,
                          friction=[TOOL_TARGET_FRICTION] * 2 + [0.005, 1e-4, 1e-4], solref=list(solref))
            target_pairs.append(f"{g}-{target}")
    if kind.works_on_table:  # the tool works on the table (bristles, a hook): it touches the table
        for g in tool_geoms:
            spec.add_pair(name=f"{g}-table", geomname1=g, geomname2="table", condim=3,
                          friction=[TOOL_TABLE_FRICTION] * 2 + [0.005, 1e-4, 1e-4])
    # sensors: the tool's pose in the grasp frame, and in the world
    mj = mujoco.mjtObj
    for name, stype, ref in (("tool_pos_grasp", mujoco.mjtSensor.mjSENS_FRAMEPOS, "gripper/grasp"),
                             ("tool_quat_grasp", mujoco.mjtSensor.mjSENS_FRAMEQUAT, "gripper/grasp"),
                             ("tool_pos", mujoco.mjtSensor.mjSENS_FRAMEPOS, None),
                             ("tool_quat", mujoco.mjtSensor.mjSENS_FRAMEQUAT, None)):
        kw = dict(name=name, type=stype, objtype=mj.mjOBJ_XBODY, objname="tool")  # body frame, not inertial
        if ref:
            kw.update(reftype=mj.mjOBJ_SITE, refname=ref)
        spec.add_sensor(**kw)
    for body in kind.target_bodies:  # the task objects' world poses (logs, plots)
        spec.add_sensor(name=f"target/{body}_pos", type=mujoco.mjtSensor.mjSENS_FRAMEPOS, objtype=mj.mjOBJ_XBODY,
                        objname=body)
        spec.add_sensor(name=f"target/{body}_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT, objtype=mj.mjOBJ_XBODY,
                        objname=body)
    # pad contact: per pad, whether it touches and the force of its strongest contact (contact frame:
    # normal first). intprm = (data: found | force, reduce: max force, slots: 1), a form MJX supports.
    data_bits = (1 << int(mujoco.mjtConDataField.mjCONDATA_FOUND)) | (1 << int(mujoco.mjtConDataField.mjCONDATA_FORCE))
    for pad in ("neg", "pos"):
        spec.add_sensor(name=f"pad_{pad}_contact", type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=mj.mjOBJ_GEOM,
                        objname=f"gripper/pad_{pad}", intprm=[data_bits, 2, 1])
    for key in list(spec.keys):  # the arm's keyframe no longer matches the composed qpos
        spec.delete(key)
    model = spec.compile()

    def jid(name):
        return model.joint(name).id

    sensors = {model.sensor(i).name: (int(model.sensor_adr[i]), int(model.sensor_dim[i])) for i in range(model.nsensor)}
    arm_ids = [jid(f"ur5e/{j}") for j in ARM_JOINTS]
    return Scene(
        model=model, kind=task.kind, tool=tool,
        arm_qpos=np.array([model.jnt_qposadr[j] for j in arm_ids]),
        arm_dof=np.array([model.jnt_dofadr[j] for j in arm_ids]),
        finger_qpos=np.array([model.jnt_qposadr[jid(f"gripper/finger_{s}")] for s in ("neg", "pos")]),
        tool_qpos=int(model.jnt_qposadr[jid("tool")]), tool_dof=int(model.jnt_dofadr[jid("tool")]),
        grip_actuator=model.actuator("gripper/grip").id,
        arm_actuators=np.array([model.actuator(f"ur5e/{j}").id for j in ARM_JOINTS]),
        arm_vel_actuators=np.array([model.actuator(f"ur5e/{j}_vel").id for j in ARM_JOINTS]),
        grasp_site=model.site("gripper/grasp").id, ft_site=model.site("gripper/ft_site").id,
        sensors=sensors,
        tool_target_pairs=np.array([model.pair(n).id for n in target_pairs]),
        pad_tool_pairs=np.array([model.pair(n).id for n in pad_pairs]),
    )

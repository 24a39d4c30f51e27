"""Rollout logs as MCAP with Foxglove schemas: open a rollout in Foxglove, or read it back in Python.

    res = itup.simulate(tool, task, grasps, traces=True)
    write_rollout_mcap("rollout.mcap", scene, task, res, index=0)
    log = read_rollout_mcap("rollout.mcap")      # {topic: [decoded JSON messages]}, plus "metadata"

Channels (JSON messages, each with a JSON Schema registered under the name Foxglove recognises):
  /tf            foxglove.FrameTransforms  world -> gripper (the grasp frame), world -> tool,
                                           world -> target/<body> for every task object, and
                                           world -> body/<name> for every arm and gripper link, per step
  /scene         foxglove.SceneUpdate      primitives attached to those frames (tool capsules/boxes, or
                                           a user's mesh tool as triangles,
                                           the two pads, the task objects, the arm's and gripper's
                                           links) and the static environment (table, board) in the
                                           world frame, once, frame-locked
  /wrist_wrench  itup.WristWrench          force (N) and torque (N m) at the wrist F/T site, per step
  /pad_contact   itup.PadContact           normal force of each pad's strongest contact (N), per step
  /labels        itup.RolloutLabels        the rollout's labels, once at the end
and an MCAP metadata record `itup.rollout` (task, tool, grasp, physics). Times are simulation time
from the first recorded step, in nanoseconds. The links' poses are the model's forward kinematics of the
arm's joint angles, recovered by the closed-form IK (`ik.track`) from the flange pose that the recorded
grasp frame gives: the arm as it was, not as it was commanded. Files are written atomically; uncompressed (the
`mcap` package's compressors need extra dependencies), about 0.5 MB per rollout at the default
decimation.
"""

from __future__ import annotations

import io
import json
import math
import os
from typing import Any

import mujoco
import numpy as np
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from itup_jax.atomic import atomic_write
from itup_jax.errors import InputError
from itup_jax.rotations import quat_mul, quat_rotate
from itup_jax.sim.scene import Scene, target_bodies
from itup_jax.task import Task

_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_TIME = {"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0},
                                          "nsec": {"type": "integer", "minimum": 0}}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}}

#: JSON Schemas of the channels (foxglove.* follow Foxglove's published message definitions).
SCHEMAS: dict[str, dict] = {
    "foxglove.FrameTransforms": {
        "title": "foxglove.FrameTransforms", "type": "object",
        "properties": {"transforms": {"type": "array", "items": {
            "type": "object",
            "properties": {"timestamp": _TIME, "parent_frame_id": {"type": "string"},
                           "child_frame_id": {"type": "string"}, "translation": _VEC3, "rotation": _QUAT}}}}},
    "foxglove.SceneUpdate": {
        "title": "foxglove.SceneUpdate", "type": "object",
        "properties": {
            "deletions": {"type": "array", "items": {"type": "object"}},
            "entities": {"type": "array", "items": {
                "type": "object",
                "properties": {
                    "timestamp": _TIME, "frame_id": {"type": "string"}, "id": {"type": "string"},
                    "lifetime": _TIME, "frame_locked": {"type": "boolean"},
                    "cubes": {"type": "array", "items": {"type": "object", "properties": {
                        "pose": _POSE, "size": _VEC3, "color": _COLOR}}},
                    "cylinders": {"type": "array", "items": {"type": "object", "properties": {
                        "pose": _POSE, "size": _VEC3, "bottom_scale": {"type": "number"},
                        "top_scale": {"type": "number"}, "color": _COLOR}}},
                    "spheres": {"type": "array", "items": {"type": "object", "properties": {
                        "pose": _POSE, "size": _VEC3, "color": _COLOR}}},
                    "triangles": {"type": "array", "items": {"type": "object", "properties": {
                        "pose": _POSE, "points": {"type": "array", "items": _VEC3}, "color": _COLOR,
                        "indices": {"type": "array", "items": {"type": "integer", "minimum": 0}}}}}}}}}},
    "itup.WristWrench": {
        "title": "itup.WristWrench", "type": "object",
        "properties": {"timestamp": _TIME, "frame_id": {"type": "string"}, "force": _VEC3, "torque": _VEC3,
                       "torque_norm": {"type": "number"}}},
    "itup.PadContact": {
        "title": "itup.PadContact", "type": "object",
        "properties": {"timestamp": _TIME, "neg_normal_force": {"type": "number"},
                       "pos_normal_force": {"type": "number"}, "neg_found": {"type": "boolean"},
                       "pos_found": {"type": "boolean"}}},
    "itup.RolloutLabels": {"title": "itup.RolloutLabels", "type": "object",
                           "additionalProperties": {"type": ["number", "boolean"]}},
}
TOPICS = {"/tf": "foxglove.FrameTransforms", "/scene": "foxglove.SceneUpdate",
          "/wrist_wrench": "itup.WristWrench", "/pad_contact": "itup.PadContact", "/labels": "itup.RolloutLabels"}


def _time(ns: int) -> dict:
    return {"sec": int(ns // 1_000_000_000), "nsec": int(ns % 1_000_000_000)}


def _v(p) -> dict:
    return {"x": float(p[0]), "y": float(p[1]), "z": float(p[2])}


def _q(q_wxyz) -> dict:
    return {"x": float(q_wxyz[1]), "y": float(q_wxyz[2]), "z": float(q_wxyz[3]), "w": float(q_wxyz[0])}


def _tf(ns: int, parent: str, child: str, p, q_wxyz) -> dict:
    return {"timestamp": _time(ns), "parent_frame_id": parent, "child_frame_id": child,
            "translation": _v(p), "rotation": _q(q_wxyz)}


def _grasp_pose_world(p_tool: np.ndarray, q_tool: np.ndarray, p_tool_g: np.ndarray, q_tool_g: np.ndarray):
    """World pose of the grasp frame from the tool's world pose and its pose in the grasp frame:
    T_wg = T_wt T_gt^-1."""
    q_gt_inv = np.array([q_tool_g[0], -q_tool_g[1], -q_tool_g[2], -q_tool_g[3]])
    q_wg = quat_mul(q_tool, q_gt_inv)
    R_wg = np.empty(9)
    mujoco.mju_quat2Mat(R_wg, q_wg)
    p_wg = p_tool - R_wg.reshape(3, 3) @ p_tool_g
    return p_wg, q_wg


def _pose(p=(0, 0, 0), q_wxyz=(1, 0, 0, 0)) -> dict:
    return {"position": _v(p), "orientation": _q(q_wxyz)}


def _rgba(r, g, b, a=1.0) -> dict:
    return {"r": r, "g": g, "b": b, "a": a}


def _capsule_entities(p0, p1, radius, color) -> tuple[list, list]:
    """A capsule as a cylinder between p0 and p1 plus two end spheres (Foxglove has no capsule)."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    axis = p1 - p0
    length = float(np.linalg.norm(axis))
    q = np.array([1.0, 0, 0, 0])
    if length > 0:
        mujoco.mju_quatZ2Vec(q, axis / length)
    d = 2 * radius
    cyl = {"pose": _pose((p0 + p1) / 2, q), "size": {"x": d, "y": d, "z": length}, "bottom_scale": 1.0,
           "top_scale": 1.0, "color": color}
    sph = [{"pose": _pose(p), "size": {"x": d, "y": d, "z": d}, "color": color} for p in (p0, p1)]
    return [cyl], sph


def _triangles(vertices: np.ndarray, faces: np.ndarray, pose: dict, color: dict) -> dict:
    """A Foxglove triangle list of a mesh: vertices [V, 3] (m) and faces [F, 3] (indices into them)."""
    return {"pose": pose, "points": [_v(p) for p in np.asarray(vertices, float)], "color": color,
            "indices": np.asarray(faces, np.int64).ravel().tolist()}


def _geom_primitives(m: mujoco.MjModel, geoms, poses=None) -> dict[str, list]:
    """Foxglove cubes, cylinders, spheres and triangle lists of MuJoCo geoms: in their body's frame (the
    model's geom_pos, geom_quat), or at `poses` [(pos, quat_wxyz)] when given. Planes become 2 mm slabs;
    a mesh geom (a user's tool: its convex hull) becomes its triangles."""
    out = {"cubes": [], "cylinders": [], "spheres": [], "triangles": []}
    G = mujoco.mjtGeom
    for k, g in enumerate(geoms):
        size = np.asarray(m.geom_size[g], float)
        pos, quat = (m.geom_pos[g], m.geom_quat[g]) if poses is None else poses[k]
        color = _rgba(*map(float, m.geom_rgba[g]))
        kind = m.geom_type[g]
        if kind == G.mjGEOM_BOX:
            out["cubes"].append({"pose": _pose(pos, quat), "size": _v(2 * size), "color": color})
        elif kind == G.mjGEOM_PLANE:
            half = [size[0] or 0.6, size[1] or 0.6]
            slab = np.asarray(pos, float) - quat_rotate(quat, [0.0, 0.0, 0.001])
            out["cubes"].append({"pose": _pose(slab, quat), "size": _v([2 * half[0], 2 * half[1], 0.002]),
                                 "color": color})
        elif kind == G.mjGEOM_CYLINDER:
            d = 2 * float(size[0])
            out["cylinders"].append({"pose": _pose(pos, quat), "size": {"x": d, "y": d, "z": 2 * float(size[1])},
                                     "bottom_scale": 1.0, "top_scale": 1.0, "color": color})
        elif kind == G.mjGEOM_CAPSULE:
            axis = quat_rotate(quat, [0.0, 0.0, float(size[1])])
            c, sp = _capsule_entities(np.asarray(pos) - axis, np.asarray(pos) + axis, float(size[0]), color)
            out["cylinders"] += c
            out["spheres"] += sp
        elif kind == G.mjGEOM_SPHERE:
            d = 2 * float(size[0])
            out["spheres"].append({"pose": _pose(pos, quat), "size": {"x": d, "y": d, "z": d}, "color": color})
        elif kind == G.mjGEOM_MESH:
            k_mesh = int(m.geom_dataid[g])
            v0, nv = int(m.mesh_vertadr[k_mesh]), int(m.mesh_vertnum[k_mesh])
            f0, nf = int(m.mesh_faceadr[k_mesh]), int(m.mesh_facenum[k_mesh])
            out["triangles"].append(_triangles(m.mesh_vert[v0:v0 + nv], m.mesh_face[f0:f0 + nf], _pose(pos, quat), color))
    return out


def robot_bodies(m: mujoco.MjModel) -> list[int]:
    """The arm's and gripper's bodies with geoms of their own (`ur5e/...`, `gripper/...`)."""
    return [b for b in range(1, m.nbody) if m.body(b).name.startswith(("ur5e/", "gripper/"))
            and np.any(m.geom_bodyid == b)]


def static_geoms(m: mujoco.MjModel) -> list[int]:
    """Geoms fixed in the world that belong to neither the robot nor the tool: the table, a board."""
    out = []
    for g in range(m.ngeom):
        b = int(m.geom_bodyid[g])
        name = m.body(b).name
        if m.body_weldid[b] == 0 and not name.startswith(("ur5e/", "gripper/")) and name != "tool":
            out.append(g)
    return out


def robot_link_poses(scene: Scene, p_grasp: np.ndarray, q_grasp: np.ndarray, finger_qpos: np.ndarray):
    """World poses of the robot's links at each step, from the recorded grasp frame's world pose
    (p_grasp [S, 3], q_grasp [S, 4] wxyz): the flange pose, the closed-form IK tracked over the steps
    from 'home', and the model's forward kinematics with the fingers at `finger_qpos` [2].
    Returns (bodies [L], pos [S, L, 3], quat [S, L, 4]); rows where IK finds no solution are NaN."""
    from itup_jax import ik
    from itup_jax.robot import HOME_Q
    from itup_jax.rotations import pose_matrix, quat_to_matrix_np
    from itup_jax.sim.arm import grasp_flange_pose

    m = scene.model
    S = len(p_grasp)
    T_world_grasp = pose_matrix(quat_to_matrix_np(np.asarray(q_grasp, float)), np.asarray(p_grasp, float))
    q = ik.track(T_world_grasp @ grasp_flange_pose(), HOME_Q)  # [S, 6]
    bodies = robot_bodies(m)
    pos = np.full((S, len(bodies), 3), np.nan)
    quat = np.full((S, len(bodies), 4), np.nan)
    d = mujoco.MjData(m)
    d.qpos[scene.finger_qpos] = finger_qpos
    for k in range(S):
        if not np.all(np.isfinite(q[k])):
            continue
        d.qpos[scene.arm_qpos] = q[k]
        mujoco.mj_kinematics(m, d)
        pos[k] = d.xpos[bodies]
        quat[k] = d.xquat[bodies]
    return bodies, pos, quat


def _scene_update(scene: Scene, task: Task, width: float) -> dict:
    """Frame-locked primitives: the tool's collision primitives, the pads, the task objects', the robot links' and
    the static environment's geoms (`_geom_primitives`)."""
    m = scene.model
    entities = []
    cyls, sphs, cubes = [], [], []
    wood = _rgba(0.55, 0.4, 0.25)
    for prim in scene.tool.primitives:
        if prim[0] == "capsule":
            c, s = _capsule_entities(prim[1], prim[2], prim[3], wood)
            cyls += c
            sphs += s
        elif prim[0] == "box":
            lo, hi = np.asarray(prim[1]), np.asarray(prim[2])
            cubes.append({"pose": _pose((lo + hi) / 2), "size": _v(hi - lo), "color": _rgba(0.5, 0.5, 0.55)})
    # a user's mesh tool (its primitives are convex pieces) is drawn as its mesh, in the tool frame
    mesh_tool = any(prim[0] == "hull" for prim in scene.tool.primitives)
    tris = [_triangles(scene.tool.mesh.vertices, scene.tool.mesh.faces, _pose(), wood)] if mesh_tool else []
    entities.append({"timestamp": _time(0), "frame_id": "tool", "id": "tool", "lifetime": _time(0),
                     "frame_locked": True, "cubes": cubes, "cylinders": cyls, "spheres": sphs, "triangles": tris})
    pad = m.geom("gripper/pad_neg")
    half = np.asarray(m.geom_size[pad.id], float)
    pads = [{"pose": _pose((0, s * (width / 2 + half[1]), 0)), "size": _v(2 * half), "color": _rgba(0.2, 0.2, 0.2)}
            for s in (-1.0, 1.0)]
    entities.append({"timestamp": _time(0), "frame_id": "gripper", "id": "pads", "lifetime": _time(0),
                     "frame_locked": True, "cubes": pads})
    for body in target_bodies(task.kind):
        prims = _geom_primitives(m, np.nonzero(m.geom_bodyid == m.body(body).id)[0])
        entities.append({"timestamp": _time(0), "frame_id": f"target/{body}", "id": body, "lifetime": _time(0),
                         "frame_locked": True, **prims})
    for b in robot_bodies(m):
        name = m.body(b).name
        prims = _geom_primitives(m, np.nonzero(m.geom_bodyid == b)[0])
        entities.append({"timestamp": _time(0), "frame_id": f"body/{name}", "id": name, "lifetime": _time(0),
                         "frame_locked": True, **prims})
    entities.append(_environment(m, static_geoms(m)))
    return {"deletions": [], "entities": entities}


def _environment(m: mujoco.MjModel, geoms) -> dict:
    """A frame-locked entity of the world-fixed `geoms` at their poses in the model's reference state."""
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    poses = []
    for g in geoms:
        qw = np.zeros(4)
        mujoco.mju_mat2Quat(qw, d.geom_xmat[g])
        poses.append((d.geom_xpos[g].copy(), qw))
    return {"timestamp": _time(0), "frame_id": "world", "id": "environment", "lifetime": _time(0),
            "frame_locked": True, **_geom_primitives(m, geoms, poses)}


def _jsonable(v) -> Any:
    v = np.asarray(v)
    if v.dtype == bool:
        return bool(v)
    x = float(v)
    return x if math.isfinite(x) else None


def rollout_mcap_bytes(scene: Scene, task: Task, result: Any, index: int, *, every: int = 2,
                       grasp: Any = None) -> bytes:
    """The MCAP of rollout `index` of a `SimResult` made with traces=True (every `every`-th step)."""
    tr = result.traces
    if tr is None:
        raise InputError("write_rollout_mcap: the SimResult has no traces; call simulate(..., traces=True)")
    n = len(result.labels.valid)
    if not 0 <= index < n:
        raise InputError(f"write_rollout_mcap: index {index} out of range for {n} rollouts")
    if every < 1:
        raise InputError(f"write_rollout_mcap: every must be >= 1, got {every}")
    t = np.asarray(tr["t"], float)
    t_ns = np.round((t - t[0]) * 1e9).astype(np.int64)
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE)
    w.start(profile="", library="itup-jax")
    chan = {}
    for topic, name in TOPICS.items():
        sid = w.register_schema(name=name, encoding="jsonschema", data=json.dumps(SCHEMAS[name]).encode())
        chan[topic] = w.register_channel(topic=topic, message_encoding="json", schema_id=sid)

    def put(topic: str, ns: int, msg: dict, seq: int) -> None:
        w.add_message(chan[topic], log_time=int(ns), publish_time=int(ns), sequence=seq,
                      data=json.dumps(msg, separators=(",", ":")).encode())

    # without the grasp, the planned finger openings (each half the width less the initial squeeze)
    width = float(result.plan.qpos0[index, scene.finger_qpos].sum()) if grasp is None else float(grasp.width)
    put("/scene", 0, _scene_update(scene, task, width), 0)
    p_t, q_t = tr["tool_pos"][index], tr["tool_quat"][index]
    p_tg, q_tg = tr["tool_pos_grasp"][index], tr["tool_quat_grasp"][index]
    force, torque = tr["gripper/wrist_force"][index], tr["gripper/wrist_torque"][index]
    pad = {s: tr[f"pad_{s}_contact"][index] for s in ("neg", "pos")}
    targets = [(b, tr[f"target/{b}_pos"][index], tr[f"target/{b}_quat"][index]) for b in target_bodies(task.kind)]
    steps = list(range(0, len(t), every))
    grasp_world = [_grasp_pose_world(p_t[k], q_t[k], p_tg[k], q_tg[k]) for k in steps]
    links, link_p, link_q = robot_link_poses(scene, np.array([g[0] for g in grasp_world]),
                                             np.array([g[1] for g in grasp_world]),
                                             result.plan.qpos0[index, scene.finger_qpos])
    link_names = [scene.model.body(b).name for b in links]
    for seq, k in enumerate(steps):
        ns = int(t_ns[k])
        p_g, q_g = grasp_world[seq]
        tfs = [_tf(ns, "world", "gripper", p_g, q_g), _tf(ns, "world", "tool", p_t[k], q_t[k])]
        tfs += [_tf(ns, "world", f"target/{b}", p[k], q[k]) for b, p, q in targets]
        if np.all(np.isfinite(link_p[seq])):
            tfs += [_tf(ns, "world", f"body/{name}", link_p[seq, j], link_q[seq, j]) for j, name in enumerate(link_names)]
        put("/tf", ns, {"transforms": tfs}, seq)
        put("/wrist_wrench", ns, {"timestamp": _time(ns), "frame_id": "gripper/ft_site", "force": _v(force[k]),
                                  "torque": _v(torque[k]), "torque_norm": float(np.linalg.norm(torque[k]))}, seq)
        # contact sensor layout per pad: (found, force in the contact frame: normal first)
        put("/pad_contact", ns, {"timestamp": _time(ns), "neg_found": bool(pad["neg"][k, 0] > 0),
                                 "pos_found": bool(pad["pos"][k, 0] > 0),
                                 "neg_normal_force": abs(float(pad["neg"][k, 1])), "pos_normal_force": abs(float(pad["pos"][k, 1]))}, seq)
    labels = {f: _jsonable(v[index]) for f, v in result.labels.as_dict().items()}
    put("/labels", int(t_ns[-1]), labels, 0)
    ph = {f: float(getattr(result.physics, f)[index]) for f in
          ("mass_scale", "mu", "restitution", "contact_duration", "grip_force")}
    meta = {"task": task.kind, "tool": scene.tool.name, "index": str(index), "backend": result.backend,
            "physics": json.dumps(ph), "every_nth_step": str(every)}
    if grasp is not None:
        meta["grasp"] = json.dumps({"p_tool_grasp_m": np.asarray(grasp.p_tool_grasp, float).tolist(),
                                    "q_tool_grasp_wxyz": np.asarray(grasp.q_tool_grasp, float).tolist(),
                                    "width_m": float(grasp.width)})
    w.add_metadata("itup.rollout", meta)
    w.finish()
    return buf.getvalue()


def bodies_mcap_bytes(m: mujoco.MjModel, t: np.ndarray, pos: np.ndarray, quat: np.ndarray, bodies,
                      metadata: dict | None = None) -> bytes:
    """An MCAP of recorded body poses: `/tf` world -> body/<name> per step (t [S] s, pos [S, B, 3], quat
    [S, B, 4] wxyz of `bodies` [B]) and `/scene` with each body's geoms frame-locked to it, plus the static
    geoms in the world frame. For rollouts stepped outside `simulate` (the pick, `pickup.execute_pick`)."""
    t = np.asarray(t, float)
    t_ns = np.round((t - t[0]) * 1e9).astype(np.int64)
    buf = io.BytesIO()
    w = Writer(buf, compression=CompressionType.NONE)
    w.start(profile="", library="itup-jax")
    chan = {}
    for topic in ("/tf", "/scene"):
        name = TOPICS[topic]
        sid = w.register_schema(name=name, encoding="jsonschema", data=json.dumps(SCHEMAS[name]).encode())
        chan[topic] = w.register_channel(topic=topic, message_encoding="json", schema_id=sid)
    names = [m.body(int(b)).name for b in bodies]
    entities = [{"timestamp": _time(0), "frame_id": f"body/{n}", "id": n, "lifetime": _time(0), "frame_locked": True,
                 **_geom_primitives(m, np.nonzero(m.geom_bodyid == int(b))[0])} for b, n in zip(bodies, names)]
    entities.append(_environment(m, [g for g in range(m.ngeom) if m.geom_bodyid[g] == 0]))
    w.add_message(chan["/scene"], log_time=0, publish_time=0, sequence=0,
                  data=json.dumps({"deletions": [], "entities": entities}, separators=(",", ":")).encode())
    for k, ns in enumerate(t_ns):
        tfs = [_tf(int(ns), "world", f"body/{n}", pos[k, j], quat[k, j]) for j, n in enumerate(names)]
        w.add_message(chan["/tf"], log_time=int(ns), publish_time=int(ns), sequence=k,
                      data=json.dumps({"transforms": tfs}, separators=(",", ":")).encode())
    w.add_metadata("itup.bodies", {k: str(v) for k, v in (metadata or {}).items()})
    w.finish()
    return buf.getvalue()


def write_rollout_mcap(path: str, scene: Scene, task: Task, result: Any, index: int, *, every: int = 2,
                       grasp: Any = None) -> str:
    """Write rollout `index` of `result` (simulate(..., traces=True)) to `path` atomically; returns path."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise InputError(f"write_rollout_mcap: folder {folder!r} does not exist")
    atomic_write(path, rollout_mcap_bytes(scene, task, result, index, every=every, grasp=grasp))
    return path


def read_rollout_mcap(path: str) -> dict[str, Any]:
    """{topic: [messages as dicts], 'schemas': {topic: schema name}, 'metadata': {name: dict}}."""
    out: dict[str, Any] = {"schemas": {}, "metadata": {}}
    with open(path, "rb") as fh:
        reader = make_reader(fh)
        for schema, channel, message in reader.iter_messages():
            out["schemas"][channel.topic] = schema.name if schema else None
            out.setdefault(channel.topic, []).append(json.loads(message.data))
        fh.seek(0)
        for rec in make_reader(fh).iter_metadata():
            out["metadata"][rec.name] = dict(rec.metadata)
    return out

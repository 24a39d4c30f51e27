"""MCAP rollout logs: Foxglove schemas, readable back, the logged wrench is the simulated one."""

import os

import mujoco
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.dataset import GenerateConfig, generate
from itup_jax.mcap_log import SCHEMAS, read_rollout_mcap, write_rollout_mcap
from itup_jax.sim.scene import build_scene


@pytest.fixture(scope="module")
def logged(tasks, tmp_path_factory):
    tool, task = tasks["hammer"]
    scene = build_scene(tool, task)
    g = itup.sample_grasps(tool, 4, seed=0)
    res = itup.simulate(tool, task, g, scene=scene, traces=True, randomize=None)
    i = int(np.argmax(res.labels.valid))
    path = str(tmp_path_factory.mktemp("mcap") / "r.mcap")
    write_rollout_mcap(path, scene, task, res, i, every=1, grasp=g[i])
    return res, i, read_rollout_mcap(path)


def test_channels_carry_the_foxglove_schemas(logged):
    _, _, log = logged
    assert log["schemas"]["/tf"] == "foxglove.FrameTransforms"
    assert log["schemas"]["/scene"] == "foxglove.SceneUpdate"
    assert set(log["schemas"].values()) <= set(SCHEMAS)
    frames = {t["child_frame_id"] for t in log["/tf"][0]["transforms"]}
    assert {"gripper", "tool", "target/nail"} <= frames
    t0 = log["/tf"][0]["transforms"][0]
    assert set(t0) == {"timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"}
    q = t0["rotation"]
    assert abs(np.linalg.norm([q["x"], q["y"], q["z"], q["w"]]) - 1) < 1e-6
    ents = {e["id"]: e for e in log["/scene"][0]["entities"]}
    assert {"tool", "pads", "nail"} <= set(ents) and ents["tool"]["cylinders"]


def test_logged_wrench_is_the_simulated_one(logged):
    res, i, log = logged
    tau = res.traces["gripper/wrist_torque"][i]
    logged_tau = np.array([[m["torque"][k] for k in "xyz"] for m in log["/wrist_wrench"]])
    np.testing.assert_allclose(logged_tau, tau, rtol=0, atol=1e-12)
    # the grasp frame's logged world pose holds the tool where the grasp-frame sensor says
    tf = log["/tf"][-1]["transforms"]
    g, t = tf[0], tf[1]
    assert g["child_frame_id"] == "gripper" and t["child_frame_id"] == "tool"
    p_g = np.array([g["translation"][k] for k in "xyz"])
    p_t = np.array([t["translation"][k] for k in "xyz"])
    assert np.isclose(np.linalg.norm(p_t - p_g), np.linalg.norm(res.traces["tool_pos_grasp"][i, -1]), atol=1e-9)
    lab = log["/labels"][0]
    assert lab["peak_torque"] == pytest.approx(float(res.labels.peak_torque[i]))
    times = [m["timestamp"]["sec"] * 10**9 + m["timestamp"]["nsec"] for m in log["/wrist_wrench"]]
    assert times[0] == 0 and np.all(np.diff(times) > 0)
    assert "grasp" in log["metadata"]["itup.rollout"]


def test_a_result_without_traces_is_refused(tasks, tmp_path):
    tool, task = tasks["hammer"]
    scene = build_scene(tool, task)
    g = itup.sample_grasps(tool, 1, seed=0)
    res = itup.simulate(tool, task, g, scene=scene, randomize=None)
    with pytest.raises(itup.InputError, match="traces"):
        write_rollout_mcap(str(tmp_path / "x.mcap"), scene, task, res, 0)
    assert not os.listdir(tmp_path)


@pytest.mark.slow
def test_generate_logs_mcap_without_changing_the_shards(tmp_path):
    cfg = GenerateConfig(tasks=("reach",), tools_per_task=1, grasps=6, seed=1)
    a = generate(str(tmp_path / "a"), cfg, progress=False)
    b = generate(str(tmp_path / "b"), cfg, progress=False, mcap_dir=str(tmp_path / "logs"), mcap_per_shard=1)
    assert [s["sha256"] for s in a["shards"]] == [s["sha256"] for s in b["shards"]]
    logs = os.listdir(tmp_path / "logs")
    assert a["totals"]["valid"] >= 1  # this config has a valid rollout to log
    assert len(logs) == 1 and logs[0].startswith("reach_000_")
    log = read_rollout_mcap(str(tmp_path / "logs" / logs[0]))
    assert log["/wrist_wrench"] and log["schemas"]["/tf"] == "foxglove.FrameTransforms"


def test_the_log_shows_the_arm_gripper_and_environment(logged, tasks):
    """Every arm and gripper link has a frame per step and primitives; the links' poses put the gripper's
    grasp site where the recorded grasp frame is (IK of the recorded flange pose, then MuJoCo's forward
    kinematics); the table and the board are drawn in the world frame."""
    from itup_jax.mcap_log import robot_bodies

    res, i, log = logged
    tool, task = tasks["hammer"]
    scene = build_scene(tool, task)
    m = scene.model
    names = {m.body(b).name for b in robot_bodies(m)}
    assert {"ur5e/shoulder_link", "ur5e/wrist_3_link"} <= names and any(n.startswith("gripper/") for n in names)
    frames = {t["child_frame_id"] for t in log["/tf"][0]["transforms"]}
    assert {f"body/{n}" for n in names} <= frames
    ents = {e["id"]: e for e in log["/scene"][0]["entities"]}
    assert names <= set(ents) and all(ents[n]["cubes"] or ents[n]["cylinders"] for n in names)
    env = ents["environment"]
    assert env["frame_id"] == "world" and len(env["cubes"]) >= 2  # the table (a slab) and the board
    # the grasp site, placed by the links' poses, lies on the recorded grasp frame
    site = m.site("gripper/grasp")
    body = int(m.site_bodyid[site.id])
    tf = [{t["child_frame_id"]: t for t in msg["transforms"]} for msg in log["/tf"][::400]]
    for frame in tf:
        g, b = frame["gripper"], frame[f"body/{m.body(body).name}"]
        p_b = np.array([b["translation"][k] for k in "xyz"])
        q_b = np.array([b["rotation"][k] for k in "wxyz"])
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, q_b)
        p_site = p_b + R.reshape(3, 3) @ m.site_pos[site.id]
        np.testing.assert_allclose(p_site, [g["translation"][k] for k in "xyz"], atol=1e-6)


def test_a_mesh_geom_is_drawn_as_its_triangles():
    """A mesh geom (a user's tool: its convex hull) becomes a Foxglove triangle list whose points, placed
    at the geom's pose, span the mesh where MuJoCo has it (MuJoCo re-centres mesh vertices on their
    centroid and moves the geom's pose to match)."""
    import trimesh

    from itup_jax.mcap_log import _geom_primitives

    box = trimesh.creation.box(extents=[0.02, 0.04, 0.30])
    box.apply_translation([0.01, 0.0, 0.15])  # the handle's end at the origin, off the centroid
    spec = mujoco.MjSpec()
    spec.add_mesh(name="hull", uservert=np.asarray(box.vertices, float).ravel(),
                  userface=np.asarray(box.faces, np.int32).ravel())
    body = spec.worldbody.add_body(name="tool")
    body.add_geom(name="tool_0", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="hull")
    m = spec.compile()
    prims = _geom_primitives(m, [0])
    (tri,) = prims["triangles"]
    pts = np.array([[p["x"], p["y"], p["z"]] for p in tri["points"]])
    idx = np.array(tri["indices"])
    assert len(idx) == 3 * len(box.faces) and idx.min() == 0 and idx.max() == len(pts) - 1
    o = tri["pose"]["orientation"]
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.array([o["w"], o["x"], o["y"], o["z"]]))
    pos = np.array([tri["pose"]["position"][k] for k in "xyz"])
    placed = pts @ R.reshape(3, 3).T + pos
    np.testing.assert_allclose(placed.min(0), [0.0, -0.02, 0.0], atol=1e-9)
    np.testing.assert_allclose(placed.max(0), [0.02, 0.02, 0.30], atol=1e-9)
    assert not prims["cubes"] and not prims["cylinders"] and not prims["spheres"]


def test_a_users_mesh_tool_is_drawn_in_the_task_log(user_mallet):
    """A mesh tool collides by its convex pieces, but the task log's tool entity carries its mesh itself,
    in the tool frame (no cube or cylinder stands in for it)."""
    from itup_jax.mcap_log import _scene_update

    tool = user_mallet
    assert tool.primitives and all(p[0] == "hull" for p in tool.primitives)
    task = itup.make_task("knock", tool)
    (ent,) = [e for e in _scene_update(build_scene(tool, task), task, 0.03)["entities"] if e["id"] == "tool"]
    (tri,) = ent["triangles"]
    pts = np.array([[p["x"], p["y"], p["z"]] for p in tri["points"]])
    np.testing.assert_allclose(pts, tool.mesh.vertices)
    assert len(tri["indices"]) == 3 * len(tool.mesh.faces) and ent["frame_id"] == "tool"
    assert not ent["cubes"] and not ent["cylinders"]

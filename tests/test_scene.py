"""Scenes: every task scene composes and compiles for MuJoCo and MJX, with the tool's physics."""

import math

import mujoco
import numpy as np
import pytest
import trimesh

import itup_jax as itup
from itup_jax.scene import TIMESTEP, build_scene, restitution_solref
from itup_jax.simulate import plan, sample_physics


@pytest.fixture(scope="module")
def scenes(tasks):
    return {kind: build_scene(tool, task) for kind, (tool, task) in tasks.items()}


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
def test_scene_compiles_with_the_tools_physics_in_mujoco_and_mjx(scenes, tasks, kind):
    from itup_jax.simulate import import_mjx

    mjx = import_mjx()
    sc = scenes[kind]
    m = sc.model
    tool = tasks[kind][0]
    assert m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and m.opt.impratio == 10.0  # kept through attach
    b = m.body("tool").id
    assert m.body_mass[b] == pytest.approx(tool.mass, rel=1e-9)
    np.testing.assert_allclose(np.sort(m.body_inertia[b]), np.sort(np.linalg.eigvalsh(np.asarray(tool.params.inertia))), rtol=1e-6)
    assert m.ngeom < 40 and m.npair > 0  # primitive geoms, explicit pairs only
    assert np.all(m.geom_contype == 0) and np.all(m.geom_conaffinity == 0)
    mjx.put_model(m)  # raises for anything MJX cannot collide or integrate


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
def test_trajectory_runs_without_nan_or_mujoco_warnings(scenes, tasks, kind):
    tool, task = tasks[kind]
    sc = scenes[kind]
    g = itup.sample_grasps(tool, 12, seed=5)
    phys = sample_physics(tool, len(g), spread=None)
    p = plan(sc, task, g, phys)
    i = int(np.nonzero(~p.infeasible)[0][0])
    d = mujoco.MjData(sc.model)
    d.qpos[:] = p.qpos0[i]
    for k in range(p.nstep):
        d.ctrl[:] = p.ctrl[i, k]
        mujoco.mj_step(sc.model, d)
    assert np.all(np.isfinite(d.qpos)) and np.all(np.isfinite(d.sensordata))
    assert sum(w.number for w in d.warning) == 0


def test_restitution_maps_to_a_damping_ratio_and_the_contact_duration():
    for e, dur in ((0.4, 0.02), (0.7, 0.05), (0.2, 0.01)):
        tc, zeta = restitution_solref(e, dur)
        assert math.exp(-zeta * math.pi / math.sqrt(1 - zeta**2)) == pytest.approx(e, rel=1e-12)
        assert math.pi * tc * zeta / math.sqrt(1 - zeta**2) == pytest.approx(dur, rel=1e-12)
    tc, _ = restitution_solref(0.4, 1e-4)
    assert tc == 2 * TIMESTEP  # clamped to two timesteps, as MuJoCo would


def test_a_users_mesh_tool_gets_its_convex_hull(tmp_path, tools):
    trimesh.creation.box((0.03, 0.025, 0.30)).export(tmp_path / "stick.stl")
    (tmp_path / "stick.toml").write_text(
        'name = "stick"\ncategory = "mallet"\ncontact_point = [0.0, 0.0, 0.15]\ncontact_normal = [1.0, 0.0, 0.0]\n'
        "grasp_region = { min = [-0.02, -0.02, -0.15], max = [0.02, 0.02, 0.0] }\n")
    tool = itup.load_tool(str(tmp_path / "stick.stl"), spec=str(tmp_path / "stick.toml"))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        task = itup.make_task("knock", tool)
    m = build_scene(tool, task).model
    assert m.geom("tool_0").type == mujoco.mjtGeom.mjGEOM_MESH

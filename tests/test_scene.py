"""Scenes: every task scene composes and compiles for MuJoCo and MJX, with the tool's physics."""

import math

import mujoco
import numpy as np
import pytest
import trimesh

import itup_jax as itup
from itup_jax import tasks as registry
from itup_jax.robot import ARM_JOINTS, JOINT_TORQUE_LIMITS
from itup_jax.sim.arm import plan
from itup_jax.sim.physics import mjx_model_fields, randomized_model, sample_physics
from itup_jax.sim.restitution import delivered_restitution, textbook_dampratio
from itup_jax.sim.scene import CONTACT_MIN_TIMECONST, build_scene, restitution_solref, scene_xml, target_solref
from itup_jax.tasks.hammer import NAIL_DEPTH_SUCCESS
from itup_jax.tasks.knock import TOPPLE_SUCCESS, TOWER_STANDING

TASK_TIMESTEP = registry.timesteps()


def target_bodies_of(kind):
    return registry.get(kind).target_bodies


@pytest.fixture(scope="module")
def scenes(tasks):
    return {kind: build_scene(tool, task) for kind, (tool, task) in tasks.items()}


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
def test_scene_compiles_with_the_tools_physics_in_mujoco_and_mjx(scenes, tasks, kind):
    from itup_jax.sim.mjx import import_mjx

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


def test_each_arm_joint_exerts_at_most_its_ur_torque_rating_in_all(scenes):
    """Command an impossible motion (every joint a radian away and at 3 rad/s towards it at once):
    both servos saturate, and the joint's total actuator torque stays at UR's rating (without the
    joint's clamp they add up to twice it)."""
    sc = scenes["hammer"]
    m = sc.model
    np.testing.assert_array_equal(m.jnt_actfrcrange[[m.joint(f"ur5e/{j}").id for j in ARM_JOINTS]],
                                  np.stack([-JOINT_TORQUE_LIMITS, JOINT_TORQUE_LIMITS], 1))
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    pos = [m.actuator(f"ur5e/{j}").id for j in ARM_JOINTS]
    vel = [m.actuator(f"ur5e/{j}_vel").id for j in ARM_JOINTS]
    d.ctrl[pos] = d.qpos[sc.arm_qpos] + 1.0
    d.ctrl[vel] = 3.0
    peak, servo_sum = np.zeros(6), np.zeros(6)
    for _ in range(20):
        mujoco.mj_step(m, d)
        peak = np.maximum(peak, np.abs(d.qfrc_actuator[sc.arm_dof]))
        servo_sum = np.maximum(servo_sum, np.abs(d.actuator_force[pos] + d.actuator_force[vel]))
    np.testing.assert_allclose(peak, JOINT_TORQUE_LIMITS, rtol=1e-9)  # saturated, and not beyond
    assert np.all(servo_sum > 1.5 * JOINT_TORQUE_LIMITS)  # what the servos ask for together


#: How far a task's objects may move, left alone for 2 s: a tenth of what the task's success counts
#: (the nail driven 0.1 mm, the top block moved 3 cm, debris 10 cm past a line, the block pulled half of
#: about 10 cm).
_AT_REST = {"hammer": 0.1 * NAIL_DEPTH_SUCCESS, "knock": 0.1 * TOPPLE_SUCCESS, "sweep": 0.01, "reach": 0.005}


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
def test_task_objects_left_alone_stay_put(scenes, kind):
    """No task is done by itself. The nail crept under its own weight through MuJoCo's soft frictionloss
    (6.5 mm over a rollout, which counted as driven; the scene now compensates its weight)."""
    m = scenes[kind].model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)  # the tool starts away from the objects and falls clear of them
    start = {b: d.body(b).xpos.copy() for b in target_bodies_of(kind)}
    for _ in range(int(round(2.0 / m.opt.timestep))):
        mujoco.mj_step(m, d)
    moved = {b: float(np.linalg.norm(d.body(b).xpos - p)) for b, p in start.items()}
    assert max(moved.values()) < _AT_REST[kind], moved


@pytest.mark.parametrize("kind, gap", [("sweep", 0.001), ("knock", 0.0005), ("reach", 0.001)])
def test_targets_keep_their_mjcf_height_and_face_the_contact_point(scenes, tasks, kind, gap):
    """Every target of the sweep, the knock and the reach keeps its MJCF height, and the face the tool
    meets lies `gap` past the task's contact point, horizontally along the interaction normal (the
    sweep's normal is tilted: its cubes are pushed along its horizontal part): `FACE_TO_CENTRE`
    is the MJCF target's half depth plus that gap. The knock's tower moves as one column, its top block
    at the struck point's height."""
    face_to_centre = getattr(registry, kind).FACE_TO_CENTRE
    spec = mujoco.MjSpec.from_file(str(scene_xml(kind)))
    bodies = target_bodies_of(kind)
    half = {b: np.asarray(spec.geom(b).size, float) for b in bodies}  # [3] m, each target's half extents
    _, task = tasks[kind]
    n = np.asarray(task.n_world[0], float)
    if kind != "sweep":
        assert abs(n[2]) < 1e-12
    h = n[:2] / np.linalg.norm(n[:2])  # [2] the horizontal direction from the target into the tool
    struck = [bodies[-1]] if kind == "knock" else bodies  # the tool meets the knock's top block only
    for b in struck:
        assert half[b][0] == half[b][1]  # square in plan, so the face's distance does not turn with n
        assert face_to_centre == pytest.approx(half[b][0] + gap, abs=1e-12)
    m = scenes[kind].model
    for b in bodies:
        assert m.body(b).pos[2] == spec.body(b).pos[2]
    c_obj = np.asarray(task.c_obj_world, float)
    if kind == "knock":  # the tower (bottom to top) moves as one column, its top block at the struck height
        pos = np.array([m.body(b).pos for b in bodies])  # [4, 3] m, world (children of world)
        assert list(pos[:, 2]) == sorted(pos[:, 2])
        np.testing.assert_array_equal(pos[:, :2], np.broadcast_to(pos[0, :2], (len(bodies), 2)))
        assert pos[-1, 2] == pytest.approx(c_obj[0, 2], abs=1e-12)
    for i, b in enumerate(struck):
        c = c_obj[0 if kind == "knock" else i]  # the knock has one contact, on its top block
        face = np.asarray(m.body(b).pos)[:2] + half[b][0] * h  # [2] the face towards the tool, in plan
        np.testing.assert_allclose(c[:2] - face, gap * h, atol=1e-9)


def test_knock_scene_refuses_a_strike_off_the_top_block(tools):
    from itup_jax.errors import InputError
    task = itup.make_task("knock", tools["mallet"], target=(0.50, 0.0, 0.15))  # the third block's height
    with pytest.raises(InputError, match="must be within 0.02 m of the top block's height 0.21 m"):
        build_scene(tools["mallet"], task)


def test_a_tower_pushed_over_before_the_motion_is_no_knock(scenes, tasks):
    """Grasp 29 of 64 on the built-in mallet (seed 0, nominal physics) cannot hold the tool still: during
    the settle the tool droops in the pads onto the tower, 6 cm from its face, and pushes it over before
    the swing starts. That is no knock (measured from the first step it would count as one, with the low
    torque of a swing that meets nothing). Every other tower
    stands still sideways through the settle (it sinks ~1.4 mm straight down into its soft contacts), and
    its label is whether the motion moved the top block 3 cm."""
    tool, task = tasks["knock"]
    grasps = itup.sample_grasps(tool, 64, seed=0, config=itup.SamplerConfig(contact="point"))[24:32]
    res = itup.simulate(tool, task, grasps, scene=scenes["knock"], backend="native", randomize=None, traces=True)
    labels, top, n = res.labels, res.traces["top_block"], res.plan.n_settle
    sideways = np.linalg.norm((top[:, n - 1] - top[:, 0])[:, :2], axis=-1)  # during the settle
    in_motion = np.linalg.norm(top[:, -1] - top[:, n - 1], axis=-1)
    ok = labels.valid
    assert ok.sum() >= 4 and ok[5]
    pushed = ok & (sideways > TOWER_STANDING)
    assert pushed.tolist() == [i == 5 for i in range(8)], sideways
    assert sideways[5] > 0.1 and np.linalg.norm(top[5, -1] - top[5, 0]) > TOPPLE_SUCCESS  # over, before the swing
    assert not labels.success[5]
    assert sideways[ok & ~pushed].max() < 1e-5
    np.testing.assert_allclose(labels.task_metric[ok], in_motion[ok])
    np.testing.assert_array_equal(labels.success[ok & ~pushed], in_motion[ok & ~pushed] >= TOPPLE_SUCCESS)
    assert labels.success[ok & ~pushed].any()  # some swings do knock it over


def test_strikes_leave_the_nail_within_its_travel(scenes, tasks):
    """The joint's range stops the nail head 1 mm above the board; no strike drives it further. Every
    reachable grasp of 64 of the built-in hammer (seed 0, nominal physics); a soft stop would let the
    follow-through push it 20-50 mm."""
    tool, task = tasks["hammer"]
    scene = scenes["hammer"]
    labels = itup.simulate(tool, task, itup.sample_grasps(tool, 64, seed=0), scene=scene, backend="native",
                           randomize=None).labels
    travel = -float(scene.model.joint("nail_depth").range[0])
    assert travel == pytest.approx(0.009)
    ok = labels.valid
    assert ok.sum() >= 20 and labels.success[ok].sum() >= 3  # some strikes drive the nail
    assert (labels.task_metric[ok] <= travel + 2e-4).all(), (labels.task_metric[ok].max(), travel)


def _nail_and_block(block_mass: float) -> mujoco.MjModel:
    """The hammer scene's nail (as the XML gives it, 20 mm of travel) under a free 20 mm block whose
    face is 0.1 mm above the nail head, touching it as a tool would, at the hammer's step."""
    spec = mujoco.MjSpec.from_file(str(scene_xml("hammer")))
    head_top = spec.body("nail").pos[2]
    body = spec.worldbody.add_body(name="block", pos=[spec.body("nail").pos[0], 0.0, head_top + 0.0101])
    body.add_freejoint(name="block")
    body.add_geom(name="block", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.01] * 3, mass=block_mass,
                  contype=0, conaffinity=0)
    spec.add_pair(geomname1="block", geomname2="nail_head", condim=3, solref=list(target_solref("hammer", 0.4, 2e-3)))
    spec.option.timestep = TASK_TIMESTEP["hammer"]
    return spec.compile()


def test_a_struck_nail_is_driven_by_the_work_energy_law():
    """A block of mass M hitting the nail (mass m, gripped with F by the wood) at v shares its momentum
    (plastic contact) and the pair is stopped by F against the block's weight:
    depth = (M v)^2 / (2 (M + m)) / (F - M g). Strong blows land within 10 %; none beyond the bound."""
    for M, v in ((0.5, 0.8), (1.0, 0.8), (0.5, 1.2), (0.2, 0.8), (0.5, 0.5)):
        m = _nail_and_block(M)
        d = mujoco.MjData(m)
        d.qvel[m.jnt_dofadr[m.joint("block").id] + 2] = -v  # falling at v, touching the head in 0.1 mm
        for _ in range(int(0.5 / m.opt.timestep)):
            mujoco.mj_step(m, d)
        nail = m.joint("nail_depth")
        grip, m_nail = float(m.dof_frictionloss[nail.dofadr[0]]), float(m.body("nail").mass[0])
        bound = (M * v) ** 2 / (2 * (M + m_nail)) / (grip - M * 9.81)
        depth = -float(d.qpos[nail.qposadr[0]])
        assert depth <= 1.05 * bound, (M, v, depth, bound)
        if bound >= 0.004:
            assert depth == pytest.approx(bound, rel=0.10), (M, v)
        assert d.qvel[m.jnt_dofadr[m.joint("block").id] + 2] == pytest.approx(0.0, abs=1e-3)  # at rest on it


def test_the_nail_holds_below_its_grip_and_stops_at_its_limit():
    m = _nail_and_block(0.5)
    nail = m.joint("nail_depth")
    grip = float(m.dof_frictionloss[nail.dofadr[0]])
    assert grip == 40.0
    for push, duration, most in ((0.5 * grip, 0.1, 5e-5), (5 * grip, 0.5, -float(nail.range[0]) + 2e-4)):
        d = mujoco.MjData(m)
        d.qpos[m.jnt_qposadr[m.joint("block").id] + 2] += 0.5  # the block out of the way
        for _ in range(int(duration / m.opt.timestep)):
            d.qfrc_applied[nail.dofadr[0]] = -push
            mujoco.mj_step(m, d)
        depth = -float(d.qpos[nail.qposadr[0]])
        assert depth < most, (push, depth)
        if push > grip:
            assert depth > -float(nail.range[0]) - 1e-4  # it did go, to the stop


def test_the_hammers_contact_with_the_nail_is_plastic(tasks):
    """The nail gives way: its pairs are critically damped whatever the tool's restitution; the other
    kinds' targets bounce with the restitution (`restitution_solref`)."""
    assert {k for k in itup.TASK_KINDS if registry.get(k).plastic_target} == {"hammer"}
    for kind in itup.TASK_KINDS:
        tc, zeta = target_solref(kind, 0.4, 2e-3)
        assert tc == restitution_solref(0.4, 2e-3)[0]
        assert zeta == (1.0 if kind == "hammer" else restitution_solref(0.4, 2e-3)[1])
    scene = build_scene(*tasks["hammer"])
    assert (scene.model.pair_solref[scene.tool_target_pairs, 1] == 1.0).all()
    # and so are the per-rollout models both backends step, whatever restitution the physics draws
    tool = tasks["hammer"][0]
    physics = sample_physics(tool, 4, seed=3)
    assert np.ptp(physics.restitution) > 0
    solref = mjx_model_fields(scene, physics)[3]
    assert (solref[:, scene.tool_target_pairs, 1] == 1.0).all()
    for i in range(4):
        m = randomized_model(scene, physics, i)
        np.testing.assert_array_equal(m.pair_solref[scene.tool_target_pairs], solref[i, scene.tool_target_pairs])


def test_restitution_solref_delivers_the_restitution_over_about_the_contact_duration():
    for e, dur in ((0.4, 0.02), (0.7, 0.05), (0.2, 0.01)):
        tc, zeta = restitution_solref(e, dur, 0.0005)
        zeta0 = textbook_dampratio(e)
        # the time constant: the textbook spring-damper's whose half period is the duration, to 2 digits
        assert math.pi * tc * zeta0 / math.sqrt(1 - zeta0**2) == pytest.approx(dur, rel=0.05)
        assert delivered_restitution((tc, zeta), 0.0005) == pytest.approx(e, abs=0.02)
    tc, _ = restitution_solref(0.4, 1e-4)
    assert tc == CONTACT_MIN_TIMECONST == 0.004  # the floor: the 2 ms scenes' two-step clamp, at any finer step
    assert restitution_solref(0.4, 1e-4, 0.0005)[0] == CONTACT_MIN_TIMECONST
    assert restitution_solref(0.4, 1e-4, 0.005)[0] == 0.01  # coarser than 2 ms: two steps, as MuJoCo would clamp


def test_each_task_is_integrated_at_its_own_step_with_one_contact_model(tasks):
    """The default scene step is the task's (`TASK_TIMESTEP`), an explicit one overrides it, and the
    contacts (their solref, the pads' and the tool-target pairs') are the same at every step <= 2 ms."""
    assert set(TASK_TIMESTEP) == set(itup.TASK_KINDS)
    assert TASK_TIMESTEP["hammer"] == TASK_TIMESTEP["knock"] == TASK_TIMESTEP["sweep"] == 0.0005
    assert TASK_TIMESTEP["reach"] == 0.0005
    tool, task = tasks["hammer"]
    fine, coarse = build_scene(tool, task), build_scene(tool, task, timestep=0.002)
    assert fine.model.opt.timestep == 0.0005 and coarse.model.opt.timestep == 0.002
    np.testing.assert_array_equal(fine.model.pair_solref, coarse.model.pair_solref)
    np.testing.assert_array_equal(fine.model.pair_solimp, coarse.model.pair_solimp)
    assert build_scene(*tasks["reach"]).model.opt.timestep == 0.0005
    assert build_scene(*tasks["reach"], timestep=0.002).model.opt.timestep == 0.002
    with pytest.raises(itup.InputError, match="task kind 'drill': unknown"):
        itup.task_timestep("drill")


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

"""Tasks: Omega and schedules consistent with the trajectory; defaults inside the UR5e's limits."""

import warnings

import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import robot
from itup_jax.task import peak_speeds

KINDS = itup.TASK_KINDS


@pytest.mark.parametrize("kind", KINDS)
def test_defaults_build_without_speed_warnings(tools, kind):
    from itup_jax.task import DEFAULT_TOOL
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        task = itup.make_task(kind, tools[DEFAULT_TOOL[kind]])
    peaks = peak_speeds(task, tools[DEFAULT_TOOL[kind]])
    assert peaks["angular"] <= robot.UR5E_MAX_JOINT_SPEED
    T, K = task.num_steps, task.num_contacts
    assert task.impact.shape == task.drag.shape == (T, K)
    assert task.traj.R_world_tool.shape == (T, 3, 3)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(task.n_world), axis=1), 1.0, atol=1e-12)
    assert set(task.omega) == {"c_tool", "c_obj", "n", "d"}


@pytest.mark.parametrize("kind", ["hammer", "knock"])
def test_swing_strikes_the_target_at_the_impact_speed(tasks, kind):
    tool, task = tasks[kind]
    i = int(np.argmax(np.asarray(task.impact[:, 0])))
    c_world = np.asarray(task.traj.point_position(task.c_tool[0]))[i]
    np.testing.assert_allclose(c_world, np.asarray(task.c_obj_world[0]), atol=1e-12)
    v_c = np.asarray(task.traj.point_velocity(task.c_tool[0]))[i]
    default = itup.tasks.get(kind).params().impact_speed
    assert np.linalg.norm(v_c) == pytest.approx(default, rel=1e-9)
    n = np.asarray(task.n_world[0])
    assert v_c @ n < -0.9 * np.linalg.norm(v_c)  # moving into the target, nearly along its normal
    # the face that strikes is the tool's contact face
    R = np.asarray(task.traj.R_world_tool[i])
    np.testing.assert_allclose(R @ tool.contact_normal, -n, atol=1e-12)


def test_hammer_winds_up_before_it_swings(tasks):
    tool, task = tasks["hammer"]
    z = np.asarray(task.traj.point_position(task.c_tool[0]))[:, 2]
    i = int(np.argmax(np.asarray(task.impact[:, 0])))
    assert z[:i].max() > z[i] + 0.2  # the head rises well above the nail first


def test_hammer_holds_still_after_its_follow_through(tools):
    """The hammer ends with `t_hold` s at its follow-through pose (the rollout sees the blow land even
    when the arm lags its reference); `t_hold=0` ends on the follow-through."""
    tool = tools["hammer"]
    prm = itup.tasks.hammer.HammerParams()
    assert prm.t_hold == 0.2
    task = itup.make_task("hammer", tool)
    t = np.asarray(task.traj.t)
    i = int(np.argmax(np.asarray(task.impact[:, 0])))
    c = np.asarray(task.traj.point_position(task.c_tool[0]))
    held = t >= t[-1] - prm.t_hold + 1e-9
    assert held.sum() >= 5 and not held[: i + 1].any()
    np.testing.assert_allclose(c[held], np.broadcast_to(c[-1], c[held].shape), atol=1e-12)
    np.testing.assert_allclose(np.asarray(task.traj.point_velocity(task.c_tool[0]))[held], 0.0, atol=1e-12)
    # the last pose is the follow-through's: the contact point past the impact pose, along the swing
    assert c[-1, 2] < c[i, 2] - 0.004
    bare = itup.make_task("hammer", tool, t_hold=0.0, follow_through=0.05)
    longer = itup.make_task("hammer", tool, follow_through=0.05)
    assert np.asarray(longer.traj.t)[-1] == pytest.approx(np.asarray(bare.traj.t)[-1] + prm.t_hold)
    np.testing.assert_allclose(np.asarray(bare.traj.point_position(bare.c_tool[0]))[-1],
                               np.asarray(longer.traj.point_position(longer.c_tool[0]))[-1], atol=1e-9)
    # without the hold, the 15 ms follow-through is shorter than one of 64 samples: refused, not cut off
    with pytest.raises(itup.InputError, match="falls off the end"):
        itup.make_task("hammer", tool, t_hold=0.0)
    with pytest.raises(itup.InputError, match="t_hold"):
        itup.make_task("hammer", tool, t_hold=-0.1)


def test_sweep_has_several_contacts_at_once(tasks):
    _, task = tasks["sweep"]
    acting = (np.maximum(np.asarray(task.impact), np.asarray(task.drag)) > 0).sum(axis=1)
    assert acting.max() >= 3
    first_hits = np.argmax(np.asarray(task.impact[:, :-1]), axis=0)
    assert np.all(np.diff(first_hits) > 0)  # debris further ahead is met later


@pytest.mark.parametrize("mode,sign", [("pull", -1.0), ("push", 1.0)])
def test_reach_moves_the_block_towards_or_away_from_the_robot(tools, mode, sign):
    task = itup.make_task("reach", tools["l_stick"], mode=mode)
    assert float(task.d_world[0]) == sign
    acting = np.asarray(task.drag[:, 0]) > 0
    v = np.asarray(task.traj.v_world)[acting]
    assert np.all(v[:, 0] * sign >= -1e-12) and (v[:, 0] * sign).max() > 0.1
    # the face in contact pushes along the motion: the block's normal opposes the motion
    assert float(task.n_world[0] @ task.d_world) == pytest.approx(-1.0)


@pytest.mark.parametrize("variant", [0, 3])  # the built-in stick (hook tip 0.100 m), and a stretched one (0.121 m)
@pytest.mark.parametrize("clearance", [0.010, 0.020])
def test_reach_works_with_the_hook_tip_clearance_above_the_table(tools, variant, clearance):
    """From the end of the lowering on, the stick's lowest point is `clearance` above the table top
    (z = 0) whatever the hook's length, `lift` higher while it extends, and the hook's contact point
    meets the block's face. (Up to 0.7.0 the tool-frame origin sat at a fixed height, which drove this
    variant's hook 21 mm into the table.)"""
    from itup_jax.dataset import GenerateConfig, unit_tool
    from itup_jax.tasks.reach import BLOCK_HEIGHT as REACH_BLOCK_HEIGHT
    from itup_jax.tasks.reach import ReachParams
    tool = tools["l_stick"] if variant == 0 else unit_tool(GenerateConfig(seed=1), "reach", variant)[0]
    task = itup.make_task("reach", tool, clearance=clearance)
    v = np.asarray(tool.mesh.vertices)
    R, p = np.asarray(task.traj.R_world_tool), np.asarray(task.traj.p_world_tool)
    lowest = np.einsum("tj,nj->tn", R[:, 2], v).min(1) + p[:, 2]  # [T] m
    t = np.asarray(task.traj.t)
    prm = ReachParams()
    at_work = t >= prm.t_extend + prm.t_pause - 1e-9
    assert lowest[at_work] == pytest.approx(clearance, abs=1e-9)
    assert lowest[t <= prm.t_extend + 1e-9] == pytest.approx(clearance + prm.lift, abs=1e-9)
    assert 0.0 < float(task.c_obj_world[0, 2]) < REACH_BLOCK_HEIGHT
    if variant:
        assert v[:, 0].max() > tools["l_stick"].mesh.vertices[:, 0].max() + 0.015  # the longer hook


def test_reach_block_height_is_the_scene_block():
    """The height `make_task('reach')` checks the hook's contact point against is the MJCF block's."""
    import mujoco

    from itup_jax.sim.scene import scene_xml
    from itup_jax.tasks.reach import BLOCK_HEIGHT as REACH_BLOCK_HEIGHT
    spec = mujoco.MjSpec.from_file(str(scene_xml("reach")))
    body, geom = spec.body("block"), spec.geom("block")
    assert body.pos[2] - geom.size[2] == pytest.approx(0.0) and 2 * geom.size[2] == pytest.approx(REACH_BLOCK_HEIGHT)


@pytest.mark.slow
def test_overrides_change_the_trajectory(tools):
    fast = itup.make_task("hammer", tools["hammer"], impact_speed=1.0, steps=80)
    assert fast.num_steps == 80
    i = int(np.argmax(np.asarray(fast.impact[:, 0])))
    assert np.linalg.norm(np.asarray(fast.traj.point_velocity(fast.c_tool[0]))[i]) == pytest.approx(1.0)


def test_absurd_speed_warns(tools):
    with pytest.warns(UserWarning, match="joint-speed limit"):
        itup.make_task("hammer", tools["hammer"], impact_speed=20.0)


@pytest.mark.parametrize("kind,kwargs,match", [
    ("drill", {}, r"task kind 'drill'.*known: hammer"),
    ("hammer", {"speed": 1.0}, r"unknown parameter.*speed"),
    ("hammer", {"impact_speed": -1.0}, r"impact_speed.*> 0"),
    ("hammer", {"impact_speed": float("nan")}, r"impact_speed"),
    ("hammer", {"steps": 3}, r"steps.*>= 8"),
    ("hammer", {"target": (0.0, float("nan"), 0.0)}, r"target"),
    ("reach", {"mode": "throw"}, r"mode.*'pull' or 'push'"),
    ("reach", {"start": (0.3, 0.0, 0.1)}, r"start: expected two finite numbers.*height follows from the tool"),
    ("reach", {"clearance": -0.01}, r"clearance: must be finite and >= 0"),
    ("reach", {"clearance": 0.08}, r"contact point would meet the block at z = 0\.11\d m, off its face"),
    ("sweep", {"debris_gaps": (0.1, 0.5)}, r"debris_gaps.*shorter than the stroke"),
])
def test_bad_task_input(tools, kind, kwargs, match):
    with pytest.raises(itup.InputError, match=match):
        itup.make_task(kind, tools[{"sweep": "broom", "reach": "l_stick"}.get(kind, "hammer")], **kwargs)


def test_task_is_a_pytree_with_static_kind(tasks):
    import jax
    _, task = tasks["hammer"]
    leaves, treedef = jax.tree_util.tree_flatten(task)
    assert all(isinstance(x, jnp.ndarray) for x in leaves)
    assert jax.tree_util.tree_unflatten(treedef, leaves).kind == "hammer"

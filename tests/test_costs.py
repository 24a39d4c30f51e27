"""Cost laws (docs/design.md, laws C1-C4), gradients against finite differences, batching, the NumPy oracle."""

import dataclasses

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np
import pytest
from transforms import move_tool_frame as _move_tool_frame
from transforms import move_world as _move_world

import itup_jax as itup
from itup_jax.costs import CostParams, Regime, batched_wrench_costs, grasp_cost_trace, grasp_costs, wrench_costs_jit
from itup_jax.grasp import Grasps, make_grasps
from itup_jax.numpy_reference import numpy_wrench_costs, to_numpy_inputs
from itup_jax.wrench import task_loads

COST_NAMES = ("tau", "slip", "align", "total", "tau_closure")
# Invariance and implementation-equivalence checks run in float64: only rounding separates the two
# sides (products of ~1e3 N forces with ~0.3 m arms), so 1e-9 relative (1e-9 absolute near zero).
INV_RTOL, INV_ATOL = 1e-9, 1e-9
# Central differences in float64 with h = 1e-6: truncation ~h^2 f''' and rounding ~eps f / h ~ 1e-10 f.
FD_STEP = 1e-6
FD_RTOL, FD_ATOL = 1e-5, 1e-6

VARIANTS = [
    CostParams(),
    CostParams(lever_arm="com"),
    CostParams(torque_projection="full"),
    CostParams(lever_arm="wrist", torque_projection="full"),
    CostParams(include_gravity=True, grip_force=15.0, w_tau=0.5, w_slip=0.1, w_align=2.0),
    CostParams.wrench(),
    CostParams(lever_arm="wrist", torque_projection="passed", grip_force=100.0),
]


def _assert_costs_close(a, b, rtol=INV_RTOL, atol=INV_ATOL):
    for k in COST_NAMES:
        np.testing.assert_allclose(np.asarray(getattr(a, k)), np.asarray(getattr(b, k)), rtol=rtol, atol=atol, err_msg=k)


@pytest.fixture(scope="module")
def grasps_by_kind(tasks):
    # generic grasps: flat-pad ones sit on a kink of the slip cost, where finite differences mislead
    return {kind: itup.sample_grasps(tool, 24, seed=11, config=itup.SamplerConfig(contact="point"))
            for kind, (tool, _) in tasks.items()}


# ------------------------------------------------------------------------------------------------ C1
@pytest.mark.parametrize("kind", itup.TASK_KINDS)
@pytest.mark.parametrize("params", VARIANTS[:1] + VARIANTS[3:])
def test_c1_rigid_transform_of_the_world_leaves_costs_unchanged(tasks, grasps_by_kind, rng, kind, params):
    tool, task = tasks[kind]
    g = grasps_by_kind[kind]
    Q = np.asarray(jaxlie.SO3.sample_uniform(jax.random.key(int(rng.integers(1000)))).as_matrix())
    t = rng.normal(size=3)
    _assert_costs_close(itup.wrench_costs(tool, task, g, params), itup.wrench_costs(tool, _move_world(task, Q, t), g, params))


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
def test_c1_choice_of_tool_frame_leaves_costs_unchanged(tasks, grasps_by_kind, rng, kind):
    tool, task = tasks[kind]
    g = grasps_by_kind[kind]
    Q = np.asarray(jaxlie.SO3.sample_uniform(jax.random.key(int(rng.integers(1000)))).as_matrix())
    t = 0.1 * rng.normal(size=3)
    tp, task2, g2 = _move_tool_frame(tool.params, task, g, Q, t)
    for params in VARIANTS:
        _assert_costs_close(itup.wrench_costs(tool, task, g, params), itup.wrench_costs(tp, task2, g2, params))


# ------------------------------------------------------------------------------------------------ C2
@pytest.mark.parametrize("kind", ["hammer", "knock"])
def test_c2_costs_are_continuous_in_the_contact_velocity(tools, kind):
    from itup_jax.task import DEFAULT_TOOL
    tool = tools[DEFAULT_TOOL[kind]]
    g = itup.sample_grasps(tool, 16, seed=2, config=itup.SamplerConfig(contact="point"))
    base = itup.wrench_costs(tool, itup.make_task(kind, tool, impact_speed=0.8), g)
    near = itup.wrench_costs(tool, itup.make_task(kind, tool, impact_speed=0.8 * (1 + 1e-7)), g)
    for k in ("tau", "slip", "total"):
        a, b = np.asarray(getattr(base, k)), np.asarray(getattr(near, k))
        assert np.max(np.abs(a - b)) <= 1e-5 * np.max(np.abs(a)) + 1e-9


def test_c2_impulse_is_continuous_where_the_contact_starts_to_separate():
    from itup_jax.wrench import normal_impulse
    n = jnp.array([0.0, 0.0, 1.0])
    J = lambda vz: float(normal_impulse(2.0, jnp.eye(3), jnp.zeros(3), n, jnp.array([0.0, 0.0, vz]), 0.5, 0.0))  # noqa: E731
    assert J(-1e-9) == pytest.approx(0.0, abs=1e-8) and J(1e-9) == 0.0


# ------------------------------------------------------------------------------------------------ C3
def _slowed(task, s):
    tr = task.traj
    return task.replace(traj=dataclasses.replace(tr, v_world=s * tr.v_world, w_world=s * tr.w_world,
                                                 a_world=s**2 * tr.a_world, alpha_world=s**2 * tr.alpha_world))


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
def test_c3_slow_motion_leaves_only_alignment(tasks, grasps_by_kind, kind):
    tool, task = tasks[kind]
    g = grasps_by_kind[kind]
    params = CostParams(w_align=0.7)
    full = itup.wrench_costs(tool, task, g, params)
    slow = itup.wrench_costs(tool, _slowed(task, 1e-7), g, params)
    assert np.max(np.asarray(slow.tau)) <= 1e-5 * np.max(np.asarray(full.tau))
    assert np.max(np.asarray(slow.slip)) <= 1e-5 * max(np.max(np.asarray(full.slip)), 1.0)
    np.testing.assert_allclose(np.asarray(slow.align), np.asarray(full.align), rtol=1e-12)
    # what is left of C beyond w_alpha C_alpha shrinks with the speed, like the load terms it sums
    load_terms = np.max(np.asarray(full.total) - 0.7 * np.asarray(full.align))
    assert np.max(np.abs(np.asarray(slow.total) - 0.7 * np.asarray(slow.align))) <= 1e-5 * load_terms


# ------------------------------------------------------------------------------------------------ C4
def test_c4_torque_cost_ignores_the_closure_axis_and_slip_cost_the_normal_force(tasks):
    """Synthetic loads: a torque along n_f and a force along n_f are not destabilising; the rest is."""
    tool, task = tasks["hammer"]
    loads = task_loads(tool.params, task)
    T = task.num_steps
    g = make_grasps([[0.0, 0.0, 0.1]], np.eye(3)[None], [0.03])[0]  # n_f = tool y
    along, across = np.zeros((T, 3)), np.zeros((T, 3))
    along[:, 1], across[:, 0] = 5.0, 5.0
    zero = jnp.zeros((T, 3))
    mk = lambda F, M: dataclasses.replace(loads, force_tool=jnp.asarray(F), moment_tool=jnp.asarray(M))  # noqa: E731
    pivot_free = CostParams(lever_arm="com")
    com = loads.com_tool
    # pure moment about the closure axis (and about the com, so no lever arm adds to it)
    c = grasp_costs(mk(zero, along), g, tool.params, pivot_free)
    assert float(c.tau) == pytest.approx(0.0, abs=1e-12) and float(c.tau_closure) == pytest.approx(5.0)
    c = grasp_costs(mk(zero, across), g, tool.params, pivot_free)
    assert float(c.tau) == pytest.approx(5.0)
    # force along the closure axis: squeezed, no slip; across it: slips by |F| - mu*0
    c = grasp_costs(mk(along, jnp.cross(com, jnp.asarray(along))), g, tool.params, pivot_free)
    assert float(c.slip) == pytest.approx(0.0, abs=1e-12)
    c = grasp_costs(mk(across, jnp.cross(com, jnp.asarray(across))), g, tool.params, pivot_free)
    assert float(c.slip) == pytest.approx(5.0)


# ------------------------------------------------------------------------------------------- gradients
@pytest.mark.parametrize("kind", ["hammer", "sweep", "reach"])
@pytest.mark.parametrize("preset", ["paper", "wrench"])
def test_gradients_match_central_finite_differences(tasks, grasps_by_kind, kind, preset):
    """d(C_tau, C_s, C_alpha, C) / d(grasp position, grasp rotation tangent, mu, mass, e, jaw opening),
    for the paper's objective and the grip-demand one."""
    tool, task = tasks[kind]
    g = grasps_by_kind[kind][3]
    R0 = jaxlie.SO3(g.q_tool_grasp)
    params = getattr(CostParams, preset)(w_slip=0.3)

    @jax.jit
    def f(x):  # x = [position (3), rotation tangent (3), mu, mass, restitution, width]
        tp = tool.params.replace(mu=x[6], mass=x[7], restitution=x[8])
        grasp = dataclasses.replace(g, p_tool_grasp=x[:3], q_tool_grasp=(jaxlie.SO3.exp(x[3:6]) @ R0).wxyz,
                                    width=x[9])
        c = grasp_costs(task_loads(tp, task), grasp, tp, params)
        return jnp.stack([c.tau, c.slip, c.align, c.total])

    x0 = np.concatenate([np.asarray(g.p_tool_grasp), np.zeros(3),
                         [float(tool.params.mu), float(tool.params.mass), float(tool.params.restitution),
                          float(g.width)]])
    jac = np.asarray(jax.jit(jax.jacfwd(f))(jnp.asarray(x0)))  # [4 costs, 10 inputs]
    fd = np.zeros_like(jac)
    for i in range(len(x0)):
        e = np.zeros_like(x0)
        e[i] = FD_STEP
        fd[:, i] = (np.asarray(f(jnp.asarray(x0 + e))) - np.asarray(f(jnp.asarray(x0 - e)))) / (2 * FD_STEP)
    assert np.abs(fd).max() > 0
    for row, cost in enumerate(("tau", "slip", "align", "total")):
        scale = max(1.0, np.abs(fd[row]).max())
        np.testing.assert_allclose(jac[row], fd[row], rtol=FD_RTOL, atol=FD_ATOL * scale, err_msg=f"d {cost}")


# --------------------------------------------------------------------------------------------- batching
def test_vmap_equals_a_loop_and_peaks_equal_trace_maxima(tasks, grasps_by_kind):
    tool, task = tasks["sweep"]
    g = grasps_by_kind["sweep"]
    params = VARIANTS[4]
    batched = itup.wrench_costs(tool, task, g, params)
    loads = task_loads(tool.params, task, params.include_gravity)
    for i in range(len(g)):
        one = grasp_costs(loads, g[i], tool.params, params)
        trace = grasp_cost_trace(loads, g[i], tool.params, params)
        for k in COST_NAMES:
            assert float(getattr(batched, k)[i]) == pytest.approx(float(getattr(one, k)), rel=1e-12, abs=1e-12)
        for k in ("tau", "slip", "align", "tau_closure"):
            assert float(getattr(trace, k).max()) == pytest.approx(float(getattr(one, k)), rel=1e-9, abs=1e-9)


@pytest.mark.parametrize("kind", itup.TASK_KINDS)
@pytest.mark.parametrize("variant", range(len(VARIANTS)))
def test_jax_matches_the_numpy_reference(tasks, grasps_by_kind, kind, variant):
    tool, task = tasks[kind]
    g = grasps_by_kind[kind]
    p = VARIANTS[variant]
    ref = numpy_wrench_costs(*to_numpy_inputs(tool.params, task, g), w_tau=p.w_tau, w_slip=p.w_slip, w_align=p.w_align,
                             grip_force=p.grip_force, lever_arm=p.lever_arm, torque_projection=p.torque_projection,
                             include_gravity=p.include_gravity)
    out = itup.wrench_costs(tool, task, g, p)
    for k in COST_NAMES:
        np.testing.assert_allclose(np.asarray(getattr(out, k)), ref[k], rtol=1e-9, atol=1e-9, err_msg=k)


def test_second_call_with_the_same_shapes_does_not_recompile(tasks, grasps_by_kind):
    tool, task = tasks["reach"]
    g = grasps_by_kind["reach"]
    itup.wrench_costs(tool, task, g)
    before = wrench_costs_jit._cache_size()
    moved = dataclasses.replace(g, p_tool_grasp=g.p_tool_grasp + 0.001)
    itup.wrench_costs(tool.with_params(mu=0.3), task, moved, CostParams(w_tau=2.0))
    assert before >= 1 and wrench_costs_jit._cache_size() == before


# -------------------------------------------------------------------------------------------- physics
@pytest.mark.parametrize("kind", ["hammer", "reach"])
def test_wrist_lever_arm_is_the_grasp_lever_arm_85_mm_back_along_the_approach(tasks, grasps_by_kind, kind):
    # the torque about the wrist site of a grasp is the torque about the grasp origin of the same grasp
    # moved back to the wrist: a closed form that a wrong axis, sign or offset breaks
    from itup_jax.robot import FLANGE_TO_GRASP
    from itup_jax.rotations import quat_to_matrix

    tool, task = tasks[kind]
    g = grasps_by_kind[kind]
    approach = np.asarray(jax.vmap(quat_to_matrix)(g.q_tool_grasp))[:, :, 2]
    back = dataclasses.replace(g, p_tool_grasp=jnp.asarray(np.asarray(g.p_tool_grasp) - FLANGE_TO_GRASP * approach))
    for proj in ("full", "perp"):
        wrist = itup.wrench_costs(tool, task, g, CostParams(lever_arm="wrist", torque_projection=proj))
        moved = itup.wrench_costs(tool, task, back, CostParams(lever_arm="grasp", torque_projection=proj))
        np.testing.assert_allclose(np.asarray(wrist.tau), np.asarray(moved.tau), rtol=1e-9, atol=1e-9)
    wrist = itup.wrench_costs(tool, task, g, CostParams(lever_arm="wrist", torque_projection="full"))
    grasp = itup.wrench_costs(tool, task, g, CostParams(torque_projection="full"))
    assert np.max(np.abs(np.asarray(wrist.tau) - np.asarray(grasp.tau))) > 1e-3  # the lever arm matters here


@pytest.mark.parametrize("kind", ["hammer", "sweep"])
def test_passed_torque_lies_between_the_perpendicular_and_the_full_torque(tasks, grasps_by_kind, kind):
    # no squeeze passes nothing about the closure axis (the paper's perpendicular torque); an unbounded
    # one passes it all (the full torque); in between it never leaves that range
    tool, task = tasks[kind]
    g = grasps_by_kind[kind]
    tau = {p: np.asarray(itup.wrench_costs(tool, task, g, CostParams(torque_projection=p, grip_force=f)).tau)
           for p, f in (("perp", 0.0), ("full", 0.0))}
    none = np.asarray(itup.wrench_costs(tool, task, g, CostParams(torque_projection="passed", grip_force=0.0)).tau)
    every = np.asarray(itup.wrench_costs(tool, task, g, CostParams(torque_projection="passed", grip_force=1e9)).tau)
    some = np.asarray(itup.wrench_costs(tool, task, g, CostParams(torque_projection="passed", grip_force=100.0)).tau)
    np.testing.assert_allclose(none, tau["perp"], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(every, tau["full"], rtol=1e-9, atol=1e-9)
    assert np.all(some >= tau["perp"] - 1e-9) and np.all(some <= tau["full"] + 1e-9)
    assert np.any(some < tau["full"] - 1e-3)  # the cap bites on some grasp here


@pytest.mark.slow
def test_com_lever_arm_variant_does_not_depend_on_grasp_position(tasks):
    tool, task = tasks["hammer"]
    R = np.eye(3)[None].repeat(3, 0)
    g = make_grasps([[0, 0, 0.02], [0, 0, 0.1], [0, 0, 0.2]], R, [0.03] * 3)
    # the full torque: the hammer's swing torque lies about the tool's y axis, these grasps' closure axis,
    # so the part off it ('perp') is zero at every grasp position (to rounding)
    com = itup.wrench_costs(tool, task, g, CostParams(lever_arm="com", torque_projection="full"))
    assert np.ptp(np.asarray(com.tau)) < 1e-9 * np.max(np.asarray(com.tau))
    grasp = itup.wrench_costs(tool, task, g, CostParams(torque_projection="full"))
    assert np.all(np.diff(np.asarray(grasp.tau)) < -1e-3)  # nearer the head, shorter lever, less torque
    assert np.max(np.asarray(itup.wrench_costs(tool, task, g).tau)) < 1e-9 * np.max(np.asarray(grasp.tau))


@pytest.mark.slow
def test_regimes_of_the_four_tasks(tasks):
    expected = {"hammer": Regime.DYNAMIC, "knock": Regime.DYNAMIC, "sweep": Regime.CLUSTERED, "reach": Regime.QUASI_STATIC}
    for kind, (tool, task) in tasks.items():
        assert itup.classify_regime(tool, task) == expected[kind], kind


def test_bad_cost_input(tasks, grasps_by_kind):
    tool, task = tasks["hammer"]
    g = grasps_by_kind["hammer"]
    bad = dataclasses.replace(g, p_tool_grasp=g.p_tool_grasp.at[2, 1].set(jnp.nan))
    with pytest.raises(itup.InputError, match=r"p_tool_grasp: NaN.*\[2\]"):
        itup.wrench_costs(tool, task, bad)
    with pytest.raises(itup.InputError, match="lever_arm"):
        CostParams(lever_arm="elbow")
    with pytest.raises(itup.InputError, match="batch"):
        itup.wrench_costs(tool, task, g[0])
    with pytest.raises(itup.InputError, match="Task"):
        itup.wrench_costs(tool, "hammer", g)


def test_costs_are_differentiable_through_the_public_batched_function(tasks, grasps_by_kind):
    tool, task = tasks["knock"]
    g = grasps_by_kind["knock"]
    grad = jax.jit(jax.grad(lambda tp: batched_wrench_costs(tp, task, g, CostParams()).total.sum()))(tool.params)
    assert all(np.all(np.isfinite(np.asarray(x))) for x in jax.tree_util.tree_leaves(grad))
    assert isinstance(g, Grasps)


@pytest.mark.parametrize("projection", ["perp", "passed"])
def test_off_axis_torque_keeps_float32_precision_where_the_torque_lies_on_the_closure_axis(projection):
    # a flat spanner's impact torque lies along the closure axis of many grasps, so the exact part off that
    # axis is ~0: taken as ||tau||^2 - (tau . n_f)^2 it cancels in float32 (errors ~1e-3 of the torque);
    # from its two grasp-frame components it keeps float32's relative precision of the torque itself
    tool = itup.load_tool("spanner")
    task = itup.make_task("hammer", tool)
    g = itup.sample_grasps(tool, 400, seed=3)
    p = CostParams(lever_arm="wrist", torque_projection=projection, grip_force=100.0)
    inputs = [{k: np.asarray(v, np.float64) for k, v in d.items()} for d in to_numpy_inputs(tool.params, task, g)]
    ref = {q: numpy_wrench_costs(*inputs, lever_arm="wrist", torque_projection=q, grip_force=100.0)["tau"]
           for q in ("perp", "full", projection)}
    exact, full = ref[projection], ref["full"]
    with jax.enable_x64(False):
        tau = itup.wrench_costs(tool, task, g, p).tau
    assert tau.dtype == jnp.float32 and np.min(ref["perp"]) < 1e-3 * np.max(full)  # some grasp nearly on the axis
    c32 = np.asarray(tau, np.float64)
    assert np.max(np.abs(c32 - exact)) <= 1e-6 * np.max(full), np.max(np.abs(c32 - exact)) / np.max(full)

"""SDG-Net features: shapes, invariance to world and tool-frame rigid transforms, sensitivity."""

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np
import pytest
from transforms import move_tool_frame as _move_tool_frame
from transforms import move_world as _move_world

import itup_jax as itup
from itup_jax.grasp import make_grasps
from itup_jax.rotations import quat_to_matrix
from itup_jax.sdgnet.features import (
    FeatureSpec,
    density_field,
    exact_occupancy,
    grasp_features,
    occupancy,
    surface_sample,
)
from itup_jax.wrench import task_loads

# float64, same computation on transformed inputs: rounding of ~0.3 m x 200 N products.
INV_ATOL = 1e-9

SPEC = FeatureSpec(num_points=256)


def _features(tool_params, points, task, grasps):
    loads = task_loads(tool_params, task)
    field = density_field(points, SPEC)
    fn = jax.jit(jax.vmap(lambda g: grasp_features(field, loads, tool_params, g, SPEC)))  # the outer call
    return np.asarray(fn(grasps))


def _exact_occupancy(points, grasps):
    fn = jax.jit(jax.vmap(lambda p, q: exact_occupancy(points, p, quat_to_matrix(q), SPEC)))
    return np.asarray(fn(grasps.p_tool_grasp, grasps.q_tool_grasp))


@pytest.fixture(scope="module")
def hammer_case(tasks):
    tool, task = tasks["hammer"]
    return tool, task, itup.sample_grasps(tool, 16, seed=4), surface_sample(tool, SPEC)


def test_shape_and_finiteness(hammer_case):
    tool, task, g, pts = hammer_case
    f = _features(tool.params, pts, task, g)
    assert f.shape == (16, SPEC.size) and np.all(np.isfinite(f))
    occ = f[:, :SPEC.grid**3]
    assert np.all(occ >= 0) and occ.sum(1).min() > 0  # the tool is near every grasp


@pytest.mark.slow
def test_invariant_to_a_rigid_transform_of_the_world(hammer_case, rng):
    tool, task, g, pts = hammer_case
    Q = np.asarray(jaxlie.SO3.sample_uniform(jax.random.key(int(rng.integers(1000)))).as_matrix())
    f0 = _features(tool.params, pts, task, g)
    f1 = _features(tool.params, pts, _move_world(task, Q, rng.normal(size=3)), g)
    np.testing.assert_allclose(f1, f0, atol=INV_ATOL)


@pytest.mark.slow
def test_invariant_to_the_choice_of_tool_frame(hammer_case, rng):
    tool, task, g, pts = hammer_case
    Q = np.asarray(jaxlie.SO3.sample_uniform(jax.random.key(int(rng.integers(1000)))).as_matrix())
    t = 0.1 * rng.normal(size=3)
    tp, task2, g2 = _move_tool_frame(tool.params, task, g, Q, t)
    # exactly for the direct sum; to the interpolation error for the tabulated field (whose voxel grid
    # is axis-aligned in each tool frame, so it samples D at other points)
    np.testing.assert_allclose(_exact_occupancy(pts @ Q.T + t, g2), _exact_occupancy(pts, g), atol=INV_ATOL)
    f0 = _features(tool.params, pts, task, g)
    f1 = _features(tp, pts @ Q.T + t, task2, g2)
    n_occ = SPEC.grid**3
    np.testing.assert_allclose(f1[:, n_occ:], f0[:, n_occ:], atol=INV_ATOL)
    np.testing.assert_allclose(f1[:, :n_occ], f0[:, :n_occ], atol=FIELD_ATOL)


# trilinear interpolation of a Gaussian of sigma 30 mm on a 4 mm grid: error <= h^2/(8 sigma^2) of the
# peak curvature scale, about 0.3% of the largest occupancy (0.25 here)
FIELD_ATOL = 2e-3


def test_tabulated_occupancy_matches_the_direct_sum(hammer_case):
    tool, _, g, pts = hammer_case
    field = density_field(pts, SPEC)
    fast = jax.jit(jax.vmap(lambda p, q: occupancy(field, p, quat_to_matrix(q), SPEC)))(g.p_tool_grasp, g.q_tool_grasp)
    exact = _exact_occupancy(pts, g)
    assert exact.max() > 0.05  # the comparison is not between zeros
    np.testing.assert_allclose(np.asarray(fast), exact, atol=FIELD_ATOL)
    # and the field is zero far from the tool, as the direct sum is
    far = occupancy(field, g.p_tool_grasp[0] + 1.0, quat_to_matrix(g.q_tool_grasp[0]), SPEC)
    assert float(jnp.abs(far).max()) == 0.0


def test_features_see_where_the_grasp_is(hammer_case):
    tool, task, _, pts = hammer_case
    R = np.eye(3)[None].repeat(2, 0)
    g = make_grasps([[0.0, 0.0, 0.05], [0.0, 0.0, 0.22]], R, [0.029] * 2)
    f = _features(tool.params, pts, task, g)
    assert np.abs(f[0] - f[1]).max() > 1e-3
    contact = f[:, SPEC.grid**3 + 12:SPEC.grid**3 + 15]
    assert np.linalg.norm(contact[0]) > np.linalg.norm(contact[1])  # farther from the face at the butt


def test_load_features_are_the_textbook_form_bit_for_bit(tasks):
    """The load features, computed with the time axis minor, equal the row-per-step form (the loads about
    the grasp origin in grasp axes, their peak magnitudes, both at the step of peak torque), bit for bit:
    the datasets' features do not change with the layout."""
    from itup_jax.bench import random_grasps

    g = SPEC.grid**3
    for kind in ("hammer", "sweep"):
        tool, task = tasks[kind]
        grasps = random_grasps(tool, 300, seed=5)
        loads = task_loads(tool.params, task)

        def textbook(grasp):
            R = quat_to_matrix(grasp.q_tool_grasp)
            to_grasp = lambda v: v[..., 0:1] * R[0] + v[..., 1:2] * R[1] + v[..., 2:3] * R[2]  # noqa: E731
            F = to_grasp(loads.force_tool)  # [T, 3]
            tau = to_grasp(loads.moment_tool - jnp.cross(grasp.p_tool_grasp, loads.force_tool))
            k = jnp.argmax(jnp.sum(tau * tau, axis=-1))
            return jnp.concatenate([jnp.abs(F).max(0), jnp.abs(tau).max(0), F[k], tau[k]])

        want = np.asarray(jax.jit(jax.vmap(textbook))(grasps))
        got = _features(tool.params, surface_sample(tool, SPEC), task, grasps)[:, g:g + 12]
        assert got.tobytes() == want.tobytes()


WRIST = FeatureSpec(num_points=256, wrist=True)


def test_wrist_block_is_the_costs_at_the_wrist(hammer_case):
    """The optional wrist block holds, as log1p(x / scale), the peaks `costs` computes on its own path:
    the full torque about the wrist site, the part the pads pass on at 100 N per pad, and the grip
    demand about the grasp (C_tau 'grip' = 2 c_t N_grip)."""
    from itup_jax.costs import CostParams, wrench_costs
    from itup_jax.robot import PAD_TORSION
    from itup_jax.sdgnet.features import WRIST_GRIP_FORCE, WRIST_SIZE, WRIST_TORQUE_SCALE

    tool, task, g, pts = hammer_case
    loads, field = task_loads(tool.params, task), density_field(pts, WRIST)
    f = np.asarray(jax.jit(jax.vmap(lambda x: grasp_features(field, loads, tool.params, x, WRIST)))(g))
    assert f.shape == (16, SPEC.size + WRIST_SIZE)
    np.testing.assert_array_equal(f[:, :SPEC.size], _features(tool.params, pts, task, g))  # the rest unchanged
    w = f[:, SPEC.size:]

    def cost(**kw):
        return np.asarray(wrench_costs(tool, task, g, CostParams(**kw)).tau, float)

    full = cost(lever_arm="wrist", torque_projection="full")
    passed = cost(lever_arm="wrist", torque_projection="passed", grip_force=WRIST_GRIP_FORCE)
    grip = cost(torque_projection="grip") / (2 * PAD_TORSION)
    np.testing.assert_allclose(WRIST_TORQUE_SCALE * np.expm1(w[:, 3]), full, rtol=1e-9)
    np.testing.assert_allclose(WRIST_TORQUE_SCALE * np.expm1(w[:, 4]), passed, rtol=1e-9)
    np.testing.assert_allclose(np.expm1(w[:, 5]), grip, rtol=1e-9)
    # the per-axis peaks bound the norm's peak: max_t |v| <= sqrt(sum_i max_t v_i^2) <= sum_i max_t |v_i|
    axes = WRIST_TORQUE_SCALE * np.expm1(w[:, :3])
    assert np.all(full <= np.sqrt((axes**2).sum(1)) * (1 + 1e-12)) and np.all(full >= axes.max(1) * (1 - 1e-12))
    assert np.all(passed <= full * (1 + 1e-12)) and np.any(passed < 0.99 * full)  # the cap binds on some grasps


def test_a_spec_without_the_wrist_block_reads_as_before():
    """Datasets and checkpoints store `to_dict()`; one written before the block existed has no 'wrist'
    key and must compare equal to, and load as, the default spec."""
    old = {"num_points": 512, "grid": 4, "grid_half_width": 0.06, "seed": 0, "field_spacing": 0.004}
    assert FeatureSpec().to_dict() == old and FeatureSpec(**old) == FeatureSpec()
    assert FeatureSpec(wrist=True).to_dict() == old | {"wrist": True}
    assert FeatureSpec(**FeatureSpec(wrist=True).to_dict()).size == FeatureSpec().size + 6


RESIDUAL = FeatureSpec(num_points=256, wrist=True, residual=True)


def test_residual_block_is_the_passed_torque_by_component(hammer_case):
    """The residual block is the rigid-body prediction of the wrench objective's targets: the wrist
    torque's grasp-frame components at the step where the passed-on torque peaks, so the norm of the
    three (transform undone) is `costs`' 'passed' peak at 100 N per pad; the closure component never
    exceeds the pads' torsional friction; the grip entry is the grip demand's peak."""
    from itup_jax.costs import CostParams, wrench_costs
    from itup_jax.robot import PAD_TORSION
    from itup_jax.sdgnet.features import RESIDUAL_SCALES, RESIDUAL_SIZE, WRIST_GRIP_FORCE, WRIST_SIZE

    tool, task, g, pts = hammer_case
    loads, field = task_loads(tool.params, task), density_field(pts, RESIDUAL)
    f = np.asarray(jax.jit(jax.vmap(lambda x: grasp_features(field, loads, tool.params, x, RESIDUAL)))(g))
    assert RESIDUAL.size == SPEC.size + WRIST_SIZE + RESIDUAL_SIZE and f.shape == (16, RESIDUAL.size)
    r = np.asarray(RESIDUAL_SCALES) * np.expm1(f[:, -RESIDUAL_SIZE:])

    def cost(**kw):
        return np.asarray(wrench_costs(tool, task, g, CostParams(**kw)).tau, float)

    passed = cost(lever_arm="wrist", torque_projection="passed", grip_force=WRIST_GRIP_FORCE)
    np.testing.assert_allclose(np.linalg.norm(r[:, :3], axis=1), passed, rtol=1e-7)
    cap = 2 * PAD_TORSION * float(tool.params.mu) * WRIST_GRIP_FORCE
    assert np.all(r[:, 1] <= cap * (1 + 1e-12)) and np.all(r[:, :3] >= 0)
    np.testing.assert_allclose(r[:, 3], cost(torque_projection="grip") / (2 * PAD_TORSION), rtol=1e-7)
    # the blocks before it are unchanged by it
    np.testing.assert_array_equal(f[:, :SPEC.size], _features(tool.params, pts, task, g))


def test_a_spec_records_the_residual_block_only_when_set():
    base = FeatureSpec().to_dict()
    assert FeatureSpec(residual=True).to_dict() == base | {"residual": True}
    assert FeatureSpec(**FeatureSpec(residual=True).to_dict()).size == FeatureSpec().size + 4


def test_residual_block_gradient_matches_finite_differences():
    """d(residual block)/d(loads, width) in float64 against central differences, at loads where the peak
    step, the cap and the grip demand's branch are each away from a tie."""
    from jax.test_util import check_grads

    from itup_jax.sdgnet.features import residual_block

    rng = np.random.default_rng(4)
    F = jnp.asarray(rng.normal(size=(3, 7)) * 20.0)
    tau = jnp.asarray(rng.normal(size=(3, 7)) * 0.5)
    f = lambda F, tau, width: residual_block(F, tau, jnp.asarray(0.8), width)  # noqa: E731
    assert np.all(np.isfinite(np.asarray(f(F, tau, jnp.asarray(0.03)))))
    check_grads(f, (F, tau, jnp.asarray(0.03)), order=1, modes=("rev",), eps=1e-6, atol=1e-6, rtol=1e-5)

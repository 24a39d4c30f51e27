"""SDG-Net features: shapes, invariance to world and tool-frame rigid transforms, sensitivity."""

import jax
import jax.numpy as jnp
import jaxlie
import numpy as np
import pytest
from transforms import move_tool_frame as _move_tool_frame
from transforms import move_world as _move_world

import itup_jax as itup
from itup_jax.features import FeatureSpec, density_field, exact_occupancy, grasp_features, occupancy, surface_sample
from itup_jax.grasp import make_grasps, rotation_matrix
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
    fn = jax.jit(jax.vmap(lambda p, q: exact_occupancy(points, p, rotation_matrix(q), SPEC)))
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


def test_invariant_to_a_rigid_transform_of_the_world(hammer_case, rng):
    tool, task, g, pts = hammer_case
    Q = np.asarray(jaxlie.SO3.sample_uniform(jax.random.key(int(rng.integers(1000)))).as_matrix())
    f0 = _features(tool.params, pts, task, g)
    f1 = _features(tool.params, pts, _move_world(task, Q, rng.normal(size=3)), g)
    np.testing.assert_allclose(f1, f0, atol=INV_ATOL)


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
    fast = jax.jit(jax.vmap(lambda p, q: occupancy(field, p, rotation_matrix(q), SPEC)))(g.p_tool_grasp, g.q_tool_grasp)
    exact = _exact_occupancy(pts, g)
    assert exact.max() > 0.05  # the comparison is not between zeros
    np.testing.assert_allclose(np.asarray(fast), exact, atol=FIELD_ATOL)
    # and the field is zero far from the tool, as the direct sum is
    far = occupancy(field, g.p_tool_grasp[0] + 1.0, rotation_matrix(g.q_tool_grasp[0]), SPEC)
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
            R = rotation_matrix(grasp.q_tool_grasp)
            to_grasp = lambda v: v[..., 0:1] * R[0] + v[..., 1:2] * R[1] + v[..., 2:3] * R[2]  # noqa: E731
            F = to_grasp(loads.force_tool)  # [T, 3]
            tau = to_grasp(loads.moment_tool - jnp.cross(grasp.p_tool_grasp, loads.force_tool))
            k = jnp.argmax(jnp.sum(tau * tau, axis=-1))
            return jnp.concatenate([jnp.abs(F).max(0), jnp.abs(tau).max(0), F[k], tau[k]])

        want = np.asarray(jax.jit(jax.vmap(textbook))(grasps))
        got = _features(tool.params, surface_sample(tool, SPEC), task, grasps)[:, g:g + 12]
        assert got.tobytes() == want.tobytes()

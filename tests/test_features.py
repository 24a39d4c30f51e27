"""SDG-Net features: shapes, invariance to world and tool-frame rigid transforms, sensitivity."""

import jax
import jaxlie
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.features import FeatureSpec, grasp_features, surface_sample
from itup_jax.grasp import make_grasps
from itup_jax.wrench import task_loads
from transforms import move_tool_frame as _move_tool_frame, move_world as _move_world

# float64, same computation on transformed inputs: rounding of ~0.3 m x 200 N products.
INV_ATOL = 1e-9

SPEC = FeatureSpec(num_points=256)


def _features(tool_params, points, task, grasps):
    loads = task_loads(tool_params, task)
    fn = jax.jit(jax.vmap(lambda g: grasp_features(points, loads, tool_params, g, SPEC)))  # the outer call
    return np.asarray(fn(grasps))


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
    f0 = _features(tool.params, pts, task, g)
    f1 = _features(tp, pts @ Q.T + t, task2, g2)
    np.testing.assert_allclose(f1, f0, atol=INV_ATOL)


def test_features_see_where_the_grasp_is(hammer_case):
    tool, task, _, pts = hammer_case
    R = np.eye(3)[None].repeat(2, 0)
    g = make_grasps([[0.0, 0.0, 0.05], [0.0, 0.0, 0.22]], R, [0.029] * 2)
    f = _features(tool.params, pts, task, g)
    assert np.abs(f[0] - f[1]).max() > 1e-3
    contact = f[:, SPEC.grid**3 + 12:SPEC.grid**3 + 15]
    assert np.linalg.norm(contact[0]) > np.linalg.norm(contact[1])  # farther from the face at the butt

"""Every outer jit of the package traces float32 (not TensorFloat32 or bfloat16) matrix products.

On a CPU the precision changes nothing, so these tests read the lowered programs: each `dot_general`
must carry precision HIGHEST. On an H100 the default (TF32) put the analytic costs 1.2e-2 relative from
the float64 reference; HIGHEST put them 7.6e-6 from it (docs/benchmarks.md, "GPU").
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax.precision import full_precision


def dot_lines(lowered) -> list[str]:
    return [line for line in lowered.as_text().splitlines() if "dot_general" in line]


def assert_full_precision(lowered):
    dots = dot_lines(lowered)
    assert dots, "no matrix product in the program"
    slow = [d.strip()[:160] for d in dots if "precision = [HIGHEST, HIGHEST]" not in d]
    assert not slow, slow


def test_full_precision_sets_highest_and_the_default_does_not():
    a = jnp.ones((3, 3), jnp.float32)
    assert all("DEFAULT" in d for d in dot_lines(jax.jit(jnp.dot).lower(a, a)))
    assert_full_precision(jax.jit(full_precision(jnp.dot)).lower(a, a))
    assert_full_precision(jax.jit(full_precision(lambda x, *, k: x @ x * k), static_argnames=("k",)).lower(a, k=2))


def test_costs_features_scoring_and_prediction_trace_float32_products(tasks):
    from itup_jax.costs import CostParams, wrench_costs_jit
    from itup_jax.scoring import ScoreWeights, sdgnet_args, sdgnet_scores_jit
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.features import batched_features
    from itup_jax.sdgnet.model import predict
    from itup_jax.wrench import task_loads

    tool, task = tasks["hammer"]
    grasps = itup.sample_grasps(tool, 8, seed=0)
    assert_full_precision(wrench_costs_jit.lower(tool.params, task, grasps, CostParams()))
    args, kw = sdgnet_args(tool, task, grasps, load_model(None), ScoreWeights())
    assert_full_precision(sdgnet_scores_jit.lower(*args, **kw))
    field, params, stats = args[0], args[4], args[5:10]
    assert_full_precision(batched_features.lower(field, task_loads(tool.params, task), tool.params, grasps, spec=kw["spec"]))
    feats = jnp.zeros((8, stats[0].shape[-1]), jnp.float32)
    assert_full_precision(predict.lower(params, *stats, feats))


@pytest.mark.slow
def test_mjx_rollout_traces_float32_products(tasks):
    import importlib

    from itup_jax.sim.scene import build_scene

    sim = importlib.import_module("itup_jax.sim.mjx")
    phys = importlib.import_module("itup_jax.sim.physics")
    tool, task = tasks["hammer"]
    scene = build_scene(tool, task, timestep=0.002)
    fn = sim.mjx_rollout_fn(scene, float64=False)  # the float32 program, where a GPU would use TF32
    physics = phys.sample_physics(tool, 2, 0)
    fields = [a.astype(fn.dtype) for a in phys.mjx_model_fields(scene, physics)]
    qpos0 = np.tile(scene.model.qpos0, (2, 1)).astype(fn.dtype)
    ctrl = np.zeros((2, 2, scene.model.nu), fn.dtype)
    assert fn.dtype == np.float32
    with jax.enable_x64(False):
        assert_full_precision(jax.jit(fn.batched).lower(*fields, qpos0, ctrl))

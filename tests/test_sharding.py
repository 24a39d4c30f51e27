"""MJX label generation sharded over two host devices gives the labels of an unsharded run.

XLA_FLAGS must be set before JAX starts, so this runs in a subprocess (two small MJX compiles, float64:
in float32 the two programs round differently from step 0 and contact dynamics amplify it).
"""

import json
import os
import pathlib
import subprocess
import sys
import textwrap

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent

SCRIPT = textwrap.dedent("""
    import json, sys
    import jax, numpy as np
    jax.config.update("jax_enable_x64", True)
    jax.config.update("jax_compilation_cache_dir", sys.argv[1])
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 2.0)
    import itup_jax as itup
    from itup_jax.sim.scene import build_scene
    from itup_jax.sim.labels import LABEL_FIELDS
    assert jax.device_count() == 2, jax.devices()
    tool = itup.load_tool("hammer")
    task = itup.make_task("hammer", tool)
    scene = build_scene(tool, task, timestep=0.002)  # the sharding does not depend on the step: 2 ms, 4x fewer steps
    g = itup.sample_grasps(tool, 3, seed=0)  # 3 over 2 devices: one padded row
    sharded = itup.simulate(tool, task, g, scene=scene, backend="mjx", seed=0).labels
    single = itup.simulate(tool, task, g, scene=scene, backend="mjx", seed=0, devices=jax.devices()[:1]).labels
    print(json.dumps({"sharded": {f: np.asarray(getattr(sharded, f)).tolist() for f in LABEL_FIELDS},
                      "single": {f: np.asarray(getattr(single, f)).tolist() for f in LABEL_FIELDS}}))
""")

# float64 programs that differ only in how XLA partitions them: labels agree to ~1e-7 relative
RTOL = 1e-5


@pytest.mark.slow
def test_sharded_mjx_labels_equal_unsharded():
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2", JAX_PLATFORMS="cpu")
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(ROOT / ".jax_cache")], env=env, cwd=ROOT,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    import numpy as np

    for f, a in out["single"].items():
        b = out["sharded"][f]
        if isinstance(a[0], bool):
            assert a == b, f
        else:
            np.testing.assert_allclose(b, a, rtol=RTOL, atol=1e-9, err_msg=f)
    assert any(out["single"]["valid"])  # at least one real label compared


@pytest.mark.parametrize("n", [130])
def test_cpu_mjx_batches_are_chunked_not_hung(n, monkeypatch):
    """A CPU batch above 64 per device is split into chunks of <= 64 (128 hangs MJX here)."""
    import importlib

    import numpy as np

    sim = importlib.import_module("itup_jax.sim.mjx")

    seen = []

    def fake_fn(*args, mesh=None):
        seen.append(args[0].shape[0])
        b = args[0].shape[0]
        return np.zeros((b, args[-1].shape[1])), np.zeros((b, args[-1].shape[1], 2))

    fake_fn.dtype = np.float64

    class P:
        qpos0 = np.zeros((n, 3))
        ctrl = np.zeros((n, 5, 2))

    monkeypatch.setattr(sim, "mjx_rollout_fn", lambda scene, float64=None: fake_fn)
    monkeypatch.setattr(sim, "mjx_model_fields", lambda scene, physics: (np.arange(n, dtype=float)[:, None],))
    import jax

    qv, sens = sim.rollout_mjx(None, P, None, devices=jax.devices()[:1])
    assert max(seen) <= sim.MJX_CPU_MAX_BATCH and len(set(seen)) == 1  # one shape: one compile
    assert qv.shape == (n, 5) and sens.shape == (n, 5, 2)


@pytest.mark.parametrize("n, batch", [(1, 1), (3, 4), (64, 64), (65, 128), (179, 256)])
def test_accelerator_batches_are_padded_to_a_power_of_two(n, batch, monkeypatch):
    """On an accelerator one MJX compile takes 45-100 s: batches share programs by power-of-two shapes."""
    import importlib

    import numpy as np

    sim = importlib.import_module("itup_jax.sim.mjx")
    seen = []

    def fake_fn(*args, mesh=None):
        seen.append(args[0].shape[0])
        rows = args[0][:, 0]  # each row's index: the padding must repeat the last row, then be dropped
        return np.repeat(rows[:, None], 5, axis=1), np.zeros((len(rows), 5, 2))

    fake_fn.dtype = np.float64

    class P:
        qpos0 = np.zeros((n, 3))
        ctrl = np.zeros((n, 5, 2))

    class GPU:
        platform, id = "gpu", 0

    monkeypatch.setattr(sim, "mjx_rollout_fn", lambda scene, float64=None: fake_fn)
    monkeypatch.setattr(sim, "mjx_model_fields", lambda scene, physics: (np.arange(n, dtype=float)[:, None],))
    monkeypatch.setattr(sim.jax, "device_put", lambda a, place: a)
    qv, sens = sim.rollout_mjx(None, P, None, devices=[GPU()])
    assert seen == [batch]
    assert qv.shape == (n, 5) and sens.shape == (n, 5, 2)
    np.testing.assert_array_equal(qv[:, 0], np.arange(n))


def test_mjx_rolls_out_in_float64_unless_told_whatever_the_process_says(monkeypatch):
    """`rollout_mjx` runs MJX in float64 by default (simulate.MJX_FLOAT64: in float32 the pads' contacts
    spike), with its inputs placed as float64, also in a float32 process; float64=False gives float32."""
    import importlib

    import jax
    import numpy as np

    sim = importlib.import_module("itup_jax.sim.mjx")
    seen = []

    def fake_rollout_fn(scene, float64=None):
        def fn(*args, mesh=None):
            seen.append((float64, bool(jax.config.jax_enable_x64), args[0].dtype))
            b = args[0].shape[0]
            return np.zeros((b, 5)), np.zeros((b, 5, 2))

        fn.dtype = np.float64 if float64 else np.float32
        return fn

    class P:
        qpos0 = np.zeros((3, 3))
        ctrl = np.zeros((3, 5, 2))

    monkeypatch.setattr(sim, "mjx_rollout_fn", fake_rollout_fn)
    monkeypatch.setattr(sim, "mjx_model_fields", lambda scene, physics: (np.zeros((3, 1)),))
    with jax.enable_x64(False):
        sim.rollout_mjx(None, P, None, devices=jax.devices()[:1])
        assert seen[-1] == (True, True, np.float64)
    sim.rollout_mjx(None, P, None, devices=jax.devices()[:1], float64=False)
    assert seen[-1] == (False, False, np.float32)
    assert jax.config.jax_enable_x64  # the tests' setting is back

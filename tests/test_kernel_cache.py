"""kernel_cache: kept kernels give the jit's outputs bit for bit, exported or read back from the folder."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import compile_cache, kernel_cache


@pytest.fixture
def folder(tmp_path):
    kernel_cache.forget()
    try:
        yield tmp_path
    finally:
        kernel_cache.enable(None)
        kernel_cache.forget()


def _plan_arrays(plan) -> dict:
    guard = plan.guard
    return {"ranking": plan.ranking, "pick": plan.pick, "regime": plan.regime,
            "graspnet_rotation": plan.graspnet_rotation,
            "p_tool_grasp": plan.grasps.p_tool_grasp, "width": plan.grasps.width,
            **{f: getattr(plan.scores, f) for f in ("tau", "slip", "align", "total", "grip", "p_success", "p_failed")
               if getattr(plan.scores, f) is not None},
            "guard_score": guard.score, "guard_per_candidate": guard.per_candidate,
            "guard_groups": np.array(list(guard.groups.values()))}


@pytest.mark.slow  # ~20 s: three plans, six kernels exported
def test_a_plan_with_kept_kernels_is_the_jits_bit_for_bit_exported_and_read_back(tasks, folder, monkeypatch):
    tool, task = tasks["hammer"]
    plain = _plan_arrays(itup.plan_grasp(tool, task, n=24, seed=3))
    kernel_cache.enable(folder)
    exported = _plan_arrays(itup.plan_grasp(tool, task, n=24, seed=3))
    entries = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    assert len(entries) >= 4  # the sampler's collision check, the scorer, the guard, the regime, quaternions

    kernel_cache.forget()  # as a fresh process: every kernel read from the folder, none traced or exported
    calls = []
    monkeypatch.setattr(jax.export, "export", lambda *a, **k: calls.append(a) or pytest.fail("exported again"))
    read = _plan_arrays(itup.plan_grasp(tool, task, n=24, seed=3))
    assert not calls and {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == entries
    for name, value in plain.items():
        np.testing.assert_array_equal(np.asarray(exported[name]), np.asarray(value), err_msg=name)
        np.testing.assert_array_equal(np.asarray(read[name]), np.asarray(value), err_msg=name)


def test_entries_are_keyed_by_shapes_and_static_arguments_and_a_broken_one_is_exported_again(folder):
    kernel = kernel_cache.kept(lambda x, p: jnp.sin(x) ** p, "test.power", static_argnames="p")
    ref = jax.jit(lambda x, p: jnp.sin(x) ** p, static_argnames="p")
    kernel_cache.enable(folder)
    cases = [(jnp.linspace(0.0, 1.0, 3), 2), (jnp.linspace(0.0, 1.0, 4), 2), (jnp.linspace(0.0, 1.0, 3), 3)]
    for x, p in cases:
        np.testing.assert_array_equal(kernel(x, p=p), ref(x, p=p))
    entries = sorted(folder.iterdir())
    assert len(entries) == 3
    entries[0].write_bytes(b"not an exported module")
    kernel_cache.forget()
    for x, p in cases:
        np.testing.assert_array_equal(kernel(x, p=p), ref(x, p=p))
    assert len(list(folder.iterdir())) == 3 and entries[0].stat().st_size > 100  # written again
    np.testing.assert_array_equal(kernel(jnp.ones(2), 2), ref(jnp.ones(2), 2))  # positional: a plain jit
    assert len(list(folder.iterdir())) == 3


def test_off_or_with_outputs_the_format_cannot_store_a_kernel_is_a_plain_jit(folder):
    @jax.tree_util.register_dataclass
    @dataclasses.dataclass(frozen=True)
    class Out:
        a: jax.Array

    twice = kernel_cache.kept(lambda x: 2.0 * x, "test.twice")
    np.testing.assert_array_equal(twice(jnp.arange(3.0)), 2.0 * np.arange(3.0))
    assert not any(folder.iterdir())  # keeping is off until enable
    kernel_cache.enable(folder)
    custom = kernel_cache.kept(lambda x: Out(a=x + 1.0), "test.custom_output")
    assert isinstance(custom(jnp.arange(3.0)), Out)
    np.testing.assert_array_equal(custom(jnp.arange(3.0)).a, np.arange(3.0) + 1.0)
    assert not any(folder.iterdir())


def test_the_command_lines_cache_keeps_the_kernels_in_its_subfolder(folder, monkeypatch):
    updates = {}
    monkeypatch.setattr(jax.config, "update", lambda name, value: updates.__setitem__(name, value))
    assert compile_cache.enable(folder) == folder
    assert kernel_cache.folder() == folder / "exported"
    assert updates["jax_compilation_cache_dir"] == str(folder)

"""The task cache kept between CLI runs (task_cache.py): the same Task bit for bit, keyed by every input."""

import argparse
import dataclasses
import warnings

import jax
import numpy as np
import pytest

import itup_jax as itup
from itup_jax import task_cache
from itup_jax.task import DEFAULT_TOOL


def _bits(task):
    """{path: raw bytes} of every array of a task, with its dtype and shape."""
    leaves = jax.tree_util.tree_flatten_with_path(task)[0]
    return {jax.tree_util.keystr(p): (np.asarray(v).dtype.str, np.asarray(v).shape, np.asarray(v).tobytes())
            for p, v in leaves}


@pytest.mark.parametrize("kind", ["hammer", "sweep", "knock", "reach"])
def test_a_cached_task_is_the_built_one_bit_for_bit(tools, tasks, kind, tmp_path):
    tool, built = tasks[kind]
    first = task_cache.make_task(kind, tool, folder=tmp_path)  # a miss: built and written
    assert len(list(tmp_path.glob("*.npz"))) == 1
    again = task_cache.make_task(kind, tool, folder=tmp_path)  # a hit: read
    for t in (first, again):
        assert t.kind == built.kind and _bits(t) == _bits(built)
    assert type(again.traj) is type(built.traj)


def test_every_input_is_in_the_key(tools, monkeypatch):
    hammer = tools["hammer"]
    k = task_cache.key("hammer", hammer, {})
    assert task_cache.key("hammer", hammer, {}) == k
    assert task_cache.key("hammer", itup.load_tool("hammer"), {}) == k  # the same tool built again
    others = [task_cache.key("knock", hammer, {}),
              task_cache.key("hammer", hammer, {"steps": 80}),
              task_cache.key("hammer", hammer, {"impact_speed": 0.9}),
              task_cache.key("hammer", hammer.with_params(mu=float(hammer.params.mu) + 0.01), {}),
              task_cache.key("hammer", tools["mallet"], {})]
    moved = hammer.mesh.copy()
    moved.vertices[0] += 1e-6
    others.append(task_cache.key("hammer", dataclasses.replace(hammer, mesh=moved), {}))
    monkeypatch.setattr(task_cache, "code_digest", lambda: "another version of the code")
    others.append(task_cache.key("hammer", hammer, {}))
    assert len(set(others) | {k}) == len(others) + 1


def test_an_unreadable_entry_is_rebuilt(tools, tasks, tmp_path):
    tool, built = tasks["hammer"]
    entry = tmp_path / f"{task_cache.key('hammer', tool, {})}.npz"
    entry.write_bytes(b"not an npz file")
    assert _bits(task_cache.make_task("hammer", tool, folder=tmp_path)) == _bits(built)
    assert _bits(task_cache._decode(entry.read_bytes())[0]) == _bits(built)  # rewritten whole
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp")]


def test_the_build_warnings_are_raised_again_on_a_hit(tools, tmp_path):
    for _ in range(2):  # a miss, then a hit
        with pytest.warns(UserWarning, match="joint-speed limit"):
            task_cache.make_task("hammer", tools["hammer"], folder=tmp_path, impact_speed=20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning from a task that raises none
        task_cache.make_task("hammer", tools["hammer"], folder=tmp_path)
        task_cache.make_task("hammer", tools["hammer"], folder=tmp_path)


def test_bad_input_is_refused_before_the_cache_and_an_unwritable_folder_is_no_cache(tools, tasks, tmp_path):
    with pytest.raises(itup.InputError, match="impact_speed"):
        task_cache.make_task("hammer", tools["hammer"], folder=tmp_path, impact_speed=-1.0)
    assert not list(tmp_path.iterdir())
    blocker = tmp_path / "file"
    blocker.write_text("a regular file where the folder would be")
    t = task_cache.make_task("hammer", tools["hammer"], folder=blocker / "tasks")
    assert _bits(t) == _bits(tasks["hammer"][1])


def test_the_cli_keeps_tasks_when_it_keeps_kernels(tools, monkeypatch, tmp_path):
    from itup_jax import compile_cache
    from itup_jax.cli import _make_task
    from itup_jax.sim import restitution

    monkeypatch.setenv(task_cache.ENV_DIR, str(tmp_path))
    assert task_cache.cache_dir() == tmp_path
    tool = tools[DEFAULT_TOOL["reach"]]
    monkeypatch.setenv(compile_cache.ENV_SWITCH, "0")
    _make_task(argparse.Namespace(task="reach", no_compile_cache=False), tool)
    assert not list(tmp_path.iterdir())
    monkeypatch.delenv(compile_cache.ENV_SWITCH)
    _make_task(argparse.Namespace(task="reach", no_compile_cache=True), tool)
    assert not list(tmp_path.iterdir())
    try:
        _make_task(argparse.Namespace(task="reach", no_compile_cache=False), tool)
        assert restitution.tables_folder() == task_cache.restitution_dir() == tmp_path / "restitution"
    finally:
        restitution.keep_tables(None)
    assert len(list(tmp_path.glob("*.npz"))) == 1

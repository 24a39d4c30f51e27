"""The CLI keeps compiled kernels between runs: the cache folder, its switches, and entries written."""

import os
import subprocess
import sys

import pytest

from itup_jax import compile_cache


def test_the_cache_folder_and_its_switches(monkeypatch, tmp_path):
    monkeypatch.delenv(compile_cache.ENV_DIR, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compile_cache.cache_dir() == tmp_path / "xdg" / "itup-jax" / "jax"
    monkeypatch.setenv(compile_cache.ENV_DIR, str(tmp_path / "mine"))
    assert compile_cache.cache_dir() == tmp_path / "mine"
    for value, on in (("1", True), ("0", False), ("false", False), ("no", False), ("off", False), ("yes", True)):
        monkeypatch.setenv(compile_cache.ENV_SWITCH, value)
        assert compile_cache.wanted() is on
        assert compile_cache.wanted(flag_off=True) is False


def test_the_cli_turns_the_cache_on_unless_told_not_to(monkeypatch):
    from itup_jax.cli import main

    calls = []
    monkeypatch.setattr(compile_cache, "enable", lambda folder=None: calls.append(folder))
    monkeypatch.delenv(compile_cache.ENV_SWITCH, raising=False)
    assert main(["tools"]) == 0 and len(calls) == 1
    assert main(["--no-compile-cache", "tools"]) == 0 and len(calls) == 1
    monkeypatch.setenv(compile_cache.ENV_SWITCH, "0")
    assert main(["tools"]) == 0 and len(calls) == 1


@pytest.mark.slow
def test_a_cli_run_writes_compiled_kernels(tmp_path):
    """`itup bench costs` (one jit) in a fresh process leaves cache entries in the cache folder."""
    env = {k: v for k, v in os.environ.items() if k != compile_cache.ENV_SWITCH}
    env[compile_cache.ENV_DIR] = str(tmp_path / "cache")
    run = subprocess.run([sys.executable, "-m", "itup_jax.cli", "bench", "costs", "--n", "64", "--t", "64",
                          "--repeats", "1", "--json"], capture_output=True, text=True, env=env, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert any(p.is_file() for p in (tmp_path / "cache").rglob("*"))

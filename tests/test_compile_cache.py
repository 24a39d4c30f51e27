"""The CLI keeps compiled kernels between runs: the cache folder, its switches, and entries written."""

import os
import subprocess
import sys

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


def test_a_cli_run_writes_compiled_kernels_and_the_flag_turns_it_off(tmp_path):
    """`itup bench costs` (one jit) in a fresh process leaves cache entries in the folder; with
    --no-compile-cache it leaves none."""
    env = {k: v for k, v in os.environ.items() if k != compile_cache.ENV_SWITCH}
    for flag, folder in (([], tmp_path / "on"), (["--no-compile-cache"], tmp_path / "off")):
        env[compile_cache.ENV_DIR] = str(folder)
        run = subprocess.run([sys.executable, "-m", "itup_jax.cli", *flag, "bench", "costs", "--n", "64", "--t", "64",
                              "--repeats", "1", "--json"], capture_output=True, text=True, env=env, timeout=300)
        assert run.returncode == 0, run.stderr[-2000:]
        entries = list(folder.rglob("*")) if folder.exists() else []
        assert (len(entries) > 0) == (not flag), (flag, entries)

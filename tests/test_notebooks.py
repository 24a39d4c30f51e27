"""Notebooks run top to bottom in quick mode (they are jupytext py:percent scripts)."""

import pathlib
import runpy

import pytest

NOTEBOOKS = sorted(pathlib.Path(__file__).resolve().parent.parent.joinpath("notebooks").glob("[0-9]*.py"))


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(path, tmp_path, monkeypatch):
    monkeypatch.setenv("ITUP_QUICK", "1")
    monkeypatch.setenv("ITUP_NOTEBOOK_OUT", str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    runpy.run_path(str(path), run_name="__main__")
    assert any(f.suffix == ".png" for f in tmp_path.iterdir())

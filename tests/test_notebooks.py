"""Notebooks run top to bottom in quick mode (they are jupytext py:percent scripts): every cell runs, the
checks written in them hold, and every figure each one draws is written and is a picture."""

import pathlib
import re
import runpy

import pytest

#: Slow tier (`-m slow`): each notebook runs end to end.
pytestmark = pytest.mark.slow

NOTEBOOKS = sorted(pathlib.Path(__file__).resolve().parent.parent.joinpath("notebooks").glob("[0-9]*.py"))
#: bytes: a drawn figure is larger than an empty canvas.
MIN_FIGURE_BYTES = 5_000


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_runs(path, tmp_path, monkeypatch):
    monkeypatch.setenv("ITUP_QUICK", "1")
    monkeypatch.setenv("ITUP_NOTEBOOK_OUT", str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    figures = sorted(set(re.findall(r"\{OUT\}/([\w.]+\.png)", path.read_text())))
    assert figures, f"{path.name} draws no figure into OUT"
    namespace = runpy.run_path(str(path), run_name="__main__")  # the notebook's own asserts run here
    assert "OUT" in namespace
    for name in figures:
        f = tmp_path / name
        assert f.is_file(), f"{path.name} did not write {name}"
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f.stat().st_size > MIN_FIGURE_BYTES, name

"""Every bad input a new user is likely to give ends with a clear message and a non-zero exit, before
long work starts, with nothing half-written."""

import dataclasses
import json
import os
import re

import numpy as np
import pytest

import itup_jax as itup
from itup_jax.cli import EXIT_NO_PICK, main


def _hammer_files(tmp_path, scale=1.0, contact_shift=0.0, units=None):
    h = itup.load_tool("hammer")
    mesh = h.mesh.copy()
    mesh.apply_scale(scale)
    mesh.export(tmp_path / "hammer.stl")
    cp = (scale * (h.contact_point + [contact_shift, 0.0, 0.0])).tolist()
    lo, hi = (scale * h.grasp_region.lo).tolist(), (scale * h.grasp_region.hi).tolist()
    (tmp_path / "hammer.toml").write_text(
        f'name = "mine"\ncategory = "hammer"\ncontact_point = {cp}\ncontact_normal = [1.0, 0.0, 0.0]\n'
        f"grasp_region = {{ min = {lo}, max = {hi} }}\n" + (f'units = "{units}"\n' if units else ""))
    return ["--tool", str(tmp_path / "hammer.stl"), "--tool-spec", str(tmp_path / "hammer.toml")]


def _err(capsys):
    return capsys.readouterr().err


@pytest.mark.parametrize("task", ["hammer", "reach"])
def test_a_hammer_in_millimetres(tmp_path, capsys, task):
    assert main(["plan", "--task", task, *_hammer_files(tmp_path, scale=1000.0)]) == 2
    assert "largest extent is 301 m" in (e := _err(capsys)) and 'looks like millimetres: add units = "mm"' in e
    with pytest.raises(itup.InputError, match="looks like millimetres"):
        itup.load_tool(str(tmp_path / "hammer.stl"), spec=str(tmp_path / "hammer.toml"))


def test_a_contact_point_a_metre_away(tmp_path, capsys):
    assert main(["plan", "--n", "8", *_hammer_files(tmp_path, contact_shift=1.0)]) == 2
    assert "field 'contact_point' lies" in (e := _err(capsys)) and "from the mesh's surface" in e


def _checkpoint_with(tmp_path, fill):
    from itup_jax.sdgnet import checkpoint
    from itup_jax.sdgnet.config import DEFAULT_MODEL

    layers, spec = checkpoint.load(DEFAULT_MODEL)
    path = str(tmp_path / "bad.npz")
    checkpoint.save(path, [(np.full_like(W, fill), b) for W, b in layers], spec)
    return path


def test_a_checkpoint_of_nans(tmp_path, capsys, monkeypatch):
    path = _checkpoint_with(tmp_path, np.nan)
    monkeypatch.setattr(itup, "sample_grasps", lambda *a, **k: pytest.fail("sampled before the model was checked"))
    assert main(["plan", "--n", "8", "--model", path]) == 2
    assert f"checkpoint {path!r}: layer array W0 holds NaN" in _err(capsys)
    assert main(["demo", "--model", path, "--out", str(tmp_path / "d")]) == 2
    assert not (tmp_path / "d").exists()


def test_random_bytes_named_npz(tmp_path, capsys):
    path = tmp_path / "model.npz"
    path.write_bytes(np.random.default_rng(0).bytes(4096))
    assert main(["plan", "--n", "8", "--model", str(path)]) == 2
    e = _err(capsys)
    assert "not a checkpoint (not an .npz archive" in e and "pickle" not in e


@pytest.mark.parametrize("text,match", [
    ("{}", "missing config, code_version, shards"),
    ('{"config": {}, "code_version": "0.8.0", "shar', "not valid JSON"),
    ('{"config": {}, "code_version": "0.8.0", "shards": [{"file": "x.npz"}]}', "'shards' must be a list of entries"),
])
def test_a_broken_manifest(tmp_path, capsys, text, match):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "manifest.json").write_text(text)
    assert main(["train", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "m.npz")]) == 2
    assert "manifest.json" in (e := _err(capsys)) and match in e
    assert not (tmp_path / "m.npz").exists()


def test_a_deleted_shard(tmp_path, capsys):
    (tmp_path / "data").mkdir()
    entry = {"file": "hammer_000.npz", "task": "hammer", "sha256": "0" * 64, "variant": 0}
    from itup_jax.dataset import GenerateConfig

    config = GenerateConfig(tasks=("hammer",), tools_per_task=1, grasps=4).to_json()
    (tmp_path / "data" / "manifest.json").write_text(json.dumps(
        {"config": config, "code_version": itup.__version__, "shards": [entry]}))
    assert main(["train", "--data", str(tmp_path / "data"), "--out", str(tmp_path / "m.npz")]) == 2
    assert "hammer_000.npz': listed in manifest.json but missing" in _err(capsys)


@pytest.mark.parametrize("argv", [
    ["generate", "--out", "{f}/data", "--tasks", "hammer", "--tools-per-task", "1", "--grasps", "4"],
    ["demo", "--out", "{f}/demo"],
    ["train", "--data", "{f}", "--out", "{f}/m.npz"],
    ["plan", "--n", "4", "--json", "{f}/plan.json"],
])
def test_an_output_under_a_regular_file(tmp_path, capsys, argv, monkeypatch):
    f = tmp_path / "afile"
    f.write_text("not a folder")
    monkeypatch.setattr(itup, "sample_grasps", lambda *a, **k: pytest.fail("work started before the check"))
    assert main([a.format(f=f) for a in argv]) == 2
    assert str(f) in (e := _err(capsys)) and ("is a file, not a folder" in e)
    assert f.read_text() == "not a folder"


def test_json_into_a_missing_folder_is_refused_before_planning(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(itup, "sample_grasps", lambda *a, **k: pytest.fail("planned before the check"))
    assert main(["plan", "--json", str(tmp_path / "no" / "plan.json")]) == 2
    assert "does not exist" in _err(capsys)


@pytest.mark.slow
def test_verify_where_no_verified_grasp_does_the_task(tmp_path, capsys, monkeypatch):
    """Every verified rollout misses the task (the sweep's outcome made to fail): no pick, exit 3."""
    from itup_jax import tasks

    kind = tasks.get("sweep")

    def never(scene, task, sensordata, p):
        metric, success = kind.outcome(scene, task, sensordata, p)
        return metric, np.zeros_like(success)

    monkeypatch.setitem(tasks._REGISTRY, "sweep", dataclasses.replace(kind, outcome=never))
    out = tmp_path / "v.json"
    assert main(["plan", "--task", "sweep", "--n", "30", "--verify", "2", "--json", str(out)]) == EXIT_NO_PICK
    res = json.loads(out.read_text())
    assert res["status"] == "no_verified_success" and res["best"] is None and res["verified"]["pick"] is None
    text = capsys.readouterr().out
    assert "no pick: none of the 2 verified grasps did the task and held" in text and "<- pick" not in text
    from jsonschema import validate

    from itup_jax.schemas import load_schema

    validate(res, load_schema("plan"))
    assert os.path.exists(out)


@pytest.mark.parametrize("name,content,match", [
    ("junk.stl", bytes(range(256)) * 12, r"not a readable STL \(binary or ASCII\) file"),
    ("text.obj", b"hello\nnot a mesh\n", r"\(read as Wavefront OBJ\): mesh is empty"),
    ("tool.step", b"ISO-10303-21;", r"\.step is not a mesh format read here; give STL"),
])
def test_a_mesh_file_that_cannot_be_read_names_the_format(tmp_path, capsys, name, content, match):
    """The message names the file and the format it was read as, never a library's internal module."""
    (tmp_path / name).write_bytes(content)
    args = _hammer_files(tmp_path)
    args[1] = str(tmp_path / name)
    assert main(["plan", "--n", "8", *args]) == 2
    err = _err(capsys)
    assert re.search(match, err) and name in err and "module" not in err

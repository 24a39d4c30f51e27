"""Label datasets: resume after an interruption gives the same bytes; checksums catch corruption."""

import json
import os
import shutil
import subprocess
import sys
import warnings

import numpy as np
import pytest
import trimesh

import itup_jax as itup
from itup_jax.cli import main
from itup_jax.dataset import GenerateConfig, generate, unit_tool
from itup_jax.dataset_load import MANIFEST, load_dataset, load_datasets, load_shard
from itup_jax.tools.variants import vary_tool

SMALL = GenerateConfig(tasks=("reach",), tools_per_task=3, grasps=6, seed=1, contact="point")  # a fixture with 8+ valid rows


class Interrupt(Exception):
    pass


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("full"))
    return out, generate(out, SMALL, progress=False)


def _files(folder):
    return {f: open(os.path.join(folder, f), "rb").read() for f in sorted(os.listdir(folder))}


def test_interrupted_and_resumed_run_equals_an_uninterrupted_one(full_run, tmp_path):
    out, manifest = full_run
    resumed = str(tmp_path / "resumed")

    def stop_after_first(k):
        if k == 0:
            raise Interrupt

    with pytest.raises(Interrupt):
        generate(resumed, SMALL, progress=False, after_shard=stop_after_first)
    assert len(json.load(open(os.path.join(resumed, "manifest.json")))["shards"]) == 1
    again = generate(resumed, SMALL, progress=False)
    assert again == manifest
    assert _files(resumed) == _files(out)  # same seed, same dataset, byte for byte
    assert not [f for f in os.listdir(resumed) if f.startswith(".tmp-")]


def test_manifest_counts_and_loading(full_run):
    out, manifest = full_run
    assert len(manifest["shards"]) == 3 and manifest["totals"]["n"] == 18
    assert manifest["totals"]["valid"] + manifest["totals"]["infeasible"] + manifest["totals"]["diverged"] >= 18
    data = load_dataset(out)
    assert len(data["features"]) == manifest["totals"]["valid"]
    assert data["label_valid"].all() and np.all(np.isfinite(data["label_peak_torque_induced"]))


def test_corrupted_shard_is_detected_and_regenerated(full_run, tmp_path):
    out, manifest = full_run
    copy = str(tmp_path / "copy")
    shutil.copytree(out, copy)
    path = os.path.join(copy, manifest["shards"][1]["file"])
    raw = bytearray(open(path, "rb").read())
    raw[len(raw) // 2] ^= 0xFF
    open(path, "wb").write(bytes(raw))
    with pytest.raises(itup.InputError, match="checksum mismatch"):
        load_shard(copy, manifest["shards"][1])
    with pytest.warns(UserWarning, match=r"shard_\w+\.npz does not match its checksum .* making it again"):
        generate(copy, SMALL, progress=False)  # resume: the bad shard is made again, and it says so
    assert _files(copy) == _files(out)
    os.remove(path)
    with pytest.warns(UserWarning, match="listed in manifest.json but missing; making it again"):
        generate(copy, SMALL, progress=False)
    assert _files(copy) == _files(out)


def test_another_config_in_the_same_folder_is_refused(full_run, tmp_path):
    out, _ = full_run
    copy = str(tmp_path / "copy2")
    shutil.copytree(out, copy)
    with pytest.raises(itup.InputError, match="another config") as e:
        generate(copy, GenerateConfig(tasks=("reach",), tools_per_task=3, grasps=7, seed=1, contact="point"), progress=False)
    # the message names the setting that differs, its value there and its value now, and only that one
    assert "(grasps 6 there, 7 now)" in str(e.value) and "resuming would mix" in str(e.value)


def test_resuming_a_dataset_of_another_label_version_is_refused(full_run, tmp_path):
    """The label version decides: another package version with the same labels resumes; another label
    version (or an old manifest whose code version differs, which recorded no label version) does not."""
    from itup_jax.dataset import LABEL_VERSION

    out, _ = full_run
    copy = str(tmp_path / "copy3")
    shutil.copytree(out, copy)
    path = os.path.join(copy, MANIFEST)
    m = json.load(open(path))
    assert m["label_version"] == LABEL_VERSION and m["code_version"] == itup.__version__
    json.dump(dict(m, code_version="0.0.1"), open(path, "w"))
    assert len(generate(copy, SMALL, progress=False)["shards"]) == len(m["shards"])  # same labels: resumes
    json.dump(dict(m, label_version="0.0.1"), open(path, "w"))
    with pytest.raises(itup.InputError, match="holds labels of version 0.0.1"):
        generate(copy, SMALL, progress=False)
    json.dump({k: v for k, v in dict(m, code_version="0.0.2").items() if k != "label_version"}, open(path, "w"))
    with pytest.raises(itup.InputError, match="holds labels of version 0.0.2"):
        generate(copy, SMALL, progress=False)


def test_resuming_after_a_tasks_default_step_changed_is_refused(full_run, tmp_path):
    """A dataset made with the tasks' default steps records them; if a default has changed since, a
    resumed run would add shards of another step, so it is refused (and a manifest without the per-task
    record falls back to its config's step, and resumes when that matches)."""
    out, _ = full_run
    copy = str(tmp_path / "copy4")
    shutil.copytree(out, copy)
    path = os.path.join(copy, MANIFEST)
    m = json.load(open(path))
    m["timesteps"] = {"reach": 0.001}
    json.dump(m, open(path, "w"))
    with pytest.raises(itup.InputError, match=r"simulated at \{'reach': 0.001\} s, this run would use \{'reach': 0.0005\} s"):
        generate(copy, SMALL, progress=False)
    del m["timesteps"]  # no per-task record: the config's step (None here: each task's own), which matches
    json.dump(m, open(path, "w"))
    assert len(generate(copy, SMALL, progress=False)["shards"]) == 3


def test_variant_mass_properties_are_exact_for_a_box(tmp_path):
    a, b, c = 0.03, 0.02, 0.30
    trimesh.creation.box((a, b, c)).export(tmp_path / "box.stl")
    (tmp_path / "box.toml").write_text(
        'name = "box"\ncategory = "mallet"\ncontact_point = [0.015, 0.0, 0.1]\n'
        "grasp_region = { min = [-0.02, -0.02, -0.15], max = [0.02, 0.02, 0.0] }\ndensity = 700.0\n")
    tool = itup.load_tool(str(tmp_path / "box.stl"), spec=str(tmp_path / "box.toml"))
    v = vary_tool(tool, 3)
    lo, hi = v.mesh.bounds
    A, B, C = hi - lo  # the stretched box
    rho = float(v.params.mass) / (A * B * C)  # the variant's (scaled) density
    m = rho * A * B * C
    np.testing.assert_allclose(np.asarray(v.params.inertia),
                               m / 12 * np.diag([B**2 + C**2, A**2 + C**2, A**2 + B**2]), rtol=1e-6, atol=1e-12)
    assert not np.isclose(A * B * C, a * b * c)  # it did change shape
    np.testing.assert_allclose(v.mesh.volume, A * B * C, rtol=1e-6)


def _prism_mass(prim, density, sections=48):
    """kg of the 48-facet cylinder behind a capsule primitive (the capsule spans the cylinder's length
    less one radius at each end): density x the prism's cross-section x its length."""
    _, p0, p1, r = prim
    return density * 0.5 * sections * r**2 * np.sin(2 * np.pi / sections) * (np.linalg.norm(p1 - p0) + 2 * r)


def test_part_variants_vary_the_head_against_the_handle():
    """The part-wise family builds each part at its material's density (the head's times its factor), and,
    unlike the stretch family, changes the head's mass against the handle's."""
    from itup_jax.tools.priors import MATERIAL_DENSITY
    from itup_jax.tools.variants import PART_RANGES, part_variant

    base = itup.load_tool("hammer")
    ratios, factors = {"stretch": [], "parts": []}, []
    for seed in range(1, 9):
        t = part_variant("hammer", seed)
        (_, _, m_handle), (_, _, m_head) = t.parts
        handle, head = t.primitives
        assert m_handle == pytest.approx(_prism_mass(handle, MATERIAL_DENSITY["hickory"]), rel=1e-3)  # parts rounds to 0.1 g
        factor = m_head / _prism_mass(head, MATERIAL_DENSITY["steel"])
        assert PART_RANGES["hammer"]["head_density"][0] - 1e-3 <= factor <= PART_RANGES["hammer"]["head_density"][1] + 1e-3
        factors.append(factor)
        assert float(t.params.mass) == pytest.approx(m_handle + m_head, abs=1e-4)
        # the grasp region stays on the handle, below the head, and the face is the head's +x end
        assert t.grasp_region.hi[2] < head[1][2] - head[3] and t.contact_point[0] == pytest.approx(head[2][0] + head[3])
        ratios["parts"].append(m_head / m_handle)
        v = vary_tool(base, seed)
        ratios["stretch"].append(v.parts[1][2] / v.parts[0][2])
    assert np.ptp(ratios["stretch"]) / np.mean(ratios["stretch"]) < 0.01  # stretching keeps the ratio
    assert np.ptp(ratios["parts"]) / np.mean(ratios["parts"]) > 0.5
    assert np.ptp(factors) > 0.3  # the head's density factor is drawn, not fixed
    again = part_variant("hammer", 3)  # the seed makes the tool
    np.testing.assert_array_equal(again.mesh.vertices, part_variant("hammer", 3).mesh.vertices)
    assert again.name == "hammer#3" and float(again.params.mass) != float(part_variant("hammer", 4).params.mass)
    for other in ("mallet", "broom", "l_stick"):  # every built-in has the family
        assert part_variant(other, 5).category == itup.load_tool(other).category
    with pytest.raises(itup.InputError, match="part_variant: base must be one of"):
        part_variant("drill", 1)


@pytest.mark.slow
def test_the_variant_family_is_recorded_and_the_default_reads_as_before(tmp_path, capsys):
    """A "parts" dataset records its family; the default ("stretch") is left out of the config, so the
    manifests of every dataset made before the option read the same and resume."""
    assert "variants" not in SMALL.to_json() and GenerateConfig.from_json(SMALL.to_json()) == SMALL
    parts = GenerateConfig(tasks=("reach",), tools_per_task=2, grasps=4, seed=1, variants="parts")
    assert parts.to_json()["variants"] == "parts" and GenerateConfig.from_json(parts.to_json()) == parts
    with pytest.raises(itup.InputError, match="variants must be one of"):
        generate(str(tmp_path / "bad"), GenerateConfig(variants="bend"), progress=False)
    out = str(tmp_path / "parts")
    assert main(["generate", "--out", out, "--tasks", "reach", "--tools-per-task", "2", "--grasps", "4",
                 "--seed", "1", "--variants", "parts", "--quiet"]) == 0
    data = load_dataset(out, valid_only=False)
    assert sorted(set(data["tool"].tolist())) == sorted(["l_stick", unit_tool(parts, "reach", 1)[0].name])
    assert "#" in unit_tool(parts, "reach", 1)[0].name
    assert json.load(open(os.path.join(out, MANIFEST)))["config"]["variants"] == "parts"


def test_the_contact_model_is_recorded_and_reaches_the_grasps(tmp_path, capsys):
    """`--contact flat` (the default) samples the shard's grasps with the flat-pad sampler (the same grasps
    as `sample_grasps(..., SamplerConfig(contact="flat"))` with the shard's seed) and the manifest records
    it; the point-contact model is left out of the config, so every manifest made before code 0.6.0 reads
    as before."""
    from itup_jax.dataset import _unit_seed
    from itup_jax.dataset_load import read_manifest
    from itup_jax.grasp_sampler import SamplerConfig

    point = GenerateConfig(tasks=("reach",), tools_per_task=1, grasps=4, seed=1, contact="point")
    assert "contact" not in point.to_json() and GenerateConfig.from_json(point.to_json()) == point
    flat = GenerateConfig(tasks=("reach",), tools_per_task=1, grasps=4, seed=1)  # the default since 0.6.0
    assert flat.to_json()["contact"] == "flat" and GenerateConfig.from_json(flat.to_json()) == flat
    with pytest.raises(itup.InputError, match="contact must be one of"):
        generate(str(tmp_path / "bad"), GenerateConfig(contact="soft"), progress=False)
    assert not os.path.exists(tmp_path / "bad" / MANIFEST)
    out = str(tmp_path / "flat")
    assert main(["generate", "--out", out, "--tasks", "reach", "--tools-per-task", "1", "--grasps", "4",
                 "--seed", "1", "--contact", "flat", "--quiet"]) == 0
    m = read_manifest(out)
    assert m["config"]["contact"] == "flat"
    a = load_shard(out, m["shards"][0])
    want = itup.sample_grasps(unit_tool(flat, "reach", 0)[0], 4, seed=_unit_seed(flat, "reach", 0),
                              config=SamplerConfig(contact="flat"))
    np.testing.assert_array_equal(a["grasp_width"], np.asarray(want.width))
    np.testing.assert_array_equal(a["grasp_p"], np.asarray(want.p_tool_grasp))


def test_generate_cli(tmp_path, capsys):
    out = str(tmp_path / "cli")
    assert main(["generate", "--out", out, "--tasks", "reach", "--tools-per-task", "1", "--grasps", "4", "--quiet"]) == 0
    assert "1 shards, 4 rollouts" in capsys.readouterr().out
    assert main(["generate", "--out", out, "--tasks", "drill", "--quiet"]) == 2


@pytest.mark.slow
def test_a_dataset_at_another_timestep_holds_that_steps_labels(tmp_path, capsys):
    """`--timestep` reaches the simulation: the shard's labels are those of a scene built at that step
    (and differ from the 2 ms ones), and a bad step is refused before anything is written."""
    from itup_jax.dataset import unit_tool
    from itup_jax.sim.scene import build_scene

    out = str(tmp_path / "fine")
    assert main(["generate", "--out", out, "--tasks", "knock", "--tools-per-task", "1", "--grasps", "6",
                 "--timestep", "0.001", "--nominal", "--contact", "point", "--quiet"]) == 0  # 2+ reachable of 6
    capsys.readouterr()
    manifest = json.load(open(os.path.join(out, MANIFEST)))
    config = GenerateConfig.from_json(manifest["config"])
    assert config.timestep == 0.001 and manifest["timesteps"] == {"knock": 0.001}
    a = load_shard(out, manifest["shards"][0])
    tool, task = unit_tool(config, "knock", 0)
    g = itup.Grasps(a["grasp_p"], a["grasp_q"], a["grasp_width"])
    ok = a["label_valid"].astype(bool)
    assert ok.sum() >= 2
    at = {dt: np.asarray(itup.simulate(tool, task, g, randomize=None, backend="native",
                                       scene=build_scene(tool, task, timestep=dt)).labels.peak_torque_projected)[ok]
          for dt in (0.001, 0.002)}
    np.testing.assert_array_equal(a["label_peak_torque_projected"][ok], at[0.001])
    assert not np.allclose(at[0.001], at[0.002], rtol=1e-3)
    # another task at its own (default) step mixes with it: the check is per task
    reach = str(tmp_path / "reach")
    generate(reach, GenerateConfig(tasks=("reach",), tools_per_task=1, grasps=2, seed=0), progress=False)
    both, _ = load_datasets([out, reach])
    assert sorted(set(both["task"].tolist())) == ["knock", "reach"]
    # FOLDER:TASKS takes only those tasks from a folder: here its reach rows, whose knock rows (at 0.5 ms)
    # would not mix with the 1 ms ones
    mixed = str(tmp_path / "mixed")
    generate(mixed, GenerateConfig(tasks=("knock", "reach"), tools_per_task=2, grasps=8, seed=3), progress=False)
    with pytest.raises(itup.InputError, match="knock rows simulated at a 0.0005 s timestep"):
        load_datasets([out, mixed])
    both, _ = load_datasets([out, mixed + ":reach"])
    only = load_dataset(mixed, tasks=["reach"])
    np.testing.assert_array_equal(both["features"][both["task"] == "reach"], only["features"])
    assert sorted(set(both["task"].tolist())) == ["knock", "reach"]
    with pytest.raises(itup.InputError, match="no shards for reach"):
        load_datasets([out + ":reach", mixed])
    with pytest.raises(itup.InputError, match="unknown: 'knok'"):
        load_datasets([out, mixed + ":knok"])
    ckpt = str(tmp_path / "m.npz")
    assert main(["train", "--data", out, mixed + ":reach", "--out", ckpt, "--epochs", "1", "--hidden", "4", "--quiet"]) == 0
    from itup_jax.sdgnet.checkpoint import load

    assert [d["tasks"] for d in load(ckpt)[1]["datasets"]] == [None, ["reach"]]
    assert main(["train", "--data", mixed + ":nail", "--out", ckpt, "--quiet"]) == 2
    assert "unknown: 'nail'" in capsys.readouterr().err
    assert main(["generate", "--out", str(tmp_path / "bad"), "--timestep", "-1", "--quiet"]) == 2
    assert "timestep must be in (0, 0.01] s" in capsys.readouterr().err and not (tmp_path / "bad").exists()


def test_config_round_trips_through_the_manifest_and_rebuilds_a_shards_tool(full_run):
    from itup_jax.dataset import unit_tool
    from itup_jax.errors import InputError

    out, _ = full_run
    with open(os.path.join(out, "manifest.json")) as fh:
        manifest = json.load(fh)
    config = GenerateConfig.from_json(manifest["config"])
    assert config == SMALL
    with pytest.raises(InputError, match="unknown keys"):
        GenerateConfig.from_json(dict(manifest["config"], typo=1))
    # the tool rebuilt from the manifest is the shard's tool: its analytic costs match the stored ones
    entry = manifest["shards"][1]
    a = load_shard(out, entry)
    tool, task = unit_tool(config, entry["task"], entry["variant"])
    assert tool.name == json.loads(bytes(a["meta_json"]))["tool"]
    g = itup.Grasps(a["grasp_p"], a["grasp_q"], a["grasp_width"])
    np.testing.assert_allclose(np.asarray(itup.wrench_costs(tool, task, g).tau), a["analytic_tau"], rtol=1e-5)


@pytest.mark.slow
def test_several_datasets_load_and_train_as_one(full_run, tmp_path, capsys):
    from itup_jax.sdgnet.checkpoint import load

    out, manifest = full_run
    other = str(tmp_path / "seed2")
    generate(other, GenerateConfig(tasks=("reach",), tools_per_task=3, grasps=6, seed=2, contact="point"), progress=False)
    a, b = load_dataset(out), load_dataset(other)
    both, manifests = load_datasets([out, other])
    assert [m["seed"] for m in manifests] == [1, 2]
    assert len(both["features"]) == len(a["features"]) + len(b["features"])
    np.testing.assert_array_equal(both["features"], np.concatenate([a["features"], b["features"]]))
    # one id per tool across the datasets: the built-in tool (variant 0) shares its id, variants do not
    names = {}
    for name, i in zip(both["tool"], both["tool_id"]):
        assert names.setdefault(name, i) == i
    assert len(set(names.values())) == len(names) == len(set(a["tool"]) | set(b["tool"]))
    builtin = [n for n in names if "~" not in n]
    assert len(builtin) == 1 and set(a["tool"]) & set(b["tool"]) == set(builtin)
    np.testing.assert_array_equal(both["tool_id"][: len(a["tool_id"])], a["tool_id"])  # the first keeps its ids

    with pytest.raises(itup.InputError, match="given twice"):
        load_datasets([out, out + "/"])
    with pytest.raises(itup.InputError, match="no manifest.json there"):
        load_datasets([out, str(tmp_path / "missing")])
    again = str(tmp_path / "again")  # the same seed's reach regenerated with one tool more: three shards again
    generate(again, GenerateConfig(tasks=("reach",), tools_per_task=4, grasps=6, seed=2, contact="point"), progress=False)
    with pytest.warns(UserWarning) as caught:
        twice, _ = load_datasets([other, again])  # the three read once, the new one read
    assert [str(w.message).split(": ", 1)[1].split(" (")[0] for w in caught] == [
        f"shard shard_reach_00{i}.npz is byte for byte shard_reach_00{i}.npz of {other!r}" for i in (0, 1, 2)]
    new = load_dataset(again)
    new = {k: v[new["tool"] == new["tool"][-1]] for k, v in new.items()}  # the fourth tool's rows
    np.testing.assert_array_equal(twice["features"], np.concatenate([b["features"], new["features"]]))
    with pytest.warns(UserWarning, match="read once"):
        assert len(load_datasets([out, other, again], tasks=["reach"])[0]["features"]) == len(twice["features"]) + sum(
            a["task"] == "reach")
    with pytest.warns(UserWarning, match="read once"):  # nothing left of `other`: not read
        assert len(load_datasets([again, other])[0]["features"]) == len(twice["features"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_datasets([out, again])  # another seed: other shards
    with pytest.raises(itup.InputError, match="no manifest.json there"):
        load_dataset(str(tmp_path / "missing"))
    odd = str(tmp_path / "odd")
    shutil.copytree(other, odd)
    m = json.load(open(os.path.join(odd, MANIFEST)))
    m["config"]["feature_spec"]["grid"] = 5
    json.dump(m, open(os.path.join(odd, MANIFEST), "w"))
    with pytest.raises(itup.InputError, match="cannot be mixed"):
        load_datasets([out, odd])
    fine = str(tmp_path / "fine")
    shutil.copytree(other, fine)
    m = json.load(open(os.path.join(fine, MANIFEST)))
    assert m["config"]["timestep"] is None and m["timesteps"] == {"reach": 0.0005}  # each task's step, recorded
    m["timesteps"] = {"reach": 0.001}
    json.dump(m, open(os.path.join(fine, MANIFEST), "w"))
    with pytest.raises(itup.InputError, match="reach rows simulated at a 0.001 s timestep, but those of .* at 0.0005 s; "
                                              "their labels cannot be mixed"):
        load_datasets([out, fine])
    del m["timesteps"]  # the manifests before per-task steps: one config.timestep, or none (2 ms)
    m["config"]["timestep"] = 0.001
    json.dump(m, open(os.path.join(fine, MANIFEST), "w"))
    with pytest.raises(itup.InputError, match="0.001 s timestep, but those of .* at 0.0005 s"):
        load_datasets([out, fine])
    del m["config"]["timestep"]
    json.dump(m, open(os.path.join(fine, MANIFEST), "w"))
    with pytest.raises(itup.InputError, match="0.002 s timestep, but those of .* at 0.0005 s"):
        load_datasets([out, fine])  # the oldest manifests: 2 ms, the reach's default step until 0.8.0
    m["config"]["timestep"] = 0.0005
    json.dump(m, open(os.path.join(fine, MANIFEST), "w"))
    load_datasets([out, fine])  # one config step for every task, equal to the reach's default: they mix

    ckpt = str(tmp_path / "m.npz")
    capsys.readouterr()
    assert main(["train", "--data", out, other, again, "--out", ckpt, "--epochs", "2", "--hidden", "8", "--quiet"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if line.startswith("itup train: note: dataset")]
    assert len(notes) == 3 and all(line.endswith("read once") for line in notes)  # one line per shard, no traceback
    spec = load(ckpt)[1]
    assert [d["config"]["seed"] for d in spec["datasets"]] == [1, 2, 2]
    assert spec["n_train"] + spec["n_val"] == len(both["features"]) + len(new["features"])
    # beside the checkpoint, the guard's reference: rows of the very training rows, per task
    from itup_jax import ood

    ref = ood.load_reference(str(tmp_path / "m.reference.npz"))
    rows = np.concatenate([both["features"], new["features"]]).astype(np.float16).astype(np.float32)
    assert set(ref.features) == {"reach"} and len(ref.features["reach"]) == min(ood.REFERENCE_ROWS, len(rows))
    assert all(any(np.array_equal(r, x) for x in rows) for r in ref.features["reach"][:5])
    assert ood.reference_path_of(ckpt) == str(tmp_path / "m.reference.npz")
    # fine-tuned per task from the CLI: one network per task, the shared network's figures kept beside them
    assert main(["train", "--data", out, "--out", ckpt, "--epochs", "2", "--hidden", "8", "--finetune-epochs", "2",
                 "--rank-weight", "0.5", "--rank-temperature", "0.4", "--quiet"]) == 0
    spec = load(ckpt)[1]
    assert list(spec["by_task"]) == ["reach"] and spec["config"]["finetune_epochs"] == 2
    assert spec["config"]["rank_weight"] == 0.5 and spec["config"]["rank_temperature"] == 0.4
    assert spec["shared"]["n_val"] == spec["n_val"]
    # a larger share of the tools held out: recorded, and more rows validate
    halves = str(tmp_path / "halves.npz")
    assert main(["train", "--data", out, "--out", halves, "--epochs", "1", "--hidden", "4", "--val-fraction", "0.5",
                 "--quiet"]) == 0
    hspec = load(halves)[1]
    assert hspec["config"]["val_fraction"] == 0.5 and hspec["n_val"] > spec["n_val"]
    # distilled: trained on a teacher checkpoint's predictions, which the spec names
    student = str(tmp_path / "student.npz")
    assert main(["train", "--data", out, "--out", student, "--epochs", "2", "--hidden", "8", "--teacher", ckpt,
                 "--quiet"]) == 0
    assert load(student)[1]["teacher"]["file"] == os.path.abspath(ckpt)
    layers, tspec = load(ckpt)
    tspec["feature_spec"] = {**tspec["feature_spec"], "grid": 5}
    from itup_jax.sdgnet.checkpoint import save

    save(str(tmp_path / "odd_teacher.npz"), layers, tspec)
    assert main(["train", "--data", out, "--out", student, "--teacher", str(tmp_path / "odd_teacher.npz"), "--quiet"]) == 2
    assert "its features were made with" in capsys.readouterr().err
    # distilled while adapting (`--init M --teacher E`): every output trained towards the teacher's predictions,
    # so the adapted network predicts closer to the teacher than the checkpoint it started from and than the
    # same adaptation to the labels
    from itup_jax.sdgnet.checkpoint import load_model
    from itup_jax.sdgnet.model import predict_costs

    adapted, to_labels = str(tmp_path / "adapted.npz"), str(tmp_path / "to_labels.npz")
    for path, extra in ((adapted, ["--teacher", student]), (to_labels, [])):
        assert main(["train", "--data", out, "--out", path, "--init", ckpt, *extra, "--finetune-epochs", "40",
                     "--finetune-lr", "1e-2", "--ema", "0.5", "--patience", "40", "--quiet"]) == 0
    aspec = load(adapted)[1]
    assert aspec["teacher"]["file"] == os.path.abspath(student) and aspec["adapted_from"]["ema"] == 0.5
    feats = load_datasets([out])[0]["features"]
    feats = feats[np.isfinite(feats).all(1)]  # the rows with features (not the infeasible ones)

    def learnt(m):  # every regression output on the scale the network learns it, log1p(y / scale)
        model = load_model(m)
        p = predict_costs(model, feats, "reach")
        return np.stack([np.log1p(np.asarray(p[k]) / s) for k, s in zip(model.output_names, model.spec["target_scales"])], 1)

    gap = lambda m: float(np.mean(np.abs(learnt(m) - learnt(student))))  # noqa: E731
    assert gap(adapted) < 0.8 * gap(ckpt) and gap(adapted) < 0.5 * gap(to_labels)  # measured: 0.17, 0.26, 0.75
    assert main(["train", "--data", out, "--out", adapted + ".x", "--init", ckpt, "--teacher", student, "--keep", "tau",
                 "--quiet"]) == 2
    assert "give one" in capsys.readouterr().err and not os.path.exists(adapted + ".x")
    assert main(["train", "--data", out, "--out", adapted + ".x", "--init", ckpt, "--teacher",
                 str(tmp_path / "odd_teacher.npz"), "--quiet"]) == 2
    assert "its features were made with" in capsys.readouterr().err


@pytest.mark.slow
def test_processes_run_one_after_another_make_the_single_process_dataset(full_run, tmp_path):
    """Process i of n makes the shards i, i + n, ...; each resumes its own after a kill, and once all have
    run the folder is the single process's, byte for byte."""
    out, manifest = full_run
    split = str(tmp_path / "split")
    m1 = generate(split, SMALL, progress=False, process_index=1, process_count=2)
    assert [s["file"] for s in m1["shards"]] == ["shard_reach_001.npz"]  # units[1::2]
    assert m1["totals"]["n"] == 6 and sorted(f for f in os.listdir(split) if f.endswith(".npz")) == ["shard_reach_001.npz"]

    def stop_after_first(k):
        if k == 0:
            raise Interrupt

    with pytest.raises(Interrupt):
        generate(split, SMALL, progress=False, process_index=0, process_count=2, after_shard=stop_after_first)
    listed = json.load(open(os.path.join(split, MANIFEST)))["shards"]
    assert [s["file"] for s in listed] == ["shard_reach_000.npz", "shard_reach_001.npz"]  # process 1's kept
    assert generate(split, SMALL, progress=False, process_index=0, process_count=2) == manifest
    assert _files(split) == _files(out)
    # a process whose shards are all done makes nothing and reports the whole manifest
    assert generate(split, SMALL, progress=False, process_index=1, process_count=2) == manifest


@pytest.mark.slow
def test_concurrent_processes_make_the_single_process_dataset(full_run, tmp_path):
    """Two `itup generate` processes at once on one folder, one stepping thread each (the fixture used
    every core): the file lock keeps both processes' shards in the manifest, and the folder equals the
    single process's."""
    out, manifest = full_run
    both = str(tmp_path / "both")
    args = ["--out", both, "--tasks", "reach", "--tools-per-task", "3", "--grasps", "6", "--seed", "1", "--contact", "point", "--quiet",
            "--threads", "1", "--process-count", "2"]
    code = "import sys; from itup_jax.cli import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, JAX_ENABLE_X64="1")  # as the tests run (conftest.py), so the bytes compare
    procs = [subprocess.Popen([sys.executable, "-c", code, "generate", *args, "--process-index", str(i)], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for i in (0, 1)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert _files(both) == _files(out)
    assert sum("3 shards, 18 rollouts" in o for o, _ in outs) >= 1  # the last to finish sees every shard


def test_bad_process_arguments_are_refused(tmp_path, capsys):
    for index, count, match in ((2, 2, r"process_index must be in 0\.\.1 \(process_count 2\), got 2"),
                                (-1, 2, "process_index must be in"), (0, 0, "process_count must be >= 1"),
                                (0.5, 2, "process_index must be an integer")):
        with pytest.raises(itup.InputError, match=match):
            generate(str(tmp_path / "bad"), SMALL, progress=False, process_index=index, process_count=count)
    with pytest.raises(itup.InputError, match="nthread must be an integer >= 1"):
        generate(str(tmp_path / "bad"), SMALL, progress=False, nthread=0)
    assert main(["generate", "--out", str(tmp_path / "bad"), "--tasks", "reach", "--process-index", "3",
                 "--process-count", "2", "--quiet"]) == 2
    assert "process_index must be in 0..1" in capsys.readouterr().err
    assert not os.path.exists(os.path.join(tmp_path, "bad", MANIFEST))


@pytest.mark.slow
def test_the_manifest_lock_excludes_another_process(tmp_path):
    """While one process holds the manifest's lock, another cannot take it; once it lets go, it can."""
    import fcntl

    from itup_jax.dataset import LOCK, _manifest_lock

    code = ("import sys; from itup_jax.dataset import _manifest_lock\n"
            "with _manifest_lock(sys.argv[1]):\n    print('locked', flush=True); sys.stdin.readline()\n")
    holder = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], stdin=subprocess.PIPE,
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        fd = os.open(os.path.join(tmp_path, LOCK), os.O_RDWR)
        try:
            with pytest.raises(OSError):
                fcntl.lockf(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)
    finally:
        holder.communicate("go\n", timeout=60)
    with _manifest_lock(str(tmp_path)):  # released with the process
        pass


def test_deterministic_gpu_flag_is_added_once_and_a_users_choice_stands():
    from itup_jax.sim.mjx import DETERMINISTIC_GPU_FLAG, request_deterministic_gpu

    env = {}
    assert request_deterministic_gpu(env) and env["XLA_FLAGS"] == DETERMINISTIC_GPU_FLAG
    assert not request_deterministic_gpu(env) and env["XLA_FLAGS"] == DETERMINISTIC_GPU_FLAG
    env = {"XLA_FLAGS": "--xla_force_host_platform_device_count=2"}
    assert request_deterministic_gpu(env)
    assert env["XLA_FLAGS"] == "--xla_force_host_platform_device_count=2 " + DETERMINISTIC_GPU_FLAG
    for chosen in ("--xla_gpu_deterministic_ops=false", "--xla_gpu_exclude_nondeterministic_ops=true"):
        env = {"XLA_FLAGS": chosen}
        assert not request_deterministic_gpu(env) and env["XLA_FLAGS"] == chosen
    # a similar name is not the flag
    env = {"XLA_FLAGS": "--xla_gpu_deterministic_ops_foo=1"}
    assert request_deterministic_gpu(env)


def test_gpu_determinism_reads_the_flags_value():
    from itup_jax.sim.mjx import gpu_determinism

    assert gpu_determinism({}) is None and gpu_determinism({"XLA_FLAGS": "--xla_dump_to=/tmp"}) is None
    assert gpu_determinism({"XLA_FLAGS": "--xla_gpu_deterministic_ops=true"}) is True
    assert gpu_determinism({"XLA_FLAGS": "--xla_gpu_deterministic_ops"}) is True
    assert gpu_determinism({"XLA_FLAGS": "--xla_gpu_exclude_nondeterministic_ops=false"}) is False
    assert gpu_determinism({"XLA_FLAGS": "--xla_gpu_deterministic_ops=true --xla_gpu_deterministic_ops=false"}) is False


def test_generate_warns_when_gpu_mjx_labels_would_not_be_reproducible(monkeypatch):
    import jax

    from itup_jax.dataset import gpu_determinism_warning
    from itup_jax.sim.mjx import DETERMINISTIC_GPU_FLAG

    monkeypatch.setattr(jax, "default_backend", lambda: "gpu")  # None resolves to MJX there
    monkeypatch.setenv("XLA_FLAGS", "")
    assert DETERMINISTIC_GPU_FLAG in gpu_determinism_warning(None)
    assert gpu_determinism_warning("mjx") and gpu_determinism_warning("native") is None
    monkeypatch.setenv("XLA_FLAGS", "--xla_gpu_deterministic_ops=false")
    assert gpu_determinism_warning(None)
    monkeypatch.setenv("XLA_FLAGS", DETERMINISTIC_GPU_FLAG)
    assert gpu_determinism_warning(None) is None
    monkeypatch.setenv("XLA_FLAGS", "")
    monkeypatch.setattr(jax, "default_backend", lambda: "cpu")  # MJX on a CPU is deterministic
    assert gpu_determinism_warning("mjx") is None


@pytest.mark.slow
def test_weak_grip_rollouts_label_the_same_candidates_on_the_same_physics_draw(full_run, tmp_path):
    """Every candidate is rolled out a second time at `WEAK_GRIP` N per pad (`label_weak_*`): the rows
    infeasible by the default rollout are not stepped at the weak grip either; a row's weak-grip labels
    are those of `simulate` at the fixed weak grip with the shard's seed (the same mass, friction,
    restitution and contact duration per row); the default labels do not change when the weak rollouts
    are left out (`weak_grip=None`, `--weak-grip 0`), which also leaves the fields out."""
    import dataclasses

    from itup_jax.dataset import WEAK_FIELDS, WEAK_GRIP, shard_candidates
    from itup_jax.sim.config import SimConfig
    from itup_jax.sim.physics import Randomization
    from itup_jax.sim.rollout import simulate

    out, manifest = full_run
    assert manifest["label_fields"][-len(WEAK_FIELDS):] == [f"weak_{f}" for f in WEAK_FIELDS]
    entry = manifest["shards"][0]
    a = load_shard(out, entry)
    infeasible = a["label_infeasible"]
    assert infeasible.any() and (~infeasible).any()
    assert not a["label_weak_valid"][infeasible].any() and np.isnan(a["label_weak_slip_rotation"][infeasible]).all()
    meta = json.loads(bytes(a["meta_json"]).decode())
    tool, task, grasps = shard_candidates(SMALL, entry["task"], entry["variant"])
    again = simulate(tool, task, grasps, seed=meta["seed"], backend="native",
                     randomize=dataclasses.replace(Randomization(), grip_force=0.0),
                     config=SimConfig(grip_force=WEAK_GRIP))
    assert np.all(again.physics.grip_force == WEAK_GRIP)
    for name in ("mass_scale", "mu", "restitution", "contact_duration"):  # the default rollout's draw
        np.testing.assert_array_equal(getattr(again.physics, name), a["physics"][:, meta["physics_fields"].index(name)])
    for f in WEAK_FIELDS:
        np.testing.assert_array_equal(np.asarray(getattr(again.labels, f)), a[f"label_weak_{f}"])
    # the weak grip is a different rollout where it is stepped: the grasps turn further in weaker pads
    run = ~infeasible
    assert np.nanmedian(a["label_weak_slip_rotation"][run]) > np.nanmedian(a["label_slip_rotation"][run])

    plain = dataclasses.replace(SMALL, weak_grip=None)
    assert "weak_grip" not in plain.to_json() and GenerateConfig.from_json(plain.to_json()) == plain
    assert GenerateConfig.from_json(SMALL.to_json()) == SMALL and SMALL.to_json()["weak_grip"] == WEAK_GRIP
    m = generate(str(tmp_path / "plain"), dataclasses.replace(plain, tools_per_task=1), progress=False)
    b = load_shard(str(tmp_path / "plain"), m["shards"][0])
    assert not any(k.startswith("label_weak") for k in b) and "weak_failed" not in m["label_fields"]
    for k in b:
        if k != "meta_json":
            np.testing.assert_array_equal(b[k], a[k])
    # below the gripper's 20 N (a probe) the grip actuator is opened, so the rollout gets the force asked for
    from itup_jax.dataset import weak_rollouts
    from itup_jax.sim.scene import build_scene
    from itup_jax.stress import probe_scene

    probe = dataclasses.replace(SMALL, weak_grip=15.0)
    scene = build_scene(tool, task)
    got = weak_rollouts(tool, task, grasps, probe, seed=meta["seed"], scene=scene)
    spread = dataclasses.replace(Randomization(), grip_force=0.0)
    opened, clamped = (simulate(tool, task, grasps, seed=meta["seed"], backend="native", randomize=spread, scene=sc,
                                config=SimConfig(grip_force=15.0)).labels for sc in (probe_scene(scene), scene))
    np.testing.assert_array_equal(got["label_weak_slip_rotation"], np.asarray(opened.slip_rotation))
    assert not np.array_equal(got["label_weak_slip_rotation"][run], np.asarray(clamped.slip_rotation)[run])
    for bad in (0.0, -5.0, 300.0, float("nan")):
        with pytest.raises(itup.InputError, match="weak_grip"):
            generate(str(tmp_path / "bad"), dataclasses.replace(SMALL, weak_grip=bad), progress=False)
    assert not os.path.exists(tmp_path / "bad")  # refused before anything is written

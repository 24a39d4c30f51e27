"""The sealed evaluation (`itup_jax.sealed`, experiments/sealed_eval.py and sealed_reopen.py): how its
test tools are drawn, its summaries on rows whose answers are known, its refusals before any work, and
(slow) a quick run reopened in every mode, each output against its schema."""

import json
import os

import jsonschema
import numpy as np
import pytest
from conftest import run_experiment

import itup_jax as itup
from itup_jax import sealed as se
from itup_jax.schemas import load_schema


def _run(name, argv, monkeypatch):
    monkeypatch.setenv("MPLBACKEND", "Agg")
    run_experiment(name, *argv)


def test_sealed_tools_are_drawn_from_the_checkpoint():
    """Seed = first 8 bytes (big-endian) of SHA-256(checkpoint || round salt || task || i); half part-wise
    variants of the built-in tool, half the task's other families (the held-out ones and the round's
    sealed-test ones) in turn; a new round draws new tools; --quick's tools are never the sealed ones."""
    import hashlib

    ck = b"checkpoint bytes"
    assert se.sealed_seed(ck, "knock", 3) == int.from_bytes(hashlib.sha256(b"checkpoint bytesknock3").digest()[:8], "big")
    assert se.sealed_seed(ck, "knock", 3) != se.sealed_seed(ck + b"x", "knock", 3)
    assert se.round_salt(1) == b"" and se.round_salt(2) == b"/round2" and se.ROUND == 7
    # no round is sealed now (rounds 1 to 6 ran): the other families are the held-out ones until a
    # round adds its own
    assert se.other_families("knock") == ["screwdriver", "spanner", "hatchet"]
    assert se.other_families("sweep") == ["squeegee"] and se.other_families("reach") == ["pry_bar"]
    tools = se.sealed_tools(ck + se.round_salt(2), "knock", 16)
    assert [t["kind"] for t in tools] == ["builtin"] * 8 + ["other"] * 8
    assert [t["family"] for t in tools[8:]] == ["screwdriver", "spanner", "hatchet"] * 2 + ["screwdriver", "spanner"]
    assert tools[0]["tool"].name == f"mallet#{se.sealed_seed(ck + b'/round2', 'knock', 0)}"
    assert tools[9]["tool"].name == f"spanner@{se.sealed_seed(ck + b'/round2', 'knock', 9)}"
    round1 = se.sealed_tools(ck, "knock", 16)
    assert {t["seed"] for t in round1}.isdisjoint({t["seed"] for t in tools})
    quick = se.sealed_tools(ck + se.round_salt(2) + se.QUICK_SALT, "knock", 2)
    assert {t["seed"] for t in quick}.isdisjoint({t["seed"] for t in tools} | {t["seed"] for t in round1})


def test_retest_summary_reads_each_tool_against_its_own_ceiling():
    """Per task and kind: medians of the retest and the ceiling, the tools whose ceiling lies below the
    kind's goal, and each scorer's median share of its tool's ceiling (rho / ceiling)."""

    def row(kind, retest, rho, task="hammer"):
        c = float(np.sqrt(retest))
        return {"task": task, "kind": kind, "retest": retest, "ceiling": c, "rho": {"sdgnet": rho, "analytic": None},
                "rho_mean": {"sdgnet": rho + 0.01, "analytic": None}}

    rows = [row("builtin", 0.81, 0.72), row("builtin", 0.64, 0.4), row("other", 0.36, 0.3), row("other", 0.64, 0.6),
            row("other", 0.81, 0.45), row("builtin", 0.9, 0.9, task="reach")]
    s = se.retest_summary(rows)
    b, o = s["hammer"]["builtin"], s["hammer"]["other"]
    assert b["tools"] == 2 and b["goal"] == 0.85 and o["goal"] == 0.7
    assert b["retest"] == pytest.approx(0.725) and b["ceiling"] == pytest.approx(0.85)
    assert b["ceiling_below_goal"] == 1 and o["ceiling_below_goal"] == 1  # 0.8 < 0.85; 0.6 < 0.7 (0.8, 0.9 not)
    assert b["share_of_ceiling"]["sdgnet"] == pytest.approx(np.median([0.72 / 0.9, 0.4 / 0.8]))
    assert o["share_of_ceiling"]["sdgnet"] == pytest.approx(np.median([0.3 / 0.6, 0.6 / 0.8, 0.45 / 0.9]))
    assert b["rho_mean"]["sdgnet"] == pytest.approx(np.median([0.73, 0.41])) and b["share_of_ceiling"]["analytic"] is None
    assert set(s) == {"hammer", "reach"} and set(s["reach"]) == {"builtin"}


def test_reopen_refuses_bad_options_before_any_work(tmp_path, monkeypatch, capsys):
    """sealed_reopen.py: a run file that is not there, checkpoints that are not there, options that do not
    go together or out of range: refused before anything is rolled out or written."""
    run = tmp_path / "run.json"
    run.write_text(json.dumps({"schema": "itup.sealed/1", "per_tool": [], "config": {"n": 4}}))
    with pytest.raises(SystemExit, match="no checkpoint at"):
        _run("sealed_reopen", [str(run), "--fidelity-of", str(tmp_path / "none.npz"), "--out", str(tmp_path / "o")],
             monkeypatch)
    for argv, says in (([str(tmp_path / "none.json")], "SEALED_JSON: no file at"),
                       ([str(run), "--redraws", "1"], "--redraws R >= 0 applies to --fidelity-of"),
                       ([str(run), "--fidelity-of", "--redraws", "-1"], "--redraws R >= 0 applies to --fidelity-of"),
                       ([str(run), "--fidelity-of", "--headroom", "1"], "does not re-plan"),
                       ([str(run), "--fidelity-of", "--model", "x.npz"], "does not re-plan"),
                       ([str(run), "--model", str(tmp_path / "none.npz")], "needs the checkpoint"),
                       ([str(run), "--guard-threshold", "-1"], "finite number > 0"),
                       ([str(run), "--planner-verify", "-1"], "must be >= 0"),
                       ([str(run), "--headroom", "1", "--tasks", "hammer,drill"], "--tasks among")):
        with pytest.raises(SystemExit):
            _run("sealed_reopen", [*argv, "--out", str(tmp_path / "o")], monkeypatch)
        assert says in capsys.readouterr().err, argv
    assert not (tmp_path / "o").exists()
    run.write_text(json.dumps({"schema": "itup.other/1"}))
    for mode in ([], ["--fidelity-of"]):
        with pytest.raises(SystemExit, match="not a sealed run"):
            _run("sealed_reopen", [str(run), *mode, "--out", str(tmp_path / "o")], monkeypatch)
    assert not (tmp_path / "o").exists()


def test_a_sealed_round_without_sealed_families_is_refused(tmp_path, monkeypatch, capsys):
    from itup_jax.tools import families

    monkeypatch.setattr(families, "sealed", lambda: ())
    with pytest.raises(SystemExit):
        _run("sealed_eval", ["--out", str(tmp_path / "s")], monkeypatch)
    assert "no sealed-test family" in capsys.readouterr().err and not (tmp_path / "s").exists()


@pytest.mark.slow
def test_sealed_eval_quick(tmp_path, monkeypatch):
    _run("sealed_eval", ["--quick", "--out", str(tmp_path)], monkeypatch)
    doc = json.loads((tmp_path / "sealed.json").read_text())
    jsonschema.validate(doc, load_schema("sealed"))
    assert doc["config"]["quick"] and set(doc["summary"]) == {"hammer", "reach"}
    for r in doc["per_tool"]:
        assert r["candidates"] > 2 and set(r["picks"]) == set(se.METHODS)
        # methods that pick the same grasp were measured once: the same numbers
        by_index = {}
        for m, p in r["picks"].items():
            by_index.setdefault(p["index"], []).append(p)
        for same in by_index.values():
            assert all(p == same[0] for p in same)
        assert all(p["weak"]["rollouts"] == doc["config"]["draws"] for p in r["picks"].values())
        assert r["fidelity"]["valid"] >= 3
        # --quick redraws the fidelity draw once: the retest, its ceiling and the ranking against the mean
        assert doc["config"]["redraws"] == 1 and r["fidelity"]["valid_all"] <= r["fidelity"]["valid"]
        assert set(r["fidelity"]["rho_mean"]) == {"sdgnet", "analytic", "analytic_wrench"}
    for k in ("hammer", "reach"):
        redrawn = [f for f in se.fidelity_rows(doc["per_tool"]) if f["task"] == k]
        assert doc["summary"][k]["fidelity_retest"] == se.retest_summary(redrawn)[k]
    s = doc["summary"]["hammer"]
    rows = [r for r in doc["per_tool"] if r["task"] == "hammer"]
    red = [100 * (1 - r["picks"]["planner"]["peak_torque_induced"] / r["picks"]["force_closure"]["peak_torque_induced"])
           for r in rows]
    assert s["vs_force_closure"]["median_pct"] == pytest.approx(np.median(red))
    assert s["vs_force_closure"]["tools_lower"] == sum(x > 0 for x in red)
    assert s["weak_grip"]["planner"]["rollouts"] == 2 * doc["config"]["draws"]
    # reopened: the run's tools planned again (each checked to give the recorded pick) with a given
    # checkpoint and threshold (here the shipped ones: nothing changes), and the oracle of the hammer's
    # tools from one more rollout of every candidate
    from itup_jax.ood import GUARD_THRESHOLD
    from itup_jax.sdgnet.config import DEFAULT_MODEL

    _run("sealed_reopen", [str(tmp_path / "sealed.json"), "--model", DEFAULT_MODEL, "--guard-threshold",
                           str(GUARD_THRESHOLD), "--headroom", "1", "--tasks", "hammer", "--out", str(tmp_path / "re")],
         monkeypatch)
    re = json.loads((tmp_path / "re" / "sealed.json").read_text())
    jsonschema.validate(re, load_schema("sealed"))
    assert re["reopened"]["replaced"] == 0 and re["summary"] == doc["summary"]  # the same planner: nothing changes
    assert re["reopened"]["guard_threshold"] == GUARD_THRESHOLD and re["reopened"]["model"] == os.path.abspath(DEFAULT_MODEL)
    for r in re["per_tool"]:
        h = r.get("headroom")
        assert (h is not None) == (r["task"] == "hammer")
        if h and h["oracle"]:
            assert 1 <= h["held"] <= r["candidates"] and h["oracle"]["valid"] >= 1
            assert all(k is None or 1 <= k <= r["candidates"] for k in h["rank_of_picks"].values())
    assert set(re["reopened"]["headroom"]["summary"]) <= {"hammer"}
    # the threshold given is the one the re-planning reads: below every tool's score the guard fires
    # everywhere (checking 1 grasp where it fires, max(5, 1) = the default 5); a checkpoint that cannot be
    # read stops it
    _run("sealed_reopen", [str(tmp_path / "sealed.json"), "--guard-threshold", "1e-6", "--planner-guard-verify", "1",
                           "--out", str(tmp_path / "t")], monkeypatch)
    rt = json.loads((tmp_path / "t" / "sealed.json").read_text())
    assert all(r["planner"]["guard_fired"] for r in rt["per_tool"] if r["picks"])
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a checkpoint")
    (tmp_path / "bad.reference.npz").write_bytes((tmp_path / "bad.npz").read_bytes())
    with pytest.raises(itup.InputError, match="not a checkpoint"):  # before any rollout, nothing written
        _run("sealed_reopen", [str(tmp_path / "sealed.json"), "--model", str(bad), "--out", str(tmp_path / "b")],
             monkeypatch)
    assert not (tmp_path / "b").exists()
    # --fidelity-of --redraws 1: the run's fidelity draw again, ranked by another checkpoint (here the
    # shipped one under a label: the run's own figure comes back, and the label ranks as the shipped
    # network does), and one more draw of the same candidates (seed RETEST_SEED + 1): the retest is the
    # Spearman of the two draws, and the ranking against their mean is over the candidates valid in both
    from itup_jax.sim.physics import Randomization
    from itup_jax.stats import spearman

    _run("sealed_reopen", [str(tmp_path / "sealed.json"), "--fidelity-of", f"same={DEFAULT_MODEL}", "--redraws", "1",
                           "--out", str(tmp_path / "rt")], monkeypatch)
    rt = json.loads((tmp_path / "rt" / "fidelity_of.json").read_text())
    jsonschema.validate(rt, load_schema("sealed_fidelity_of"))
    assert len(rt["per_tool"]) == len(doc["per_tool"]) and rt["models"] == {"same": DEFAULT_MODEL}
    for r in rt["per_tool"]:
        assert r["rho"]["sdgnet"] == pytest.approx(r["run_sdgnet"]) and r["rho"]["same"] == r["rho"]["sdgnet"]
    assert set(rt["summary"]) == {"hammer", "reach"}
    assert rt["redraws"] == 1 and set(rt["retest"]) == {"hammer", "reach"}
    row = next(r for r in doc["per_tool"] if r.get("fidelity"))
    tool, task, g, scene = se.rebuild_row(row, doc["config"]["n"])
    d0, d1 = (itup.simulate(tool, task, g, scene=scene, seed=s, randomize=Randomization()).labels
              for s in (se.FIDELITY_SEED, se.RETEST_SEED + 1))
    both = np.asarray(d0.valid) & np.asarray(d1.valid)
    y0, y1 = (np.asarray(d.peak_torque_induced, float)[both] for d in (d0, d1))
    got = next(r for r in rt["per_tool"] if r["tool"] == row["tool"] and r["task"] == row["task"])
    assert got["valid_all"] == both.sum() and got["retest"] == pytest.approx(spearman(y0, y1))
    tau = np.asarray(itup.score(tool, task, g).tau, float)[both]
    assert got["rho_mean"]["sdgnet"] == pytest.approx(spearman(tau, (y0 + y1) / 2))
    assert got["rho"]["sdgnet"] == pytest.approx(row["fidelity"]["sdgnet"])
    # the run's own redraw is the same draw (seed RETEST_SEED + 1 of the same candidates): the same retest
    assert got["retest"] == pytest.approx(row["fidelity"]["retest"])
    assert {m: got["rho_mean"][m] for m in row["fidelity"]["rho_mean"]} == pytest.approx(row["fidelity"]["rho_mean"])

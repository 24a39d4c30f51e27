"""Stress: the least holding grip by bisection, rollouts at a fixed grip, probes below the gripper's 20 N."""

import numpy as np
import pytest
from conftest import load_experiment, run_experiment

import itup_jax as itup
from itup_jax import robot, stress
from itup_jax.evaluate import feasible_candidates


@pytest.mark.parametrize("threshold", [5.5, 12.0, 37.3, 180.0])
def test_bisection_finds_a_known_threshold(threshold):
    calls = []

    def holds(f):
        calls.append(f)
        return f >= threshold

    r = stress.min_holding_grip(holds, tol=0.5)
    assert r.monotone and threshold <= r.force <= threshold + 0.5
    assert r.probe == (r.force < robot.GRIPPER_MIN_GRIP_FORCE)
    assert len(calls) <= 12 and set(r.tried) == set(calls)


def test_never_and_always_holding_and_a_non_monotone_outcome():
    assert stress.min_holding_grip(lambda f: False).force is None
    assert stress.min_holding_grip(lambda f: True).force == stress.GRIP_RANGE[0]
    # holds from 30 N, except between 60 and 80 N: the grid finds the gap and the result says so
    gap = stress.min_holding_grip(lambda f: f >= 30 and not 60 < f < 80, grid=(10, 20, 40, 50, 70, 100), tol=0.5)
    assert not gap.monotone and 30 <= gap.force <= 30.5
    assert stress.min_holding_grip(lambda f: f >= 30, grid=(10, 20, 40, 50, 70, 100)).monotone
    with pytest.raises(itup.InputError, match="lo < hi"):
        stress.min_holding_grip(lambda f: True, lo=10, hi=5)


def test_rollouts_at_a_fixed_grip_share_draws_and_weaker_grips_fail_more(tasks):
    """Each grasp's draw d is the same physics at every grip; a probe below 20 N really squeezes less
    (the actuator's range is opened for it, not clamped back to 20 N)."""
    tool, task = tasks["hammer"]
    scene = itup.build_scene(tool, task)
    cands, _ = feasible_candidates(tool, task, 2, seed=0)
    weak = stress.rollouts_at_grip(tool, task, cands, 8.0, draws=2, scene=scene)
    floor = stress.rollouts_at_grip(tool, task, cands, 20.0, draws=2, scene=scene)
    strong = stress.rollouts_at_grip(tool, task, cands, 150.0, draws=2, scene=scene)
    assert weak.valid.all() and strong.valid.all()
    # the probe's squeeze is its own, not the gripper's 20 N floor: the physics keeps 8 N, and the pads
    # press less on average than at 20 N (their peaks include the strike's own contact forces)
    from itup_jax.sim.physics import Randomization, sample_physics

    np.testing.assert_array_equal(sample_physics(tool, 3, spread=Randomization(grip_force=0.0), grip_force=8.0).grip_force, 8.0)
    assert weak.peak_pad_force.mean() < floor.peak_pad_force.mean()
    assert stress.holds(strong, 2).all()
    # draw d is the same physics for every grasp: the second grasp alone gives its rows of the pair
    alone = stress.rollouts_at_grip(tool, task, cands[1:2], 150.0, draws=2, scene=scene)
    np.testing.assert_array_equal(alone.peak_torque_induced, strong.peak_torque_induced[2:])
    assert weak.peak_pad_force.max() < 0.5 * strong.peak_pad_force.max()
    assert weak.slip_rotation.mean() > strong.slip_rotation.mean()
    assert scene.model.actuator_ctrlrange[scene.grip_actuator][0] == robot.GRIPPER_MIN_GRIP_FORCE  # untouched
    assert stress.probe_scene(scene).model.actuator_ctrlrange[scene.grip_actuator][0] == 0.0
    with pytest.raises(itup.InputError, match="grip force must be in"):
        stress.rollouts_at_grip(tool, task, cands, 0.0)


@pytest.mark.slow
def test_grip_stress_quick(tmp_path, monkeypatch):
    import json

    import jsonschema

    from itup_jax.schemas import load_schema

    run_experiment("grip_stress", "--quick", "--out", str(tmp_path))
    doc = json.loads((tmp_path / "grip_stress.json").read_text())
    jsonschema.validate(doc, load_schema("grip_stress"))
    assert {r["method"] for r in doc["rows"]} == {"sdgnet_verified", "sdgnet", "sdgnet_paper", "force_closure",
                                                  "geometric"}
    for r in doc["rows"]:  # the grid's answers are among the forces the bisection kept
        assert {k for k in r["at_grip"]} <= {f"{float(k):g}" for k in r["tried"]} | set(r["at_grip"])
        assert all(r["tried"][f"{float(g):g}"] == a["holds"] for g, a in r["at_grip"].items())
    assert (tmp_path / "grip_stress.png").stat().st_size > 5_000


@pytest.mark.slow
def test_weight_by_stress_quick(tmp_path, monkeypatch):
    """The built-in hammer, two weights: every method's pick stressed once (shared picks share rollouts),
    the rule's checks computed from those rows, and the choice made by the rule."""
    import json

    import jsonschema

    from itup_jax.schemas import load_schema

    run_experiment("weight_by_stress", "--quick", "--reference", "geometric", "--out", str(tmp_path))
    doc = json.loads((tmp_path / "weight_by_stress.json").read_text())
    jsonschema.validate(doc, load_schema("weight_by_stress"))
    methods = {r["method"] for r in doc["rows"]}
    assert methods == {"force_closure", "geometric", "sdgnet@w_align=1", "sdgnet@w_align=300"}
    c = doc["checks"]["hammer"]
    assert set(c) == {"1", "300"} and doc["weight"] == "w_align" and doc["chosen"] in (1.0, 300.0)
    ref = doc["reference"]  # the reference method's checks, from its own picks' rows
    assert ref["method"] == "geometric" and ref["passed"] == sum(ref["checks"]["hammer"][k] for k in ("S1", "S2", "T"))
    assert not ref["checks"]["hammer"]["T"]  # a baseline's torque is never below the better of it and the other
    for w, check in c.items():  # the checks follow from the rows
        mine = next(r for r in doc["rows"] if r["method"] == f"sdgnet@w_align={w}")
        assert check["median_min_holding_grip_N"] == mine["min_holding_grip_N"]
        assert check["S1"] == (check["median_min_holding_grip_N"] is not None and check["better_baseline_median_N"] is not None
                               and check["median_min_holding_grip_N"] <= check["better_baseline_median_N"])


@pytest.mark.slow
def test_weight_by_stress_rule_and_methods(tmp_path):
    """The rule: the smallest weight passing every check, else the most checks (ties to the smaller);
    a weighted method parses into the shipped scorer's weights, and a bad one is named."""
    import os
    import sys

    from itup_jax.evaluate import method_scorer

    wbs = load_experiment("weight_by_stress")
    choose, method_name = wbs.choose, wbs.method_name

    ok = {"S1": True, "S2": True, "T": True}
    bad = {"S1": False, "S2": True, "T": True}
    table = {"knock": {"1": bad, "10": ok, "30": ok}, "hammer": {"1": ok, "10": ok, "30": ok}}
    assert choose(table, (1.0, 10.0, 30.0))[0] == 10.0
    table = {"knock": {"1": bad, "10": {**bad, "T": False}, "30": bad}, "hammer": {"1": ok, "10": ok, "30": ok}}
    w, why = choose(table, (1.0, 10.0, 30.0))
    assert w == 1.0 and "5 of 6" in why
    model, weights = method_scorer("sdgnet@w_align=30,w_grip=0")
    assert model == "sdgnet" and weights.w_align == 30.0 and weights.w_grip == 0.0 and weights.w_tau == 1.0
    assert method_scorer("geometric") == ("geometric", itup.ScoreWeights())
    assert method_scorer("m.npz@w_weak=3") == ("m.npz", itup.ScoreWeights(w_weak=3.0))  # another network
    # the joint grid: another weight held fixed while --weight runs over its grid
    assert method_scorer(method_name(10.0, "w_weak", "sdgnet@w_align=300")) == (
        "sdgnet", itup.ScoreWeights(w_align=300.0, w_weak=10.0))
    assert method_name(10.0, "w_weak", "sdgnet") == "sdgnet@w_weak=10"
    for bad_method, msg in (("sdgnet@w_nope=1", "w_nope"), ("sdgnet@w_align=x", "must be a number"),
                            ("geometric@w_align=1", "weights apply to")):
        with pytest.raises(itup.InputError, match=msg):
            method_scorer(bad_method)
    # bad arguments are refused before any rollout: a grid not ascending, a checkpoint that is not one
    import subprocess

    script = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "experiments", "weight_by_stress.py")
    for args, msg in ((["--grid", "10,3"], "ascending"), (["--weight", "w_weak", "--model", str(tmp_path / "none.npz")], "none.npz"),
                      (["--grid", "1,x"], "--grid")):
        r = subprocess.run([sys.executable, script, "--quick", "--out", str(tmp_path / "o"), *args], capture_output=True,
                           text=True, timeout=120)
        assert r.returncode == 2 and msg in r.stderr, (args, r.stderr[-400:])
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_weak_grip_quick(tmp_path, monkeypatch):
    """The built-in mallet's knock: every candidate at the default grip and twice at a weak one; the rates
    and the repeatability follow from the rollouts, and every quantity is ranked against the failures."""
    import json

    import jsonschema

    from itup_jax.schemas import load_schema

    run_experiment("weak_grip", "--quick", "--out", str(tmp_path))
    doc = json.loads((tmp_path / "weak_grip.json").read_text())
    jsonschema.validate(doc, load_schema("weak_grip"))
    (row,) = doc["tasks"]["knock"]["tools"]
    assert row["candidates"] >= 20 and doc["weak_N"] == 25.0
    # a failure rate of either draw pair is a multiple of 1/(2 n) and agreement a multiple of 1/n
    assert abs(row["weak_failure_rate"] * 2 * row["candidates"] - round(row["weak_failure_rate"] * 2 * row["candidates"])) < 1e-9
    assert abs(row["weak_draws_agree"] * row["candidates"] - round(row["weak_draws_agree"] * row["candidates"])) < 1e-9
    keys = set(row["rho"])
    assert {"measured:peak_torque_induced", "measured:slip_rotation", "predicted:align", "position:grasp_z"} <= keys
    pooled = doc["tasks"]["knock"]["pooled"]
    for k, v in row["rho"].items():  # one tool: the pooled mean is that tool's rho
        assert (v is None and pooled[k]["mean_rho"] is None) or pooled[k]["mean_rho"] == pytest.approx(v)


def test_weak_grip_rejects_a_grip_outside_the_gripper(tmp_path, monkeypatch):

    with pytest.raises(SystemExit) as e:
        run_experiment("weak_grip", "--quick", "--weak", "0", "--out", str(tmp_path / "x"))
    assert e.value.code == 2 and not (tmp_path / "x").exists()


def test_split_methods_keeps_weights_together():
    """A comma list of methods where NAME=VALUE items continue the weights of the method before them."""
    from itup_jax.evaluate import method_scorer, split_methods

    assert split_methods("sdgnet@w_align=0,w_grip=0,force_closure,,geometric") == (
        "sdgnet@w_align=0,w_grip=0", "force_closure", "geometric")
    assert method_scorer(split_methods("sdgnet@w_align=0,w_grip=0")[0])[1] == itup.ScoreWeights(w_align=0.0, w_grip=0.0)
    assert split_methods("sdgnet,m.npz@w_weak=3,w_slip=0") == ("sdgnet", "m.npz@w_weak=3,w_slip=0")
    with pytest.raises(itup.InputError, match="no 'method@' before it"):
        split_methods("w_align=0,sdgnet")
    with pytest.raises(itup.InputError, match="no 'method@' before it"):
        split_methods("sdgnet,w_align=0")

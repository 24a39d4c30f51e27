"""Stress: the least holding grip by bisection, rollouts at a fixed grip, probes below the gripper's 20 N."""

import numpy as np
import pytest

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
    from itup_jax.simulate import Randomization, sample_physics

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


def test_grip_stress_quick(tmp_path, monkeypatch):
    import json
    import os
    import runpy
    import sys

    import jsonschema

    from itup_jax.schemas import load_schema

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    monkeypatch.setattr(sys, "argv", ["grip_stress.py", "--quick", "--out", str(tmp_path)])
    runpy.run_path(os.path.join(root, "experiments", "grip_stress.py"), run_name="__main__")
    doc = json.loads((tmp_path / "grip_stress.json").read_text())
    jsonschema.validate(doc, load_schema("grip_stress"))
    assert {r["method"] for r in doc["rows"]} == {"sdgnet", "sdgnet_paper", "force_closure", "geometric"}
    for r in doc["rows"]:  # the grid's answers are among the forces the bisection kept
        assert {k for k in r["at_grip"]} <= {f"{float(k):g}" for k in r["tried"]} | set(r["at_grip"])
        assert all(r["tried"][f"{float(g):g}"] == a["holds"] for g, a in r["at_grip"].items())
    assert (tmp_path / "grip_stress.png").stat().st_size > 5_000

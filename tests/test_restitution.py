"""The restitution MuJoCo delivers: a free rod dropped on a plane (`itup_jax.sim.restitution`)."""

import math

import numpy as np
import pytest

from itup_jax.sim import restitution
from itup_jax.sim.restitution import calibrated_dampratio, delivered_restitution, textbook_dampratio
from itup_jax.sim.scene import build_scene, restitution_solref


@pytest.mark.parametrize("timestep", [0.0005, 0.002])
def test_calibrated_contacts_deliver_the_wanted_restitution_within_0_02(timestep):
    for e in (0.1, 0.3, 0.5, 0.7):
        for timeconst in (0.004, 0.01, 0.05):
            zeta = calibrated_dampratio(e, timeconst, timestep)
            assert delivered_restitution((timeconst, zeta), timestep) == pytest.approx(e, abs=0.02)


def test_tables_kept_on_disk_are_read_back_bit_for_bit_and_a_broken_one_is_measured_again(tmp_path):
    args = (0.0047, 0.0005)  # a time constant no other test asks, so the in-memory cache holds no table of it
    measured = restitution.delivered_table.__wrapped__(*args)[1]
    try:
        restitution.keep_tables(tmp_path)
        restitution.delivered_table.cache_clear()
        written = restitution.delivered_table(*args)[1]
        (entry,) = tmp_path.iterdir()
        np.testing.assert_array_equal(written, measured)
        entry.write_bytes(np.zeros(80).tobytes())  # no .npy header: measured again, and rewritten
        restitution.delivered_table.cache_clear()
        np.testing.assert_array_equal(restitution.delivered_table(*args)[1], measured)
        np.testing.assert_array_equal(np.load(entry), measured)
        restitution.delivered_table.cache_clear()
        np.save(entry, np.full(80, 0.5))  # a readable entry is what is read: the table comes from disk
        assert restitution.delivered_table(*args)[1][0] == 0.5
        assert restitution.delivered_table(0.0047, 0.001)[1].shape == (80,)
        assert len(list(tmp_path.iterdir())) == 2  # the step is part of the key
    finally:
        restitution.keep_tables(None)
        restitution.delivered_table.cache_clear()


def test_the_textbook_ratio_bounces_more_than_it_promises_which_is_why_it_is_calibrated():
    """MuJoCo lets a contact go when its force reaches zero: the textbook ratio delivers more than e."""
    zeta0 = textbook_dampratio(0.4)
    assert math.exp(-math.pi * zeta0 / math.sqrt(1 - zeta0**2)) == pytest.approx(0.4, rel=1e-12)
    assert delivered_restitution((0.0055, zeta0), 0.0005) > 0.45
    assert calibrated_dampratio(0.4, 0.0055, 0.0005) > zeta0 + 0.05


def test_the_drop_measures_a_rebound_and_more_damping_bounces_less():
    es = [delivered_restitution((0.006, z), 0.0005) for z in (0.1, 0.3, 0.6, 1.0)]
    assert all(a > b for a, b in zip(es, es[1:]))
    assert 0.1 < es[-1] < 0.2  # a critically damped MuJoCo contact still bounces (the hammer's nail)
    assert es[0] > 0.8


@pytest.mark.parametrize("kind", ["sweep", "knock", "reach"])
def test_every_scene_s_tool_target_contact_delivers_its_tool_s_restitution(tasks, kind):
    tool, task = tasks[kind]
    scene = build_scene(tool, task)
    solref = scene.model.pair_solref[scene.tool_target_pairs]
    assert np.ptp(solref, axis=0).max() == 0
    e = float(tool.params.restitution)
    assert tuple(solref[0]) == pytest.approx(restitution_solref(e, float(tool.params.contact_duration),
                                                                scene.model.opt.timestep))
    assert delivered_restitution(solref[0], scene.model.opt.timestep) == pytest.approx(e, abs=0.05)

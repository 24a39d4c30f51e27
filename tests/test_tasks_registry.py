"""The task registry: every kind is one module, and a kind registered from outside runs end to end."""

import dataclasses

import numpy as np
import pytest

import itup_jax as itup
from itup_jax import tasks
from itup_jax.tasks import hammer


def test_the_built_in_kinds_are_registered_in_order():
    assert tasks.names() == ("hammer", "sweep", "knock", "reach") == itup.TASK_KINDS
    for name in tasks.names():
        kind = tasks.get(name)
        assert kind.name == name and dataclasses.is_dataclass(kind.params)
        assert kind.default_tool in itup.tools.BUILTIN_TOOLS
        assert kind.summary
    with pytest.raises(itup.InputError, match="task kind 'drill': unknown; known: hammer, sweep"):
        tasks.get("drill")
    with pytest.raises(itup.InputError, match="registered already"):
        tasks.register(tasks.get("hammer"))


@dataclasses.dataclass(frozen=True)
class TapParams(hammer.HammerParams):
    impact_speed: float = 0.3  # m/s, a gentle tap on the nail


def _tap_outcome(scene, task, sensordata, p):
    depth, _ = hammer.outcome(scene, task, sensordata, p)
    return depth, depth < hammer.NAIL_DEPTH_SUCCESS  # a tap that leaves the nail where it was


@pytest.fixture
def tap():
    kind = tasks.register(tasks.TaskKind(
        name="tap", params=TapParams,
        build=lambda tool, prm: dataclasses.replace(hammer.build(tool, prm), kind="tap"),
        default_tool="hammer", timestep=0.0005, target_geoms=("nail_head",), target_bodies=("nail",),
        place=hammer.place, outcome=_tap_outcome, plastic_target=True, scene="scenes/hammer.xml",
        summary="tap the nail without driving it"))
    yield kind
    tasks.unregister("tap")


def test_a_fifth_kind_is_one_registration(tap, tools):
    """A kind registered from outside the package is built, composed into a scene, rolled out and
    labelled by the same code as the built-in ones, and the CLI offers it."""
    assert "tap" in itup.TASK_KINDS and itup.TASK_TIMESTEP["tap"] == 0.0005
    tool = tools["hammer"]
    task = itup.make_task("tap", tool)
    assert task.kind == "tap"
    with pytest.raises(itup.InputError, match="unknown parameter"):
        itup.make_task("tap", tool, stroke=0.1)
    scene = itup.build_scene(tool, task)
    assert scene.kind == "tap" and scene.model.opt.timestep == 0.0005
    grasps = itup.sample_grasps(tool, 64, seed=0)
    from itup_jax.sim.arm import reachable
    ok = np.nonzero(reachable(task, grasps))[0][:2]
    labels = itup.simulate(tool, task, grasps[ok], seed=0, backend="native").labels
    assert labels.valid.all() and labels.success.all()  # a 0.3 m/s tap does not drive the nail
    from itup_jax.cli import build_parser
    parser = build_parser()
    assert parser.parse_args(["plan", "--task", "tap"]).task == "tap"

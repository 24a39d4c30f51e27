"""Shared fixtures. Tests run in float64 (gradient checks need it), as jax-md's CI does."""

import jax

jax.config.update("jax_enable_x64", True)
# Persistent compilation cache: a second local run reuses the MJX rollout's compile (tens of seconds).
jax.config.update("jax_compilation_cache_dir", str(__import__("pathlib").Path(__file__).resolve().parent.parent / ".jax_cache"))
jax.config.update("jax_persistent_cache_min_compile_time_secs", 2.0)
# the CLI's own cache (`compile_cache.enable`, on in `itup`) would redirect the cache above to the user's
# home and write every compile there for the rest of the session: the tests call `main` with it off
__import__("os").environ["ITUP_COMPILE_CACHE"] = "0"

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import itup_jax as itup  # noqa: E402
from itup_jax.task import DEFAULT_TOOL  # noqa: E402

#: MJX against native MuJoCo (tests/test_simulate.py, the mjx_vs_native quick run in tests/test_evaluate.py).
#: MJX runs in float64 (`sim.mjx.MJX_FLOAT64`) but its contact solver differs in detail from the C one: raw
#: peak torques agree to ~10 % on firm grasps (docs/design.md measured 3 % on a simpler scene), slip to a
#: few mm, alignment drift to a few hundredths of a radian. Labels of grasps that slip (> FIRM_SLIP m) are
#: chaotic and not compared.
MJX_TORQUE_RTOL = 0.15
MJX_SLIP_ATOL = 3e-3
MJX_DRIFT_ATOL = 0.03
FIRM_SLIP = 5e-3


@pytest.fixture(scope="session")
def tools():
    """The four built-in tools, built once per session."""
    return {name: itup.load_tool(name) for name in ("hammer", "broom", "mallet", "l_stick")}


@pytest.fixture(scope="session")
def tasks(tools):
    """Default task of each kind with its default tool: {kind: (tool, task)}."""
    return {kind: (tools[DEFAULT_TOOL[kind]], itup.make_task(kind, tools[DEFAULT_TOOL[kind]]))
            for kind in itup.TASK_KINDS}


@pytest.fixture(scope="session")
def hammer_grasps(tools):
    """200 sampled grasps on the built-in hammer (seed 0)."""
    return itup.sample_grasps(tools["hammer"], 200, seed=0)


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture(scope="session")
def user_mallet(tmp_path_factory):
    """A user's mesh tool: a mallet (28 mm round handle, 90 x 40 x 40 mm head) written as STL, in metres,
    handle along +z and face along +x, loaded through the spec path (`itup.load_tool`)."""
    import trimesh

    folder = tmp_path_factory.mktemp("user_mallet")
    handle = trimesh.creation.cylinder(radius=0.014, height=0.28,
                                       transform=trimesh.transformations.translation_matrix([0, 0, 0.14]))
    head = trimesh.creation.box(extents=[0.09, 0.04, 0.04], transform=trimesh.transformations.translation_matrix([0, 0, 0.30]))
    trimesh.boolean.union([handle, head], engine="manifold").export(folder / "mallet.stl")
    spec = {"name": "my_mallet", "category": "mallet", "contact_point": [0.045, 0, 0.30], "contact_normal": [1, 0, 0],
            "grasp_region": {"min": [-0.03, -0.03, 0], "max": [0.03, 0.03, 0.2]}}
    return itup.load_tool(str(folder / "mallet.stl"), spec)


#: The repository's root (experiments/ and notebooks/ sit there).
ROOT = __import__("pathlib").Path(__file__).resolve().parent.parent


def load_experiment(name: str):
    """An experiment script (experiments/<name>.py) as a module, to test its own functions; what the
    experiments share lives in the package (`itup_jax.heldout`, `itup_jax.fidelity`, ...)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"experiment_{name}", ROOT / "experiments" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_experiment(name: str, *argv: str) -> None:
    """Run experiments/<name>.py as `python experiments/<name>.py ARGV` runs it (its main, in this process)."""
    import sys

    module = load_experiment(name)
    saved = sys.argv
    sys.argv = [f"{name}.py", *argv]
    try:
        module.main() if module.main.__code__.co_argcount == 0 else module.main(list(argv))
    finally:
        sys.argv = saved

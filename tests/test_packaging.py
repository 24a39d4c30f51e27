"""The package installs as a wheel (not editable) and runs from outside the repository: the MJCF, the
shipped checkpoint and the schemas travel inside it."""

import os
import subprocess
import sys
import venv
import zipfile
from pathlib import Path

import pytest

#: Slow tier (`-m slow`): a wheel is built and installed in a fresh environment.
pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    # no build isolation: the build tools come with the test extra, so nothing is downloaded here
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation",
                    "-w", str(out), str(REPO)], check=True, capture_output=True, cwd=out)
    (whl,) = out.glob("itup_jax-*.whl")
    return whl


def test_the_wheel_carries_every_asset(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    mjcf = {str(p.relative_to(REPO)) for p in (REPO / "mjcf").rglob("*.xml")}
    assert mjcf and {f"itup_jax/{p}" for p in mjcf} <= names
    assert "itup_jax/models/sdgnet_default.npz" in names
    assert {f"itup_jax/schemas/{p.name}" for p in (REPO / "itup_jax" / "schemas").glob("*.json")} <= names
    assert {f"itup_jax/tasks/{k}.py" for k in ("hammer", "sweep", "knock", "reach")} <= names


def test_the_installed_wheel_runs_the_demo_from_another_folder(wheel, tmp_path):
    """A fresh virtual environment with the wheel installed (its dependencies borrowed from the test
    environment's site-packages, after its own, so nothing is downloaded) runs `itup demo --quick` in a
    folder outside the repository, with the repository's files out of reach."""
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False)
    py = env_dir / "bin" / "python"
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          check=True, capture_output=True, text=True).stdout.strip()
    deps = [p for p in sys.path if p.endswith("site-packages")]
    Path(site, "zz_test_deps.pth").write_text("\n".join(deps) + "\n")
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", site, str(wheel)],
                   check=True, capture_output=True)
    work = tmp_path / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "ITUP_MJCF_DIR")}
    env["ITUP_COMPILE_CACHE"] = "0"
    where = subprocess.run([str(py), "-c", "import itup_jax, itup_jax.sim.scene as s; print(itup_jax.__file__); "
                            "print(s.MJCF_DIR)"], check=True, capture_output=True, text=True, cwd=work, env=env)
    pkg, mjcf = where.stdout.split()
    assert pkg.startswith(site) and mjcf.startswith(site), where.stdout
    run = subprocess.run([str(py), "-m", "itup_jax.cli", "demo", "--quick", "--out", "demo"], capture_output=True,
                         text=True, cwd=work, env=env, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    assert {"picks.png", "demo.json", "sdgnet_verified.mcap", "force_closure.mcap"} <= {p.name for p in (work / "demo").iterdir()}

"""The distribution installs by its name: the wheel built from this checkout goes into a fresh
virtual environment from a local folder (no index, no network) as ``imesh-retarget``, and that
environment's ``imesh demo`` runs from another folder.

The fresh environment sees this interpreter's heavy dependencies (numpy, scipy, pinocchio,
DART...: hundreds of MB, no network here to fetch them) through a ``.pth`` file listing the
directories of this interpreter's ``sys.path``, not through ``--system-site-packages``: that
would also run the ``.pth`` hook of an editable install of this checkout, and the environment
would import the checkout instead of the wheel.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DIST = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["name"]


def _run(cmd, **kwargs) -> subprocess.CompletedProcess:
    done = subprocess.run(cmd, capture_output=True, text=True, **kwargs)
    assert done.returncode == 0, f"{cmd} -> {done.returncode}\n{done.stdout}\n{done.stderr}"
    return done


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheelhouse")
    _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
          "--no-index", "-q", "-w", str(out), str(ROOT)], cwd=out)
    wheels = list(out.glob("*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_the_name_is_ours_and_the_wheel_holds_the_robots(wheel):
    assert DIST == "imesh-retarget"  # 'imesh' on PyPI is an unrelated project
    assert wheel.name.startswith("imesh_retarget-")
    names = zipfile.ZipFile(wheel).namelist()
    for robot in ("jvrc1", "g1", "hrp4c"):
        assert f"imesh/robots/{robot}/robot.toml" in names
        assert f"imesh/robots/{robot}/markers.toml" in names
    assert "imesh/robots/planar_biped/planar_biped.urdf" in names
    assert "imesh/data/demo/cmu_02_01_walk.bvh" in names
    assert not [n for n in names if n.startswith(("tests/", "benchmarks/", "robots/"))]


def test_a_fresh_venv_installs_it_by_name_and_runs_the_demo(wheel, tmp_path):
    venv = tmp_path / "venv"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    python = venv / "bin" / "python"
    site = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_path("
                                         "'purelib'))"]).stdout.strip())
    here = {str(Path(p).resolve()) for p in sys.path if p and Path(p).is_dir()}
    stdlib = Path(sysconfig.get_path("stdlib")).resolve()
    deps = sorted(p for p in here if not Path(p).is_relative_to(ROOT)
                  and (p == str(stdlib / "site-packages") or "site-packages" in p))
    (site / "dependencies_of_the_test.pth").write_text("\n".join(deps) + "\n")
    # by name from a local folder; the editable install of this checkout (same name, seen
    # through the .pth) must not count as installed: --force-reinstall --no-deps
    _run([str(python), "-m", "pip", "install", "--no-index", "--find-links",
          str(wheel.parent), "--force-reinstall", "--no-deps", "-q", DIST], cwd=tmp_path)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    work = tmp_path / "elsewhere"
    work.mkdir()
    where = _run([str(python), "-c", "import imesh, imesh.robot.config as c; "
                  "print(imesh.__file__); print(c.ROBOTS_DIR)"], cwd=work, env=env).stdout
    module, robots = where.split()
    assert Path(module).is_relative_to(site) and Path(robots).is_relative_to(site)
    demo = _run([str(venv / "bin" / "imesh"), "-q", "demo", "-o", "out"], cwd=work, env=env,
                timeout=600)
    assert "verification: passed every gate" in demo.stdout
    report = json.loads((work / "out" / "report.json").read_text())
    # the demo scores the close-pair error on the clip's frames (not "n/a")
    close = report["metrics"]["close_pair_error"]
    assert isinstance(close["value"], float) and 0.0 < close["value"] < 0.1
    assert close["frames"] == 86

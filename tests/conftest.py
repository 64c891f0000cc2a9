"""Shared fixtures: real data from IMESH_DATA (default ../shared/data beside the project)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def data_root() -> Path:
    return Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data")).resolve()


def mocap_path(name: str) -> Path:
    path = data_root() / "mocap" / name
    if not path.is_file():
        pytest.fail(f"test data {path} not found: set IMESH_DATA to the shared data folder")
    return path


def hrp4c_urdf() -> Path:
    """The HRP-4C URDF beside the shared data (a user-supplied model; never copied here)."""
    path = data_root().parent / "robots" / "hrp4c" / "HRP4Cmain_reduced.urdf"
    if not path.is_file():
        pytest.fail(f"HRP-4C URDF {path} not found: set IMESH_DATA to the shared data folder")
    return path


_ROBOTS: dict = {}


def modules_after(statement: str, predicate: str) -> list[str]:
    """The modules a fresh interpreter has loaded after ``statement`` for which the Python
    expression ``predicate`` (of ``m``, a module name) holds, sorted."""
    code = f"import sys; {statement}; print(sorted(m for m in sys.modules if {predicate}))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.strip()
    return eval(out)  # noqa: S307 - a list of names printed by our own child process


def load_test_robot(name: str):
    """A robot by name, loaded once per session (HRP-4C from :func:`hrp4c_urdf`)."""
    from imesh.robot import load_robot

    if name not in _ROBOTS:
        _ROBOTS[name] = load_robot(name, urdf=hrp4c_urdf() if name == "hrp4c" else None)
    return _ROBOTS[name]


@pytest.fixture(scope="session")
def mocap():
    """Function mocap(name) -> Path of a clip in IMESH_DATA/mocap (fails if absent)."""
    return mocap_path


def made_once(tmp_path_factory, name: str, make) -> Path:
    """The folder ``name`` that ``make(folder)`` fills, made once per test run: with
    pytest-xdist the workers share it (the first one that needs it makes it while the others
    wait on a lock; they never write into it). A ``make`` that raises leaves no folder, and the
    next test needing it tries again (and fails with the same error)."""
    import fcntl
    import shutil

    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the run's folder above every worker's basetemp
    folder = root / f"made-once-{name}"
    with open(root / f"made-once-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not (folder / ".done").is_file():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            try:
                make(folder)
            except BaseException:
                shutil.rmtree(folder, ignore_errors=True)
                raise
            (folder / ".done").touch()
    return folder


def _demo_walk(tmp_path_factory, robot: str):
    """``imesh retarget`` of the demo walk to ``robot`` with default settings, made once per
    test run (:func:`made_once`): (the motion file, the retarget's JSON report, the adapted
    markers file of ``--markers``)."""
    import json

    from imesh.api import demo_clip
    from imesh.cli import main

    out, report, markers = (f"walk_{robot}.npz", f"walk_{robot}.json",
                            f"walk_{robot}_markers.npz")

    def make(folder: Path) -> None:
        assert main(["-q", "retarget", str(demo_clip()), "--robot", robot, "-o",
                     str(folder / out), "--json", str(folder / report), "--markers",
                     str(folder / markers)]) == 0

    folder = made_once(tmp_path_factory, f"walk_{robot}", make)
    return folder / out, json.loads((folder / report).read_text()), folder / markers


@pytest.fixture(scope="session")
def g1_walk(tmp_path_factory):
    """The demo walk retargeted to the G1 by ``imesh retarget`` (30 s alone here, once per test run,
    shared by the xdist workers): (the motion file, the retarget's JSON report, the adapted
    markers file). Read it; never write into its folder."""
    return _demo_walk(tmp_path_factory, "g1")


@pytest.fixture(scope="session")
def jvrc1_walk(tmp_path_factory):
    """The demo walk retargeted to JVRC-1 by ``imesh retarget``, as :func:`g1_walk`."""
    return _demo_walk(tmp_path_factory, "jvrc1")


def run_cli(capsys, *argv) -> tuple[int, str]:
    """Exit status and the error line of ``imesh argv`` (stdout when it succeeds); asserts the
    error is one line and there is no traceback."""
    from imesh.cli import main

    status = main([str(a) for a in argv])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    if status != 0:
        lines = [ln for ln in captured.err.splitlines() if ln.startswith("imesh: error:")]
        assert len(lines) == 1, captured.err
        return status, lines[0]
    return status, captured.out


#: The holosoma climb the scene tests use (data/interaction/MANIFEST.md).
CLIMB_SEQ = "interaction/holosoma_climb/mocap_climb_seq_1"


def climb_window(start: int, stop: int, robot_name: str = "g1"):
    """(window, robot, scene): source frames [start, stop) of the holosoma climb seq_1 at
    120 fps, the robot, and the boxes scaled and placed like the person for it; skips the test
    when the data is not under IMESH_DATA."""
    from imesh.io import load_motion
    from imesh.scene.morph_frame import scene_for_clip

    seq = data_root() / CLIMB_SEQ
    if not seq.is_dir():
        pytest.skip(f"{seq} not found (IMESH_DATA)")
    clip = load_motion(seq / "mocap_climb_seq_1_joint_positions_f0-2422.npy", fps=120.0)
    window = clip.frames(start, stop)
    robot = load_test_robot(robot_name)
    scene = scene_for_clip(sorted((seq / "box_models").glob("*.obj")), window, robot)
    return window, robot, scene

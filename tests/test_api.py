"""The top-level Python API: names, version, typing marker and the docstring examples (run)."""

from __future__ import annotations

import doctest
import importlib
import re
from pathlib import Path

import pytest
from conftest import modules_after

import imesh
from imesh.cli import main

ROOT = Path(__file__).resolve().parents[1]
API = ("retarget", "evaluate", "load_motion", "load_robot", "load_robot_motion",
       "export_motion", "demo_clip", "RobotMotion", "RetargetConfig", "__version__")


def test_top_level_names():
    for name in API:
        assert name in imesh.__all__, name
        assert getattr(imesh, name) is not None
    # importing the package of the same name (imesh/evaluate/) keeps the function
    importlib.import_module("imesh.pipeline.retarget")
    importlib.import_module("imesh.evaluate.scoreboard")
    assert callable(imesh.retarget) and imesh.retarget.__module__ == "imesh.api"
    assert callable(imesh.evaluate) and imesh.evaluate.__module__ == "imesh.api"
    from imesh.pipeline.retarget import RetargetConfig

    assert RetargetConfig is imesh.RetargetConfig


def test_version_single_source(capsys):
    text = (ROOT / "pyproject.toml").read_text()
    assert 'dynamic = ["version"]' in text
    assert 'version = { attr = "imesh.__version__" }' in text
    assert re.fullmatch(r"\d+\.\d+\.\d+", imesh.__version__)
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"imesh {imesh.__version__}"


def test_typed_package():
    assert (ROOT / "imesh" / "py.typed").is_file()
    assert '"py.typed"' in (ROOT / "pyproject.toml").read_text()


def test_import_stays_light():
    assert modules_after("import imesh; imesh.__version__",
                         "m in ('scipy', 'pinocchio', 'ray', 'mujoco', 'mkdocs')") == []


@pytest.mark.parametrize("name", ["demo_clip", "load_robot", "load_robot_motion", "evaluate",
                                  "retarget"])
def test_docstring_examples_run(name):
    """Every API function's docstring example runs and prints what it shows."""
    import imesh.api as api

    func = getattr(api, name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    tests = finder.find(func, name, globs={})
    assert tests and tests[0].examples, f"{name} has no docstring example"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for t in tests:
        runner.run(t)
    assert runner.summarize(verbose=False).failed == 0


def test_evaluate_file_names_its_robot(tmp_path):
    robot = imesh.load_robot("jvrc1")
    motion = imesh.RobotMotion(q=[robot.q_nominal] * 30, fps=30.0, robot="jvrc1",
                               joint_names=robot.joint_names)
    path = tmp_path / "still.npz"
    imesh.export_motion(motion, path)
    report = imesh.evaluate(path)  # the robot read from the file
    assert report["limit_violation_frames"]["value"] == 0
    imesh.export_motion(motion, tmp_path / "still.csv", "csv")
    with pytest.raises(imesh.MotionFileError, match="does not name its robot"):
        imesh.evaluate(tmp_path / "still.csv")
    report = imesh.evaluate(tmp_path / "still.csv", "jvrc1")
    assert report["limit_violation_frames"]["value"] == 0

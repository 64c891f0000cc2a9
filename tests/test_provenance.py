"""Motion files carry their provenance (imesh.core.provenance) and the commands that read them
use it: ``imesh evaluate --source`` compares the clip with the motion's own frames of it (the
same close-pair error as the retarget's report), refuses another clip by its SHA-256, and
``view``/``evaluate``/``export`` take the robot from the file. On the G1 walk of the demo clip
(conftest's g1_walk) and on HRP-4C, a user-supplied URDF."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pytest
from conftest import hrp4c_urdf, load_test_robot

from imesh.api import demo_clip
from imesh.cli import main
from imesh.errors import SourceMismatchError


def test_the_file_records_its_timeline_clip_and_robot(g1_walk):
    from imesh.core.provenance import file_sha256, robot_sha256
    from imesh.io.robot_motion import load_robot_motion

    path, report, _ = g1_walk
    motion = load_robot_motion(path)
    prov = motion.provenance
    assert (prov.lead_in, prov.lead_out) == tuple(report["lead_frames"]) == (30, 30)
    assert motion.n_frames == 30 + 86 + 30  # 2.85 s of the clip at 30 fps between them
    assert prov.source.path == str(demo_clip().resolve())
    assert prov.source.sha256 == file_sha256(demo_clip())
    assert (prov.source.frames, round(prov.source.fps, 3)) == (343, 120.005)
    assert prov.robot == "g1" and prov.robot_sha256 == robot_sha256(load_test_robot("g1"))
    import imesh

    assert prov.imesh_version == imesh.__version__


def test_evaluate_source_gives_the_retargets_close_pair_error(g1_walk, tmp_path, capsys):
    """Acceptance 2: the retarget's report, ``imesh evaluate --source`` (no --robot) and the
    figure on the clip's frames computed by hand agree within 1e-6 (0.0380 on this walk)."""
    from imesh.evaluate.scoreboard import evaluate_motion
    from imesh.io.robot_motion import load_robot_motion

    path, report, _ = g1_walk
    own = report["metrics"]["close_pair_error"]["value"]
    out = tmp_path / "ev.json"
    assert main(["-q", "evaluate", str(path), "--source", str(demo_clip()),
                 "--json", str(out)]) == 0
    assert "146 frames of g1 at 30 fps" in capsys.readouterr().out
    evaluated = json.loads(out.read_text())["close_pair_error"]
    # by hand: the clip's frames of the motion (no provenance on a slice) against the clip
    # resampled to 30 fps
    motion = load_robot_motion(path)
    robot = load_test_robot("g1")
    a, b = report["lead_frames"]
    by_hand = evaluate_motion(robot, motion.frames(a, motion.n_frames - b), source=demo_clip(),
                              resample=True)["close_pair_error"]
    assert by_hand["frames"] == evaluated["frames"] == 86
    assert abs(evaluated["value"] - own) <= 1e-6
    assert abs(by_hand["value"] - own) <= 1e-6
    assert own == pytest.approx(0.0380, abs=5e-4)
    # a copy of the clip is the same clip (same bytes)
    copy = tmp_path / "copy.bvh"
    shutil.copyfile(demo_clip(), copy)
    assert main(["-q", "evaluate", str(path), "--source", str(copy), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["close_pair_error"]["value"] == evaluated["value"]


def test_marker_rms_splits_the_clips_frames_from_the_lead(g1_walk):
    """``marker_rms_mm`` of a written retarget gives the clip's frames and the lead apart:
    the clip's figure is the one of the motion cut to the clip (no provenance on a slice),
    and the two recombine to the whole motion's RMS."""
    from imesh.evaluate.motion_files import read_markers
    from imesh.evaluate.scoreboard import evaluate_motion
    from imesh.io.robot_motion import load_robot_motion

    path, report, markers = g1_walk
    motion = load_robot_motion(path)
    robot = load_test_robot("g1")
    whole = evaluate_motion(robot, motion, adapted=str(markers))["marker_rms_mm"]
    a, b = report["lead_frames"]
    stop = motion.n_frames - b
    cut = evaluate_motion(robot, motion.frames(a, stop),
                          adapted=read_markers(markers).frames(a, stop))["marker_rms_mm"]
    assert "clip_frames_mm" not in cut
    assert whole["clip_frames_mm"] == pytest.approx(cut["value"], abs=0.06)
    n_clip, n_lead = motion.n_frames - a - b, a + b
    recombined = np.sqrt((n_clip * whole["clip_frames_mm"] ** 2
                          + n_lead * whole["lead_frames_mm"] ** 2) / motion.n_frames)
    assert recombined == pytest.approx(whole["value"], abs=0.1)
    # the worst half second: 15 frames at 30 fps, at least as far as the whole motion and as
    # any half second of the clip alone; its seconds also on the clip's clock
    w, wc = whole["worst_window"], cut["worst_window"]
    (w0, w1), fps = w["frames"], motion.fps
    assert w1 - w0 == 15 and wc["frames"][1] - wc["frames"][0] == 15
    assert w["rms_mm"] >= max(whole["value"], wc["rms_mm"] - 0.05)
    assert w["clip_seconds"] == [round((w0 - a) / fps, 2), round((w1 - a) / fps, 2)]
    assert "clip_seconds" not in wc  # a slice has no provenance


def test_another_clip_is_refused_by_hash(g1_walk, mocap, capsys):
    from imesh.evaluate.scoreboard import evaluate_motion
    from imesh.io.robot_motion import load_robot_motion

    path = g1_walk[0]
    other = mocap("cmu_16_11_walk_veer_left.bvh")  # a walk too, at 120 fps
    assert main(["-q", "evaluate", str(path), "--source", str(other), "--resample"]) == 2
    err = capsys.readouterr().err
    assert "is not the clip the motion was made from" in err and "SHA-256" in err
    with pytest.raises(SourceMismatchError) as info:
        evaluate_motion(load_test_robot("g1"), load_robot_motion(path), source=other)
    assert info.value.what == "sha256"
    # a loaded clip of another length is refused by its frame count
    from imesh import load_motion

    with pytest.raises(SourceMismatchError, match="343 frames at 120.005 fps") as info:
        evaluate_motion(load_test_robot("g1"), load_robot_motion(path),
                        source=load_motion(other))
    assert info.value.what == "frames"


def test_view_evaluate_export_take_the_robot_from_the_file(g1_walk, tmp_path, capsys):
    """Acceptance 3: a G1 file, no --robot."""
    from imesh.io.formats import read_export

    path = g1_walk[0]
    page = tmp_path / "v.html"
    assert main(["-q", "view", str(path), "--html", str(page)]) == 0
    assert page.stat().st_size > 100_000 and '"g1"' in page.read_text()
    assert main(["-q", "evaluate", str(path)]) == 0
    assert "frames of g1" in capsys.readouterr().out
    csv = tmp_path / "w.csv"
    assert main(["-q", "export", str(path), "--format", "csv", "-o", str(csv)]) == 0
    assert read_export(csv, "g1").n_frames == 146
    # told otherwise: the file is a G1's, not a JVRC-1's
    assert main(["-q", "evaluate", str(path), "--robot", "jvrc1"]) == 2
    assert "this is a motion of robot 'g1', not of 'jvrc1'" in capsys.readouterr().err


def test_a_user_robot_is_found_by_its_provenance(tmp_path, capsys, caplog):
    """HRP-4C's model is the user's (load_robot('hrp4c') alone refuses): the file's provenance
    names the URDF it was made with."""
    from imesh.core.provenance import Provenance, robot_sha256
    from imesh.core.robot_motion import RobotMotion
    from imesh.io.formats import robot_for_motion_file
    from imesh.io.robot_motion import save_robot_motion
    from imesh.robot.errors import RobotConfigError

    robot = load_test_robot("hrp4c")
    with pytest.raises(RobotConfigError):
        robot_for_motion_file(_hrp4c_file(tmp_path, robot, None))
    # --urdf alone: HRP-4C with that model, not a robot generated from the URDF ('hrp4')
    assert robot_for_motion_file(_hrp4c_file(tmp_path, robot, None),
                                 urdf=hrp4c_urdf()).name == "hrp4c"
    assert main(["-q", "evaluate", str(_hrp4c_file(tmp_path, robot, None)), "--urdf",
                 str(hrp4c_urdf())]) == 0
    assert "40 frames of hrp4c" in capsys.readouterr().out
    prov = Provenance(lead_in=5, lead_out=5, robot="hrp4c", robot_sha256=robot_sha256(robot),
                      robot_toml=str(robot.config.path), urdf=str(hrp4c_urdf()),
                      imesh_version="0")
    path = _hrp4c_file(tmp_path, robot, prov)
    assert robot_for_motion_file(path).name == "hrp4c"
    assert main(["-q", "evaluate", str(path)]) == 0
    assert "40 frames of hrp4c" in capsys.readouterr().out
    # a changed configuration is reported, not refused
    save_robot_motion(path, RobotMotion(q=np.tile(robot.q_nominal, (40, 1)), fps=30.0,
                                        robot="hrp4c", joint_names=robot.joint_names,
                                        provenance=dataclasses.replace(prov,
                                                                       robot_sha256="0" * 64)))
    assert main(["-q", "evaluate", str(path)]) == 0
    assert "changed since the motion was made" in caplog.text


def _hrp4c_file(tmp_path, robot, prov):
    from imesh.core.robot_motion import RobotMotion
    from imesh.io.robot_motion import save_robot_motion

    path = tmp_path / f"hrp4c_{prov is not None}.npz"
    save_robot_motion(path, RobotMotion(q=np.tile(robot.q_nominal, (40, 1)), fps=30.0,
                                        robot="hrp4c", joint_names=robot.joint_names,
                                        provenance=prov))
    return path

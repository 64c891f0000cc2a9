"""Issue 17: never report garbage as success. Every bad input and bad output path is a one-line
error with exit status 2, found before the work, no traceback, no file left behind.

Each case runs the command line in-process (``imesh.cli.app``) on files made in tmp_path from the
real clips of IMESH_DATA.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import run_cli as run

from imesh.cli.loading import PIPELINE_MIN_FRAMES
from imesh.errors import (
    ImplausibleMotionError,
    MotionFileError,
    OutputPathError,
    SourceMismatchError,
    TooFewFramesError,
)
from imesh.io import load_motion
from imesh.io.atomic import atomic_path, output_transaction, write_json
from imesh.io.npz import save_marker_motion

ROOT = Path(__file__).resolve().parents[1]
WALK = "cmu_02_01_walk.bvh"
TRC = "roboptim_human_grab_box.trc"
QUALISYS = "ezc3d_Qualisys_gait.c3d"




# ----------------------------------------------------------------------------------------------
# files derived from the real clips


def bvh_rows(mocap) -> tuple[str, list[str]]:
    """(everything up to 'Frame Time' line included, data rows) of the CMU walk."""
    text = mocap(WALK).read_text()
    head, rows = text.split("Frame Time:")
    rows = rows.splitlines()
    return head + "Frame Time:" + rows[0] + "\n", [r for r in rows[1:] if r.strip()]


def write_bvh(path: Path, head: str, rows: list[str]) -> Path:
    head = re.sub(r"Frames:\s*\d+", f"Frames: {len(rows)}", head)
    path.write_text(head + "\n".join(rows) + "\n")
    return path


def edit_root(rows: list[str], frame: int, column: int, value: str) -> list[str]:
    rows = list(rows)
    cells = rows[frame].split()
    cells[column] = value
    rows[frame] = " ".join(cells)
    return rows


def trc_with_header(mocap, tmp_path, key: str, value: str) -> Path:
    lines = mocap(TRC).read_text().splitlines(keepends=True)
    keys = lines[1].rstrip("\r\n").split("\t")
    values = lines[2].rstrip("\r\n").split("\t")
    values[keys.index(key)] = value
    lines[2] = "\t".join(values) + "\r\n"
    path = tmp_path / "edited.trc"
    path.write_text("".join(lines))
    return path


# ----------------------------------------------------------------------------------------------
# garbage reported as success


def test_positions_of_1e17_m_are_refused(capsys, mocap, tmp_path):
    head, rows = bvh_rows(mocap)
    clip = write_bvh(tmp_path / "huge.bvh", head, edit_root(rows, 40, 0, "1e17"))
    status, err = run(capsys, "inspect", clip)
    assert status == 2
    assert "huge.bvh, frame 40, marker Hips" in err
    assert "5.644e+15 m" in err and "|coordinate| <= 1000 m" in err
    with pytest.raises(ImplausibleMotionError) as info:
        load_motion(clip)
    assert info.value.check == "position range" and info.value.frame == 40


@pytest.mark.parametrize("frames", [1, 2, PIPELINE_MIN_FRAMES - 1])
def test_too_short_clips_are_refused_before_the_work(capsys, mocap, tmp_path, frames):
    head, rows = bvh_rows(mocap)
    clip = write_bvh(tmp_path / "short.bvh", head, rows[:frames])
    out = tmp_path / "out.npz"
    status, err = run(capsys, "adapt", clip, "-o", out)
    assert status == 2
    assert f"short.bvh: {frames} frame" in err
    assert f"valid: at least {PIPELINE_MIN_FRAMES} frames" in err
    assert not out.exists()
    assert run(capsys, "inspect", clip)[0] == 0  # inspecting a short clip is fine


def test_one_frame_retarget_is_refused(capsys, mocap, tmp_path):
    """Was a ValueError traceback from contacts.py."""
    head, rows = bvh_rows(mocap)
    clip = write_bvh(tmp_path / "one.bvh", head, rows[:1])
    out = tmp_path / "robot.npz"
    status, err = run(capsys, "retarget", clip, "--robot", "jvrc1", "-o", out)
    assert status == 2 and "1 frame, too short for imesh retarget" in err
    assert not out.exists()
    with pytest.raises(TooFewFramesError) as info:
        from imesh.core.motion import require_frames

        require_frames(load_motion(clip), PIPELINE_MIN_FRAMES, "test")
    assert (info.value.frames, info.value.needed) == (1, PIPELINE_MIN_FRAMES)


def _c3d_all_missing(src: bytes) -> bytes:
    """The Qualisys clip (float data) with every residual word set to -1: all markers gone."""
    data = bytearray(src)
    n_points = int.from_bytes(data[2:4], "little")
    n_analog = int.from_bytes(data[4:6], "little")
    first, last = (int.from_bytes(data[k:k + 2], "little") for k in (6, 8))
    start = (int.from_bytes(data[16:18], "little") - 1) * 512
    frame_words = 4 * n_points + n_analog
    n = (last - first + 1) * frame_words
    table = np.frombuffer(bytes(data[start:start + 4 * n]), "<f4").reshape(-1, frame_words).copy()
    table[:, 3:4 * n_points:4] = -1.0
    data[start:start + 4 * n] = table.tobytes()
    return bytes(data)


def test_c3d_with_every_marker_missing(capsys, mocap, tmp_path):
    clip = tmp_path / "gone.c3d"
    clip.write_bytes(_c3d_all_missing(mocap(QUALISYS).read_bytes()))
    status, err = run(capsys, "inspect", clip, "--json")
    assert status == 2
    assert "gone.c3d: all 55 markers are missing in all 340 frames" in err


def test_one_corrupted_root_sample_is_named_by_frame(capsys, mocap, tmp_path):
    head, rows = bvh_rows(mocap)
    x = float(rows[150].split()[0])
    clip = write_bvh(tmp_path / "glitch.bvh", head, edit_root(rows, 150, 0, f"{x + 20:.6f}"))
    status, err = run(capsys, "inspect", clip)
    assert status == 2
    assert "glitch.bvh, frame 150, marker Hips: corrupted sample" in err
    assert "(and 37 other markers)" in err  # the root carries every joint
    assert re.search(r"1\.1\d m in one frame = 13\d m/s", err)  # 20 CMU units = 1.13 m
    assert "at most 100 m/s" in err
    with pytest.raises(ImplausibleMotionError) as info:
        load_motion(clip)
    assert info.value.check == "marker speed" and info.value.frame == 150


def test_good_clips_still_load(mocap):
    for name in (WALK, "cmu_05_06_dance_pirouettes_jete.bvh", "cmu_07_05.amc", QUALISYS,
                 "ezc3d_BTS_gait.c3d", TRC, "cmu_60_10_salsa_partnerA_sl_scaled.bvh"):
        assert load_motion(mocap(name)).n_frames > 100


def test_implausible_height_suggests_units(capsys, mocap):
    status, err = run(capsys, "inspect", mocap(TRC), "--units", "m")
    assert status == 2
    assert re.search(r"body height 14\d\d m \(units m: wrong units\? pass --units\); valid: "
                     r"0.3 to 3 m", err), err


# ----------------------------------------------------------------------------------------------
# crashes and hangs


def test_trc_inf_in_header(capsys, mocap, tmp_path):
    clip = trc_with_header(mocap, tmp_path, "NumFrames", "inf")
    status, err = run(capsys, "inspect", clip)
    assert status == 2
    assert "edited.trc, line 3: NumFrames 'inf' is not a count" in err


def test_trc_absurd_marker_count_is_refused_before_allocating(capsys, mocap, tmp_path):
    clip = trc_with_header(mocap, tmp_path, "NumMarkers", "1e308")
    t0 = time.perf_counter()
    status, err = run(capsys, "inspect", clip)
    assert time.perf_counter() - t0 < 2.0
    assert status == 2
    assert "NumMarkers '1e308' is not a count this file can hold" in err
    assert re.search(r"valid: an integer from 1 to \d+", err)


def test_evaluate_empty_npz(capsys, tmp_path):
    empty = tmp_path / "empty.npz"
    empty.write_bytes(b"")
    status, err = run(capsys, "evaluate", empty, "--robot", "jvrc1")
    assert status == 2
    assert "empty.npz: empty file (0 bytes): not a readable .npz file" in err


def test_broken_pipe_is_quiet():
    """``imesh inspect CLIP --json | head -c 20``: no BrokenPipeError traceback."""
    code = "import sys; from imesh.cli import entry_point; sys.argv[0] = 'imesh'; entry_point()"
    clip = str(Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data")) / "mocap" /
               "cmu_02_10_wash_self_cc3rig.bvh")
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen([sys.executable, "-c", code, "inspect", clip], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.read(10)
    proc.stdout.close()  # the reader goes away, as head does
    err = proc.stderr.read().decode()
    status = proc.wait(timeout=60)
    assert "Traceback" not in err and "BrokenPipe" not in err
    assert status in (0, 141)  # 0 when everything fitted in the pipe before it closed


# ----------------------------------------------------------------------------------------------
# output paths, checked before the work


def _walk_args(mocap, out, *more):
    return ["adapt", mocap(WALK), "-o", out, *more]


def test_output_extension_checked_before_the_work(capsys, mocap, tmp_path):
    t0 = time.perf_counter()
    status, err = run(capsys, *_walk_args(mocap, tmp_path / "x.txt"))
    assert time.perf_counter() - t0 < 3.0  # was rejected after 24 s of work
    assert status == 2
    assert "output -o" in err and "extension '.txt' not supported; valid: .npz, .csv" in err
    status, err = run(capsys, *_walk_args(mocap, tmp_path / "x.npz", "--json",
                                          tmp_path / "r.txt"))
    assert status == 2 and "output --json" in err and "valid: .json" in err
    assert not (tmp_path / "x.npz").exists()


def _unwritable_folder(tmp_path: Path) -> Path:
    """A folder this process cannot write: mode 0555, or /sys for root (root ignores modes)."""
    folder = tmp_path / "read_only"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        (folder / "probe").write_bytes(b"")
    except OSError:
        return folder
    (folder / "probe").unlink()
    return Path("/sys")


def test_read_only_output_folder(capsys, mocap, tmp_path):
    folder = _unwritable_folder(tmp_path)
    t0 = time.perf_counter()
    status, err = run(capsys, *_walk_args(mocap, folder / "out.npz"))
    assert time.perf_counter() - t0 < 3.0
    assert status == 2 and f"folder '{folder}' is not writable" in err
    assert not (folder / "out.npz").exists()


def test_parent_that_is_a_file(capsys, mocap, tmp_path):
    (tmp_path / "file").write_text("x")
    status, err = run(capsys, *_walk_args(mocap, tmp_path / "out.npz", "--json",
                                          tmp_path / "file" / "r.json"))
    assert status == 2 and "is a file, not a folder" in err
    assert not (tmp_path / "out.npz").exists()
    status, err = run(capsys, *_walk_args(mocap, tmp_path / "missing" / "out.npz"))
    assert status == 2 and "does not exist" in err


def test_retarget_outputs_checked_before_the_robot_work(capsys, mocap, tmp_path):
    (tmp_path / "plots").write_text("a file where the plots folder goes")
    t0 = time.perf_counter()
    status, err = run(capsys, "retarget", mocap(WALK), "-o", tmp_path / "r.npz", "--markers",
                      tmp_path / "m.npz", "--plots", tmp_path / "plots")
    assert time.perf_counter() - t0 < 3.0
    assert status == 2 and "output --plots" in err and "exists and is not a folder" in err
    status, err = run(capsys, "retarget", mocap(WALK), "-o", tmp_path / "r.npz", "--markers",
                      tmp_path / "r.npz")
    assert status == 2 and "also given as -o" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plots"]


def test_outputs_written_together_or_not_at_all(mocap, tmp_path):
    """A failure after the first output was written removes it and restores what it replaced."""
    motion = load_motion(mocap(WALK))
    markers, report, old = tmp_path / "m.npz", tmp_path / "r.json", tmp_path / "old.csv"
    old.write_text("previous result\n")
    with pytest.raises(TypeError), output_transaction():
        save_marker_motion(markers, motion)
        save_marker_motion(old, motion.frames(0, 3))
        assert markers.exists()
        write_json(report, {"not json": object()})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.csv"]
    assert old.read_text() == "previous result\n"
    with output_transaction():
        save_marker_motion(markers, motion)
        write_json(report, {"frames": motion.n_frames})
    assert {p.name for p in tmp_path.iterdir()} == {"m.npz", "r.json", "old.csv"}


def test_written_files_get_the_umask_permissions(tmp_path):
    mask = os.umask(0o022)
    try:
        write_json(tmp_path / "r.json", {"a": 1})
        assert (tmp_path / "r.json").stat().st_mode & 0o777 == 0o644
        os.umask(0o077)
        write_json(tmp_path / "s.json", {"a": 1})
        assert (tmp_path / "s.json").stat().st_mode & 0o777 == 0o600
    finally:
        os.umask(mask)
    with pytest.raises(OutputPathError, match="not writable|cannot write"), \
            atomic_path(_unwritable_folder(tmp_path) / "x.json"):
        pass


# ----------------------------------------------------------------------------------------------
# silent mismatches


def _robot_motion(path: Path, frames: int, fps: float):
    from conftest import load_test_robot

    from imesh.core.robot_motion import RobotMotion
    from imesh.io.robot_motion import save_robot_motion

    robot = load_test_robot("jvrc1")
    q = np.tile(robot.q_nominal, (frames, 1))
    save_robot_motion(path, RobotMotion(q=q, fps=fps, robot=robot.name,
                                        joint_names=robot.joint_names))
    return path


def test_evaluate_source_of_another_clip(capsys, mocap, tmp_path):
    clip = mocap("cmu_141_16_wave_hello.bvh")
    motion = _robot_motion(tmp_path / "m.npz", 60, load_motion(clip).fps)
    status, err = run(capsys, "evaluate", motion, "--robot", "jvrc1", "--source", clip)
    assert status == 2
    assert "has 299 frames at 120.005 fps, the motion 60 frames at 120.005 fps" in err
    assert "--resample" in err
    status, _ = run(capsys, "evaluate", motion, "--robot", "jvrc1", "--source",
                    mocap("cmu_141_16_wave_hello.bvh"), "--resample")
    assert status == 0


def test_source_mismatch_is_an_error_in_the_library(mocap):
    from conftest import load_test_robot

    from imesh.core.robot_motion import RobotMotion
    from imesh.evaluate.scoreboard import evaluate_motion

    robot = load_test_robot("jvrc1")
    motion = RobotMotion(q=np.tile(robot.q_nominal, (30, 1)), fps=60.0, robot=robot.name,
                         joint_names=robot.joint_names)
    with pytest.raises(SourceMismatchError) as info:
        evaluate_motion(robot, motion, source=mocap("cmu_141_16_wave_hello.bvh"))
    assert (info.value.what, info.value.expected) == ("fps", 60.0)
    assert info.value.found == pytest.approx(120.005, abs=1e-3)


def test_amc_skeleton_option(capsys, mocap, tmp_path):
    amc = tmp_path / "walk.amc"
    amc.write_bytes(mocap("cmu_07_05.amc").read_bytes())
    status, err = run(capsys, "inspect", amc)
    assert status == 2 and "pass the skeleton explicitly (--asf FILE" in err
    status, out = run(capsys, "inspect", amc, "--asf", mocap("cmu_07.asf"), "--json")
    assert status == 0 and '"frames": 517' in out


def test_corrupt_npz_members_are_motion_file_errors(tmp_path):
    """A member whose header declares more data than it holds is refused before reading."""
    import zipfile

    from imesh.io.robot_motion import load_robot_motion

    path = tmp_path / "big.npz"
    header = "{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000, 1000), }"
    npy = b"\x93NUMPY\x01\x00" + len(header + "\n").to_bytes(2, "little") + \
        (header + "\n").encode() + b"\0" * 64
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("fps.npy", npy)
    with pytest.raises(MotionFileError, match="declares shape"):
        load_robot_motion(path)


@pytest.mark.parametrize("options", [["--balance", "none"], ["--allow-flight"]])
def test_noise_clip_is_never_a_success(capsys, mocap, tmp_path, options):
    """The walk's skeleton with every channel replaced by noise (issue 17: reported as success
    with 30 m marker RMS, or a LinAlgError with the flight option): refused when loaded (2) or
    by the output gates (3), one line, no file."""
    head, rows = bvh_rows(mocap)
    rng = np.random.default_rng(5)
    noise = [" ".join(f"{v:.4f}" for v in rng.uniform(-40, 40, len(r.split())))
             for r in rows[:120]]
    clip = write_bvh(tmp_path / "noise.bvh", head, noise)
    out = tmp_path / "noise.npz"
    status, line = run(capsys, "-q", "retarget", clip, "--robot", "jvrc1", "-o", out, *options)
    assert status in (2, 3), line
    assert not out.exists()


def test_a_missing_optional_dependency_names_the_pip_command(monkeypatch):
    """One lazy-import helper for the heavy extras: the error names the feature and the command
    that installs what it needs."""
    from imesh.core.lazy import optional
    from imesh.errors import MissingDependencyError

    monkeypatch.setitem(sys.modules, "dartpy", None)  # an import of it now fails
    with pytest.raises(MissingDependencyError) as info:
        optional("dartpy", "pip install dartpy", "the physics check")
    assert str(info.value) == "the physics check needs dartpy: pip install dartpy"
    assert (info.value.module, info.value.pip) == ("dartpy", "pip install dartpy")
    assert optional("json", "pip install json", "x") is sys.modules["json"]

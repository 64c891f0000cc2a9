"""The pipeline end to end on real clips: limits hold, outputs follow the contract."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import hrp4c_urdf, load_test_robot

from imesh import load_motion
from imesh.cli import main
from imesh.pipeline.retarget import RetargetConfig, retarget

ROBOTS = ("jvrc1", "g1", "hrp4c")


@pytest.fixture(scope="module")
def wave(mocap):
    return load_motion(mocap("cmu_141_16_wave_hello.bvh"))


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_limits_hold_on_a_real_clip(name, wave):
    """The initial fit (balance "none") keeps every limit on the wave."""
    robot = load_test_robot(name)
    result = retarget(wave, robot, config=RetargetConfig(balance="none"))
    motion = result.motion
    dt = 1.0 / motion.fps
    jp = motion.joint_positions
    assert not ((jp < robot.q_lower - 1e-9) | (jp > robot.q_upper + 1e-9)).any()
    vel = np.diff(jp, axis=0) / dt
    assert (np.abs(vel) <= robot.v_max + 1e-6).all()
    acc = np.diff(jp, 2, axis=0) / dt**2
    assert (np.abs(acc) <= robot.a_max + 1e-6).all()
    assert result.morph.bone_residual_m <= 1e-6
    report = result.report()
    assert report["fit"]["marker_rms_mm"] < 100.0  # reported per clip by benchmarks/fitting.py


def test_wholebody_solves_the_wave(wave):
    """The wave starts with the right foot lifted and pitched and rests it on its toes: the
    lead-in steps it, the standing phase holds it flat; the evaluator finds no limit violation
    and the ZMP inside the support polygon."""
    from imesh.evaluate.scoreboard import evaluate_motion, metric_values

    robot = load_test_robot("jvrc1")
    res = retarget(wave, robot)
    m = metric_values(evaluate_motion(robot, res.motion, adapted=res.adapted))
    assert m["limit_violation_frames"] == 0
    assert m["zmp_inside_fraction"] >= 0.95  # issue 14 asks 0.99: docs/wholebody.md
    # 81 mm before the normal-force bound clipped the ankle polygons at 1.3 m g (docs/wholebody.md)
    assert m["marker_rms_mm"] <= 95.0
    assert res.wholebody.history[-1].sole_error_m <= 2e-3


def test_cli_retarget_writes_the_contract(mocap, tmp_path):
    out = tmp_path / "wave.npz"
    code = main(["-q", "retarget", str(mocap("cmu_141_16_wave_hello.bvh")), "--robot", "hrp4c",
                 "--urdf", str(hrp4c_urdf()), "-o", str(out), "--balance", "none"])
    assert code == 0
    with np.load(out) as data:
        assert set(data.files) == {"fps", "robot", "joint_names", "base_position",
                                   "base_quat_xyzw", "joint_positions", "adapted_positions_m",
                                   "adapted_marker_names"}
        assert str(data["robot"]) == "hrp4c"
        t = data["joint_positions"].shape[0]
        assert data["base_position"].shape == (t, 3) and data["base_quat_xyzw"].shape == (t, 4)
        np.testing.assert_allclose(np.linalg.norm(data["base_quat_xyzw"], axis=1), 1.0,
                                   atol=1e-9)


def test_cli_retarget_without_urdf_for_a_user_model_fails_cleanly(mocap, tmp_path, capsys):
    out = tmp_path / "x.npz"
    assert main(["-q", "retarget", str(mocap("cmu_141_16_wave_hello.bvh")), "--robot", "hrp4c",
                 "-o", str(out)]) == 2
    assert "--urdf" in capsys.readouterr().err
    assert not out.exists()


def _bvh_excerpt(src, dst, frames: int) -> None:
    """The first ``frames`` frames of a BVH file (text: header, 'Frames:' line, one line per
    frame)."""
    head, motion = src.read_text().split("MOTION", 1)
    lines = motion.strip().splitlines()
    body = [ln for ln in lines[2:] if ln.strip()][:frames]
    dst.write_text(head + "MOTION\n" + f"Frames: {len(body)}\n" + lines[1] + "\n"
                   + "\n".join(body) + "\n")


def test_flight_option_lists_unconstrained_frames_and_is_verified(mocap, tmp_path):
    """The leap of the pirouette/jete dance with --allow-flight: the run finishes, the report
    lists the flight frames left without support and ZMP constraints, and the written file is
    judged by the gates: without --force a failed verification exits 3 and writes nothing."""
    import json

    from imesh.evaluate.verify import failed_gates

    clip = tmp_path / "leap.bvh"
    _bvh_excerpt(mocap("cmu_05_06_dance_pirouettes_jete.bvh"), clip, 240)  # 2 s, one leap
    out, rep = tmp_path / "leap.npz", tmp_path / "leap.json"
    code = main(["-q", "retarget", str(clip), "--robot", "jvrc1", "--allow-flight", "--force",
                 "-o", str(out), "--json", str(rep)])
    assert code == 0 and out.is_file()
    report = json.loads(rep.read_text())
    flights = report["unconstrained_frames"]
    assert flights and all(30 <= a < b <= report["frames"] - 30 for a, b in flights)
    failed = failed_gates(report["metrics"])
    assert report["verification"]["passed"] == (not failed)
    out2 = tmp_path / "again.npz"
    code = main(["-q", "retarget", str(clip), "--robot", "jvrc1", "--allow-flight",
                 "-o", str(out2)])
    assert code == (3 if failed else 0)
    assert out2.is_file() == (not failed)


def test_evaluate_reads_the_adapted_markers_from_the_motion_file(mocap, tmp_path, capsys):
    """retarget stores the adapted markers in its .npz: imesh evaluate measures marker_rms_mm
    against them (the same number as with --adapted), not against the arranged source."""
    import json

    out, markers = tmp_path / "walk.npz", tmp_path / "walk_markers.npz"
    assert main(["-q", "retarget", str(mocap("cmu_02_01_walk.bvh")), "--robot", "jvrc1", "-o",
                 str(out), "--markers", str(markers)]) == 0
    reports = []
    for extra in ([], ["--adapted", str(markers)]):
        rep = tmp_path / f"rep{len(reports)}.json"
        assert main(["evaluate", str(out), "--robot", "jvrc1", "--json", str(rep), *extra]) == 0
        reports.append(json.loads(rep.read_text())["marker_rms_mm"])
    capsys.readouterr()
    assert reports[0]["reference"] == reports[1]["reference"] == "adapted markers"
    assert reports[0]["value"] == pytest.approx(reports[1]["value"], abs=1e-9)
    assert reports[0]["value"] < 60.0

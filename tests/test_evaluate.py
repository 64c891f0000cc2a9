"""Quality metrics and ``imesh evaluate``: collision and ground checks on constructed motions,
support/ZMP/skid/limit metrics, marker metrics, motion files from other tools, bad inputs."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest
from conftest import load_test_robot

from imesh.cli.evaluate import run
from imesh.cli.parsers import add_evaluate as add_parser
from imesh.core.robot_motion import RobotMotion
from imesh.errors import ImeshError, MotionFileError
from imesh.evaluate.motion_files import load_motion_file
from imesh.evaluate.scoreboard import METRIC_NAMES, evaluate_motion, metric_values
from imesh.evaluate.table import format_table
from imesh.io.robot_motion import save_robot_motion
from imesh.metrics import close_pair_error, keypoint_motion, marker_rms_mm
from imesh.metrics.collision import check_ground, check_self_collisions
from imesh.metrics.derivatives import motion_derivatives
from imesh.metrics.limits import limit_violations
from imesh.metrics.polygon import convex_hull_2d, inside_polygon, polygon_centroid
from imesh.metrics.skid import foot_skid
from imesh.metrics.soles import sole_tracks
from imesh.metrics.support import EVALUATOR_SUPPORT, detect_support
from imesh.robot import load_robot

ROOT = Path(__file__).resolve().parents[1]
DESIGN = ROOT.parent / "shared" / "DESIGN.md"


@pytest.fixture(scope="module")
def jvrc1():
    return load_robot("jvrc1")


def motion_of(robot, q: np.ndarray, fps: float = 30.0) -> RobotMotion:
    return RobotMotion(q=q, fps=fps, robot=robot.name, joint_names=robot.joint_names)


def standing_q(robot, n: int) -> np.ndarray:
    return np.repeat(robot.q_nominal[None], n, axis=0)


def arm_through_torso(robot, n: int = 61) -> np.ndarray:
    """The left upper arm swung inward through the chest and back (shoulder roll -> -1 rad)."""
    q = standing_q(robot, n)
    s = np.sin(np.linspace(0, np.pi, n)) ** 2
    i = 7 + robot.joint_index("L_SHOULDER_R")
    q[:, i] += (-1.0 - q[0, i]) * s
    q[:, 7 + robot.joint_index("L_SHOULDER_P")] += -0.6 * s
    return q


# ----------------------------------------------------------------------------------------------
# acceptance 3: constructed self-collision and ground penetration


def test_arm_through_torso_is_flagged_with_the_right_pair(jvrc1):
    """The evaluator scores the URDF geometry (the forearm in the chest), with the capsules'
    figure beside it; the upper arm and the chest capsule overlap in the standing pose (an
    ignored pair, robots/jvrc1/collision_pairs.toml), so the forearm's pair is flagged."""
    q = arm_through_torso(jvrc1)
    check = check_self_collisions(jvrc1, q)
    assert 0 < check.mesh.n_frames < len(q)
    assert not check.mesh.colliding[0] and not check.mesh.colliding[-1]
    assert check.mesh.colliding[len(q) // 2]
    worst = check.mesh.pairs[0]
    assert worst.frames == ("L_ELBOW_P_S", "WAIST_R_S")
    assert worst.worst_frame == pytest.approx(len(q) // 2, abs=3)
    entry = evaluate_motion(jvrc1, motion_of(jvrc1, q))["self_collision_frames"]
    assert entry["value"] == check.mesh.n_frames
    assert entry["capsule_frames"] == check.capsules.n_frames >= check.mesh.n_frames
    assert entry["worst_pairs"][0]["pair"] == ["L_ELBOW_P_S", "WAIST_R_S"]
    assert entry["deepest_mm"] == pytest.approx(1e3 * worst.max_depth_m, abs=0.01)
    assert 30 < entry["deepest_mm"] <= entry["capsule_deepest_mm"]
    assert "capsules" in format_table({"self_collision_frames": entry})


def test_feet_5_cm_below_ground_are_flagged(jvrc1):
    q = standing_q(jvrc1, 30)
    q[:, 2] -= 0.05
    ground = check_ground(jvrc1, q)
    assert ground.penetration_mm == pytest.approx(50.0, abs=0.5)
    assert ground.lowest_frame[ground.worst_frame] in (jvrc1.foot_frames.values())
    rep = evaluate_motion(jvrc1, motion_of(jvrc1, q))
    assert rep["ground_penetration_mm"]["value"] == pytest.approx(50.0, abs=0.5)
    assert rep["ground_penetration_mm"]["frames_below_5mm"] == 30


def test_floating_robot_is_flagged(jvrc1):
    q = standing_q(jvrc1, 30)
    q[:, 2] += 0.05
    from imesh.metrics.support import planted_feet

    soles = sole_tracks(jvrc1, q, 30.0)
    ground = check_ground(jvrc1, q, planted=planted_feet(soles))
    assert ground.penetration_mm == 0.0 and ground.floating.all()
    rep = evaluate_motion(jvrc1, motion_of(jvrc1, q))
    assert rep["ground_penetration_mm"]["floating_frames"] == 30
    assert rep["zmp_inside_fraction"]["value"] is None  # the soles never touch the ground
    assert "no support" in rep["zmp_inside_fraction"]["reason"]


# ----------------------------------------------------------------------------------------------
# kinematic metrics


def test_standing_motion_scores_clean(jvrc1):
    rep = evaluate_motion(jvrc1, motion_of(jvrc1, standing_q(jvrc1, 45)))
    assert list(rep) == list(METRIC_NAMES)
    v = metric_values(rep)
    assert v["self_collision_frames"] == 0
    assert v["ground_penetration_mm"] < 1e-3
    assert v["foot_skid_mm_per_frame"] == pytest.approx(0.0, abs=1e-9)
    assert v["limit_violation_frames"] == 0
    assert v["zmp_inside_fraction"] == 1.0
    # static: ZMP = CoM projection; desired = centre of the two soles' hull
    soles = sole_tracks(jvrc1, jvrc1.q_nominal[None], 30.0)
    hull = convex_hull_2d(np.concatenate([soles.corners[s][0, :, :2] for s in soles.corners]))
    expected = 1e3 * np.linalg.norm(jvrc1.com(jvrc1.q_nominal)[:2] - polygon_centroid(hull))
    assert v["zmp_error_mm"] == pytest.approx(expected, rel=1e-6)
    assert rep["zmp_error_mm"]["double_support_frames"] == 45
    for name in ("marker_rms_mm", "close_pair_error", "physics_fell", "seconds_per_frame"):
        assert v[name] is None and rep[name]["reason"]
    assert "self_collision_frames" in format_table(rep)


def test_sliding_feet_skid(jvrc1):
    """The whole robot sliding at 0.15 m/s with its soles on the ground: 5 mm per 30-fps frame
    at any frame rate."""
    for fps in (30.0, 120.0):
        q = standing_q(jvrc1, int(fps))
        q[:, 0] += 0.15 * np.arange(len(q)) / fps
        soles = sole_tracks(jvrc1, q, fps)
        support = detect_support(soles).support
        assert support.all()
        skid = foot_skid(soles, support)
        assert skid.mean_mm_per_frame == pytest.approx(5.0, rel=1e-6)
        assert skid.fraction_over_10mm == 0.0


def test_planned_support_is_judged_as_planned(jvrc1):
    """A motion that carries its planned contact modes is judged by them: the robot standing
    for 1 s and then sliding both feet at 0.15 m/s for 1 s. Planned as a slide, the standing
    part has no skid and the slide is reported apart (5 mm per 30-fps frame); without the
    plan the detection calls the whole clip support and the skid is their mixture; a plan that
    swings the left foot leaves its flat, sliding sole out of the footprints."""
    fps = 30.0
    q = standing_q(jvrc1, 60)
    q[30:, 0] += 0.15 * np.arange(1, 31) / fps
    modes = np.ones((60, 2), dtype=np.int8)
    modes[30:] = 2  # slide
    planned = RobotMotion(q=q, fps=fps, robot=jvrc1.name, joint_names=jvrc1.joint_names,
                          contact_modes=modes)
    rep = evaluate_motion(jvrc1, planned)
    skid = rep["foot_skid_mm_per_frame"]
    assert skid["value"] == pytest.approx(0.0, abs=1e-9)
    assert skid["slide_mm_per_frame"] == pytest.approx(5.0, rel=1e-6)
    # frames 0-28 per foot: the frame beside a slide counts with it
    assert skid["support_samples"] == 2 * 28 and skid["support"].startswith("planned")
    assert rep["sole_deviation_mm"]["value"] == pytest.approx(0.0, abs=1e-4)
    detected = evaluate_motion(jvrc1, motion_of(jvrc1, q))
    assert detected["foot_skid_mm_per_frame"]["value"] == pytest.approx(5.0 * 30 / 59, rel=1e-6)
    assert detected["sole_deviation_mm"]["value"] > 70.0  # the slide's sole off its footprint
    modes[30:] = [0, 1]  # the left foot swung: its slide frames are not judged
    swung = evaluate_motion(jvrc1, RobotMotion(q=q, fps=fps, robot=jvrc1.name,
                                               joint_names=jvrc1.joint_names,
                                               contact_modes=modes))
    assert swung["foot_skid_mm_per_frame"]["support_samples"] == 59 + 29


def test_support_phases_follow_the_soles(jvrc1):
    """A foot lifted 10 cm for a third of a second leaves support; a fast foot touching the
    ground with its toe only is not in support either; a fast foot lying flat on the ground
    for 0.2 s or more slides: in support (it carries the body)."""
    fps, n = 60.0, 120
    q = standing_q(jvrc1, n)
    soles = sole_tracks(jvrc1, q, fps)
    soles.centers["left"][40:60, 2] += 0.1
    soles.corners["left"][40:60, :, 2] += 0.1
    soles.centers["right"][80:, 0] += np.arange(n - 80) * 2.0 / fps  # 2 m/s
    heel = soles.corners["right"][:, :, 0] < soles.centers["right"][:1, None, 0]
    soles.corners["right"][80:, :, 2] += np.where(heel[80:], 0.015, 0.0)  # on its toe
    support = detect_support(soles).support
    # (the instantaneous 10 cm step is a fast frame on either side of the lift)
    assert support[:39, 0].all() and not support[42:58, 0].any() and support[62:, 0].all()
    assert support[:78, 1].all() and not support[82:, 1].any()
    soles.corners["right"][80:, :, 2] -= np.where(heel[80:], 0.015, 0.0)  # flat: a slide
    assert detect_support(soles, EVALUATOR_SUPPORT).support[:, 1].all()
    assert not detect_support(soles).support[82:, 1].any()  # the solve's and DART's: as before


def test_limit_violations_position_and_velocity(jvrc1):
    q = standing_q(jvrc1, 20)
    i = jvrc1.joint_index("L_KNEE")
    q[5:8, 7 + i] = jvrc1.q_upper[i] + 0.1  # out of range for 3 frames
    j = jvrc1.joint_index("R_ELBOW_P")
    q[12:, 7 + j] -= 2 * jvrc1.v_max[j] / 30.0  # a step of twice the velocity limit
    rep = limit_violations(jvrc1, q, 30.0)
    assert rep.position.sum() == 3 and rep.position_joints == {"L_KNEE": 3}
    # velocity: entering and leaving the knee excursion, and the elbow step
    assert rep.velocity_joints["R_ELBOW_P"] == 1
    assert rep.worst_velocity_ratio >= 2.0 and rep.velocity_joints["L_KNEE"] == 2
    ev = evaluate_motion(jvrc1, motion_of(jvrc1, q))["limit_violation_frames"]
    assert ev["position"] == 3 and ev["value"] == int(rep.any.sum())


def test_polygon_helpers():
    square = convex_hull_2d(np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]]))
    assert len(square) == 4
    assert inside_polygon(np.array([0.5, 0.5]), square)
    assert not inside_polygon(np.array([1.5, 0.5]), square)
    np.testing.assert_allclose(polygon_centroid(square), [0.5, 0.5])


def test_motion_derivatives_of_a_constant_twist(jvrc1):
    """A base moving with a constant body twist and joints at constant rates."""
    fps, n = 100.0, 50
    twist = np.r_[0.3, -0.1, 0.05, 0.2, -0.4, 0.6]
    rates = np.linspace(-1, 1, jvrc1.dof)
    q = np.array([jvrc1.integrate(jvrc1.q_nominal, np.r_[twist, rates] * t / fps)
                  for t in range(n)])
    v, a = motion_derivatives(q, fps)
    np.testing.assert_allclose(v[1:-1, 6:], np.tile(rates, (n - 2, 1)), atol=1e-9)
    np.testing.assert_allclose(v[1:-1, 3:6], np.tile(twist[3:], (n - 2, 1)), atol=1e-9)
    np.testing.assert_allclose(v[1:-1, :3], np.tile(twist[:3], (n - 2, 1)), atol=1e-4)
    assert np.abs(a[2:-2]).max() < 1e-2


def test_zmp_jitter_is_the_zig_zag_central_differences_do_not_see(jvrc1):
    """A standing robot whose base zig-zags +-1 mm in x between frames has a CoM accelerating
    by 4 A / h^2 from frame to frame, a ZMP swinging z_c / g of that, which central
    differences (and so zmp_inside_fraction, but at the clip's ends, where they are one-sided)
    do not see; still, it is 0."""
    from imesh.metrics.zmp import zmp_jitter_mm

    fps, n, amp = 30.0, 40, 1e-3
    still = standing_q(jvrc1, n)
    q = still.copy()
    q[:, 0] += amp * (-1.0) ** np.arange(n)
    com = np.array([jvrc1.com(qt) for qt in q])
    expect = 1e3 * np.mean(com[:, 2]) / 9.81 * 4 * amp * fps ** 2
    assert zmp_jitter_mm(com, fps) == pytest.approx(expect, rel=1e-9)
    assert expect > 300.0  # a 1 mm zig-zag swings the ZMP by a third of a metre
    assert zmp_jitter_mm(np.array([jvrc1.com(qt) for qt in still]), fps) < 1e-9
    rep = evaluate_motion(jvrc1, motion_of(jvrc1, q, fps))
    assert rep["zmp_inside_fraction"]["value"] >= 0.9
    assert rep["zmp_inside_fraction"]["zmp_jitter_mm"] == pytest.approx(expect, rel=1e-6)


# ----------------------------------------------------------------------------------------------
# marker metrics


def test_marker_metrics_against_the_robot_itself(jvrc1):
    q = arm_through_torso(jvrc1, 20)
    kp = keypoint_motion(jvrc1, q, 30.0)
    assert marker_rms_mm(kp, kp) == 0.0
    moved = kp.with_positions(kp.positions_m + [0.0, 0.0, 0.01])
    assert marker_rms_mm(kp, moved) == pytest.approx(10.0)
    assert close_pair_error(kp, moved) == pytest.approx(0.0, abs=1e-12)
    rep = evaluate_motion(jvrc1, motion_of(jvrc1, q), source=kp, adapted=moved)
    assert rep["marker_rms_mm"]["value"] == pytest.approx(10.0)
    assert rep["marker_rms_mm"]["reference"] == "adapted markers"
    assert rep["close_pair_error"]["value"] == pytest.approx(0.0, abs=1e-12)


def test_source_clip_is_arranged_for_the_robot(jvrc1, mocap):
    """With a real clip as source, the metrics compare the robot to the arranged human."""
    from imesh.human.arrange import arrange_for_robot
    from imesh.io import load_motion
    from imesh.morph.adapt import prepare_markers

    clip = mocap("cmu_141_16_wave_hello.bvh")
    arranged = arrange_for_robot(prepare_markers(load_motion(clip)), jvrc1).motion
    q = standing_q(jvrc1, arranged.n_frames)
    rep = evaluate_motion(jvrc1, motion_of(jvrc1, q, arranged.fps), source=clip)
    assert rep["marker_rms_mm"]["reference"].startswith("arranged source")
    assert rep["marker_rms_mm"]["frames"] == arranged.n_frames
    assert rep["marker_rms_mm"]["value"] > 10  # a standing robot at the origin vs a human
    assert rep["close_pair_error"]["value"] > 0


# ----------------------------------------------------------------------------------------------
# files from imesh and other tools; bad inputs (acceptance 4)


def plain_npz(path, model, q, fps=30.0, quat="xyzw", names=None, **extra):
    quat_arr = q[:, 3:7] if quat == "xyzw" else q[:, [6, 3, 4, 5]]
    np.savez(path, joint_names=np.array(names or model.joint_names),
             joint_positions=q[:, 7:], base_position=q[:, :3],
             **{f"base_quat_{quat}": quat_arr}, fps=fps, **extra)


def test_plain_arrays_from_other_tools(jvrc1, tmp_path):
    q = arm_through_torso(jvrc1, 10)
    a, b = tmp_path / "xyzw.npz", tmp_path / "wxyz.npz"
    plain_npz(a, jvrc1, q)
    # another tool's joint order and quaternion order
    perm = np.random.default_rng(1).permutation(jvrc1.dof)
    shuffled = np.concatenate([q[:, :7], q[:, 7:][:, perm]], axis=1)
    plain_npz(b, jvrc1, shuffled, quat="wxyz", names=[jvrc1.joint_names[i] for i in perm])
    for path in (a, b):
        motion = load_motion_file(path, jvrc1)
        np.testing.assert_allclose(motion.q, q, atol=1e-12)
        assert motion.robot == "jvrc1" and motion.fps == 30.0


def test_bad_motion_files_give_clear_errors(jvrc1, tmp_path):
    q = standing_q(jvrc1, 5)
    wrong_count = tmp_path / "count.npz"
    plain_npz(wrong_count, jvrc1, np.concatenate([q, q[:, -1:]], axis=1))
    with pytest.raises(MotionFileError, match="joint_positions has shape"):
        load_motion_file(wrong_count, jvrc1)
    unknown = tmp_path / "unknown.npz"
    plain_npz(unknown, jvrc1, q, names=["KNEE_X"] + list(jvrc1.joint_names[1:]))
    with pytest.raises(MotionFileError, match="unknown joint names KNEE_X.*L_HIP_P"):
        load_motion_file(unknown, jvrc1)
    nan = tmp_path / "nan.npz"
    q_nan = q.copy()
    q_nan[3, 10] = np.nan
    plain_npz(nan, jvrc1, q_nan)
    with pytest.raises(MotionFileError, match="non-finite value .* frame 3"):
        load_motion_file(nan, jvrc1)
    missing = tmp_path / "missing.npz"
    np.savez(missing, joint_positions=q[:, 7:])
    with pytest.raises(MotionFileError, match="missing keys"):
        load_motion_file(missing, jvrc1)
    no_fps = tmp_path / "nofps.npz"
    np.savez(no_fps, joint_names=np.array(jvrc1.joint_names), joint_positions=q[:, 7:],
             base_position=q[:, :3], base_quat_xyzw=q[:, 3:7])
    with pytest.raises(MotionFileError, match="--fps"):
        load_motion_file(no_fps, jvrc1)
    assert load_motion_file(no_fps, jvrc1, fps=50.0).fps == 50.0
    # an imesh file with a NaN and one with a wrong joint count
    good = tmp_path / "good.npz"
    save_robot_motion(good, motion_of(jvrc1, q))
    data = dict(np.load(good))
    data["joint_positions"] = data["joint_positions"][:, :-1]
    np.savez(tmp_path / "short.npz", **data)
    with pytest.raises(ImeshError, match="columns|joint"):
        load_motion_file(tmp_path / "short.npz", jvrc1)


def test_motion_for_another_robot_names_the_mismatch(jvrc1, tmp_path):
    q = standing_q(jvrc1, 5)
    path = tmp_path / "g1.npz"
    plain_npz(path, jvrc1, q, robot="g1")
    with pytest.raises(MotionFileError, match="robot 'g1', not of 'jvrc1'"):
        load_motion_file(path, jvrc1)
    hrp = load_test_robot("hrp4c")
    imesh_file = tmp_path / "jvrc.csv"
    save_robot_motion(imesh_file, motion_of(jvrc1, q))
    with pytest.raises(MotionFileError, match="'jvrc1', not of 'hrp4c'"):
        load_motion_file(imesh_file, hrp)
    with pytest.raises(ImeshError, match="'jvrc1', not 'hrp4c'"):
        evaluate_motion(hrp, motion_of(jvrc1, q))


# ----------------------------------------------------------------------------------------------
# the command line and the JSON keys


def design_metric_names() -> list[str]:
    """The metric names of DESIGN.md's "Quality metrics" table."""
    import re

    text = DESIGN.read_text()
    table = text[text.index("## Quality metrics"):]
    table = table[:table.index("\n## ", 5)]
    names = []
    for line in table.splitlines():
        if line.startswith("| `"):
            names += re.findall(r"`([a-z_]+)`", line.split("|")[1])
    return names


def test_metric_names_are_design_names():
    if not DESIGN.is_file():
        pytest.skip("DESIGN.md not beside the project")
    assert list(METRIC_NAMES) == design_metric_names()


def _cli(argv):
    parser = argparse.ArgumentParser(prog="imesh")
    add_parser(parser.add_subparsers(dest="command"))
    return run(parser.parse_args(argv))


def test_cli_json_keys_are_exactly_the_metric_names(jvrc1, tmp_path, capsys):
    motion = tmp_path / "m.csv"
    save_robot_motion(motion, motion_of(jvrc1, arm_through_torso(jvrc1, 30)))
    out = tmp_path / "report.json"
    plot = tmp_path / "run.png"
    assert _cli(["evaluate", str(motion), "--robot", "jvrc1", "--physics", "--json", str(out),
                 "--plot", str(plot)]) == 0
    report = json.loads(out.read_text())
    assert list(report) == list(METRIC_NAMES)
    assert report["self_collision_frames"]["value"] > 0
    assert report["physics_fell"]["value"] in (True, False)
    assert report["tracking_rms_rad"]["value"] is not None
    assert plot.is_file()
    printed = capsys.readouterr().out
    assert "self_collision_frames" in printed and "-WAIST_R_S" in printed


def test_cli_malformed_file_is_an_imesh_error(tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, something=np.zeros(3))
    with pytest.raises(ImeshError, match="missing keys"):
        _cli(["evaluate", str(bad), "--robot", "jvrc1"])


def test_cli_main_wiring(jvrc1, tmp_path, capsys):
    """Through ``imesh.cli.main``, the command line's entry point."""
    from imesh import cli

    motion = tmp_path / "m.npz"
    save_robot_motion(motion, motion_of(jvrc1, standing_q(jvrc1, 10)))
    out = tmp_path / "r.json"
    assert cli.main(["evaluate", str(motion), "--robot", "jvrc1", "--json", str(out)]) == 0
    assert list(json.loads(out.read_text())) == list(METRIC_NAMES)
    bad = tmp_path / "bad.npz"
    np.savez(bad, something=np.zeros(3))
    assert cli.main(["evaluate", str(bad), "--robot", "jvrc1"]) == 2
    assert "missing keys" in capsys.readouterr().err

"""Arm imitation of Kim, Kim & Oh 2005 (imesh.arms) on the real wave clip and the three robots:
bounds, residuals, analytic gradients, the W10 term, solvers, the CLI mode and the DART PID."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from conftest import load_test_robot

import imesh
from imesh.arms import (
    ArmsConfig,
    ArmsError,
    FrameObjective,
    arm_model,
    check_limits,
    derived_arm_joints,
    imitate_arms,
    refine_arms,
)
from imesh.arms.solvers import solve_gn, solve_slsqp
from imesh.cli import main
from imesh.core.limits import JointLimits, LimitOptions
from imesh.core.robot_motion import RobotMotion
from imesh.io.robot_motion import NPZ_KEYS
from imesh.robot.hands import suggest_hand_points

ROBOTS = ("jvrc1", "g1", "hrp4c")
WAVE = "cmu_141_16_wave_hello.bvh"
ARM_DOF = {"jvrc1": 7, "g1": 7, "hrp4c": 6}

_RUNS: dict = {}


@pytest.fixture(scope="module")
def wave(mocap):
    return imesh.load_motion(mocap(WAVE))


def run(robot_name: str, clip, **changes):
    """imitate_arms on the wave, cached per (robot, settings)."""
    key = (robot_name, tuple(sorted(changes.items())))
    if key not in _RUNS:
        _RUNS[key] = imitate_arms(load_test_robot(robot_name), clip,
                                  config=ArmsConfig(**changes))
    return _RUNS[key]


# ----------------------------------------------------------------------------------------------
# the robot side


@pytest.mark.parametrize("name", ROBOTS)
def test_arm_model_from_markers_toml(name):
    robot = load_test_robot(name)
    for side in ("left", "right"):
        arm = arm_model(robot, side)
        assert arm.n == ARM_DOF[name] == len(derived_arm_joints(robot, side))
        assert arm.joints == derived_arm_joints(robot, side)  # [arms] gives no joints
        # the shipped [arms] points are the ones the derivation rule gives
        frame, points = suggest_hand_points(robot, side)
        assert frame == robot.markers.arms[side].frame
        np.testing.assert_allclose(arm.offsets_m[:3], points, atol=6e-5)
        assert 0.3 < arm.length_m < 0.6


def test_unknown_arm_joint_is_named():
    from imesh.robot import load_robot

    robot = load_robot("jvrc1")  # its own Robot object: the cached test robot stays intact
    table = dataclasses.replace(robot.markers.arms["left"], joints=("L_SHOULDER_P", "L_ELBOW"))
    robot.markers = dataclasses.replace(robot.markers,
                                        arms={**robot.markers.arms, "left": table})
    with pytest.raises(ArmsError, match="L_ELBOW.*not an actuated.*valid: L_ELBOW_Y, L_ELBOW_P"):
        arm_model(robot, "left")
    table = dataclasses.replace(table, joints=("L_SHOULDER_P", "R_ELBOW_P"))
    robot.markers = dataclasses.replace(robot.markers,
                                        arms={**robot.markers.arms, "left": table})
    with pytest.raises(ArmsError, match="R_ELBOW_P.*does not move the hand link"):
        arm_model(robot, "left")


def test_arms_table_errors(tmp_path):
    from imesh.robot.errors import RobotConfigError
    from imesh.robot.markers_config import load_markers_config

    base = (load_test_robot("jvrc1").markers.path).read_text()
    bad = tmp_path / "markers.toml"
    bad.write_text(base + '\n[arms.middle]\nframe = "X"\n')
    with pytest.raises(RobotConfigError, match=r"arms.middle.*valid: left, right"):
        load_markers_config(bad)
    bad.write_text(base.replace("thumb = [0.09, 0.0, 0.0]", "thumb = [0.09, 0.0]", 1))
    with pytest.raises(RobotConfigError, match=r"arms.left.thumb"):
        load_markers_config(bad)


# ----------------------------------------------------------------------------------------------
# the objective and its gradient (eqs 2-6, 16-18)


def _problem(name: str, side: str, seed: int) -> tuple[FrameObjective, np.ndarray]:
    robot = load_test_robot(name)
    arm = arm_model(robot, side)
    rng = np.random.default_rng(seed)
    q = robot.q_nominal.copy()
    j = arm.joint_index
    q[7 + j] = np.clip(q[7 + j] + rng.uniform(-0.6, 0.6, arm.n), robot.q_lower[j],
                       robot.q_upper[j])
    targets = arm.points(q)[:3] + rng.normal(0.0, 0.05, (3, 3))
    a_hat = rng.normal(size=3)
    obj = FrameObjective(arm, q, targets, np.array([1.0, 0.7, 0.4]), a_hat / np.linalg.norm(a_hat),
                         upper_arm_weight=1.3, damping=1e-2)
    return obj, rng.uniform(-0.05, 0.05, arm.n)


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("side", ["left", "right"])
def test_gradient_matches_central_differences(name, side):
    obj, x = _problem(name, side, seed=3 if side == "left" else 4)
    f, grad = obj.value_and_gradient(x)
    h = 1e-6
    fd = np.array([(obj.value(x + h * e) - obj.value(x - h * e)) / (2 * h)
                   for e in np.eye(len(x))])
    assert np.abs(fd - grad).max() <= 1e-6 * np.abs(grad).max()
    assert f == pytest.approx(obj.value(x), rel=1e-12)
    # the least-squares form used by Gauss-Newton is the same function and gradient
    r, jac = obj.residuals_and_jacobian(x)
    assert float(r @ r) == pytest.approx(f, rel=1e-12)
    np.testing.assert_allclose(2.0 * jac.T @ r, grad, rtol=1e-10, atol=1e-14)


def test_upper_arm_term_is_the_squared_perpendicular_component():
    """Eq. 4 (with its sign corrected): ||s||^2 = |r|^2 sin^2(angle between r and a_hat)."""
    obj, x = _problem("jvrc1", "right", seed=5)
    _, s2 = obj.terms(x)
    p = obj.arm.points(obj.configuration(x))
    r = p[3] - p[4]
    sin2 = 1.0 - (r @ obj.a_hat / np.linalg.norm(r)) ** 2
    assert s2 == pytest.approx(float(r @ r) * sin2, rel=1e-10)
    assert s2 >= 0.0


@pytest.mark.parametrize("name", ["jvrc1", "hrp4c"])
def test_gn_and_slsqp_reach_the_same_optimum(name, wave):
    """Same frame problems (the boxes of a real run), same start: the objectives agree."""
    res = run(name, wave)
    arm = res.arms["right"]
    for t in (40, 90, 150, 220):
        q_prev = res.motion.q[t - 1].copy()
        base = q_prev[7 + arm.arm.joint_index]
        lo, hi = arm.box_lo[t] - base, arm.box_hi[t] - base
        obj = FrameObjective(arm.arm, q_prev, arm.targets.hand_m[t], arm.targets.weights[t],
                             arm.targets.upper_arm_dir[t], 1.0, 1e-2)
        x_gn, info_gn = solve_gn(obj, lo, hi, np.zeros(arm.arm.n), 50, 1e-7, 1e-12)
        x_sl, info_sl = solve_slsqp(obj, lo, hi, np.zeros(arm.arm.n), 100, 1e-7, 1e-12)
        assert np.all(x_gn >= lo) and np.all(x_gn <= hi)
        f_gn, f_sl = obj.value(x_gn), obj.value(x_sl)
        assert f_gn <= f_sl * (1 + 1e-6) + 1e-12, (t, f_gn, f_sl)
        assert info_gn.converged


# ----------------------------------------------------------------------------------------------
# the wave on every robot (acceptance 1)


@pytest.mark.parametrize("name", ROBOTS)
def test_wave_within_all_bounds(name, wave):
    robot = load_test_robot(name)
    res = run(name, wave)
    report = res.report()
    assert report["frames_outside"] == {"position": 0, "velocity": 0, "acceleration": 0}
    q = res.motion.q
    assert q.shape == (wave.n_frames, robot.nq)
    arm_cols = np.concatenate([a.arm.joint_index for a in res.arms.values()])
    # independent check from the output: robot limits, backward differences
    limits = JointLimits(lower=robot.q_lower[arm_cols], upper=robot.q_upper[arm_cols],
                         v_max=robot.v_max[arm_cols], a_max=robot.a_max[arm_cols])
    counts = check_limits(q[:, 7 + arm_cols], limits, res.motion.fps).counts()
    assert counts == {"position": 0, "velocity": 0, "acceleration": 0}
    # base, legs, torso and head stay at the nominal pose
    others = np.setdiff1d(np.arange(robot.dof), arm_cols)
    np.testing.assert_array_equal(q[:, :7], np.tile(robot.q_nominal[:7], (len(q), 1)))
    np.testing.assert_array_equal(q[:, 7 + others], np.tile(robot.q_nominal[7 + others],
                                                            (len(q), 1)))
    left, right = report["arms"]["left"], report["arms"]["right"]
    assert left["hand_rms_mm"] < 10.0 and left["upper_arm_rms_deg"] < 3.0  # the resting arm
    assert right["hand_rms_mm"] < 80.0 and right["upper_arm_rms_deg"] < 12.0  # the wave
    assert 0.6 < right["rho"] < 1.6
    assert right["frames_at_velocity_bound"] + right["frames_at_acceleration_bound"] > 0


@pytest.mark.parametrize("name", ROBOTS)
def test_upper_arm_term_lowers_the_upper_arm_error(name, wave):
    """Ablation of eq. 2's second term: W10 = 0 vs the default W10 = 1."""
    on, off = run(name, wave), run(name, wave, upper_arm_weight=0.0)
    for side in ("left", "right"):
        a_on = on.arms[side].upper_arm_rms_deg
        a_off = off.arms[side].upper_arm_rms_deg
        assert a_on < 0.7 * a_off, (side, a_on, a_off)
    assert off.report()["frames_outside"] == {"position": 0, "velocity": 0, "acceleration": 0}


def test_velocity_bounds_hold_where_the_human_is_faster(wave):
    """HRP-4C's arm motors (2-4 rad/s) are slower than the wave: unbounded, the solution
    exceeds them; bounded, it stays within and pays in hand-point error."""
    free = run("hrp4c", wave,
               limits=LimitOptions(enforce_velocity=False, enforce_acceleration=False))
    bounded = run("hrp4c", wave, limits=LimitOptions(enforce_acceleration=False))
    a_free, a_bounded = free.arms["right"], bounded.arms["right"]
    assert a_free.violations.worst_velocity_ratio > 2.0
    assert a_free.violations.velocity.sum() > 10
    counts = a_bounded.violations.counts()  # (acceleration not enforced in either run)
    assert counts["position"] == 0 and counts["velocity"] == 0
    assert a_bounded.violations.worst_velocity_ratio <= 1.0 + 1e-6
    assert a_bounded.hand_rms_mm > a_free.hand_rms_mm


def test_lookahead_keeps_every_limit_where_the_per_frame_scheme_runs_off(wave):
    """With the 8 Hz low-pass the wave's 4.7 Hz hand flap needs far more than 100 rad/s^2: the
    greedy per-frame bounds lose the arm; the look-ahead projection keeps it near the target."""
    greedy = run("jvrc1", wave, sides=("right",), lowpass_hz=8.0)
    ahead = run("jvrc1", wave, sides=("right",), lowpass_hz=8.0, lookahead=True)
    for res in (greedy, ahead):
        assert res.report()["frames_outside"] == {"position": 0, "velocity": 0,
                                                  "acceleration": 0}
    assert ahead.arms["right"].hand_rms_mm < 0.6 * greedy.arms["right"].hand_rms_mm


def test_check_limits_counts_backward_differences():
    lim = JointLimits(lower=np.array([-1.0]), upper=np.array([1.0]), v_max=np.array([1.0]),
                      a_max=np.array([10.0]))
    fps = 10.0
    theta = np.array([[0.0], [0.1], [0.2], [0.35], [1.2]])
    v = check_limits(theta, lim, fps)
    assert v.position.tolist() == [False, False, False, False, True]
    assert v.velocity.tolist() == [False, False, False, True, True]
    assert v.acceleration.tolist() == [False, False, False, False, True]  # 0.05 <= 0.1 rad


# ----------------------------------------------------------------------------------------------
# the main pipeline's arms (--fit sqp), CLI, plots, errors


def test_refine_arms_replaces_only_the_arm_joints(wave):
    robot = load_test_robot("jvrc1")
    from imesh.arms import human_arm_markers

    human = human_arm_markers(wave, None)
    q = np.tile(robot.q_nominal, (wave.n_frames, 1))
    q[:, 7 + robot.joint_index("WAIST_Y")] = np.linspace(0.0, 0.2, wave.n_frames)
    motion = RobotMotion(q=q, fps=wave.fps, robot=robot.name, joint_names=robot.joint_names)
    out, report = refine_arms(robot, motion, human, ArmsConfig(frame="torso"))
    arm_cols = [robot.joint_index(n) for a in report["arms"].values() for n in a["joints"]]
    others = np.setdiff1d(np.arange(robot.dof), arm_cols)
    np.testing.assert_array_equal(out.q[:, 7 + others], q[:, 7 + others])
    assert report["mode"] == "refine" and set(report["before"]) == {"left", "right"}
    assert report["frames_outside"] == {"position": 0, "velocity": 0, "acceleration": 0}
    assert report["arms"]["left"]["hand_rms_mm"] < report["before"]["left"]["hand_rms_mm"]
    with pytest.raises(ArmsError, match="frames"):
        refine_arms(robot, motion.frames(0, 10), human)


def test_cli_arms_mode_writes_motion_report_and_plots(mocap, tmp_path, capsys):
    out, rep, plots = tmp_path / "w.npz", tmp_path / "w.json", tmp_path / "plots"
    code = main(["-q", "retarget", str(mocap(WAVE)), "--robot", "jvrc1", "--mode", "arms",
                 "-o", str(out), "--json", str(rep), "--plots", str(plots)])
    assert code == 0
    with np.load(out) as data:
        assert sorted(data.files) == sorted(NPZ_KEYS)
    report = json.loads(rep.read_text())
    assert report["mode"] == "arms" and report["frames_outside"]["velocity"] == 0
    names = sorted(p.name for p in plots.glob("*.png"))
    assert names == [f"jvrc1_fig{k}_{s}.png" for k in ("3_hand_points", "4_joint_bounds")
                     for s in ("left", "right")]
    assert all(p.stat().st_size > 10_000 for p in plots.glob("*.png"))
    assert "frames outside position/velocity/acceleration bounds 0/0/0" in capsys.readouterr().out


def test_cli_fit_sqp_re_solves_the_pipeline_arms(mocap, tmp_path, capsys):
    """The main pipeline with its arm joints re-solved (``--fit sqp``): same output keys, the
    arms within every limit and closer to their targets than the DLS fit."""
    out, rep = tmp_path / "f.npz", tmp_path / "f.json"
    code = main(["-q", "retarget", str(mocap(WAVE)), "--robot", "jvrc1", "--fit", "sqp",
                 "-o", str(out), "--json", str(rep)])
    assert code == 0
    with np.load(out) as data:  # the motion, the adapted markers it was fitted to, its plan
        assert sorted(data.files) == sorted(
            (*NPZ_KEYS, "adapted_positions_m", "adapted_marker_names", "provenance",
             "contact_modes"))
    sqp = json.loads(rep.read_text())["fit_sqp"]
    assert sqp["mode"] == "refine"
    assert sqp["frames_outside"] == {"position": 0, "velocity": 0, "acceleration": 0}
    for side, arm in sqp["arms"].items():
        assert arm["hand_rms_mm"] < sqp["before"][side]["hand_rms_mm"]


def test_missing_marker_and_bad_config_fail_cleanly(wave):
    robot = load_test_robot("jvrc1")
    from imesh.arms import human_arm_markers, solve_arms

    human = human_arm_markers(wave, None)
    partial = human.subset([n for n in human.names if n != "elbow_r"])
    with pytest.raises(ArmsError, match="elbow_r"):
        solve_arms(robot, partial, robot.q_nominal)
    with pytest.raises(ArmsError, match="valid: gn, slsqp"):
        ArmsConfig(solver="newton")
    with pytest.raises(ArmsError, match="sides"):
        ArmsConfig(sides=("left", "middle"))


# ----------------------------------------------------------------------------------------------
# dynamics (acceptance 5)


@pytest.mark.parametrize("name", ROBOTS)
def test_dart_pid_tracks_the_wave_with_fixed_base(name, wave):
    pytest.importorskip("dartpy")
    from imesh.physics.arms import track_arms

    robot = load_test_robot(name)
    res = run(name, wave)
    joints = [n for a in res.arms.values() for n in a.arm.joints]
    tracking = track_arms(robot, res.motion, joints)
    assert not tracking.diverged
    assert tracking.arm_rms_rad < 0.03
    assert np.isfinite(tracking.physics.joint_error_rad).all()

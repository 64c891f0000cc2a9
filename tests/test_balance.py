"""Balance: analytic ZMP cases, the Nishiwaki solve, contact states on real clips, and the
waist feedback loop on a real clip."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_test_robot, mocap_path

import imesh
from imesh.balance import BalanceConfig, ConvergenceConfig, FlightPhaseError, nishiwaki_correction
from imesh.contacts.phases import detect_contacts, runs
from imesh.metrics.zmp import zmp_trajectory
from imesh.morph.adapt import prepare_markers
from imesh.pipeline.retarget import RetargetConfig, retarget
from imesh.robot.configuration import GRAVITY

ROBOTS = ("jvrc1", "g1", "hrp4c")


@pytest.mark.parametrize("name", ROBOTS)
def test_static_pose_zmp_is_com_projection(name):
    robot = load_test_robot(name)
    q = robot.q_nominal.copy()
    zero = np.zeros(robot.nv)
    np.testing.assert_allclose(robot.zmp(q, zero, zero), robot.com(q)[:2], atol=1e-12)


@pytest.mark.parametrize("name", ROBOTS)
def test_constant_acceleration_zmp(name):
    """The whole robot translating with constant horizontal acceleration at constant height
    (no rotation, so no angular momentum): ZMP = x - (z / g) xddot, from finite differences of
    the sampled trajectory (exact for a parabola)."""
    robot = load_test_robot(name)
    fps, n = 100.0, 21
    t = np.arange(n) / fps
    acc = np.array([1.3, -0.7])
    q = np.repeat(robot.q_nominal[None], n, axis=0)
    q[:, :2] += 0.5 * t[:, None] ** 2 * acc
    zmp = zmp_trajectory(robot, q, fps)
    com = np.array([robot.com(x) for x in q])
    inner = slice(2, -2)  # one-sided differences at the ends
    expected = com[inner, :2] - com[inner, 2:3] / GRAVITY * acc
    np.testing.assert_allclose(zmp[inner], expected, atol=1e-9)


@pytest.mark.parametrize("name", ROBOTS)
def test_a_spinning_body_thrown_is_ballistic_by_its_own_samples(name):
    """A robot thrown while it turns 0.5 rad a frame (CMU 05_06's jete turns at 30 fps), its
    CoM on a parabola under gravity: the trajectory's CoM acceleration (the evaluator's and the
    whole-body solve's) is gravity to 1e-9 m/s^2. Pinocchio's continuous-time rate with the
    frames' finite-difference twists, which the evaluator used before, is 0.77-1.07 m/s^2 off
    here (the base's turn between the frames)."""
    import pinocchio as pin
    from scipy.spatial.transform import Rotation

    from imesh.metrics.derivatives import motion_derivatives

    robot = load_test_robot(name)
    fps, n = 30.0, 12
    t = np.arange(n) / fps
    q = np.repeat(robot.q_nominal[None], n, axis=0)
    turn = Rotation.from_euler("z", 0.5 * np.arange(n)[:, None]) * Rotation.from_euler("x", 0.2)
    q[:, 3:7] = turn.as_quat()
    com_body = robot.com(robot.q_nominal) - robot.q_nominal[:3]  # base at identity rotation
    com = np.c_[1.2 * t, 0.4 * t, 1.0 + 2.0 * t - 0.5 * GRAVITY * t ** 2]
    q[:, :3] = com - turn.apply(Rotation.from_quat(robot.q_nominal[3:7]).inv().apply(com_body))
    v, a = motion_derivatives(q, fps)
    c, dh, _ = robot.centroidal_trajectory(q, v, fps)
    np.testing.assert_allclose(c, com, atol=1e-9)
    inner = slice(2, -2)  # one-sided differences at the ends
    np.testing.assert_allclose(dh[inner, :3] / robot.mass, [[0.0, 0.0, -GRAVITY]] * (n - 4),
                               atol=1e-9)
    model, data = robot._trajectory.model, robot._trajectory.data
    old = np.array([pin.computeCentroidalMomentumTimeVariation(model, data, q[k], v[k],
                                                               a[k]).np[:3]
                    for k in range(n)]) / robot.mass
    assert np.abs(old[inner] - [0.0, 0.0, -GRAVITY]).max() > 0.5


def _forward_eq10(dx, z, zdd, fps):
    """ZMP change of a CoM correction by eq. 10 with zero-slope ends (the model's forward map)."""
    dt = 1.0 / fps
    prev = np.concatenate([dx[:1], dx[:-1]])
    nxt = np.concatenate([dx[1:], dx[-1:]])
    k = (z / ((GRAVITY + zdd) * dt * dt))[:, None]
    return dx - k * (prev - 2.0 * dx + nxt)


def test_nishiwaki_reproduces_a_known_correction():
    fps, n = 120.0, 400
    t = np.arange(n) / fps
    dx = np.stack([0.04 * np.sin(2 * np.pi * 0.8 * t), 0.02 * np.cos(2 * np.pi * 1.1 * t)], 1)
    z = 0.8 + 0.03 * np.sin(2 * np.pi * 1.7 * t)  # variable CoM height (eq. 10)
    zdd = -0.03 * (2 * np.pi * 1.7) ** 2 * np.sin(2 * np.pi * 1.7 * t)
    dp = _forward_eq10(dx, z, zdd, fps)
    np.testing.assert_allclose(nishiwaki_correction(dp, z, zdd, fps), dx, atol=1e-10)
    # a constant ZMP error asks for the same constant CoM shift (static equilibrium)
    const = nishiwaki_correction(np.full((n, 2), 0.05), z, zdd, fps)
    np.testing.assert_allclose(const, 0.05, atol=1e-9)


def _ankle_footfalls(motion):
    """Independent count: ankle swings (ankle more than 5 % of the body height above its rest)
    longer than 0.15 s that end before the clip does; each ends in a footfall."""
    count = 0
    for side in "lr":
        z = motion.positions_m[:, motion.index(f"ankle_{side}"), 2]
        swing = runs(z > np.percentile(z, 5) + 0.05 * motion.height_m)
        count += sum(1 for a, b in swing if b - a > 0.15 * motion.fps and b < len(z))
    return count


@pytest.mark.parametrize("clip, expected", [("cmu_02_01_walk.bvh", 5),
                                            ("cmu_16_11_walk_veer_left.bvh", 8)])
def test_contact_detection_counts_footfalls(clip, expected):
    motion = prepare_markers(imesh.load_motion(mocap_path(clip)))
    contacts = detect_contacts(motion)
    assert _ankle_footfalls(motion) == expected
    assert contacts.footfalls() == expected
    assert not contacts.flight_phases()


def test_leaps_are_flight_phases():
    """The dance's flights are reported and the paper's Nishiwaki loop (no flight model) refuses
    the clip naming the frames. Both ankles in the air is not flight by itself (issue 31): in
    the pirouettes the markers read 10 cm up while the trunk does not fall
    (tests/test_flight_slide.py); the whole-body solve plans the flights."""
    motion = imesh.load_motion(mocap_path("cmu_05_06_dance_pirouettes_jete.bvh"))
    std = prepare_markers(motion)
    assert detect_contacts(std).flight_phases()
    with pytest.raises(FlightPhaseError, match=r"flight phase\(s\).*frames \d+-\d+"):
        retarget(motion, load_test_robot("jvrc1"), config=RetargetConfig(balance="nishiwaki"))


def test_balance_loop_lowers_the_zmp_error_on_a_real_clip():
    motion = imesh.load_motion(mocap_path("cmu_02_10_wash_self_cc3rig.bvh")).frames(0, 480)
    robot = load_test_robot("jvrc1")
    result = retarget(motion, robot, config=RetargetConfig(
        balance="nishiwaki", nishiwaki=BalanceConfig(convergence=ConvergenceConfig(iterations=3),
                                                 error_lowpass_hz=1.5)))
    bal = result.balance
    assert bal.after.zmp_error_mm < 0.9 * bal.before.zmp_error_mm
    assert bal.after.zmp_inside_fraction >= bal.before.zmp_inside_fraction
    q = result.motion.joint_positions
    dt = 1.0 / result.motion.fps
    assert not ((q < robot.q_lower - 1e-9) | (q > robot.q_upper + 1e-9)).any()
    assert (np.abs(np.diff(q, axis=0)) / dt <= robot.v_max + 1e-6).all()
    assert (np.abs(np.diff(q, 2, axis=0)) / dt**2 <= robot.a_max + 1e-6).all()
    report = result.report()["balance"]
    assert report["iterations_run"] >= 1 and len(report["per_iteration"]) >= 2




@pytest.mark.parametrize("error, stops", [
    (imesh.SolverError("conflicting hard constraints"), True),
    (imesh.OptionError("weight", -1.0, "a number >= 0"), False)])
def test_balance_loop_stops_only_when_the_morph_cannot_meet_a_correction(error, stops):
    """A SolverError from the morph/fit step ends the loop with the best iterate so far (the
    unbalanced motion here); any other ImeshError is not swallowed."""
    from imesh.balance import balance_loop

    robot = load_test_robot("jvrc1")
    q = np.tile(robot.q_nominal, (40, 1))  # standing: the ZMP is off the desired by > 1 um
    support = np.ones((len(q), 2), dtype=bool)
    calls = []

    def step(waist_xy):
        calls.append(waist_xy)
        raise error

    config = BalanceConfig(convergence=ConvergenceConfig(iterations=3, tolerance_mm=1e-3,
                                                       inside_target=1.0))
    if stops:
        result = balance_loop(robot, q, 30.0, support, q[:, :2], step, config)
        assert len(calls) == 1 and result.best == 0 and len(result.iterations) == 1
        np.testing.assert_array_equal(result.q, q)
    else:
        with pytest.raises(type(error)):
            balance_loop(robot, q, 30.0, support, q[:, :2], step, config)

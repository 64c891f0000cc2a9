"""Planted support feet (imesh.fit.legs): leg chains, leg IK, footprints, base smoothing and
drop, the limit projection with planted weights."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_test_robot

from imesh.contacts import SIDES
from imesh.fit import FitConfig
from imesh.fit.dls import joint_limits
from imesh.fit.legs import (
    FootTargets,
    PlantConfig,
    base_drop,
    plant_feet,
    resolve_legs,
    smooth_base,
    sole_poses,
)
from imesh.metrics.kinematics import desired_zmp, inside_polygon, sole_tracks, support_polygons
from imesh.robot import ROBOTS_DIR, load_robot_config
from imesh.robot.registry import package_available

ROBOTS = ["jvrc1", "g1", "hrp4c"]


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    if request.param == "g1" and not package_available(
            load_robot_config(ROBOTS_DIR / "g1" / "robot.toml")):
        pytest.skip("example-robot-data not installed (pip install imesh[g1])")
    return load_test_robot(request.param)


def _swaying(robot, n: int = 120, fps: float = 60.0, amplitude_m: float = 0.02):
    """The nominal pose with the base swaying (x, y) and bobbing, legs frozen: the soles slide
    with the base, as a fit that traded the feet for other key points would."""
    t = np.arange(n) / fps
    q = np.repeat(robot.q_nominal[None], n, axis=0)
    q[:, 0] += amplitude_m * np.sin(2 * np.pi * 0.5 * t)
    q[:, 1] += amplitude_m * np.sin(2 * np.pi * 0.7 * t)
    q[:, 2] -= 0.01 * (1 - np.cos(2 * np.pi * 0.5 * t))
    return q, fps


def test_every_leg_is_a_six_joint_chain(robot):
    """Each sole hangs on its own 6-joint chain (hip x3, knee, ankle x2) off the base."""
    chains = [robot.supporting_joints(robot.soles[side].frame) for side in SIDES]
    assert [len(c) for c in chains] == [6, 6]
    assert not set(chains[0]) & set(chains[1])
    for chain in chains:
        assert "knee" in robot.joint_names[chain[3]].lower()


def test_leg_ik_recovers_a_known_leg_pose(robot):
    """FK of a random within-limit leg configuration -> sole targets -> solved from the
    nominal legs: the soles reach their targets to 1e-6 m / 1e-6 rad."""
    rng = np.random.default_rng(0)
    limits = joint_limits(robot, FitConfig())
    q_true = robot.q_nominal.copy()
    for side in SIDES:
        chain = robot.supporting_joints(robot.soles[side].frame)
        lo, hi = robot.q_lower[chain], robot.q_upper[chain]
        mid, half = (lo + hi) / 2, (hi - lo) / 2
        q_true[7 + chain] = np.clip(robot.q_nominal[7 + chain] + 0.3 * rng.uniform(-1, 1, 6)
                                    * np.minimum(half, 0.5), mid - 0.9 * half, mid + 0.9 * half)
    poses = sole_poses(robot, q_true[None])
    targets = FootTargets(poses=np.repeat(poses, 3, axis=0), blend=np.ones((3, 2)))
    start = np.repeat(robot.q_nominal[None], 3, axis=0)
    out = resolve_legs(robot, start, targets, 30.0, limits)
    assert out.position_error_m.max() < 1e-6
    assert out.rotation_error_rad.max() < 1e-6
    np.testing.assert_allclose(sole_poses(robot, out.q), targets.poses, atol=1e-6)


def test_planted_soles_stand_flat_and_still(robot):
    """A swaying base with frozen legs: the planted soles do not move (slip < 0.01 mm per
    frame), lie flat on the ground (lowest corner within 0.1 mm of z = 0) and the joints stay
    within position, velocity and acceleration limits."""
    q, fps = _swaying(robot)
    support = np.ones((len(q), 2), dtype=bool)
    limits = joint_limits(robot, FitConfig())
    out = plant_feet(robot, q, fps, support, limits)
    soles = sole_tracks(robot, out.q, fps)
    for side in SIDES:
        step = np.linalg.norm(np.diff(soles.centers[side][:, :2], axis=0), axis=1)
        assert step.max() < 1e-5
        assert np.abs(soles.corners[side][..., 2]).max() < 1e-4
    lower, upper, vmax, amax = limits
    joints = out.q[:, 7:]
    assert np.all((joints >= lower) & (joints <= upper))
    assert np.all(np.abs(np.diff(joints, axis=0)) * fps <= vmax * (1 + 1e-9))
    assert np.all(np.abs(np.diff(joints, n=2, axis=0)) * fps**2 <= amax * (1 + 1e-9))
    assert out.unplanted is None or not out.unplanted.any()


def test_base_drop_bends_the_knees(robot):
    """Lowering the base by base_drop leaves every planted knee bent by >= min_knee_rad
    (the hip-knee-ankle triangle of the nominal pose; to within 0.02 rad)."""
    q, fps = _swaying(robot, n=30)
    q[:, 2] += 0.05  # raise the base: the nominal knees would have to stretch
    support = np.ones((len(q), 2), dtype=bool)
    poses = sole_poses(robot, np.repeat(robot.q_nominal[None], len(q), axis=0))
    targets = FootTargets(poses=poses, blend=np.ones((len(q), 2)))
    drop = base_drop(robot, q, targets, 0.6)
    assert drop > 0.0
    q[:, 2] -= drop
    limits = joint_limits(robot, FitConfig())
    nolimits = (limits[0], limits[1], np.full_like(limits[2], np.inf),
                np.full_like(limits[3], np.inf))
    out = resolve_legs(robot, q, targets, fps, nolimits)
    assert out.position_error_m.max() < 1e-6
    for side in SIDES:
        knee = robot.supporting_joints(robot.soles[side].frame)[3]
        # the hip-knee-ankle triangle is exact for JVRC-1; HRP-4C within 3 mrad, G1 (hip axes
        # apart) within 16 mrad
        assert np.abs(out.q[:, 7 + knee]).min() >= 0.6 - 0.02
    assert support.all()


def test_smooth_base_removes_wobble_keeps_slow_motion(robot):
    fps = 120.0
    t = np.arange(600) / fps
    q = np.repeat(robot.q_nominal[None], len(t), axis=0)
    slow = 0.1 * np.sin(2 * np.pi * 0.2 * t)
    q[:, 0] += slow + 0.005 * np.sin(2 * np.pi * 15 * t)
    out = smooth_base(q, fps, 6.0, 0.5)
    inner = slice(60, -60)
    assert np.abs(out[inner, 0] - robot.q_nominal[0] - slow[inner]).max() < 5e-4
    np.testing.assert_allclose(np.linalg.norm(out[:, 3:7], axis=1), 1.0, atol=1e-12)


def test_desired_zmp_stays_inside_the_support_polygon(robot):
    """Alternating single supports with short double supports: the desired ZMP is inside the
    support polygon in every support frame (the transitions happen in double support)."""
    q, fps = _swaying(robot, n=240, fps=120.0, amplitude_m=0.0)
    soles = sole_tracks(robot, q, fps)
    support = np.ones((len(q), 2), dtype=bool)
    for k, (a, b) in enumerate([(20, 70), (80, 130), (140, 190), (200, 230)]):
        support[a:b, k % 2] = False  # swing of one foot: single support of the other
    desired = desired_zmp(soles, support, 0.1)
    polys = support_polygons(soles, support)
    assert all(inside_polygon(desired[t], polys[t]) for t in range(len(q)))
    # single support: the sole centre
    np.testing.assert_allclose(desired[40], soles.centers["right"][40, :2], atol=1e-12)


def test_plant_config_validates():
    from imesh.errors import OptionError

    with pytest.raises(OptionError):
        PlantConfig(iterations=0)
    with pytest.raises(OptionError):
        PlantConfig(base_lowpass_hz=-1.0)

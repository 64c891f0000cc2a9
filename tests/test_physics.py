"""The DART dynamics check: model consistency with pinocchio, standing for 5 s on every robot,
falls, controllers, fixed base, results and errors.

Every simulation but the required 5 s standing runs is kept under 2 s of simulated time.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
from conftest import load_test_robot

from imesh.core.robot_motion import RobotMotion
from imesh.errors import ImeshError, MissingDependencyError
from imesh.robot import ROBOTS_DIR, load_robot_config
from imesh.robot.registry import package_available
from imesh.viz.physics import plot_physics

pytest.importorskip("dartpy")

from imesh.physics import (  # noqa: E402
    PHYSICS_METRICS,
    ControlConfig,
    DartRobot,
    PhysicsConfig,
    PhysicsResult,
    TimingConfig,
    simulate_motion,
)

ROBOTS = ["jvrc1", "g1", "hrp4c"]


def _load(name: str):
    if name == "g1" and not package_available(load_robot_config(ROBOTS_DIR / "g1" /
                                                                "robot.toml")):
        pytest.skip("example-robot-data not installed (pip install imesh-retarget[g1])")
    return load_test_robot(name)


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    return _load(request.param)


@pytest.fixture(scope="module")
def jvrc1():
    return _load("jvrc1")


def standing(robot, seconds: float, fps: float = 30.0) -> RobotMotion:
    n = int(round(seconds * fps)) + 1
    return RobotMotion(q=np.repeat(robot.q_nominal[None], n, axis=0), fps=fps, robot=robot.name,
                       joint_names=robot.joint_names)


# ----------------------------------------------------------------------------------------------
# the DART model is the pinocchio model


def test_dart_model_matches_pinocchio(robot):
    """Same mass (massless links stay massless), same centre of mass and CoM velocity at random
    states (conversions of the base position/velocity conventions), same sole frame poses."""
    sim = DartRobot(robot, PhysicsConfig())
    assert sim.skeleton.getMass() == pytest.approx(robot.mass, rel=1e-6)
    assert sim.n_dofs == robot.nv
    rng = np.random.default_rng(3)
    for _ in range(3):
        q = robot.random_configuration(rng)
        v = rng.normal(size=robot.nv)
        sim.set_state(q, v)
        np.testing.assert_allclose(sim.skeleton.getCOM(), robot.com(q), atol=1e-9)
        np.testing.assert_allclose(sim.skeleton.getCOMLinearVelocity(),
                                   robot.com_jacobian(q) @ v, atol=1e-8)
        back = sim.q_from_positions(sim.skeleton.getPositions())
        np.testing.assert_allclose(back[7:], q[7:], atol=1e-12)
        np.testing.assert_allclose(np.abs(back[3:7] @ q[3:7]), 1.0, atol=1e-12)
        for side, sole in robot.soles.items():
            T = sim.body(sole.frame).getWorldTransform().matrix()
            np.testing.assert_allclose(T, robot.frame_placements(q, [sole.frame])[0],
                                       atol=1e-9, err_msg=side)
        np.testing.assert_allclose(sim.v_from_velocities(q, sim.skeleton.getVelocities()), v,
                                   atol=1e-12)


def test_pinocchio_inverse_dynamics_matches_dart(robot):
    """The feed-forward comes from pinocchio (rnea); DART's inverse dynamics of the same state
    gives the same joint torques (the two models agree on masses, inertias and kinematics).
    JVRC-1 and G1 agree to 1e-6; HRP-4C's reduced model to 2 % of the largest torque (0.5 Nm of
    29 Nm: DART keeps a minimum inertia on its near-massless links)."""
    sim = DartRobot(robot, PhysicsConfig())
    skel = sim.skeleton
    skel.setGravity(np.array([0.0, 0.0, -9.81]))
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = robot.random_configuration(rng, scale=0.5)
        v, a = rng.normal(size=robot.nv), rng.normal(size=robot.nv)
        skel.setPositions(sim.positions_from_q(q[None])[0])
        skel.setVelocities(sim.velocities_from_v(q[None], v[None])[0])
        skel.setAccelerations(sim.accelerations_from_a(q[None], v[None], a[None])[0])
        skel.computeInverseDynamics(False, True, False)
        dart_tau = np.asarray(skel.getForces())[sim.joint_dofs]
        pin_tau = robot.inverse_dynamics(q, v, a)[6:]
        scale = max(1.0, np.abs(pin_tau).max())
        tol = 2e-2 if robot.name == "hrp4c" else 1e-6
        assert np.abs(pin_tau - dart_tau).max() <= tol * scale


def test_fixed_joints_are_welded_at_pinocchio_angles(jvrc1):
    """JVRC-1's finger joints are fixed by robot.toml: DART has no DOF for them and the finger
    links sit where pinocchio puts them."""
    sim = DartRobot(jvrc1, PhysicsConfig())
    names = {sim.skeleton.getDof(i).getName() for i in range(sim.n_dofs)}
    assert not names & set(jvrc1.config.fixed_joints)
    q = jvrc1.q_nominal
    sim.set_state(q)
    for link in ("L_UTHUMB_S", "R_LLITTLE_S"):
        np.testing.assert_allclose(sim.body(link).getWorldTransform().matrix(),
                                   jvrc1.frame_placements(q, [link])[0], atol=1e-9)


# ----------------------------------------------------------------------------------------------
# acceptance 1: standing 5 s


def test_nominal_pose_stands_for_5_s(robot):
    """Every robot standing in its nominal pose for 5 s: no fall, base height drift <= 1 cm,
    the contact forces carry the weight with their centre of pressure at the planned ZMP."""
    result = simulate_motion(robot, standing(robot, 5.0),
                             config=PhysicsConfig(control=ControlConfig(controller="spd")))
    assert not result.fell, result.fall_reason
    assert result.survived_s == pytest.approx(5.0)
    assert result.base_height_drift_m <= 0.01
    assert result.base_drift_m <= 0.01
    assert result.tracking_rms_rad < 0.005
    assert result.torque_ratio_max < 1.0
    weight = robot.mass * 9.81
    assert np.nanmean(result.contact_force_n) == pytest.approx(weight, rel=0.02)
    assert result.zmp_contact_error_mm < 10.0
    assert result.real_time_factor > 0.5  # >= 1 on an idle machine; loose under parallel load


# ----------------------------------------------------------------------------------------------
# falls, controllers, fixed base


def test_weak_motors_fall_and_the_result_says_when(jvrc1):
    """With 2 % of the torque the robot collapses: fell, survived < duration, NaN after."""
    config = PhysicsConfig(control=ControlConfig(controller="spd", torque_limit_scale=0.02),
                           timing=TimingConfig(settle_s=0.05))
    result = simulate_motion(jvrc1, standing(jvrc1, 1.5), config=config)
    assert result.fell
    assert "below the reference" in result.fall_reason or "tilted" in result.fall_reason
    assert 0.0 <= result.survived_s < 1.5
    assert result.torque_ratio_max > 1.0 and result.saturation_fraction > 0.5
    assert np.isnan(result.q[-1]).all()
    m = result.metrics()
    assert m["physics_fell"] is True and m["physics_survived_s"] == result.survived_s


def test_pid_controller_stands(jvrc1):
    result = simulate_motion(jvrc1, standing(jvrc1, 1.0),
                             config=PhysicsConfig(control=ControlConfig(controller="pid"),
                                                  timing=TimingConfig(settle_s=0.2)))
    assert not result.fell
    assert result.tracking_rms_rad < 0.01


def test_fixed_base_tracks_an_arm_motion(jvrc1):
    """Base welded at the first pose, no ground: a 1 s shoulder/elbow swing is tracked closely
    with torques within the limits."""
    fps, n = 100.0, 101
    q = np.repeat(jvrc1.q_nominal[None], n, axis=0)
    q[:, 2] += 0.3  # in the air: a fixed base needs no ground
    t = np.arange(n) / fps
    for name, amp in (("L_SHOULDER_P", -0.8), ("L_ELBOW_P", -0.6), ("R_SHOULDER_R", -0.5)):
        q[:, 7 + jvrc1.joint_index(name)] += amp * np.sin(np.pi * t) ** 2
    motion = RobotMotion(q=q, fps=fps, robot=jvrc1.name, joint_names=jvrc1.joint_names)
    result = simulate_motion(jvrc1, motion, config=PhysicsConfig(
        fixed_base=True, timing=TimingConfig(settle_s=0.1)))
    assert not result.fell
    assert result.tracking_rms_rad < 0.01
    assert np.nanmax(np.abs(result.joint_error_rad)) < 0.05
    assert result.torque_ratio_max < 1.0
    np.testing.assert_allclose(result.q[:, :7], q[:, :7], atol=1e-9)  # the base did not move
    assert np.isnan(result.zmp_contact_m).all()


# ----------------------------------------------------------------------------------------------
# result object and errors


def test_result_metrics_and_plot(jvrc1, tmp_path):
    result = simulate_motion(jvrc1, standing(jvrc1, 0.5), config=PhysicsConfig(
        timing=TimingConfig(settle_s=0.1)))
    assert isinstance(result, PhysicsResult)
    assert tuple(result.metrics()) == PHYSICS_METRICS
    T = 16
    assert result.q.shape == (T, jvrc1.nq) and result.joint_error_rad.shape == (T, jvrc1.dof)
    assert result.zmp_contact_m.shape == result.zmp_planned_m.shape == (T, 2)
    assert result.torques_nm.shape == (T, jvrc1.dof)
    summary = result.summary()
    assert summary["real_time_factor"] > 0 and summary["controller"] == "wbc"
    assert summary["keypoint_rms_mm"] < 5.0 and summary["slip_mm"] < 1.0
    assert summary["cop_margin_mm"] > 0.0 and 0.0 <= summary["friction_ratio"] < 0.7
    plot_physics(result, tmp_path / "run.png")
    assert (tmp_path / "run.png").stat().st_size > 10_000


def test_motion_of_another_robot_is_refused(jvrc1):
    g1_like = RobotMotion(q=np.zeros((2, 7 + 3)) + [0, 0, 0, 0, 0, 0, 1, 0, 0, 0], fps=30,
                          robot="g1", joint_names=("a", "b", "c"))
    with pytest.raises(ImeshError, match="'g1'.*'jvrc1'"):
        simulate_motion(jvrc1, g1_like)


def test_bad_config_values():
    with pytest.raises(ImeshError, match="controller"):
        ControlConfig(controller="lqr")
    with pytest.raises(ImeshError, match="dt"):
        TimingConfig(dt=0.05)
    with pytest.raises(ImeshError, match="mass_matrix_every"):
        ControlConfig(mass_matrix_every=0)


def test_missing_dartpy_says_how_to_install(jvrc1, monkeypatch):
    monkeypatch.setitem(sys.modules, "dartpy", None)
    with pytest.raises(MissingDependencyError, match="pip install dartpy"):
        simulate_motion(jvrc1, standing(jvrc1, 0.1))


def test_import_does_not_load_dartpy():
    import subprocess

    code = "import sys, imesh.physics, imesh.evaluate; assert 'dartpy' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_feasible_squat_is_tracked_without_falling(jvrc1):
    """A slow squat (knees +0.7 rad) with an arm raise, soles flat: tracked to < 0.005 rad,
    the contact ZMP follows the planned multibody ZMP within 2 cm."""
    fps, n = 30.0, 46
    t = np.arange(n) / fps
    q = np.repeat(jvrc1.q_nominal[None], n, axis=0)
    squat = 0.35 * (0.5 - 0.5 * np.cos(2 * np.pi * t / 1.5))
    for hip, knee, ankle in (("L_HIP_P", "L_KNEE", "L_ANKLE_P"),
                             ("R_HIP_P", "R_KNEE", "R_ANKLE_P")):
        q[:, 7 + jvrc1.joint_index(hip)] -= squat
        q[:, 7 + jvrc1.joint_index(knee)] += 2 * squat
        q[:, 7 + jvrc1.joint_index(ankle)] -= squat
    q[:, 7 + jvrc1.joint_index("L_SHOULDER_P")] -= np.sin(np.pi * t / 1.5) ** 2
    for i in range(n):
        q[i, 2] -= jvrc1.sole_center(q[i], "left")[2]
    motion = RobotMotion(q=q, fps=fps, robot=jvrc1.name, joint_names=jvrc1.joint_names)
    result = simulate_motion(jvrc1, motion, config=PhysicsConfig(
        control=ControlConfig(controller="spd"), timing=TimingConfig(settle_s=0.2)))
    assert not result.fell, result.fall_reason
    assert result.tracking_rms_rad < 0.005
    assert result.base_drift_m < 0.01
    assert result.zmp_contact_error_mm < 20.0
    assert result.torque_ratio_max < 1.0


def test_slip_counts_only_the_corners_on_the_ground():
    """A sole that slides flat 1 mm per frame slips 9 mm over 10 frames; a sole that turns on
    its toe edge, its heel corners 1.8 mm up and swinging 9 mm sideways (the JVRC-1 walk's
    right sole before a lift-off), does not slip: its toe corners stay put. Counted within
    5 mm of the ground, as before, the lifted heel read as 9 mm of slip."""
    from imesh.physics.simulate import CONTACT_M, sole_slip

    T = 10
    sole = np.array([[0.1, 0.05, 0.0], [0.1, -0.05, 0.0], [-0.1, -0.05, 0.0],
                     [-0.1, 0.05, 0.0]])  # front-left, front-right, back-right, back-left
    corners = np.zeros((T, 2, 4, 3))
    corners[:] = sole
    corners[:, 1, :, 1] -= 0.2  # the right sole beside the left
    support = np.zeros((T, 2), dtype=bool)
    support[:, 0] = True
    slide = corners.copy()
    slide[:, 0, :, 0] += 0.001 * np.arange(T)[:, None]
    slip, side, frame = sole_slip(slide, support)
    assert slip == pytest.approx(0.009) and (side, frame) == (0, T - 1)

    turn = corners.copy()
    turn[-2:, 0, 2:, 2] = 0.0018  # the heel up in the last two frames ...
    turn[-2:, 0, 2:, 1] += np.array([0.004, 0.009])[:, None]  # ... and swinging sideways
    assert CONTACT_M < 0.0018
    assert sole_slip(turn, support) == (0.0, -1, -1)
    assert sole_slip(turn, support, contact_m=0.005)[0] == pytest.approx(0.009)
    # a support phase of the other sole counts from the frame each corner is down
    support[5:, 1] = True
    turn[5:7, 1, :, 2] = 0.01  # landing: down from frame 7
    turn[7:, 1, :, 0] += 0.002 * np.arange(3)[:, None]
    slip, side, frame = sole_slip(turn, support)
    assert slip == pytest.approx(0.004) and (side, frame) == (1, T - 1)


def test_props_in_the_world_must_be_boxes_in_the_robots_world():
    """The DART world takes a scene's props as boxes, in the robot's world: a wedge is
    refused by name, and so is a scene still in its file's frame."""
    import trimesh

    from imesh.physics import PhysicsError
    from imesh.scene import Prop, Scene

    robot = _load("jvrc1")
    box = trimesh.creation.box(bounds=[[1.0, -0.5, 0.0], [1.5, 0.5, 0.3]])
    v = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1) if not (x and z)],
                 dtype=float) + [2.0, 0.0, 0.0]
    wedge = trimesh.Trimesh(v).convex_hull
    props = (Prop("step", np.asarray(box.vertices), np.asarray(box.faces)),
             Prop("ramp", np.asarray(wedge.vertices), np.asarray(wedge.faces)))
    with pytest.raises(PhysicsError, match=r"not boxes: \['ramp'\]"):
        DartRobot(robot, PhysicsConfig(), scene=Scene(props, frame="robot", scale=0.8))
    with pytest.raises(PhysicsError, match="robot's world"):
        DartRobot(robot, PhysicsConfig(), scene=Scene(props[:1], frame="file"))
    sim = DartRobot(robot, PhysicsConfig(), scene=Scene(props[:1], frame="robot", scale=0.8))
    assert len(sim.props) == 1
    node = sim.props[0].getBodyNode(0).getShapeNode(0)
    T = node.getWorldTransform().matrix()
    half = 0.5 * np.asarray(node.getShape().getSize())
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * half
    world = corners @ T[:3, :3].T + T[:3, 3]
    assert np.allclose(world.min(axis=0), [1.0, -0.5, 0.0], atol=1e-12)
    assert np.allclose(world.max(axis=0), [1.5, 0.5, 0.3], atol=1e-12)

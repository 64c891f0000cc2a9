"""The whole-body controller of the DART check: its dynamics terms against finite differences
and inverse dynamics, its contact wrench cone against the centre-of-pressure and friction
definitions, and closed-loop runs that must stand and runs that must fall."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load_test_robot

from imesh.balance.cwc import sole_wrench_cone
from imesh.contacts.phases import SIDES
from imesh.core.robot_motion import RobotMotion
from imesh.errors import OptionError
from imesh.metrics.markers import keypoint_motion
from imesh.physics.config import WbcConfig
from imesh.robot import ROBOTS_DIR, load_robot_config
from imesh.robot.registry import package_available


def _robot(name: str):
    if name == "g1" and not package_available(load_robot_config(ROBOTS_DIR / "g1" /
                                                                "robot.toml")):
        pytest.skip("example-robot-data not installed (pip install imesh-retarget[g1])")
    return load_test_robot(name)


@pytest.fixture(scope="module")
def jvrc1():
    return load_test_robot("jvrc1")


def test_dynamics_terms_match_inverse_dynamics_and_finite_differences(jvrc1):
    """``M a + h`` equals RNEA; ``J a + Jdot v`` equals the finite-difference rate of ``J v``
    for the sole centres and the CoM (the QP's acceleration rows are exact)."""
    robot = jvrc1
    rng = np.random.default_rng(3)
    q = robot.random_configuration(rng, 0.3)
    v, a = rng.normal(size=robot.nv) * 0.5, rng.normal(size=robot.nv)
    frames = [robot.soles[s].frame for s in SIDES]
    centres = np.array([robot.soles[s].center for s in SIDES])
    d = robot.dynamics(q, v, frames, centres)
    np.testing.assert_allclose(d.mass_matrix, d.mass_matrix.T)
    np.testing.assert_allclose(d.mass_matrix @ a + d.bias, robot.inverse_dynamics(q, v, a),
                               atol=1e-9)
    eps = 1e-6
    d2 = robot.dynamics(robot.integrate(q, eps * v), v + eps * a, frames, centres)
    acc = np.einsum("fij,j->fi", d.jacobians, a) + d.drifts
    np.testing.assert_allclose((d2.twists - d.twists) / eps, acc, atol=1e-4)
    np.testing.assert_allclose((d2.poses[:, :3, 3] - d.poses[:, :3, 3]) / eps, d.twists[:, :3],
                               atol=1e-4)
    np.testing.assert_allclose((d2.com_velocity - d.com_velocity) / eps,
                               d.com_jacobian @ a + d.com_drift, atol=1e-4)
    np.testing.assert_allclose(d.poses[:, :3, 3],
                               robot.frame_positions(q, frames, centres), atol=1e-12)


@pytest.mark.parametrize(("force", "moment", "inside"), [
    ((0, 0, 100), (0, 0, 0), True),            # centre of pressure at the centre
    ((0, 0, 100), (2.9, 0, 0), True),          # CoP y = -29 mm on a 30 mm half width
    ((0, 0, 100), (3.1, 0, 0), False),         # CoP y = -31 mm: outside
    ((0, 0, 100), (0, -8.4, 0), True),         # CoP x = +84 mm on an 85 mm half length
    ((0, 0, 100), (0, -8.6, 0), False),
    ((69, 0, 100), (0, 0, 0), True),           # friction 0.69 < mu = 0.7
    ((0, 71, 100), (0, 0, 0), False),          # friction 0.71 > mu
    ((0, 0, -1), (0, 0, 0), False),            # pulling on the ground
    ((0, 0, 100), (0, 0, 7.0), True),          # yaw moment below mu (X + Y) fz = 8.05 Nm
    ((0, 0, 100), (0, 0, 8.2), False),
])
def test_wrench_cone_is_the_contact_conditions(force, moment, inside):
    """Caron et al. 2015's cone of a 170 x 60 mm sole, mu = 0.7: a wrench is inside exactly
    when its centre of pressure is on the sole, its tangential force within the friction cone,
    its normal force pushing and its yaw moment within what friction can hold."""
    C = sole_wrench_cone(0.085, 0.03, 0.7)
    w = np.r_[force, moment].astype(float)
    assert bool(np.all(C @ w <= 1e-12)) is inside


def test_wbc_config_checks():
    with pytest.raises(OptionError, match="cop_margin"):
        WbcConfig(cop_margin=1.0)
    with pytest.raises(OptionError, match="torque_fraction"):
        WbcConfig(torque_fraction=1.5)
    with pytest.raises(OptionError, match="landing_depth_m"):
        WbcConfig(landing_depth_m=-0.01)


def _standing(robot, seconds: float, fps: float = 30.0) -> RobotMotion:
    n = int(round(seconds * fps)) + 1
    return RobotMotion(q=np.repeat(robot.q_nominal[None], n, axis=0), fps=fps, robot=robot.name,
                       joint_names=robot.joint_names)


@pytest.mark.parametrize(("name", "seconds"), [("jvrc1", 10.0), ("g1", 1.5)])
def test_wbc_stands_and_tracks(name, seconds):
    """Closed loop on the nominal pose (JVRC-1 for 10 s): no fall, key points within 5 mm of
    the reference, every torque within the effort limits (constraints of the QP, never
    clamped), the weight carried by the soles with their centres of pressure inside."""
    pytest.importorskip("dartpy")
    from imesh.physics import PhysicsConfig, TimingConfig, simulate_motion

    robot = _robot(name)
    result = simulate_motion(robot, _standing(robot, seconds),
                             config=PhysicsConfig(timing=TimingConfig(settle_s=0.2)))
    assert result.config.control.controller == "wbc"
    assert not result.fell, result.fall_reason
    assert result.survived_s == pytest.approx(seconds)
    assert result.keypoint_rms_mm < 5.0 and result.keypoint_max_mm < 10.0
    assert result.torque_ratio_max <= 1.0 + 1e-9 and result.saturation_fraction == 0.0
    assert result.relaxed_fraction == 0.0
    assert result.base_drift_m < 0.01
    assert result.slip_mm < 1.0
    assert result.cop_margin_mm > 5.0
    assert np.nanmean(result.contact_force_n) == pytest.approx(robot.mass * 9.81, rel=0.03)


def test_wbc_holds_an_off_centre_com_where_the_reference_has_it(jvrc1):
    """Leaning forward (waist pitched 0.3 rad: the CoM 46 mm ahead of the ankles), the
    centres of pressure must sit off the sole centres; the QP's regularization of the contact
    moments must not pull the CoM back from the reference (at the old weight 1e-2: 1.4 mm
    behind for good)."""
    pytest.importorskip("dartpy")
    from imesh.physics import PhysicsConfig, TimingConfig, simulate_motion

    robot = jvrc1
    q0 = robot.q_nominal.copy()
    q0[7 + robot.joint_index("WAIST_P")] = 0.3
    motion = RobotMotion(q=np.repeat(q0[None], 61, axis=0), fps=30.0, robot=robot.name,
                         joint_names=robot.joint_names)
    result = simulate_motion(robot, motion,
                             config=PhysicsConfig(timing=TimingConfig(settle_s=0.2)))
    assert not result.fell
    error = robot.com(result.q[-1]) - robot.com(result.q_reference[-1])
    assert np.linalg.norm(error[:2]) < 3e-4
    # the report names where the largest key-point error is: the key point and its time
    sim = keypoint_motion(robot, result.q, result.fps)
    ref = keypoint_motion(robot, result.q_reference, result.fps)
    d = 1e3 * np.linalg.norm(sim.positions_m - ref.positions_m, axis=-1)
    f, k = np.unravel_index(np.argmax(d), d.shape)
    assert result.keypoint_max_mm == pytest.approx(d.max())
    assert result.keypoint_worst == sim.names[k]
    assert result.keypoint_worst_s == pytest.approx(f / result.fps)


def test_a_sliding_sole_carries_coulombs_kinetic_force(jvrc1):
    """A sole the plan slides, moving over the ground at 0.2 m/s: the controller's wrench on
    it is on the friction cone's boundary against the slide, ``f_t = -mu fz u`` (the force
    DART's Coulomb contact applies), to the QP's tolerance; the standing sole's within the
    cone it assumes (0.7 mu of 1.0); a sole the plan holds still gets no such rows."""
    from imesh.physics.reference import build_reference
    from imesh.physics.track import ReferenceTrack
    from imesh.physics.wbc import WholeBodyController

    robot = jvrc1
    motion = _standing(robot, 1.0)
    modes = np.ones((motion.n_frames, 2), dtype=np.int8)
    modes[:, 0] = 2  # the left sole slides
    ref = build_reference(robot, motion.q, motion.fps, contact_modes=modes)
    assert ref.moving[:, 0].all() and not ref.moving[:, 1].any()
    mu = 0.1
    controller = WholeBodyController(robot, ReferenceTrack(robot, ref), WbcConfig(), 1.0,
                                     slide_friction=mu)
    v = np.zeros(robot.nv)
    v[0] = 0.2  # the base, and both soles with it, moving forward
    step = controller.step(0.5, ref.q[15], v)
    assert step.contacts.all() and step.sliding.tolist() == [True, False]
    f_left, f_right = step.wrenches[0, :3], step.wrenches[1, :3]
    u = controller.robot.dynamics(ref.q[15], v, controller.frames,
                                  controller.centres).twists[0, :3]
    u = u[:2] / np.linalg.norm(u[:2])
    assert f_left[2] > 10.0
    np.testing.assert_allclose(f_left[:2], -mu * f_left[2] * u, atol=1e-6 * f_left[2])
    assert np.linalg.norm(f_right[:2]) <= 0.7 * 1.0 * f_right[2] + 1e-6
    held = controller.step(0.5, ref.q[15], np.zeros(robot.nv))
    assert held.sliding.tolist() == [False, False]
    assert np.linalg.norm(held.wrenches[0, :2]) <= 0.7 * mu * held.wrenches[0, 2] + 1e-6


def test_a_sole_on_its_toe_edge_has_the_grounds_friction_cone(jvrc1):
    """A sole rolled 30 deg onto its toe edge stands on the ground, whose normal is the world's
    z: a force at the toe strip's centre is in its cone up to the assumed friction (0.7 of the
    floor's 1.0) of its normal force, measured in the world, not in the tilted sole's frame
    (where a forward push of 0.9 of the vertical force was inside, and the toes slipped)."""
    from scipy.spatial.transform import Rotation

    from imesh.physics.reference import build_reference
    from imesh.physics.track import ReferenceTrack
    from imesh.physics.wbc import WholeBodyController

    robot = jvrc1
    motion = _standing(robot, 0.5)
    controller = WholeBodyController(
        robot, ReferenceTrack(robot, build_reference(robot, motion.q, motion.fps)),
        WbcConfig(), 1.0)
    s = 0
    # heel up: the sole's x axis points 30 deg down (pitch about the sole's y)
    Rc = Rotation.from_euler("y", 30, degrees=True).as_matrix() @ controller.contact_R[s]
    d = Rc[:, 0] * controller.strip_offsets[s]  # sole centre -> strip centre
    C = controller._toe_cone(s, Rc)

    def wrench(fx):  # a force at the strip's centre, written at the sole centre
        f = np.array([fx, 0.0, 100.0])
        return np.r_[f, np.cross(d, f)]

    assert (C @ wrench(0.0)).max() < 0.0
    assert (C @ wrench(0.69 * 100.0)).max() <= 1e-9
    assert (C @ wrench(0.75 * 100.0)).max() > 0.0
    assert (C @ wrench(-0.75 * 100.0)).max() > 0.0


def test_wbc_falls_when_the_motion_cannot_be_performed(jvrc1):
    """The check can fail: a reference with both feet 0.3 m in the air for 1 s (no support:
    nothing can hold the robot up there) is judged a fall."""
    pytest.importorskip("dartpy")
    from imesh.physics import PhysicsConfig, TimingConfig, simulate_motion

    robot = jvrc1
    q = _standing(robot, 2.0).q.copy()
    q[15:45, 2] += 0.3
    motion = RobotMotion(q=q, fps=30.0, robot=robot.name, joint_names=robot.joint_names)
    result = simulate_motion(robot, motion,
                             config=PhysicsConfig(timing=TimingConfig(settle_s=0.2)))
    assert result.fell
    assert "below the reference" in result.fall_reason
    assert 0.5 <= result.survived_s < 1.5


def test_wbc_models_the_joint_damping_the_simulator_applies():
    """HRP-4C's URDF gives every joint 0.2 N m s/rad of damping, which DART applies and
    pinocchio's dynamics leave out: a wrist of a few grams then barely moves under the torques
    a model without it computes (0.20 rad RMS behind a 0.3 rad, 1 Hz wrist wave). With the
    damping in the controller's joint rows as an explicit force it followed within 0.034 rad
    RMS; DART integrates the damping implicitly (``M + dt B``), and with that in the
    controller's torque rows within 0.018 rad."""
    pytest.importorskip("dartpy")
    from imesh.physics import PhysicsConfig, TimingConfig, simulate_motion
    from imesh.physics.world import DartRobot

    robot = _robot("hrp4c")
    sim = DartRobot(robot, PhysicsConfig())
    assert np.allclose(sim.joint_damping, 0.2)
    t = np.arange(61) / 30.0
    q = np.repeat(robot.q_nominal[None], len(t), axis=0)
    wrist = robot.joint_index("R_WRIST_Y")
    q[:, 7 + wrist] += 0.3 * np.sin(2 * np.pi * t)
    motion = RobotMotion(q=q, fps=30.0, robot=robot.name, joint_names=robot.joint_names)
    result = simulate_motion(robot, motion,
                             config=PhysicsConfig(timing=TimingConfig(settle_s=0.2)))
    assert not result.fell
    assert np.sqrt(np.nanmean(result.joint_error_rad[:, wrist] ** 2)) < 0.025


def _lean(robot, theta: float) -> np.ndarray:
    """(nq,) the nominal pose leaned forward by ``theta`` [rad] about the ankles: base rotated
    about the left ankle's axis, both ankle pitches opened by as much (the soles stay put)."""
    import pinocchio as pin
    from scipy.spatial.transform import Rotation

    q0 = robot.q_nominal.copy()
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q0)
    ankle = data.oMi[robot.model.getJointId("L_ANKLE_P")].translation.copy()
    turn = Rotation.from_rotvec([0.0, theta, 0.0])
    q = q0.copy()
    q[:3] = ankle + turn.apply(q0[:3] - ankle)
    q[3:7] = (turn * Rotation.from_quat(q0[3:7])).as_quat()
    for name in ("L_ANKLE_P", "R_ANKLE_P"):
        q[7 + robot.joint_index(name)] -= theta
    return q


def test_wbc_loses_a_motion_whose_com_leaves_the_soles(jvrc1):
    """The check can fail a motion the controller survives by not performing it: JVRC-1 leans
    0.3 rad forward about its ankles for 0.5 s (the CoM 0.09 m beyond the toes: no contact
    can hold that). The controller stays up by not leaning; its head is then far from the
    reference's, and the check counts the motion lost, within the lean."""
    pytest.importorskip("dartpy")
    from imesh.physics import PhysicsConfig, TimingConfig, simulate_motion

    robot = jvrc1
    soles = [robot.frame_positions(q, [robot.soles[s].frame], [robot.soles[s].center])[0]
             for q in (robot.q_nominal, _lean(robot, 0.3)) for s in ("left", "right")]
    assert np.abs(np.array(soles[:2]) - np.array(soles[2:])).max() < 1e-6
    toe = soles[0][0] + robot.soles["left"].half_extents[0]
    assert robot.com(_lean(robot, 0.3))[0] > toe + 0.08
    w = np.zeros(76)
    w[30:33] = np.linspace(0.0, 1.0, 3)
    w[33:48] = 1.0
    w[48:51] = np.linspace(1.0, 0.0, 3)
    motion = RobotMotion(q=np.array([_lean(robot, 0.3 * x) for x in w]), fps=30.0,
                         robot=robot.name, joint_names=robot.joint_names)
    result = simulate_motion(robot, motion,
                             config=PhysicsConfig(timing=TimingConfig(settle_s=0.2)))
    assert result.fell
    assert "lost the motion" in result.fall_reason
    assert 1.0 <= result.survived_s <= 1.6


def test_kinematic_mode_stands_with_exact_joints(jvrc1):
    """The paper's check: joints as velocity actuators follow the reference exactly (error
    < 1e-3 rad), the base is free, the nominal pose stands."""
    pytest.importorskip("dartpy")
    from imesh.physics import ControlConfig, PhysicsConfig, TimingConfig, simulate_motion

    result = simulate_motion(jvrc1, _standing(jvrc1, 1.5), config=PhysicsConfig(
        control=ControlConfig(controller="kinematic"), timing=TimingConfig(settle_s=0.2)))
    assert not result.fell, result.fall_reason
    assert result.tracking_rms_rad < 1e-3
    assert result.base_drift_m < 0.01


def test_a_fall_in_the_dart_check_fails_verification(jvrc1):
    """``imesh retarget --physics``: a motion the controller cannot keep up is a failed gate
    (VerificationError, exit 3); a standing motion passes it."""
    pytest.importorskip("dartpy")
    from imesh.errors import VerificationError
    from imesh.evaluate.verify import verify_motion
    from imesh.physics import PhysicsConfig, TimingConfig

    robot = jvrc1
    physics = PhysicsConfig(timing=TimingConfig(settle_s=0.2))
    q = _standing(robot, 2.0).q.copy()
    q[15:45, 2] += 0.3
    flying = RobotMotion(q=q, fps=30.0, robot=robot.name, joint_names=robot.joint_names)
    with pytest.raises(VerificationError, match="physics_fell"):
        verify_motion(robot, flying, name="flying", physics=physics)
    report, failed = verify_motion(robot, flying, name="flying", physics=physics, force=True)
    assert failed["physics_fell"][0] is True and report["physics_fell"]["value"] is True
    report, failed = verify_motion(robot, _standing(robot, 1.0), name="standing",
                                   physics=physics)
    assert not failed and report["physics_fell"]["value"] is False


def test_the_default_walk_stands_at_its_own_speed_with_the_toe_roll(request):
    """The CMU walk retargeted to G1 with default settings and read back from its file stands
    to its end in DART at the clip's own speed: key points within 25 mm RMS and 150 mm max of
    the reference (measured 5.8 / 26.7), the base within 50 mm at the end; with its soles held
    flat to the lift-off (no toe roll) the QP unloads the rear sole before it lifts, the capture
    point runs off at the lift-offs and the robot stays up only by swinging its trunk and arms
    (key points 32.0 / 166.5 mm on the plan before the ZMP's lower weight in double support).
    (A late landing driven below the ground, ``WbcConfig.landing_depth_m``, lowered this walk's
    slip from 3.2 to 1.9 mm on that plan; on this one it reads 3.2 mm with it and 2.5 without:
    docs/changelog.md.)"""
    import dataclasses

    from imesh.evaluate import load_motion_file
    from imesh.physics import PhysicsConfig, simulate_motion

    robot = _robot("g1")
    # ``imesh retarget`` of the walk (conftest's g1_walk), after the skip above
    motion = load_motion_file(request.getfixturevalue("g1_walk")[0], robot)
    physics = PhysicsConfig()
    res = simulate_motion(robot, motion, config=physics)
    assert not res.fell and res.survived_s == pytest.approx(res.duration_s)
    assert res.keypoint_rms_mm <= 25.0 and res.keypoint_max_mm <= 150.0
    assert res.base_drift_m <= 0.05
    # where the largest slip is: a sole in a planned support phase at that time
    assert res.slip_mm > 0.0
    assert res.support[int(round(res.slip_s * res.fps)), SIDES.index(res.slip_side)]
    flat = dataclasses.replace(physics, control=dataclasses.replace(
        physics.control, wbc=dataclasses.replace(physics.control.wbc, toe_roll_frames=0)))
    held = simulate_motion(robot, motion, config=flat)
    assert held.fell or held.keypoint_max_mm >= 3.0 * res.keypoint_max_mm
    assert res.slip_mm <= 5.0


def test_the_veer_stands_from_its_lead_in(tmp_path):
    """The CMU veer starts with G1's right foot lifted and pitched 85 deg: the lead-in puts it
    down and swings it up into the clip, its markers carried with the foot
    (imesh.solve.lead.LeadFeet). The reference's sole rises at most 40 mm per frame in that
    swing (it rose 99 mm and pitched 32 deg in one frame, and the robot was lost in the lead-in
    at 1.17 s), and the robot stands to the end with the base within 50 mm of the reference.
    On the clip's first 1.7 s (frames 0-200 at 120 fps: the lifted foot's swing and two more
    steps, ending with both feet down; with the lead-in and lead-out, 3.6 s in DART), measured:
    32.8 mm rise at most (12.98 with a 0.5 s swing), the base 1.8 mm off at the end (the whole
    4.45 s veer with a 0.5 s swing: 12.81 mm and 2.0 mm, for 3.4 times the retarget's time). The
    swing takes the lead-in's last
    ``RetargetConfig.lead_swing_s`` (0.15 s, 4 frames at 30 fps): the robot stands on its left
    foot through it with the markers held at the clip's first frame, which that foot does not
    balance; the lead's key points are 42.9 mm RMS off their markers (60.8 mm with a 0.5 s
    swing, the trunk leaning over the stance foot)."""
    from conftest import mocap_path

    from imesh.evaluate import load_motion_file
    from imesh.evaluate.scoreboard import evaluate_motion
    from imesh.io import load_motion
    from imesh.io.robot_motion import save_robot_motion
    from imesh.metrics.soles import sole_tracks
    from imesh.physics import PhysicsConfig, simulate_motion
    from imesh.pipeline.retarget import retarget

    robot = _robot("g1")
    path = tmp_path / "veer.npz"
    result = retarget(load_motion(mocap_path("cmu_16_11_walk_veer_left.bvh")).frames(0, 200),
                      robot)
    save_robot_motion(path, result.motion)
    motion = load_motion_file(path, robot)
    n_in = result.lead_frames[0]
    right = result.support.support[:n_in, 1]
    assert right[:n_in - 4].all() and not right[n_in - 4:].any()
    rms = evaluate_motion(robot, result.motion, adapted=result.adapted)["marker_rms_mm"]
    assert rms["lead_frames_mm"] <= 48.0
    low = sole_tracks(robot, motion.q, motion.fps).corners["right"][:n_in + 1, :, 2].min(axis=1)
    assert np.diff(low).max() <= 0.04
    res = simulate_motion(robot, motion, config=PhysicsConfig())
    assert not res.fell, res.fall_reason
    assert res.base_drift_m <= 0.05


def test_a_sole_on_a_box_edge_stands_on_the_box(jvrc1):
    """With props, a sole's height is taken above the highest surface under its centre or a
    corner: the left sole with its toe corners on a box's top and its centre 20 mm beyond the
    box's edge is on the box (height 0), the right sole beside the box is 0.1 m above the
    floor; the contact rows drive a sole to the surface it is over."""
    import trimesh

    from imesh.physics.reference import build_reference
    from imesh.physics.track import ReferenceTrack
    from imesh.physics.wbc import WholeBodyController
    from imesh.scene import Prop, Scene
    from imesh.scene.surfaces import SupportSurfaces

    robot = jvrc1
    motion = _standing(robot, 0.2)
    ref = build_reference(robot, motion.q, motion.fps)
    q = ref.q[0].copy()
    top = 0.1
    frames = [robot.soles[s].frame for s in SIDES]
    centres = np.array([robot.soles[s].center for s in SIDES])
    poses = robot.dynamics(ref.q[0], np.zeros(robot.nv), frames, centres).poses
    floor = poses[:, 2, 3].copy()  # the soles' height standing on the floor
    q[2] += top
    left = poses[0, :3, 3]
    X = robot.soles["left"].half_extents[0]
    box = trimesh.creation.box(bounds=[[left[0] + 0.02, left[1] - 0.05, 0.0],
                                       [left[0] + X + 0.2, left[1] + 0.05, top]])
    scene = Scene((Prop("step", np.asarray(box.vertices), np.asarray(box.faces)),),
                  frame="robot")
    controller = WholeBodyController(robot, ReferenceTrack(robot, ref), WbcConfig(), 1.0,
                                     surfaces=SupportSurfaces(scene))
    dyn = robot.dynamics(q, np.zeros(robot.nv), frames, centres)
    heights = controller.sole_heights(dyn.poses, controller.contact_frames(dyn.poses))
    np.testing.assert_allclose(heights, [floor[0], floor[1] + top], atol=1e-9)
    # flat on the box's top: the contact rows' height error is 0 for the left sole
    assert abs(controller._flat_error(dyn.poses[0], 0)[2] + floor[0]) < 1e-9

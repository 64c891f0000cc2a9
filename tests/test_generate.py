"""Robot configurations generated from a URDF alone (imesh.robot.generate, `imesh robots init`).

The rules are checked against the three hand-written configurations (same feet, hands and soles
within 5 mm, every key point within 25 mm), on two robots that have none (Romeo and iCub of
example-robot-data), and on URDFs that are not biped humanoids (refused with what was found).
"""

from __future__ import annotations

import subprocess
import sys
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest
from conftest import hrp4c_urdf

from imesh.robot import load_robot, resolve_urdf
from imesh.robot.generate import NotHumanoidError, generate_robot_config
from imesh.robot.generate_files import write_generated

ROOT = Path(__file__).resolve().parents[1]


def erd(suffix: str) -> Path:
    """A file of the example-robot-data distribution (skip when it is not installed)."""
    try:
        files = metadata.files("example-robot-data") or []
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data not installed (pip install imesh-retarget[g1])")
    for f in files:
        if str(f).replace("\\", "/").endswith(suffix):
            return Path(f.locate())
    pytest.skip(f"example-robot-data has no {suffix}")


def zero_pose_points(robot, frames_offsets) -> np.ndarray:
    """World points of (frame, offset) pairs at the zero pose (joints 0 clipped to limits)."""
    q = robot.q_nominal.copy()
    q[:7] = [0, 0, 0, 0, 0, 0, 1]
    q[7:] = np.clip(0.0, robot.q_lower, robot.q_upper)
    frames = [f for f, _ in frames_offsets]
    return robot.frame_positions(q, frames, np.array([o for _, o in frames_offsets]))


@pytest.fixture(scope="module", params=["jvrc1", "g1", "hrp4c"])
def pair(request, tmp_path_factory):
    """(hand-written Robot, generated Robot, GeneratedConfig) of one shipped robot."""
    name = request.param
    if name == "g1":
        erd("g1_29dof_rev_1_0.urdf")
    hand = load_robot(name, urdf=hrp4c_urdf() if name == "hrp4c" else None)
    urdf, _ = resolve_urdf(hand.config, hrp4c_urdf() if name == "hrp4c" else None)
    gen = generate_robot_config(urdf)
    out = tmp_path_factory.mktemp(f"gen_{name}")
    write_generated(gen, out)
    return hand, load_robot(out / "robot.toml", urdf=urdf), gen


def test_generated_matches_hand_written(pair):
    hand, robot, gen = pair
    assert dict(gen.feet) == dict(hand.config.foot_frames)
    assert set(gen.fixed) == set(hand.config.fixed_joints)
    assert robot.joint_names == hand.joint_names
    kps = hand.markers.keypoints
    common = [m for m in kps if m in gen.keypoints]
    assert len(common) == 20  # the standard markers but the spine
    a = zero_pose_points(hand, [(kps[m].frame, kps[m].offset) for m in common])
    b = zero_pose_points(hand, [gen.keypoints[m] for m in common])
    err_mm = dict(zip(common, np.linalg.norm(a - b, axis=1) * 1000, strict=True))
    assert max(err_mm[m] for m in ("hand_l", "hand_r", "wrist_l", "wrist_r")) <= 5.0, err_mm
    assert max(err_mm.values()) <= 25.0, err_mm
    for side in ("left", "right"):
        s_hand, s_gen = hand.soles[side], robot.soles[side]
        assert np.abs(2 * (s_gen.half_extents - s_hand.half_extents)).max() <= 0.005
        assert np.abs(s_gen.center - s_hand.center).max() <= 0.005


def test_generated_nominal_pose_stands(pair):
    """Knees bent, soles level on the floor, within the joint limits."""
    _, robot, _ = pair
    q = robot.q_nominal
    assert np.all(q[7:] >= robot.q_lower - 1e-9) and np.all(q[7:] <= robot.q_upper + 1e-9)
    for side in ("left", "right"):
        assert abs(robot.sole_center(q, side)[2]) < 1e-6


@pytest.mark.parametrize("suffix, dof, fixed, sole_mm", [
    ("romeo_description/urdf/romeo.urdf", 31, 24, (194, 111)),
    ("icub_description/robots/icub.urdf", 32, 0, (156, 61)),
])
def test_robots_without_configuration(tmp_path, suffix, dof, fixed, sole_mm):
    urdf = erd(suffix)
    gen = generate_robot_config(urdf)
    assert len(gen.fixed) == fixed
    assert {k for k in gen.limbs} >= {"leg_left", "leg_right", "arm_left", "arm_right", "head"}
    files = write_generated(gen, tmp_path)
    assert {f.name for f in files} == {"robot.toml", "markers.toml", "report.txt"}
    robot = load_robot(tmp_path / "robot.toml", urdf=urdf)
    assert len(robot.joint_names) == dof
    for side in ("left", "right"):
        # iCub's meshes are Collada Y_UP: read raw, its feet would lie across (61 x 156 mm)
        size_mm = 2000 * robot.soles[side].half_extents
        assert np.allclose(size_mm, sole_mm, atol=2), size_mm
        assert abs(robot.sole_center(robot.q_nominal, side)[2]) < 1e-6
    # left is left: the toes point forward = (left hand - right hand) x up
    q = robot.q_nominal
    kp = robot.markers.keypoints
    pts = robot.frame_positions(q, [kp[m].frame for m in ("hand_l", "hand_r", "toe_l", "ankle_l")],
                                np.array([kp[m].offset for m in ("hand_l", "hand_r", "toe_l",
                                                                 "ankle_l")]))
    toe_ahead = pts[2] - pts[3]
    left = (pts[0] - pts[1]) / np.linalg.norm(pts[0] - pts[1])
    up = np.array([0.0, 0.0, 1.0])
    assert np.cross(left, up) @ toe_ahead > 0.03


@pytest.mark.parametrize("suffix, says", [
    ("solo_description/robots/solo12.urdf", "4 leg chains found"),
    ("panda_description/urdf/panda.urdf", "no leg chain found"),
    # a y-up human model: told why, not only that one "leg" (an arm hanging along -y) was found
    ("human_description/robots/human.urdf", "does not stand along z"),
])
def test_not_a_humanoid(suffix, says):
    with pytest.raises(NotHumanoidError, match=says) as info:
        generate_robot_config(erd(suffix))
    assert "leg chains" in info.value.found


_LINK = """<link name="{n}"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0"
 iyy="0.01" iyz="0" izz="0.01"/></inertial>{geo}</link>"""
_BOX = '<collision><geometry><box size="0.05 0.05 0.05"/></geometry></collision>'
_JOINT = """<joint name="{n}" type="revolute"><parent link="{p}"/><child link="{c}"/>
 <origin xyz="{xyz}"/><axis xyz="{axis}"/><limit lower="-2" upper="2" velocity="5"
 effort="50"/></joint>"""


def tiny_humanoid(foot_geometry: bool) -> str:
    """A stick humanoid: two 3-joint legs, two 3-joint arms on a torso joint."""
    links, joints = ["pelvis", "torso"], [("waist", "pelvis", "torso", "0 0 0.1", "0 0 1")]
    for s, y in (("l", 0.1), ("r", -0.1)):
        links += [f"{s}_thigh", f"{s}_shank", f"{s}_foot", f"{s}_upper", f"{s}_fore", f"{s}_hand"]
        joints += [(f"{s}_hip", "pelvis", f"{s}_thigh", f"0 {y} -0.05", "0 1 0"),
                   (f"{s}_knee", f"{s}_thigh", f"{s}_shank", "0 0 -0.4", "0 1 0"),
                   (f"{s}_ankle", f"{s}_shank", f"{s}_foot", "0 0 -0.4", "0 1 0"),
                   (f"{s}_shoulder", "torso", f"{s}_upper", f"0 {1.5 * y} 0.3", "0 1 0"),
                   (f"{s}_elbow", f"{s}_upper", f"{s}_fore", "0 0 -0.25", "0 1 0"),
                   (f"{s}_wrist", f"{s}_fore", f"{s}_hand", "0 0 -0.25", "0 1 0")]
    text = ['<robot name="tiny">']
    text += [_LINK.format(n=n, geo="" if n.endswith("foot") and not foot_geometry else _BOX)
             for n in links]
    text += [_JOINT.format(n=n, p=p, c=c, xyz=xyz, axis=ax) for n, p, c, xyz, ax in joints]
    return "\n".join(text + ["</robot>"])


def test_foot_without_sole_geometry(tmp_path):
    urdf = tmp_path / "tiny.urdf"
    urdf.write_text(tiny_humanoid(foot_geometry=False))
    with pytest.raises(NotHumanoidError, match="foot .* has no collision or visual geometry"):
        generate_robot_config(urdf)
    urdf.write_text(tiny_humanoid(foot_geometry=True))
    gen = generate_robot_config(urdf)
    assert gen.limbs["leg_left"].middle == "l_knee"
    assert gen.limbs["arm_right"].middle == "r_elbow"
    assert dict(gen.feet) == {"left": "l_foot", "right": "r_foot"}


def test_cli_init_and_urdf_alone(tmp_path):
    """`imesh robots init` writes the files and the picture; `load_robot(urdf=...)` alone
    generates (once) into the cache."""
    urdf = erd("romeo_description/urdf/romeo.urdf")
    out = tmp_path / "romeo"
    run = subprocess.run([sys.executable, "-c", "from imesh.cli import main; main()", "robots",
                          "init", str(urdf), "-o", str(out)], capture_output=True, text=True,
                         cwd=ROOT)
    assert run.returncode == 0, run.stderr
    assert "what the URDF lacks" in run.stdout
    assert {p.name for p in out.iterdir()} == {"robot.toml", "markers.toml", "report.txt",
                                               "keypoints.png"}
    assert (out / "keypoints.png").stat().st_size > 10_000
    env_code = ("import os, sys; os.environ['IMESH_CACHE_DIR'] = sys.argv[1];"
                "from imesh.robot import load_robot; r = load_robot(urdf=sys.argv[2]);"
                "print(r.name, len(r.joint_names))")
    for _ in range(2):
        run = subprocess.run([sys.executable, "-c", env_code, str(tmp_path / "cache"), str(urdf)],
                             capture_output=True, text=True, cwd=ROOT)
        assert run.returncode == 0, run.stderr
        assert run.stdout.split() == ["romeo", "31"]
    assert len(list((tmp_path / "cache" / "robots").iterdir())) == 1


def test_talos_shoulder_offset_and_gripper():
    """Talos: the first arm joint sits on the torso 14 cm inside the shoulder, and a gripper
    joint ends each arm chain; the elbow is still the 4th joint, the shoulder key point on the
    shoulder's own axes, the grippers fixed."""
    gen = generate_robot_config(erd("talos_data/robots/talos_reduced.urdf"))
    arm = gen.limbs["arm_left"]
    assert arm.middle == "arm_left_4_joint"
    assert arm.joints[-1] == "arm_left_7_joint"
    assert set(gen.fixed) >= {"gripper_left_joint", "gripper_right_joint"}
    shoulder = gen.keypoints_nominal_m["shoulder_l"]
    assert abs(shoulder[1] - 0.294) < 0.005  # arm_left_2/3 axes, not the torso joint's


def test_talos_torso_with_its_imu_box_gets_split_capsules(tmp_path, monkeypatch):
    """Talos's torso is a mesh plus the IMU link's box: the box's convex hull gives it triangles
    too, so the torso is split like any mesh body (2 capsules of 173 and 178 mm instead of one
    of 235 mm around a torso 306 x 454 mm), and the capsules still enclose every point."""
    from imesh.robot import load_robot
    from imesh.robot.capsules.bodies import body_points, robot_bodies
    from imesh.robot.capsules.robot import fit_robot_capsules

    monkeypatch.setenv("IMESH_CACHE_DIR", str(tmp_path / "cache"))
    urdf = erd("talos_data/robots/talos_reduced.urdf")
    out = tmp_path / "talos"
    write_generated(generate_robot_config(urdf), out)
    robot = load_robot(out, urdf=urdf)
    links, _ = robot_bodies(robot)
    points, triangles = body_points(robot, "torso_2_link", links["torso_2_link"])
    assert triangles is not None and len(triangles) > 12
    torso = [c for c in fit_robot_capsules(robot, cache=False) if c.body == "torso_2_link"]
    assert len(torso) >= 2 and max(c.radius for c in torso) < 0.19
    ab = np.stack([[c.a, c.b] for c in torso])  # (C, 2, 3)
    seg = ab[:, 1] - ab[:, 0]
    t = np.clip(np.einsum("pcj,cj->pc", points[:, None] - ab[:, 0], seg)
                / np.maximum(np.einsum("cj,cj->c", seg, seg), 1e-12), 0.0, 1.0)
    dist = np.linalg.norm(points[:, None] - (ab[:, 0] + t[..., None] * seg), axis=-1)
    radius = np.array([c.radius for c in torso])
    assert (dist - radius).min(axis=1).max() <= 1e-9  # every point in some capsule


@pytest.mark.parametrize("detector", ["ode", "dart"])
def test_icub_holds_its_nominal_pose_in_dart(tmp_path, detector):
    """iCub in DART: zero-mass frame links get DART's default inertia, the head and neck
    (point masses in the URDF) a sphere's inertia, the feet rest on their sole boxes only (its
    foot link l_foot sits under the sole frame l_sole), and the robot stands 2 s in its
    generated nominal pose without a joint reaching its torque limit."""
    from imesh.core.robot_motion import RobotMotion
    from imesh.physics import GroundConfig, PhysicsConfig, simulate_motion
    from imesh.physics.world import DartRobot
    from imesh.robot.inertia import sphere_moment

    urdf = erd("icub_description/robots/icub.urdf")
    write_generated(generate_robot_config(urdf), tmp_path)
    robot = load_robot(tmp_path / "robot.toml", urdf=urdf)
    config = PhysicsConfig(ground=GroundConfig(collision_detector=detector))
    sim = DartRobot(robot, config)
    head = sim.skeleton.getBodyNode("head")
    assert head.getMass() == pytest.approx(1.33687)
    assert np.diag(head.getInertia().getMoment()) == pytest.approx([sphere_moment(1.33687)] * 3)
    # the effective inertia of every joint (all other DOF free) is a physical one: with the
    # URDF's point-mass head, neck_yaw's was 1e-12 kg m^2 and the neck shook at its limit
    mass_matrix = np.asarray(sim.skeleton.getMassMatrix())
    effective = 1.0 / np.diag(np.linalg.inv(mass_matrix))[sim.joint_dofs]
    assert effective.min() > 1e-4
    motion = RobotMotion(q=[robot.q_nominal] * 60, fps=30.0, robot=robot.name,
                         joint_names=robot.joint_names)
    result = simulate_motion(robot, motion, config=config)
    assert not result.fell, result.fall_reason
    assert result.base_drift_m < 0.02
    # iCub's URDF damps every joint (1 N m s/rad) and gives its wrist pronosupination 0.45 N m:
    # the controller pays the damping the simulator applies (0.51 of that limit at rest)
    assert result.torque_ratio_max < 0.6


def test_icub_has_one_inertia_in_pinocchio_and_dart(tmp_path):
    """iCub's URDF writes its head and neck as point masses; both models of the robot get the
    same sphere inertia for them (imesh.robot.inertia), so the whole-body controller's mass
    matrix (pinocchio) is the simulator's (DART): with the URDF's, neck_yaw's diagonal was
    4.6e-4 kg m^2 in pinocchio against DART's regularized one."""
    from imesh.physics import PhysicsConfig
    from imesh.physics.world import DartRobot

    urdf = erd("icub_description/robots/icub.urdf")
    write_generated(generate_robot_config(urdf), tmp_path)
    robot = load_robot(tmp_path / "robot.toml", urdf=urdf)
    sim = DartRobot(robot, PhysicsConfig())
    q = robot.q_nominal
    sim.set_state(q)
    dart_m = np.asarray(sim.skeleton.getMassMatrix())[np.ix_(sim.joint_dofs, sim.joint_dofs)]
    pin_m = robot.configuration.dynamics(q, np.zeros(6 + robot.dof), [0],
                                         np.zeros((1, 3))).mass_matrix[6:, 6:]
    np.testing.assert_allclose(pin_m, dart_m, atol=1e-8)
    neck = robot.joint_index("neck_yaw")
    assert pin_m[neck, neck] > 2e-3

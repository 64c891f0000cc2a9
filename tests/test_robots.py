"""Robot models: configuration lint, loading, kinematics, soles, collision proxies, bad inputs.

Parametrized over the three robots: JVRC-1 (package jvrc-description), Unitree G1 (package
example-robot-data, skipped when absent) and HRP-4C (user URDF from the shared folder beside
IMESH_DATA).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import hrp4c_urdf

from imesh.errors import ImeshError
from imesh.human.markerset import STANDARD_BONE_NAMES, STANDARD_MARKERS
from imesh.robot import (
    ROBOTS_DIR,
    RobotConfigError,
    fit_primitive,
    list_robots,
    load_markers_config,
    load_robot,
    load_robot_config,
    robot_names,
)
from imesh.robot.collision import CollisionShape
from imesh.robot.registry import package_available

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ["jvrc1", "g1", "hrp4c"]
EXPECTED_DOF = {"jvrc1": 32, "g1": 29, "hrp4c": 30}


def robot_urdf(name: str) -> Path | None:
    if name != "hrp4c":
        return None
    return hrp4c_urdf()


@pytest.fixture(scope="module", params=ROBOTS)
def robot(request):
    name = request.param
    if name == "g1" and not package_available(load_robot_config(ROBOTS_DIR / "g1" /
                                                                "robot.toml")):
        pytest.skip("example-robot-data not installed (pip install imesh-retarget[g1])")
    return load_robot(name, robot_urdf(name))


def keypoint_arrays(robot):
    names, frames, offsets, weights = robot.keypoint_arrays()
    assert len(names) == len(frames) == len(offsets) == len(weights)
    assert np.all(weights > 0)
    return list(names), [int(f) for f in frames], offsets


# ------------------------------------------------------------------------------------------
# lint


def test_shipped_robots():
    assert robot_names() == sorted(ROBOTS)
    listed = {r["name"]: r for r in list_robots()}
    assert set(listed) == set(ROBOTS)
    for name, dof in EXPECTED_DOF.items():
        assert listed[name]["dof"] == dof
        assert listed[name]["licence"].startswith("BSD")
    assert listed["jvrc1"]["available"] and listed["jvrc1"]["source"] == \
        "package jvrc_description"
    assert listed["hrp4c"]["source"].startswith("user --urdf")


@pytest.mark.parametrize("name", ROBOTS)
def test_robot_folder_files_parse(name):
    folder = ROBOTS_DIR / name
    cfg = load_robot_config(folder / "robot.toml")
    assert cfg.name == name and cfg.markers_path == folder / "markers.toml"
    assert (folder / "README.md").is_file()
    markers = load_markers_config(folder / "markers.toml")
    surviving = [m for m in STANDARD_MARKERS if m not in markers.remove]
    assert list(markers.keypoints)[:len(surviving)] == surviving
    for a in markers.add:
        assert a.name in markers.keypoints
        assert abs(sum(a.human.values()) - 1) < 1e-9


def test_lint_loaded(robot):
    """Every frame named exists, limits are sane, the nominal pose is inside the limits."""
    for key, frame in robot.config.frame_references() + robot.markers.frame_references():
        assert frame in robot.frame_names, key
        robot.frame_id(frame)
    for arr in (robot.q_lower, robot.q_upper, robot.v_max, robot.a_max, robot.effort_max):
        assert arr.shape == (robot.dof,) and np.all(np.isfinite(arr))
    assert np.all(robot.q_lower < robot.q_upper)
    assert np.all(robot.v_max > 0) and np.all(robot.a_max > 0) and np.all(robot.effort_max > 0)
    joints = robot.q_nominal[7:]
    assert np.all(joints >= robot.q_lower) and np.all(joints <= robot.q_upper)
    assert robot.mass > 20


def standing_torques(robot, sides: tuple[str, ...]) -> np.ndarray:
    """(dof,) float [Nm] joint torques that hold the nominal pose still on the given soles:
    gravity torques less those of the sole-corner forces that balance the base (least-norm
    solution of inverse dynamics' 6 base rows)."""
    q = robot.q_nominal
    zero = np.zeros(robot.nv)
    gravity = robot.inverse_dynamics(q, zero, zero)
    frames = [robot.soles[s].frame for s in sides for _ in range(4)]
    corners = np.vstack([robot.soles[s].corners() for s in sides])
    J = robot.point_jacobians(q, frames, corners).reshape(-1, robot.nv)
    forces = np.linalg.lstsq(J[:, :6].T, gravity[:6], rcond=None)[0]
    return gravity[6:] - J[:, 6:].T @ forces


def test_effort_limits_well_above_standing_torques(robot):
    """Every torque limit is at least twice what standing still on both feet in the nominal
    pose takes (a limit that low is not a robot's real one: it could not walk)."""
    both = np.abs(standing_torques(robot, ("left", "right")))
    assert both.max() > 5.0  # the knees carry the bent-knee stance
    assert np.all(robot.effort_max >= 2 * both)


def test_uniform_effort_limits_are_declared_placeholders(robot):
    """One effort limit for every joint is a URDF placeholder, not motor data: robot.toml's
    limits.source and the README must say so (the README also says what was searched)."""
    if np.ptp(robot.effort_max) > 0:
        return
    assert "placeholder" in robot.config.limits.source
    readme = (ROBOTS_DIR / robot.name / "README.md").read_text(encoding="utf-8").lower()
    assert "placeholder" in readme and "searched" in readme


def test_keypoints_form_a_skeleton(robot):
    """Keypoints joined by a surviving standard bone are apart; directions match keypoints."""
    names, frames, offsets = keypoint_arrays(robot)
    pos = dict(zip(names, robot.frame_positions(robot.q_nominal, frames, offsets),
                   strict=True))
    for a, b in STANDARD_BONE_NAMES:
        if a in pos and b in pos:
            assert np.linalg.norm(pos[a] - pos[b]) > 0.03, (a, b)
    # left/right mirror each other and the left side is on +y
    for m in names:
        if m.endswith("_l"):
            pl, pr = pos[m], pos[m[:-2] + "_r"]
            assert pl[1] > 0.03 and np.allclose(pl * [1, -1, 1], pr, atol=2e-3), m
    for d in robot.markers.directions:
        R = robot.frame_rotations(robot.q_nominal, [d.frame])[0]
        u = pos[d.to_marker] - pos[d.from_marker]
        cos = (R @ d.axis) @ u / np.linalg.norm(u)
        assert cos > np.cos(np.radians(3)), (d.frame, d.from_marker, d.to_marker)


# ------------------------------------------------------------------------------------------
# loading and kinematics


def test_dof_and_sizes(robot):
    dof = EXPECTED_DOF[robot.name]
    assert robot.dof == dof and robot.nq == dof + 7 and robot.nv == dof + 6
    assert len(robot.joint_names) == dof and len(set(robot.joint_names)) == dof
    assert robot.model.joints[1].shortname() == "JointModelFreeFlyer"
    assert robot.q_nominal.shape == (robot.nq,)
    assert np.isclose(np.linalg.norm(robot.q_nominal[3:7]), 1.0)
    assert set(robot.soles) == {"left", "right"} and set(robot.foot_frames) == {"left", "right"}


def test_soles_flat_on_ground_in_nominal_pose(robot):
    q = robot.q_nominal
    for side in ("left", "right"):
        corners = robot.sole_corners(q, side)
        assert np.abs(corners[:, 2]).max() < 1e-6, side
        sole = robot.soles[side]
        n_world = robot.frame_rotations(q, [sole.frame])[0] @ sole.normal
        assert np.allclose(n_world, [0, 0, 1], atol=1e-9)
        assert np.all(sole.half_extents > 0.02)
    left, right = robot.sole_center(q, "left"), robot.sole_center(q, "right")
    assert left[1] > 0.03 > -0.03 > right[1]
    # the base is level and above the origin; the CoM is above the feet
    assert np.allclose(q[:2], 0) and np.allclose(q[3:7], [0, 0, 0, 1])
    com = robot.com(q)
    assert abs(com[1]) < 0.01 and 0.3 < com[2] < 1.2
    assert robot.lowest_point(q) > -0.005


def test_point_jacobians_match_finite_differences(robot):
    rng = np.random.default_rng(7)
    names, frames, offsets = keypoint_arrays(robot)
    h = 1e-6
    for q in (robot.q_nominal, robot.random_configuration(rng, scale=0.8)):
        J = robot.point_jacobians(q, frames, offsets)
        Jw = robot.frame_angular_jacobians(None, frames)  # reuses q
        assert J.shape == (len(frames), 3, robot.nv) and Jw.shape == J.shape
        num = np.empty_like(J)
        numw = np.empty_like(Jw)
        for k in range(robot.nv):
            dv = np.zeros(robot.nv)
            dv[k] = h
            qp, qm = robot.integrate(q, dv), robot.integrate(q, -dv)
            num[:, :, k] = (robot.frame_positions(qp, frames, offsets)
                            - robot.frame_positions(qm, frames, offsets)) / (2 * h)
            Rp, Rm = robot.frame_rotations(qp, frames), robot.frame_rotations(qm, frames)
            dR = np.einsum("fij,fkj->fik", Rp, Rm)  # Rp Rm^T ~ exp(2h [w])
            numw[:, :, k] = np.stack([dR[:, 2, 1] - dR[:, 1, 2], dR[:, 0, 2] - dR[:, 2, 0],
                                      dR[:, 1, 0] - dR[:, 0, 1]], axis=1) / (4 * h)
        assert np.abs(J - num).max() < 1e-6
        assert np.abs(Jw - numw).max() < 1e-6
        # the stacked 6-row Jacobian of the frame origins (one pinocchio call per frame)
        J6 = robot.frame_jacobians(q, frames)
        origin = robot.point_jacobians(q, frames)
        assert np.abs(J6[:, :3] - origin).max() < 1e-12
        assert np.abs(J6[:, 3:] - Jw).max() < 1e-12


def test_getters_reuse_forward_and_tangent_maps(robot):
    rng = np.random.default_rng(3)
    q0, q1 = robot.random_configuration(rng), robot.random_configuration(rng)
    names, frames, offsets = keypoint_arrays(robot)
    expected = robot.frame_positions(q1, frames, offsets)
    robot.forward(q1)
    assert np.array_equal(robot.frame_positions(None, frames, offsets), expected)
    assert np.allclose(robot.frame_positions(None, frames)[0],
                       robot.frame_placements(None, frames[:1])[0][:3, 3])
    dv = robot.difference(q0, q1)
    assert dv.shape == (robot.nv,)
    assert np.allclose(robot.frame_positions(robot.integrate(q0, dv), frames, offsets), expected,
                       atol=1e-9)
    # other pinocchio calls leave the "last configuration" consistent for q=None getters
    robot.forward(q0)
    robot.com(q1)
    assert np.allclose(robot.frame_positions(None, frames, offsets), expected, atol=1e-12)
    assert np.allclose(robot.point_jacobians(None, frames, offsets),
                       robot.point_jacobians(q1.copy(), frames, offsets), atol=1e-12)
    robot.frame_positions(q0, frames, offsets)
    J0 = robot.point_jacobians(q0, frames, offsets)  # same q: Jacobians computed, not stale
    robot.forward(q0)
    assert np.array_equal(J0, robot.point_jacobians(None, frames, offsets))
    with pytest.raises(ImeshError, match=r"shape"):
        robot.forward(q1[:-1])


def test_zmp_of_static_pose_is_com_projection(robot):
    q = robot.q_nominal
    zero = np.zeros(robot.nv)
    assert np.allclose(robot.zmp(q, zero, zero), robot.com(q)[:2], atol=1e-9)
    a = zero.copy()
    a[0] = 1.0  # base accelerating forward at 1 m/s^2 (base level: base frame = world axes)
    c = robot.com(q)
    assert np.isclose(robot.zmp(q, zero, a)[0] - c[0], -c[2] / 9.81, atol=1e-9)
    Jc = robot.com_jacobian(q)
    assert Jc.shape == (3, robot.nv) and np.allclose(Jc[:3, :3], np.eye(3), atol=1e-9)


# ------------------------------------------------------------------------------------------
# collision proxies


def test_collision_proxies_cover_main_links(robot):
    shapes = robot.collision_shapes
    assert shapes and all(s.kind in ("box", "cylinder", "sphere", "capsule") for s in shapes)
    for s in shapes:
        assert all(d >= 0 for d in s.dims) and s.volume() > 0
        R = s.placement[:3, :3]
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-9) and np.isclose(np.linalg.det(R), 1)
    shape_joints = {robot.model.frames[robot.frame_id(s.frame)].parentJoint for s in shapes}
    main = [robot.waist_frame, *robot.foot_frames.values()]
    main += [robot.markers.keypoints[m].frame for m in
             ("knee_l", "knee_r", "elbow_l", "elbow_r", "hand_l", "hand_r", "head", "chest")]
    for frame in main:
        assert robot.model.frames[robot.frame_id(frame)].parentJoint in shape_joints, frame


def test_self_collision_detected_when_legs_cross(robot):
    """Swinging the left leg inward through the right leg is reported on the URDF geometry
    (not ignored), between a left and a right body."""
    from imesh.metrics.collision import check_self_collisions

    roll = {"jvrc1": "L_HIP_R", "hrp4c": "L_HIP_R", "g1": "left_hip_roll_joint"}[robot.name]
    q = robot.q_nominal.copy()
    i = robot.joint_index(roll)
    q[7 + i] = robot.q_lower[i]  # full adduction: the left foot passes the right leg
    hits = check_self_collisions(robot, q[None]).mesh.frame_hits()[0]
    assert hits and all(a.startswith(("L_", "left_")) != b.startswith(("L_", "left_"))
                        for a, b, _ in hits), hits


@pytest.mark.parametrize("kind", ["box", "cylinder", "sphere"])
def test_fit_primitive_recovers_shape_and_encloses_points(kind):
    rng = np.random.default_rng(0)
    u = rng.normal(size=(3000, 3))
    if kind == "box":
        pts = rng.uniform(-1, 1, (3000, 3)) * [0.2, 0.05, 0.1]
    elif kind == "cylinder":
        ang = rng.uniform(0, 2 * np.pi, 3000)
        pts = np.stack([0.04 * np.cos(ang), 0.04 * np.sin(ang), rng.uniform(-0.15, 0.15, 3000)],
                       axis=1)
    else:
        pts = 0.07 * u / np.linalg.norm(u, axis=1, keepdims=True)
    rot = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    pts = pts @ rot.T + [0.1, -0.2, 0.3]
    got, dims, pose = fit_primitive(pts)
    expect = {"box": 0.4 * 0.1 * 0.2, "cylinder": np.pi * 0.04 ** 2 * 0.3,
              "sphere": 4 / 3 * np.pi * 0.07 ** 3}[kind]
    shape = CollisionShape("f", got, dims, pose)
    assert shape.volume() < 1.1 * expect, (got, dims)
    local = (pts - pose[:3, 3]) @ pose[:3, :3]
    if got == "box":
        assert np.all(np.abs(local) <= np.asarray(dims) / 2 + 1e-9)
    elif got == "sphere":
        assert np.all(np.linalg.norm(local, axis=1) <= dims[0] + 1e-9)
    else:
        radial = np.hypot(local[:, 0], local[:, 1])
        along = np.maximum(np.abs(local[:, 2]) - dims[1] / 2, 0)
        reach = radial if got == "cylinder" else np.hypot(radial, along)
        assert np.all(reach <= dims[0] + 1e-9)
        if got == "cylinder":
            assert np.all(np.abs(local[:, 2]) <= dims[1] / 2 + 1e-9)


# ------------------------------------------------------------------------------------------
# bad inputs


def test_unknown_robot_name_lists_valid_names():
    with pytest.raises(RobotConfigError) as err:
        load_robot("jvrc2")
    msg = str(err.value)
    assert "jvrc2" in msg and all(n in msg for n in ROBOTS)


def test_missing_urdf_for_user_robot():
    with pytest.raises(RobotConfigError, match=r"--urdf.*HRP4Cmain_reduced\.urdf"):
        load_robot("hrp4c")
    with pytest.raises(RobotConfigError, match="not found"):
        load_robot("hrp4c", urdf="/nonexistent/robot.urdf")


def copy_robot(tmp_path: Path, name: str, markers: bool = True) -> Path:
    folder = tmp_path / name
    folder.mkdir()
    shutil.copy(ROBOTS_DIR / name / "robot.toml", folder)
    if markers:
        shutil.copy(ROBOTS_DIR / name / "markers.toml", folder)
    return folder / "robot.toml"


def test_unknown_frame_in_robot_toml_lists_frames(tmp_path):
    toml = copy_robot(tmp_path, "jvrc1", markers=False)
    toml.write_text(toml.read_text().replace('waist = "PELVIS_S"', 'waist = "PELVIS"'))
    with pytest.raises(RobotConfigError) as err:
        load_robot(toml)
    msg = str(err.value)
    assert str(toml) in msg and "frames.waist" in msg and "'PELVIS'" in msg
    assert msg.index("PELVIS_S") < msg.index("L_HIP_P_S")  # closest match listed first


def test_unknown_frame_in_markers_toml(tmp_path):
    toml = copy_robot(tmp_path, "jvrc1")
    markers = toml.parent / "markers.toml"
    markers.write_text(markers.read_text().replace('"L_KNEE_S"', '"L_KNEE_X"'))
    with pytest.raises(RobotConfigError, match=r"markers\.toml \[keypoints\.knee_l\.frame\]"
                                               r".*'L_KNEE_X'.*valid: L_KNEE"):
        load_robot(toml)


def test_marker_without_keypoint_and_bad_keys(tmp_path):
    toml = copy_robot(tmp_path, "jvrc1")
    markers = toml.parent / "markers.toml"
    text = markers.read_text()
    markers.write_text("\n".join(line for line in text.splitlines()
                                 if not line.startswith("elbow_r =")))
    with pytest.raises(RobotConfigError, match=r"no keypoint for marker\(s\) elbow_r"):
        load_markers_config(markers)
    toml.write_text(toml.read_text().replace("[limits]", "[limit]"))
    with pytest.raises(RobotConfigError, match=r"unknown key 'limit'; valid: limits"):
        load_robot_config(toml)


def test_unknown_joint_in_config(tmp_path):
    toml = copy_robot(tmp_path, "jvrc1")
    toml.write_text(toml.read_text().replace("L_KNEE = 0.5", "L_KNEE_P = 0.5"))
    with pytest.raises(RobotConfigError, match=r"\[nominal\.L_KNEE_P\].*valid: L_KNEE"):
        load_robot(toml)


def test_urdf_that_does_not_parse(tmp_path):
    bad = tmp_path / "broken.urdf"
    bad.write_text('<robot name="x"><link name="a"></robot>')
    with pytest.raises(RobotConfigError, match=r"broken\.urdf: URDF does not parse"):
        load_robot("hrp4c", urdf=bad)
    bad.write_text('<robot name="x"><link name="a"/><joint name="j" type="revolute">'
                   '<parent link="a"/><child link="missing"/></joint></robot>')
    with pytest.raises(RobotConfigError, match=r"broken\.urdf: URDF does not parse"):
        load_robot("hrp4c", urdf=bad)


def test_missing_package_names_the_extra(tmp_path):
    toml = copy_robot(tmp_path, "g1")
    toml.write_text(toml.read_text().replace('distribution = "example-robot-data"',
                                             'distribution = "example-robot-data-absent"'))
    with pytest.raises(RobotConfigError, match=r"pip install imesh-retarget\[g1\]"):
        load_robot(toml)


def test_missing_pinocchio_is_reported(monkeypatch):
    monkeypatch.setitem(sys.modules, "pinocchio", None)
    with pytest.raises(ImeshError, match="pip install pin"):
        load_robot("jvrc1")


def test_import_does_not_load_pinocchio():
    code = "import sys, imesh.robot; assert 'pinocchio' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_cross_product_matrices_match_numpy_cross():
    """``imesh.core.skew.skew`` (the robot's Jacobian shifts, the controller's wrench transforms
    and the derivatives of the orientation metrics use it) is ``np.cross`` as a matrix, for one
    vector and for a batch, and antisymmetric."""
    from imesh.core.skew import skew

    rng = np.random.default_rng(3)
    r, x = rng.normal(size=3), rng.normal(size=3)
    assert np.allclose(skew(r) @ x, np.cross(r, x), atol=1e-15)
    R, X = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    S = skew(R)
    assert S.shape == (4, 5, 3, 3)
    assert np.allclose(np.einsum("...ij,...j->...i", S, X), np.cross(R, X), atol=1e-15)
    assert np.array_equal(S, -np.swapaxes(S, -1, -2))

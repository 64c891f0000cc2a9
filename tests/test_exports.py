"""Exports (imesh.io.formats, ``imesh export``): round trips of the CSV (LAFAN1 layout), MuJoCo
qpos and npz formats on a real G1 retarget of the demo walk, MuJoCo loading joint by joint, and
``--fps`` resampling (linear + slerp)."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import load_test_robot

from imesh.cli import main
from imesh.errors import OptionError
from imesh.io.formats import (
    ExportError,
    mujoco_model,
    read_export,
    resample_robot_motion,
    write_export,
)


@pytest.fixture(scope="module")
def g1_motion(g1_walk):
    """The demo walk retargeted to the G1 by ``imesh retarget`` (conftest's g1_walk)."""
    return read_export(g1_walk[0])


@pytest.fixture(scope="module")
def g1_mjcf(tmp_path_factory) -> Path:
    """An MJCF of the G1 made by MuJoCo from the URDF imesh uses (example-robot-data), with a
    free joint on the pelvis: the same joints as mujoco-menagerie's unitree_g1 (whose meshes
    are downloaded on first use, which needs the network)."""
    mujoco = pytest.importorskip("mujoco")
    from imesh.robot import load_robot_config, resolve_robot_toml, resolve_urdf

    urdf, _ = resolve_urdf(load_robot_config(resolve_robot_toml("g1")), None)
    root = ET.parse(urdf).getroot()
    for link in root.iter("link"):
        for tag in ("visual", "collision"):
            for el in link.findall(tag):
                link.remove(el)
    folder = tmp_path_factory.mktemp("g1_mjcf")
    raw = folder / "raw.xml"
    mujoco.mj_saveLastXML(str(raw), mujoco.MjModel.from_xml_string(
        ET.tostring(root, encoding="unicode")))
    tree = ET.parse(raw)
    world = tree.getroot().find("worldbody")
    pelvis = ET.Element("body", name="pelvis")
    ET.SubElement(pelvis, "freejoint", name="floating_base_joint")
    ET.SubElement(pelvis, "inertial", pos="0 0 0", mass="3", diaginertia="0.01 0.01 0.01")
    for child in list(world):
        world.remove(child)
        pelvis.append(child)
    world.append(pelvis)
    path = folder / "g1.xml"
    tree.write(path)
    return path


def test_csv_round_trip_lafan1_layout(g1_motion, tmp_path):
    path = write_export(g1_motion, tmp_path / "walk.csv", "csv")
    rows = path.read_text().splitlines()
    assert len(rows) == g1_motion.n_frames
    cells = rows[0].split(",")
    assert len(cells) == 7 + 29  # base xyz, quaternion xyzw, the G1's 29 joints
    float(cells[0])  # no header
    back = read_export(path, "g1", fps=g1_motion.fps)
    assert back.joint_names == g1_motion.joint_names
    assert np.max(np.abs(back.q - g1_motion.q)) <= 1e-9
    # the quaternion is x, y, z, w: columns 3..6 are the motion's base_quat_xyzw
    table = np.loadtxt(path, delimiter=",")
    assert np.array_equal(table[:, 3:7], g1_motion.base_quat_xyzw)


def test_npz_round_trip(g1_motion, tmp_path):
    back = read_export(write_export(g1_motion, tmp_path / "walk.npz", "npz"))
    # exact up to the re-normalization of the base quaternion on reading (last bits)
    assert np.abs(back.q - g1_motion.q).max() <= 1e-15 and back.fps == g1_motion.fps


def test_mujoco_export_loads_joint_by_joint(g1_motion, g1_mjcf, tmp_path):
    mujoco = pytest.importorskip("mujoco")
    path = write_export(g1_motion, tmp_path / "walk_mj.npz", "mujoco", mjcf=g1_mjcf)
    with np.load(path) as f:
        qpos = f["qpos"]
        assert list(f["filled_joints"]) == []
    model = mujoco.MjModel.from_xml_path(str(g1_mjcf))
    assert qpos.shape == (g1_motion.n_frames, model.nq)
    data = mujoco.MjData(model)
    robot = load_test_robot("g1")
    feet = [robot.frame_id("left_ankle_roll_link"), robot.frame_id("right_ankle_roll_link")]
    worst = 0.0
    for t in (0, g1_motion.n_frames // 2, g1_motion.n_frames - 1):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        for name in g1_motion.joint_names:  # joint by joint
            adr = model.jnt_qposadr[model.joint(name).id]
            assert data.qpos[adr] == g1_motion.joint_positions[t, g1_motion.joint_index(name)]
        w, x, y, z = data.qpos[3:7]
        assert np.allclose([x, y, z, w], g1_motion.base_quat_xyzw[t], atol=0, rtol=0)
        # the same pose: feet where pinocchio puts them
        pin = robot.frame_positions(g1_motion.q[t], feet)
        mj = np.array([data.body("left_ankle_roll_link").xpos,
                       data.body("right_ankle_roll_link").xpos])
        worst = max(worst, float(np.max(np.abs(pin - mj))))
    assert worst < 1e-6, worst  # the MJCF MuJoCo saved rounds body poses to ~1e-9 m
    back = read_export(path)
    assert back.joint_names == g1_motion.joint_names
    assert np.max(np.abs(back.q - g1_motion.q)) <= 1e-9


def test_mujoco_menagerie_g1(g1_motion, tmp_path):
    """With the G1 of the mujoco-menagerie package (its assets are fetched on first use)."""
    pytest.importorskip("mujoco_menagerie")
    try:
        model, source, _ = mujoco_model("g1", "menagerie")
    except ExportError as exc:
        if "DownloadError" in str(exc):
            pytest.skip(f"mujoco-menagerie cannot download the G1 assets here: {exc}")
        raise
    import mujoco

    path = write_export(g1_motion, tmp_path / "walk_mj.npz", "mujoco", mjcf="menagerie")
    qpos = np.load(path)["qpos"]
    data = mujoco.MjData(model)
    data.qpos[:] = qpos[0]
    for name in g1_motion.joint_names:
        assert data.qpos[model.jnt_qposadr[model.joint(name).id]] == \
            g1_motion.joint_positions[0, g1_motion.joint_index(name)]


def test_mujoco_refuses_robot_without_model(tmp_path):
    import imesh

    robot = load_test_robot("jvrc1")
    motion = imesh.RobotMotion(q=[robot.q_nominal] * 3, fps=30.0, robot="jvrc1",
                               joint_names=robot.joint_names)
    with pytest.raises(ExportError, match="no MuJoCo model in mujoco-menagerie.*g1.*--mjcf"):
        write_export(motion, tmp_path / "x.npz", "mujoco", mjcf="menagerie")
    assert not (tmp_path / "x.npz").exists()
    with pytest.raises(OptionError, match=r"--format.*npz.*csv.*mujoco"):
        write_export(motion, tmp_path / "x.npz", "bvh")
    with pytest.raises(OptionError, match=r"\.csv"):
        write_export(motion, tmp_path / "x.npz", "csv")


def test_resampling_linear_and_slerp(g1_motion):
    up = resample_robot_motion(g1_motion, 2 * g1_motion.fps)
    assert up.n_frames == 2 * g1_motion.n_frames - 1
    # source frames are reproduced; the way back gives the source within 1e-9
    assert np.max(np.abs(up.q[::2] - g1_motion.q)) <= 1e-9
    back = resample_robot_motion(up, g1_motion.fps)
    assert np.max(np.abs(back.q - g1_motion.q)) <= 1e-9
    # midpoints: positions and joints are the mean of their neighbours, the quaternion is
    # half-way on the great circle (equal angles to both neighbours, on the same side)
    mid = up.q[1::2]
    lin = np.r_[0:3, 7:up.q.shape[1]]
    avg = 0.5 * (g1_motion.q[:-1] + g1_motion.q[1:])
    assert np.max(np.abs(mid[:, lin] - avg[:, lin])) <= 1e-12
    a = np.abs(np.einsum("ij,ij->i", mid[:, 3:7], g1_motion.q[:-1, 3:7]))
    b = np.abs(np.einsum("ij,ij->i", mid[:, 3:7], g1_motion.q[1:, 3:7]))
    assert np.max(np.abs(a - b)) <= 1e-12
    assert np.allclose(np.linalg.norm(mid[:, 3:7], axis=1), 1.0, atol=1e-12)
    # 30 -> 50 fps: every joint value lies between the two source frames around it
    fine = resample_robot_motion(g1_motion, 50.0)
    assert fine.n_frames == int((g1_motion.n_frames - 1) * 50 / g1_motion.fps) + 1
    k = np.minimum(np.floor(np.arange(fine.n_frames) / 50.0 * g1_motion.fps + 1e-9).astype(int),
                   g1_motion.n_frames - 2)
    j0, j1 = g1_motion.joint_positions[k], g1_motion.joint_positions[k + 1]
    assert np.all(fine.joint_positions >= np.minimum(j0, j1) - 1e-12)
    assert np.all(fine.joint_positions <= np.maximum(j0, j1) + 1e-12)


def test_cli_export_round_trip(g1_motion, g1_mjcf, tmp_path):
    from imesh.io.robot_motion import save_robot_motion

    src = tmp_path / "walk.npz"
    save_robot_motion(src, g1_motion)
    assert main(["-q", "export", str(src), "--format", "csv", "-o", str(tmp_path / "w.csv")]) == 0
    assert main(["-q", "export", str(tmp_path / "w.csv"), "--robot", "g1", "-o",
                 str(tmp_path / "back.npz")]) == 0
    back = read_export(tmp_path / "back.npz")
    assert np.max(np.abs(back.q - g1_motion.q)) <= 1e-9
    assert main(["-q", "export", str(src), "--format", "mujoco", "--mjcf", str(g1_mjcf),
                 "--fps", "60", "-o", str(tmp_path / "mj.npz")]) == 0
    assert read_export(tmp_path / "mj.npz").n_frames == 2 * g1_motion.n_frames - 1
    # a suffix that does not fit the format: a one-line error, exit 2, nothing written
    assert main(["-q", "export", str(src), "--format", "csv", "-o",
                 str(tmp_path / "bad.npz")]) == 2
    assert not (tmp_path / "bad.npz").exists()


@pytest.fixture(scope="module")
def walks(g1_motion, jvrc1_walk):
    """The demo walk retargeted to G1 and JVRC-1 (conftest's g1_walk and jvrc1_walk) and its
    first two steps (clip frames 0-156, 1.3 s, ending in double support) to HRP-4C (a user
    URDF): the exports' claims hold frame by frame, whatever the length."""
    import imesh

    clip = imesh.load_motion(imesh.demo_clip()).frames(0, 156)
    return {"g1": g1_motion, "jvrc1": read_export(jvrc1_walk[0]),
            "hrp4c": imesh.retarget(clip, load_test_robot("hrp4c")).motion}


@pytest.mark.parametrize("name", ["g1", "jvrc1", "hrp4c"])
def test_mujoco_export_offline_from_the_urdf(walks, name, tmp_path, monkeypatch):
    """Acceptance 5: the default MuJoCo export compiles the robot's URDF (no menagerie, no
    network: sockets refused); the qpos of the standing first frame puts both soles on the
    floor in MuJoCo, and MuJoCo's feet are where pinocchio's are in every frame checked."""
    mujoco = pytest.importorskip("mujoco")
    import socket

    def no_network(*args, **kwargs):
        raise OSError("network off in this test")

    monkeypatch.setattr(socket.socket, "connect", no_network)
    motion, robot = walks[name], load_test_robot(name)
    path = write_export(motion, tmp_path / "mj.npz", "mujoco", robot=robot)
    with np.load(path) as f:
        qpos, xml, source = f["qpos"], str(f["mjcf_xml"]), str(f["mjcf"])
    assert source.startswith("compiled by MuJoCo from") and source.endswith(".urdf")
    model = mujoco.MjModel.from_xml_string(xml)
    assert qpos.shape == (motion.n_frames, model.nq)
    data = mujoco.MjData(model)
    lowest, worst = [], 0.0
    for t in (0, motion.n_frames // 2, motion.n_frames - 1):
        data.qpos[:] = qpos[t]
        mujoco.mj_kinematics(model, data)
        for side in ("left", "right"):
            sole = robot.soles[side]
            body = data.body(sole.frame)
            corners = body.xpos + sole.corners() @ body.xmat.reshape(3, 3).T
            if t == 0:
                lowest.append(corners[:, 2])
            pin = robot.frame_positions(motion.q[t], [robot.frame_id(sole.frame)])[0]
            worst = max(worst, float(np.max(np.abs(pin - body.xpos))))
    assert worst < 1e-6, worst
    # standing (lead-in): every sole corner on the floor within 2 mm
    assert np.max(np.abs(np.concatenate(lowest))) < 2e-3, lowest
    back = read_export(path)  # columns in the MJCF's joint order
    assert sorted(back.joint_names) == sorted(motion.joint_names)
    order = [back.joint_names.index(n) for n in motion.joint_names]
    assert np.max(np.abs(back.q[:, :7] - motion.q[:, :7])) <= 1e-9
    assert np.max(np.abs(back.joint_positions[:, order] - motion.joint_positions)) <= 1e-12


def test_cli_mujoco_export_of_a_user_robot_needs_no_robot_option(walks, tmp_path):
    """HRP-4C from the file's provenance (the URDF it was made with), no --robot/--urdf."""
    from imesh.io.robot_motion import save_robot_motion

    src = tmp_path / "hrp4c.npz"
    save_robot_motion(src, walks["hrp4c"])
    out = tmp_path / "hrp4c_mj.npz"
    assert main(["-q", "export", str(src), "--format", "mujoco", "-o", str(out)]) == 0
    assert np.load(out)["qpos"].shape[0] == walks["hrp4c"].n_frames


# ------------------------------------------------------------------------------------ GMR
def test_gmr_pickle_round_trip_scores_as_the_npz(g1_walk, tmp_path):
    """``imesh export --format gmr`` then ``imesh evaluate`` of the pickle: the joints back to
    1e-12 and the metrics of the .npz (the G1 walk: ground penetration 0.420 mm, no limit
    violation, at a4854ff+); GMR's keys and column order (unitree_g1) in the file."""
    import json
    import pickle

    from imesh.io.gmr import GMR_JOINTS

    pkl, a, b = tmp_path / "walk_g1.pkl", tmp_path / "pkl.json", tmp_path / "npz.json"
    assert main(["-q", "export", str(g1_walk[0]), "--format", "gmr", "-o", str(pkl)]) == 0
    with open(pkl, "rb") as fh:
        raw = pickle.load(fh)
    motion = read_export(g1_walk[0])
    order = [motion.joint_names.index(n) for n in GMR_JOINTS["unitree_g1"]]
    assert raw["fps"] == 30 and isinstance(raw["fps"], int)
    assert raw["dof_pos"].shape == (motion.n_frames, 29)
    assert np.array_equal(raw["dof_pos"], motion.joint_positions[:, order])
    assert np.array_equal(raw["root_rot"], motion.base_quat_xyzw)  # x, y, z, w
    back = read_export(pkl)
    assert back.joint_names == motion.joint_names
    assert np.abs(back.q - motion.q).max() <= 1e-12
    assert main(["-q", "evaluate", str(pkl), "--json", str(a)]) == 0
    assert main(["-q", "evaluate", str(g1_walk[0]), "--json", str(b)]) == 0
    ra, rb = json.loads(a.read_text()), json.loads(b.read_text())
    for key in ("ground_penetration_mm", "limit_violation_frames", "self_collision_frames",
                "foot_skid_mm_per_frame", "zmp_inside_fraction"):
        assert ra[key]["value"] == rb[key]["value"], key
    assert ra["limit_violation_frames"]["value"] == 0
    assert ra["ground_penetration_mm"]["value"] == pytest.approx(0.420, abs=0.01)
    # the provenance travels: --source compares the clip's own frames (0.0362 on this walk)
    from imesh.api import demo_clip, evaluate

    report = evaluate(pkl, source=demo_clip())
    assert report["close_pair_error"]["value"] == pytest.approx(
        g1_walk[1]["metrics"]["close_pair_error"]["value"], abs=1e-6)


def test_gmr_pickle_as_gmr_writes_it(g1_walk, tmp_path):
    """A pickle with GMR's keys only (no robot, no joint names; GMR's unitree_g1_with_hands:
    43 columns, hands between the arms) maps by name onto the G1; a robot with joints GMR's
    model lacks is refused with the joints named; code in a pickle is refused, not run."""
    import pickle

    from imesh.io.gmr import GMR_JOINTS, GMRJointError, read_gmr

    motion = read_export(g1_walk[0])
    names = GMR_JOINTS["unitree_g1_with_hands"]
    dof = np.zeros((motion.n_frames, len(names)))
    for i, n in enumerate(names):
        if n in motion.joint_names:
            dof[:, i] = motion.joint_positions[:, motion.joint_index(n)]
    path = tmp_path / "gmr.pkl"
    with open(path, "wb") as fh:
        pickle.dump({"fps": np.int64(30), "root_pos": motion.base_position,
                     "root_rot": motion.base_quat_xyzw, "dof_pos": dof,
                     "local_body_pos": None, "link_body_list": None}, fh)
    assert main(["-q", "evaluate", str(path)]) == 2  # names no robot: --robot needed
    g1 = load_test_robot("g1")
    back = read_gmr(path, g1)
    assert np.array_equal(back.q, motion.q)
    with pytest.raises(GMRJointError, match="L_HIP_P") as err:
        read_gmr(path, load_test_robot("jvrc1"))
    assert len(err.value.missing) == 32

    class Evil:
        def __reduce__(self):
            return (print, ("ran",))

    with open(path, "wb") as fh:
        pickle.dump({"fps": 30, "dof_pos": Evil()}, fh)
    with pytest.raises(Exception, match="not allowed"):
        read_gmr(path, g1)

"""RobotMotion and its .npz / .csv files: round trips, validation, bad files."""

from __future__ import annotations

import dataclasses
import zipfile
from types import SimpleNamespace

import numpy as np
import pytest

from imesh import InvalidMotionError, MotionFileError, OptionError, UnsupportedFormatError
from imesh.contacts.phases import Contacts
from imesh.core.robot_motion import CSV_BASE_COLUMNS, RobotMotion
from imesh.io.robot_motion import NPZ_KEYS, load_robot_motion, save_robot_motion

JOINTS = ("L_HIP_P", "L_KNEE", "R_HIP_P", "R_KNEE")


def make_motion(n_frames: int = 25, fps: float = 30.0, robot: str = "toy") -> RobotMotion:
    rng = np.random.default_rng(0)
    yaw = np.linspace(0.0, 1.0, n_frames)
    quat = np.stack([np.zeros(n_frames), np.zeros(n_frames), np.sin(yaw / 2), np.cos(yaw / 2)],
                    axis=1)
    base = np.column_stack([np.linspace(0, 1, n_frames), np.zeros(n_frames),
                            np.full(n_frames, 0.8)])
    joints = rng.uniform(-1, 1, (n_frames, len(JOINTS)))
    return RobotMotion.from_parts(base, quat, joints, fps=fps, robot=robot, joint_names=JOINTS)


TOY = SimpleNamespace(name="toy", joint_names=JOINTS)


def test_contact_modes_round_trip_and_validation(tmp_path):
    """The planned contact modes travel in a .npz (not in a .csv), are sliced with the frames
    and must be (T, 2) integers 0-3."""
    motion = make_motion()
    modes = np.ones((25, 2), dtype=np.int8)
    modes[5:12, 0] = 0  # a left swing
    modes[15:20, 1] = 2  # a right slide
    planned = dataclasses.replace(motion, contact_modes=modes)
    save_robot_motion(tmp_path / "m.npz", planned)
    back = load_robot_motion(tmp_path / "m.npz")
    np.testing.assert_array_equal(back.contact_modes, modes)
    assert not back.contact_modes.flags.writeable
    np.testing.assert_array_equal(back.frames(4, 13).contact_modes, modes[4:13])
    save_robot_motion(tmp_path / "m.csv", planned)
    assert load_robot_motion(tmp_path / "m.csv").contact_modes is None
    contacts = Contacts.from_modes(modes, 30.0)
    np.testing.assert_array_equal(contacts.modes, modes)
    assert contacts.phases("left") == [(0, 5), (12, 25)]
    assert contacts.moving[15:20, 1].all() and contacts.moving.sum() == 5
    for bad in (modes[:-1], modes[:, :1], modes + 3, modes.astype(float) / 2):
        with pytest.raises(InvalidMotionError, match="contact_modes"):
            dataclasses.replace(motion, contact_modes=bad)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_round_trip(tmp_path, suffix):
    motion = make_motion()
    path = tmp_path / f"motion{suffix}"
    save_robot_motion(path, motion)
    back = load_robot_motion(path)
    assert back.robot == "toy" and back.joint_names == JOINTS
    assert back.fps == pytest.approx(30.0)
    np.testing.assert_allclose(back.q, motion.q, rtol=0, atol=1e-15)
    again = load_robot_motion(path, robot=TOY)
    np.testing.assert_array_equal(again.q, back.q)
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind


def test_npz_keys_and_views(tmp_path):
    motion = make_motion()
    path = tmp_path / "m.npz"
    save_robot_motion(path, motion)
    with np.load(path, allow_pickle=False) as data:
        assert sorted(data.files) == sorted(NPZ_KEYS)
        assert data["base_position"].shape == (25, 3)
        assert data["base_quat_xyzw"].shape == (25, 4)
        assert data["joint_positions"].shape == (25, 4)
        assert list(data["joint_names"]) == list(JOINTS)
        assert str(data["robot"]) == "toy" and float(data["fps"]) == 30.0
    np.testing.assert_array_equal(motion.base_position, motion.q[:, :3])
    np.testing.assert_array_equal(motion.base_quat_xyzw, motion.q[:, 3:7])
    np.testing.assert_array_equal(motion.joint_positions, motion.q[:, 7:])
    assert motion.joint_index("R_KNEE") == 3
    assert motion.joint_velocities().shape == (25, 4)
    with pytest.raises(OptionError, match="L_HIP_P"):
        motion.joint_index("KNEE")


def test_csv_header_names_columns(tmp_path):
    path = tmp_path / "m.csv"
    save_robot_motion(path, make_motion(n_frames=3))
    lines = path.read_text().splitlines()
    assert lines[0].startswith("# imesh robot motion: robot=toy fps=30.0")
    assert lines[1].split(",") == ["frame", "time_s", *CSV_BASE_COLUMNS, *JOINTS]
    assert len(lines) == 2 + 3


def test_reorders_joint_columns_to_the_robot(tmp_path):
    motion = make_motion()
    path = tmp_path / "m.npz"
    save_robot_motion(path, motion)
    robot = SimpleNamespace(name="toy", joint_names=tuple(reversed(JOINTS)))
    back = load_robot_motion(path, robot=robot)
    assert back.joint_names == robot.joint_names
    np.testing.assert_array_equal(back.joint_positions, motion.joint_positions[:, ::-1])


def test_real_robot_motion_round_trip(tmp_path):
    from imesh.robot import load_robot

    robot = load_robot("jvrc1")
    q = np.tile(robot.q_nominal, (4, 1))
    motion = RobotMotion(q=q, fps=50.0, robot=robot.name, joint_names=robot.joint_names)
    path = tmp_path / "jvrc1.csv"
    save_robot_motion(path, motion)
    back = load_robot_motion(path, robot=robot)
    np.testing.assert_allclose(back.q, q, atol=1e-15)
    with pytest.raises(MotionFileError, match="robot 'jvrc1', not of 'g1'"):
        load_robot_motion(path, robot="g1")


# ---------------------------------------------------------------------------------- bad input
def test_validation_errors():
    good = make_motion()
    with pytest.raises(InvalidMotionError, match="columns"):
        RobotMotion(q=good.q[:, :-1], fps=30.0, robot="toy", joint_names=JOINTS)
    q = good.q.copy()
    q[4, 8] = np.nan
    with pytest.raises(InvalidMotionError, match="frame 4, column L_KNEE"):
        RobotMotion(q=q, fps=30.0, robot="toy", joint_names=JOINTS)
    q = good.q.copy()
    q[2, 3:7] *= 2.0
    with pytest.raises(InvalidMotionError, match="quaternion.*frame 2"):
        RobotMotion(q=q, fps=30.0, robot="toy", joint_names=JOINTS)
    with pytest.raises(InvalidMotionError, match="fps"):
        RobotMotion(q=good.q, fps=0.0, robot="toy", joint_names=JOINTS)
    with pytest.raises(InvalidMotionError, match="duplicate"):
        RobotMotion(q=good.q, fps=30.0, robot="toy", joint_names=("a", "a", "b", "c"))
    with pytest.raises(InvalidMotionError, match="robot name"):
        RobotMotion(q=good.q, fps=30.0, robot="", joint_names=JOINTS)
    assert not good.q.flags.writeable


def write_npz(path, **overrides):
    motion = make_motion()
    arrays = {"fps": np.float64(30.0), "robot": np.str_("toy"),
              "joint_names": np.array(JOINTS), "base_position": motion.base_position,
              "base_quat_xyzw": motion.base_quat_xyzw, "joint_positions": motion.joint_positions}
    arrays.update(overrides)
    arrays = {k: v for k, v in arrays.items() if v is not None}
    np.savez(path, **arrays)


def test_bad_npz_files(tmp_path):
    path = tmp_path / "m.npz"
    write_npz(path, joint_positions=make_motion().joint_positions[:, :3])
    with pytest.raises(MotionFileError, match="3 columns but joint_names lists 4"):
        load_robot_motion(path)
    write_npz(path, joint_names=np.array(["L_HIP_P", "L_KNEE", "R_HIP_P", "R_ANKLE"]))
    with pytest.raises(MotionFileError, match="unknown joint names R_ANKLE.*valid joints.*R_KNEE"):
        load_robot_motion(path, robot=TOY)
    nan = make_motion().joint_positions.copy()
    nan[7, 1] = np.nan
    write_npz(path, joint_positions=nan)
    with pytest.raises(MotionFileError, match="frame 7"):
        load_robot_motion(path)
    write_npz(path, robot=np.str_("hrp4c"))
    with pytest.raises(MotionFileError, match="robot 'hrp4c', not of 'toy'"):
        load_robot_motion(path, robot=TOY)
    write_npz(path, base_quat_xyzw=None)
    with pytest.raises(MotionFileError, match="missing keys.*base_quat_xyzw"):
        load_robot_motion(path)
    write_npz(path, base_position=np.zeros((5, 3)))
    with pytest.raises(MotionFileError, match="base_quat_xyzw must have shape"):
        load_robot_motion(path)
    path.write_bytes(b"not a zip file")
    with pytest.raises(MotionFileError, match="not a readable .npz"):
        load_robot_motion(path)
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("fps.npy", b"garbage")
    with pytest.raises(MotionFileError):
        load_robot_motion(path)


def test_bad_csv_files(tmp_path):
    path = tmp_path / "m.csv"
    save_robot_motion(path, make_motion(n_frames=4))
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[1:]) + "\n")  # no comment: robot and fps unknown
    with pytest.raises(MotionFileError, match="pass robot="):
        load_robot_motion(path)
    back = load_robot_motion(path, robot=TOY)  # fps from the time column
    assert back.fps == pytest.approx(30.0)
    path.write_text("\n".join(lines[:3] + [lines[3].replace(lines[3].split(",")[-1], "nan")]))
    with pytest.raises(MotionFileError, match="line 4, frame 1: non-finite value in column R_KNEE"):
        load_robot_motion(path)
    path.write_text("\n".join(lines[:3] + [lines[3] + ",1.0"]))
    with pytest.raises(MotionFileError, match="line 4"):
        load_robot_motion(path)
    path.write_text("\n".join([lines[0], "frame,time,x"] + lines[2:]))
    with pytest.raises(MotionFileError, match="header must start with"):
        load_robot_motion(path)
    robot = SimpleNamespace(name="toy", joint_names=JOINTS + ("NECK_Y",))
    save_robot_motion(path, make_motion())
    with pytest.raises(MotionFileError, match="missing NECK_Y"):
        load_robot_motion(path, robot=robot)


def test_bad_paths_and_atomic_failure(tmp_path):
    with pytest.raises(MotionFileError, match="no such file"):
        load_robot_motion(tmp_path / "absent.npz")
    (tmp_path / "m.bvh").write_text("x")
    with pytest.raises(UnsupportedFormatError, match=".npz, .csv"):
        load_robot_motion(tmp_path / "m.bvh")
    with pytest.raises(OptionError, match=".npz"):
        save_robot_motion(tmp_path / "m.txt", make_motion())
    assert not (tmp_path / "m.txt").exists()
    # a failed save leaves an existing file untouched and no temporary file
    path = tmp_path / "keep.csv"
    save_robot_motion(path, make_motion())
    before = path.read_bytes()
    bad = RobotMotion(q=make_motion().q, fps=30.0, robot="toy",
                      joint_names=("a,b", "c", "d", "e"))
    with pytest.raises(OptionError, match="commas"):
        save_robot_motion(path, bad)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.csv", "m.bvh"]


# ----------------------------------------------------------------------------------------------
# provenance (imesh.core.provenance): stored in both formats, optional, checked


def _provenance(source: bool = True):
    from imesh.core.provenance import Provenance, SourceClip

    clip = SourceClip(path="/data/walk.bvh", sha256="ab" * 32, fps=120.0048, frames=343,
                      load={"units": "cmu", "fps": 60.0}) if source else None
    return Provenance(lead_in=30, lead_out=28, robot="toy", robot_sha256="cd" * 32,
                      robot_toml="/robots/toy/robot.toml", urdf="/robots/toy.urdf",
                      imesh_version="9.9.9", source=clip)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
@pytest.mark.parametrize("source", [True, False])
def test_provenance_round_trip(tmp_path, suffix, source):
    import dataclasses

    from imesh.io.robot_motion import read_provenance

    prov = _provenance(source)
    motion = dataclasses.replace(make_motion(100), provenance=prov)
    path = tmp_path / f"m{suffix}"
    save_robot_motion(path, motion)
    back = load_robot_motion(path, robot=TOY)
    assert back.provenance == prov == read_provenance(path)
    assert back.provenance.clip_frames(back.n_frames) == (30, 72)
    if source:
        assert dict(back.provenance.source.load) == {"units": "cmu", "fps": 60.0}
    assert back.frames(0, 50).provenance is None  # a slice is no longer the whole timeline


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_files_without_provenance_still_load(tmp_path, suffix):
    from imesh.io.robot_motion import read_provenance

    path = tmp_path / f"old{suffix}"
    save_robot_motion(path, make_motion())  # the layout of imesh before provenance
    assert load_robot_motion(path).provenance is None and read_provenance(path) is None
    if suffix == ".npz":
        with np.load(path) as data:
            assert sorted(data.files) == sorted(NPZ_KEYS)


def test_bad_provenance_is_named(tmp_path):
    import dataclasses

    motion = make_motion(40)
    path = tmp_path / "m.npz"
    arrays = {"fps": 30.0, "robot": "toy", "joint_names": np.array(JOINTS),
              "base_position": motion.base_position, "base_quat_xyzw": motion.base_quat_xyzw,
              "joint_positions": motion.joint_positions}
    np.savez(path, **arrays, provenance=np.str_("{not json"))
    with pytest.raises(MotionFileError, match="m.npz: provenance is not JSON"):
        load_robot_motion(path)
    np.savez(path, **arrays, provenance=np.str_('{"format": 7}'))
    with pytest.raises(MotionFileError, match="provenance format 7; valid: 1"):
        load_robot_motion(path)
    # lead-in + lead-out longer than the motion: no frame of the clip
    save_robot_motion(path, dataclasses.replace(
        make_motion(50), provenance=dataclasses.replace(_provenance(), lead_in=30, lead_out=20)))
    with pytest.raises(MotionFileError, match="leave no clip frame of 50"):
        load_robot_motion(path)

"""Issue 34, part 1: joint-position input (``.npy`` / ``.npz`` arrays of named joints).

On the shared holosoma climbing sequences (IMESH_DATA/interaction, MANIFEST.md there): the reader
gives the MANIFEST's bone lengths, the 53-joint naming maps to the standard markers, units / up
axis / floor are detected as for other formats, and every bad input is a one-line ImeshError
naming the file.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import data_root
from conftest import run_cli as run

from imesh.errors import ImeshError, ImplausibleMotionError, MarkerMappingError, MotionFileError
from imesh.human.standard import to_standard
from imesh.io import load_motion
from imesh.io.joints import FrameRateMissingError, JointNamesError

SEQS = {"seq_0": ("mocap_climb_seq_0", "mocap_climb_seq_0_joint_positions_f900-3700.npy", 2801),
        "seq_1": ("mocap_climb_seq_1", "mocap_climb_seq_1_joint_positions_f0-2422.npy", 2423)}


def climb_dir():
    path = data_root() / "interaction" / "holosoma_climb"
    if not path.is_dir():
        pytest.fail(f"test data {path} not found: set IMESH_DATA to the shared data folder")
    return path


def seq_path(seq: str):
    folder, name, _ = SEQS[seq]
    return climb_dir() / folder / name


def names53() -> list[str]:
    return (climb_dir() / "joint_names.txt").read_text().split()




def bone(motion, a: str, b: str) -> np.ndarray:
    return np.linalg.norm(motion.positions_m[:, motion.index(a)]
                          - motion.positions_m[:, motion.index(b)], axis=1)


@pytest.mark.parametrize("seq", sorted(SEQS))
def test_bone_lengths_are_the_manifests(seq):
    """MANIFEST: thigh 0.373, shank 0.453, upper arm 0.311, forearm 0.254, foot 0.159 m in both
    sequences, constant over the frames (a fitted skeleton)."""
    m = load_motion(seq_path(seq), fps=120)
    assert m.n_frames == SEQS[seq][2] and m.fps == 120
    assert m.meta["rig"] == "holosoma_mocap"
    for (a, b), length in {("LeftUpLeg", "LeftLeg"): 0.373, ("RightUpLeg", "RightLeg"): 0.373,
                           ("LeftLeg", "LeftFoot"): 0.453, ("RightLeg", "RightFoot"): 0.453,
                           ("LeftArm", "LeftForeArm"): 0.311,
                           ("LeftForeArm", "LeftHand"): 0.254,
                           ("LeftFoot", "LeftToeBase"): 0.159}.items():
        d = bone(m, a, b)
        assert abs(np.median(d) - length) < 1e-3, (a, b, np.median(d))
        assert np.ptp(d) < 1e-4, (a, b)  # constant: nothing was rescaled per frame


def test_units_up_axis_and_floor_are_detected_and_logged():
    """Metres and Z up found from the body (nothing declared), the floor kept (toes 1-3 cm
    above z = 0, MANIFEST), so the boxes stay registered with the joints."""
    m = load_motion(seq_path("seq_0"), fps=120)
    assert m.meta["units"] == "m" and m.meta["up_axis"] == "+Z"
    assert m.meta["floor_offset_m"] == 0.0
    raw = np.load(seq_path("seq_0"))
    assert np.array_equal(m.positions_m, raw.astype(np.float64))
    assert m.meta["joint_names_from"].endswith("joint_names.txt")


def test_the_53_joint_naming_maps_to_the_standard_markers():
    m = load_motion(seq_path("seq_1"), fps=120)
    std = to_standard(m)
    assert std.meta["rig_table"] == "holosoma_mocap"
    for marker, joint in {"pelvis": "Hips", "knee_l": "LeftLeg", "ankle_r": "RightFoot",
                          "toe_l": "LeftToeBase", "head": "Head",
                          "hand_l": "LeftHandMiddle1", "shoulder_r": "RightArm"}.items():
        assert np.array_equal(std.positions_m[:, std.index(marker)],
                              m.positions_m[:, m.index(joint)]), marker
    # the shank of the standard skeleton is the MANIFEST's
    assert abs(np.median(bone(std, "knee_l", "ankle_l")) - 0.453) < 1e-3
    # the chest 4-9 cm below the shoulder line, the spine between pelvis and neck
    shoulders = 0.5 * (std.positions_m[:, std.index("shoulder_l")]
                       + std.positions_m[:, std.index("shoulder_r")])
    below = shoulders[:, 2] - std.positions_m[:, std.index("chest"), 2]
    assert 0.04 < np.median(below) < 0.09


def test_npz_in_centimetres_and_y_up_reads_back_the_same_motion(tmp_path):
    """An .npz holding names and fps, in cm and Y up: units and up axis are detected from the
    body, and the motion equals the .npy read in metres, Z up."""
    ref = load_motion(seq_path("seq_0"), fps=120)
    # world (x, y, z) -> file (y, z, x): the +Y-up convention rotation_to_z_up undoes
    file_pos = 100.0 * ref.positions_m[..., [1, 2, 0]]
    path = tmp_path / "climb_cm.npz"
    np.savez(path, positions=file_pos, names=np.array(names53()), fps=np.float64(120))
    m = load_motion(path)
    assert m.meta["units"] == "cm" and m.meta["up_axis"] == "+Y"
    assert m.fps == 120 and m.meta["rig"] == "holosoma_mocap"
    np.testing.assert_allclose(m.positions_m, ref.positions_m, atol=1e-9)


def test_a_naming_without_table_is_recognized_by_its_tree(tmp_path):
    """Unknown joint names with a ``parents`` array: the body is found by its structure
    (imesh.human.rig), and the shank is still 0.453 m."""
    names = names53()
    parent_name = {"Spine": "Hips", "Spine1": "Spine", "Neck": "Spine1", "Head": "Neck",
                   "LeftShoulder": "Spine1", "RightShoulder": "Spine1",
                   "LeftUpLeg": "Hips", "RightUpLeg": "Hips"}
    for side in ("Left", "Right"):
        chain = ["Shoulder", "Arm", "ForeArm", "Hand"]
        parent_name.update({f"{side}{b}": f"{side}{a}"
                            for a, b in zip(chain[:-1], chain[1:], strict=True)})
        for finger in ("Thumb", "Index", "Middle", "Ring", "Pinky"):
            parent_name[f"{side}Hand{finger}1"] = f"{side}Hand"
            for k in (2, 3):
                parent_name[f"{side}Hand{finger}{k}"] = f"{side}Hand{finger}{k - 1}"
        leg = ["UpLeg", "Leg", "Foot", "ToeBase"]
        parent_name.update({f"{side}{b}": f"{side}{a}"
                            for a, b in zip(leg[:-1], leg[1:], strict=True)})
        parent_name[f"{side}FootMod"] = f"{side}Foot"
    parents = np.array([names.index(parent_name[n]) if n in parent_name else -1 for n in names])
    assert (parents == -1).sum() == 1  # one root: Hips
    path = tmp_path / "renamed.npz"
    np.savez(path, positions=np.load(seq_path("seq_0"))[:600],
             names=np.array([f"j{k}" for k in range(len(names))]), parents=parents,
             fps=np.float64(120))
    m = load_motion(path)
    assert m.meta["rig"] != "holosoma_mocap" and len(m.bones) == 52
    std = to_standard(m)
    assert abs(np.median(bone(std, "knee_l", "ankle_l")) - 0.453) < 1e-3
    assert abs(np.median(bone(std, "hip_r", "knee_r")) - 0.373) < 1e-3
    # left is the performer's left, found from the geometry: j43 is LeftUpLeg
    assert np.allclose(std.positions_m[:, std.index("hip_l")], m.positions_m[:, 43])


# ----------------------------------------------------------------------------------------------
# bad input: one line, the file named, what is valid


def test_no_frame_rate_is_an_error_listing_the_options(capsys):
    with pytest.raises(FrameRateMissingError) as exc:
        load_motion(seq_path("seq_0"))
    assert str(seq_path("seq_0")) in str(exc.value) and "--source-fps" in str(exc.value)
    status, err = run(capsys, "inspect", seq_path("seq_0"))
    assert status == 2
    assert "stores no frame rate" in err and "--source-fps" in err and ".npy" in err


def test_wrong_shape(capsys, tmp_path):
    path = tmp_path / "flat.npy"
    np.save(path, np.load(seq_path("seq_0"))[:100].reshape(100, -1))
    status, err = run(capsys, "inspect", path, "--source-fps", "120", "--joints",
                      climb_dir() / "joint_names.txt")
    assert status == 2
    assert f"{path}: the array has shape (100, 159); valid: (T, J, 3)" in err


def test_name_count_mismatch(capsys, tmp_path):
    names = tmp_path / "names52.txt"
    names.write_text("\n".join(names53()[:52]) + "\n")
    path = tmp_path / "climb.npy"
    np.save(path, np.load(seq_path("seq_0"))[:100])
    with pytest.raises(JointNamesError) as exc:
        load_motion(path, fps=120, joints=names)
    assert exc.value.n_names == 52 and exc.value.n_joints == 53
    status, err = run(capsys, "inspect", path, "--source-fps", "120", "--joints", names)
    assert status == 2
    assert str(path) in err and "52 joint names" in err and "53 joints" in err


def test_no_names_found(capsys, tmp_path):
    path = tmp_path / "alone.npy"
    np.save(path, np.load(seq_path("seq_0"))[:100])
    status, err = run(capsys, "inspect", path, "--source-fps", "120")
    assert status == 2
    assert str(path) in err and "--joints FILE" in err


def test_nan_everywhere(capsys, tmp_path):
    path = tmp_path / "holes.npz"
    np.savez(path, positions=np.full((50, 53, 3), np.nan), names=np.array(names53()),
             fps=np.float64(120))
    with pytest.raises(ImplausibleMotionError, match="all 53 markers are missing"):
        load_motion(path)
    status, err = run(capsys, "inspect", path)
    assert status == 2 and str(path) in err


def test_unknown_naming_without_tree(capsys, tmp_path):
    path = tmp_path / "anon.npz"
    np.savez(path, positions=np.load(seq_path("seq_0"))[:200],
             names=np.array([f"joint{k}" for k in range(53)]), fps=np.float64(120))
    m = load_motion(path)  # readable: inspect shows it
    with pytest.raises(MarkerMappingError, match="no built-in rig table") as exc:
        to_standard(m)
    assert str(path) in str(exc.value) and "holosoma_mocap" in str(exc.value)
    status, err = run(capsys, "adapt", path, "-o", tmp_path / "out.npz")
    assert status == 2 and str(path) in err and "no built-in rig table" in err


def test_an_npz_that_is_neither_amass_nor_joints(tmp_path):
    path = tmp_path / "other.npz"
    np.savez(path, something=np.zeros(3))
    with pytest.raises(MotionFileError, match="joint positions"):
        load_motion(path)
    assert issubclass(JointNamesError, ImeshError)


def test_adapt_accepts_a_joint_position_window(capsys, tmp_path):
    """The command line takes the shared .npy (names found beside it, --source-fps), and a
    window of it saved as an .npz with names and fps."""
    window = tmp_path / "step_up.npz"
    np.savez(window, positions=np.load(seq_path("seq_0"))[200:440],
             names=np.array(names53()), fps=np.float64(120))
    out = tmp_path / "adapted.npz"
    status, text = run(capsys, "adapt", window, "-o", out, "--scale", "legs=0.9")
    assert status == 0, text
    with np.load(out) as z:
        assert z["positions_m"].shape == (240, 21, 3)
        assert float(z["fps"]) == 120

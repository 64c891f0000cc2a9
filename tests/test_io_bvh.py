"""BVH reader: every shared clip, forward-kinematics conventions, bad input, rig tables."""

from __future__ import annotations

import tomllib
from importlib import resources

import numpy as np
import pytest

import imesh.io as io
from imesh.errors import MotionFileError
from imesh.human.rig_tables import rig_of
from imesh.io.bvh import VALID_CHANNELS, read_bvh
from imesh.io.skeleton import euler_to_matrix, forward_kinematics

SALSA_A = "cmu_60_10_salsa_partnerA_sl_scaled.bvh"
SALSA_B = "cmu_61_10_salsa_partnerB_sl_scaled.bvh"
REACT = "reactidle_003_acted_idle_long.bvh"
#: metres per file unit of the rescaled salsa clips (see imesh/data/rigs/second_life.toml)
SALSA_UNIT_M = 4.0 / 3.0

# name, frames, frame time [s], rig, unit detected, points (joints + end sites), MANIFEST median
# height in file units, foot points
CLIPS = [
    ("cmu_02_01_walk.bvh", 343, 0.008333, "cmu_cgspeed", "cmu", 38, 25.11,
     ["LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase"]),
    ("cmu_02_10_wash_self_cc3rig.bvh", 1323, 0.016667, "cc3", "cm", 141, 164.8,
     ["CC_Base_L_Foot", "CC_Base_R_Foot", "CC_Base_L_ToeBase", "CC_Base_R_ToeBase"]),
    ("cmu_05_06_dance_pirouettes_jete.bvh", 885, 0.008333, "cmu_cgspeed", "cmu", 38, 24.77,
     ["LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase"]),
    ("cmu_141_16_wave_hello.bvh", 299, 0.008333, "cmu_cgspeed", "cmu", 38, 24.13,
     ["LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase"]),
    ("cmu_16_11_walk_veer_left.bvh", 534, 0.008333, "cmu_cgspeed", "cmu", 38, 24.63,
     ["LeftFoot", "RightFoot", "LeftToeBase", "RightToeBase"]),
    (SALSA_A, 1197, 0.008333, "second_life", "1.33333 m", 57, 1.13,
     ["lFoot", "rFoot", "lFoot_end", "rFoot_end"]),
    (SALSA_B, 1197, 0.008333, "second_life", "1.33333 m", 57, 1.14,
     ["lFoot", "rFoot", "lFoot_end", "rFoot_end"]),
    (REACT, 3883, 0.041667, "reactidle", "m", 26, 1.22,
     ["foot.L", "foot.R", "foot.L_end", "foot.R_end"]),
]
NAMES = [c[0] for c in CLIPS]


@pytest.fixture(scope="module")
def loaded(mocap):
    """name -> (RawMotion, MarkerMotion), read once per module."""
    out = {}
    for name in NAMES:
        raw = read_bvh(mocap(name))
        out[name] = (raw, io.finalize(raw))
    return out


@pytest.mark.parametrize("name,frames,frame_time,rig,unit,points,height,feet", CLIPS)
def test_bvh_clip_facts(loaded, name, frames, frame_time, rig, unit, points, height, feet):
    raw, motion = loaded[name]
    assert raw.format == "bvh" and raw.rig == rig
    assert raw.positions.shape == (frames, points, 3)
    assert raw.fps == pytest.approx(1.0 / frame_time, rel=1e-9)
    assert raw.declared_up == "+Y" and raw.declared_units is None
    assert raw.declared_scale_m is None
    assert len(raw.bones) == points - 1 and raw.valid.all()
    assert np.isfinite(raw.positions).all()

    assert motion.n_frames == frames
    assert motion.meta["up_axis"] == "+Y" and motion.meta["units"] == unit
    assert 1.0 <= motion.height_m <= 2.1
    assert not np.isnan(motion.positions_m).any()
    # MANIFEST median joint extent (file units) within 2 %
    assert motion.height_m == pytest.approx(height * motion.meta["unit_scale_m"], rel=0.02)
    # feet on the floor: lowest foot point of each frame, median over frames
    lowest = motion.positions_m[:, motion.indices(feet), 2].min(axis=1)
    assert abs(np.median(lowest)) < 0.1


def test_load_motion_matches_reader(loaded, mocap):
    """load_motion picks the BVH reader by extension (CMU walk: 1.42 m, as in the MANIFEST)."""
    motion = io.load_motion(mocap("cmu_02_01_walk.bvh"))
    assert motion.height_m == pytest.approx(1.42, abs=0.01)
    np.testing.assert_allclose(motion.positions_m, loaded["cmu_02_01_walk.bvh"][1].positions_m)


@pytest.mark.parametrize("name", NAMES)
def test_bone_lengths_rigid(loaded, name):
    """Forward kinematics keeps every bone length constant (1e-9). ReActIdle's position
    channels hold full offsets (6 decimals) that change direction but not length: with them
    replacing the OFFSET the lengths stay constant to rounding (adding would double them)."""
    raw, _ = loaded[name]
    moving = {raw.names.index(n) for n in raw.meta["position_channel_joints"]}
    rigid = np.array([c not in moving for _, c in raw.bones])
    lengths = np.linalg.norm(raw.positions[:, raw.bones[:, 0]] - raw.positions[:, raw.bones[:, 1]],
                             axis=-1)
    spread = lengths.max(axis=0) - lengths.min(axis=0)
    assert rigid.sum() >= 5
    assert spread[rigid].max() < 1e-9
    if name == REACT:
        assert len(moving) == 17 and spread[~rigid].max() < 1e-5


def test_names_and_end_sites(loaded):
    raw, _ = loaded["cmu_02_01_walk.bvh"]
    assert raw.names[:3] == ("Hips", "LHipJoint", "LeftUpLeg")
    assert "Head_end" in raw.names and "LeftToeBase_end" in raw.names
    assert raw.meta["joints"] == 31 and raw.meta["end_sites"] == 7
    head, end = raw.names.index("Head"), raw.names.index("Head_end")
    assert [head, end] in raw.bones.tolist()
    salsa, _ = loaded[SALSA_A]
    assert salsa.meta["rotation_orders"] == {"ZYX": 1, "ZXY": 42}
    react, _ = loaded[REACT]
    assert react.meta["rotation_orders"] == {"XYZ": 15, "YXZ": 4}


def _first_frame(path) -> list[float]:
    lines = path.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.strip().lower().startswith("frame time"))
    return [float(v) for v in lines[k + 1].split()]


def test_root_offset_added(loaded, mocap):
    """ReActIdle's root OFFSET (0, 0.657198, 0) is added to its position channels."""
    raw, _ = loaded[REACT]
    first = _first_frame(mocap(REACT))
    np.testing.assert_allclose(raw.positions[0, 0], np.add([0.0, 0.657198, 0.0], first[:3]))
    cc3, _ = loaded["cmu_02_10_wash_self_cc3rig.bvh"]
    first = _first_frame(mocap("cmu_02_10_wash_self_cc3rig.bvh"))
    np.testing.assert_allclose(cc3.positions[0, 0], np.add([0.0, 105.214226, 0.000021], first[:3]))


def test_left_is_performer_left(loaded):
    """Left joints lie on the performer's left: (left hip - right hip) . (up x forward) > 0,
    forward = heel-to-toe direction (checked on the walks and the salsa)."""
    cases = {
        "cmu_02_01_walk.bvh": ("LeftUpLeg", "RightUpLeg", "LeftFoot", "LeftToeBase"),
        "cmu_16_11_walk_veer_left.bvh": ("LeftUpLeg", "RightUpLeg", "LeftFoot", "LeftToeBase"),
        "cmu_02_10_wash_self_cc3rig.bvh": ("CC_Base_L_Thigh", "CC_Base_R_Thigh", "CC_Base_L_Foot",
                                           "CC_Base_L_ToeBase"),
        SALSA_A: ("lThigh", "rThigh", "lFoot", "lFoot_end"),
        REACT: ("thigh.L", "thigh.R", "foot.L", "foot.L_end"),
    }
    for name, (hl, hr, ankle, toe) in cases.items():
        _, m = loaded[name]
        p = m.positions_m
        fwd = p[:, m.index(toe)] - p[:, m.index(ankle)]
        left = np.cross([0.0, 0.0, 1.0], fwd)
        side = np.sum((p[:, m.index(hl)] - p[:, m.index(hr)]) * left, axis=1)
        assert np.mean(side > 0) > 0.9, name


def test_salsa_offsets_on_sl_inch_grid(mocap):
    """The salsa OFFSETs are integer multiples of 0.001905 = 0.1 inch x 0.01905 (one-decimal
    inches scaled by 0.75 x 0.0254): one file unit is 4/3 m (second_life.toml)."""
    text = mocap(SALSA_A).read_text().split("MOTION")[0]
    vals = np.array([float(v) for ln in text.splitlines() if ln.strip().startswith("OFFSET")
                     for v in ln.split()[1:]])
    trunk = vals[:15]  # hip, abdomen, chest, neck, head (abdomen Y 0.161626 is off-grid)
    legs = np.array([0.0, -0.287655, 0.005715, 0.005715, -0.352425, -0.040005])
    q = np.concatenate([trunk[[5, 7, 8, 10, 11, 12, 13, 14]], legs]) / 0.001905
    np.testing.assert_allclose(q, np.round(q), atol=2e-3)
    motion = io.load_motion(mocap(SALSA_A), units=SALSA_UNIT_M)
    assert 1.45 <= motion.height_m <= 1.6
    raw = read_bvh(mocap(SALSA_A))
    assert raw.meta["unit_hint_m"] == pytest.approx(SALSA_UNIT_M)
    assert "0.01905" in raw.meta["unit_hint_reason"]


def test_no_unit_hint_elsewhere(loaded):
    for name in NAMES:
        assert ("unit_hint_m" in loaded[name][0].meta) == (name in (SALSA_A, SALSA_B))


# ---------------------------------------------------------------- synthetic files
HEADER = """HIERARCHY
ROOT Root
{
  OFFSET 1 2 3
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Child
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 2 0
    }
  }
}
MOTION
"""


def _write(tmp_path, text: str, name: str = "syn.bvh"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_synthetic_fk(tmp_path):
    """Root at OFFSET + channels; channel order = multiplication order (ZXY on the child)."""
    rows = ["10 20 30 90 0 0 0 0 0", "0 0 0 0 0 0 30 40 50"]
    raw = read_bvh(_write(tmp_path, HEADER + "Frames: 2\nFrame Time: 0.04\n" + "\n".join(rows)))
    assert raw.names == ("Root", "Child", "Child_end") and raw.fps == pytest.approx(25.0)
    assert raw.bones.tolist() == [[0, 1], [1, 2]]
    # frame 0: root at (11, 22, 33) turned 90 deg about Z: child at +Y, end site at -X
    np.testing.assert_allclose(raw.positions[0], [[11, 22, 33], [11, 23, 33], [9, 23, 33]],
                               atol=1e-12)
    # frame 1: child rotation Rz(30) Rx(40) Ry(50)
    r = euler_to_matrix(np.deg2rad([30, 40, 50]), "ZXY")
    rz, rx, ry = (euler_to_matrix(np.deg2rad([a]), ax) for a, ax in ((30, "Z"), (40, "X"),
                                                                     (50, "Y")))
    np.testing.assert_allclose(r, rz @ rx @ ry)
    np.testing.assert_allclose(raw.positions[1, 2], np.array([2, 2, 3]) + r @ [0, 2, 0])


def test_non_root_position_channels_replace_offset(tmp_path):
    text = HEADER.replace("    CHANNELS 3 Zrotation Xrotation Yrotation",
                          "    CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
                          "Yrotation")
    raw = read_bvh(_write(tmp_path, text + "Frames: 1\nFrame Time: 0.1\n"
                          "0 0 0 0 0 0 0 5 0 0 0 0\n"))
    np.testing.assert_allclose(raw.positions[0, 1], [1, 7, 3])  # root (1,2,3) + (0,5,0)
    assert raw.meta["position_channel_joints"] == ("Child",)


def test_fk_offset_frames():
    parents = np.array([-1, 0])
    offsets = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    rot = np.broadcast_to(euler_to_matrix(np.deg2rad([[0.0], [90.0]]), "Z")[:, None],
                          (2, 2, 3, 3))
    pos_parent, _ = forward_kinematics(parents, offsets, rot)
    pos_self, _ = forward_kinematics(parents, offsets, rot, offset_frame="self")
    np.testing.assert_allclose(pos_parent[1, 1], [0, 1, 0], atol=1e-12)  # root's rotation
    np.testing.assert_allclose(pos_self[1, 1], [-1, 0, 0], atol=1e-12)   # root's @ own


def _error(tmp_path, text: str) -> MotionFileError:
    path = _write(tmp_path, text, "bad.bvh")
    with pytest.raises(MotionFileError) as info:
        read_bvh(path)
    assert type(info.value) is MotionFileError
    msg = str(info.value)
    assert "bad.bvh" in msg and "Traceback" not in msg and "numpy" not in msg.lower()
    return info.value


def test_truncated(tmp_path):
    rows = ["0 0 0 0 0 0 0 0 0"] * 3 + ["0 0 0 0"]
    err = _error(tmp_path, HEADER + "Frames: 5\nFrame Time: 0.01\n" + "\n".join(rows) + "\n")
    assert "truncated" in str(err) and "only 3 complete frames" in str(err)
    assert err.frame == 3 and err.line == 22 and "line 22, frame 3" in str(err)


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf", "NaN"])
def test_non_finite(tmp_path, bad):
    rows = ["0 0 0 0 0 0 0 0 0", f"0 0 0 0 0 0 0 {bad} 0"]
    err = _error(tmp_path, HEADER + "Frames: 2\nFrame Time: 0.01\n" + "\n".join(rows) + "\n")
    assert err.frame == 1 and err.line == 20
    assert "line 20" in str(err) and "frame 1" in str(err)
    assert "Child.Xrotation" in str(err) and "non-finite" in str(err)


def test_bad_number(tmp_path):
    rows = ["0 0 0 0 0 0 0 0 0", "0 0 0 0 1.#IND 0 0 0 0"]
    err = _error(tmp_path, HEADER + "Frames: 2\nFrame Time: 0.01\n" + "\n".join(rows) + "\n")
    assert err.frame == 1 and err.line == 20 and "Root.Yrotation" in str(err)


def test_unknown_channel(tmp_path):
    err = _error(tmp_path, HEADER.replace("Xrotation Yrotation\n", "Xrotation Wrotation\n")
                 + "Frames: 1\nFrame Time: 0.01\n0 0 0 0 0 0 0 0 0\n")
    msg = str(err)
    assert "'Wrotation'" in msg and err.line == 9 and "line 9" in msg
    assert all(c in msg for c in VALID_CHANNELS)


@pytest.mark.parametrize("frames", ["Frames: 0\nFrame Time: 0.01\n", "Frames: 0\n"])
def test_empty_motion(tmp_path, frames):
    err = _error(tmp_path, HEADER + frames)
    assert "empty MOTION block" in str(err) and err.line == 17


def test_missing_frame_time(tmp_path):
    err = _error(tmp_path, HEADER + "Frames: 1\n0 0 0 0 0 0 0 0 0\n")
    assert "Frame Time" in str(err) and err.line == 18


@pytest.mark.parametrize("text,where", [
    (HEADER.replace("  }\n}\nMOTION", "  }\nMOTION"), "closing joint Root"),
    (HEADER.replace("      OFFSET 0 2 0\n", ""), "End Site of Child has no OFFSET"),
    (HEADER.replace("  OFFSET 1 0 0\n", "  OFFSET 1 zero 0\n"), "number"),
    (HEADER.replace("HIERARCHY\n", ""), "HIERARCHY"),
    (HEADER.replace("MOTION\n", ""), "MOTION"),
    (HEADER.replace("  JOINT Child", "  BONE Child"), "unexpected"),
])
def test_malformed_hierarchy(tmp_path, text, where):
    err = _error(tmp_path, text + "Frames: 1\nFrame Time: 0.01\n0 0 0 0 0 0 0 0 0\n")
    assert where in str(err) and err.line is not None


def test_load_motion_error_names_file(tmp_path):
    path = _write(tmp_path, HEADER + "Frames: 0\nFrame Time: 0.01\n", "empty.bvh")
    with pytest.raises(MotionFileError, match="empty.bvh, line 17"):
        io.load_motion(path)


# ---------------------------------------------------------------- rig tables
BVH_RIGS = ("cmu_cgspeed", "cc3", "second_life", "reactidle")
STANDARD = ("pelvis", "hip_l", "hip_r", "knee_l", "knee_r", "ankle_l", "ankle_r", "toe_l", "toe_r",
            "spine", "chest", "neck", "head", "shoulder_l", "shoulder_r", "elbow_l", "elbow_r",
            "wrist_l", "wrist_r", "hand_l", "hand_r")


def _table(rig: str) -> dict:
    return tomllib.loads(resources.files("imesh.data").joinpath(f"rigs/{rig}.toml").read_text())


@pytest.mark.parametrize("rig", BVH_RIGS)
def test_rig_tables_match_clips(loaded, rig):
    """Each table names its rig, is the one its clips are detected as, gives the 21 standard
    markers from names present in the clips, with weights summing to 1."""
    table = _table(rig)
    assert table["name"] == rig
    assert set(table["markers"]) == set(STANDARD)
    clips = [raw for raw, _ in loaded.values() if raw.rig == rig]
    assert clips
    for raw in clips:
        assert rig_of(raw.names) == rig
        for spec in table["markers"].values():
            names = list(spec) if isinstance(spec, (list, dict)) else [spec]
            assert set(names) <= set(raw.names), names
            if isinstance(spec, dict):
                assert sum(spec.values()) == pytest.approx(1.0)


@pytest.mark.parametrize("name", NAMES)
def test_to_standard(loaded, name):
    from imesh.human import standard

    _, motion = loaded[name]
    std = standard.to_standard(motion)
    assert std.names == STANDARD and std.meta["rig"] == motion.meta["rig"]
    assert not np.isnan(std.positions_m).any()
    p = std.positions_m

    def length(a, b):
        return np.median(np.linalg.norm(p[:, std.index(a)] - p[:, std.index(b)], axis=-1))

    for side in "lr":
        assert 0.3 <= length(f"hip_{side}", f"knee_{side}") <= 0.55
        assert 0.25 <= length(f"knee_{side}", f"ankle_{side}") <= 0.55
        assert 0.18 <= length(f"shoulder_{side}", f"elbow_{side}") <= 0.4
        assert 0.15 <= length(f"elbow_{side}", f"wrist_{side}") <= 0.35
        assert 0.02 <= length(f"wrist_{side}", f"hand_{side}") <= 0.15
    z = np.median(p[..., 2], axis=0)
    order = [std.index(n) for n in ("pelvis", "spine", "chest", "neck", "head")]
    assert np.all(np.diff(z[order]) > 0.02), z[order]
    # chest below and neck not far below the shoulder line
    shoulders = z[[std.index("shoulder_l"), std.index("shoulder_r")]].mean()
    assert z[std.index("chest")] < shoulders < z[std.index("neck")] + 0.03

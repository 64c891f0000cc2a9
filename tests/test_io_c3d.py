"""C3D reader: the ezc3d Qualisys and BTS clips, synthetic files, bad input, standard mapping."""

from __future__ import annotations

import numpy as np
import pytest

import imesh.io as io
from imesh.errors import MissingMarkerError, MotionFileError
from imesh.io.c3d import read_c3d, screen_up_axis, unique_names

ezc3d = pytest.importorskip("ezc3d")

QUALISYS = "ezc3d_Qualisys_gait.c3d"
BTS = "ezc3d_BTS_gait.c3d"

# name, frames, fps, markers, up axis, missing fraction, foot markers
CLIPS = [
    (QUALISYS, 340, 200.0, 55, "+Z", 0.0, ["L_FCC", "R_FCC", "L_FM1", "L_FM5", "R_FM1", "R_FM5"]),
    (BTS, 675, 100.0, 22, "+Y", 0.52, ["r heel", "l heel", "r met", "l met"]),
]


@pytest.fixture(scope="module")
def loaded(mocap):
    """name -> (RawMotion, MarkerMotion), read once per module."""
    return {name: (io.read_raw(mocap(name)), io.load_motion(mocap(name)))
            for name, *_ in CLIPS}


@pytest.mark.parametrize("name,frames,fps,markers,up,missing,feet", CLIPS)
def test_c3d_clip_facts(loaded, name, frames, fps, markers, up, missing, feet):
    raw, motion = loaded[name]
    assert raw.format == "c3d"
    assert raw.positions.shape == (frames, markers, 3)
    assert raw.fps == fps
    assert raw.declared_units == "mm"
    assert raw.declared_up == up
    assert motion.n_frames == frames and motion.fps == fps
    assert motion.meta["units"] == "mm"
    assert motion.meta["up_axis"] == up
    assert 1.0 <= motion.height_m <= 2.1
    assert motion.missing_fraction == pytest.approx(missing, abs=0.01)
    # NaN exactly where not valid
    assert np.isfinite(motion.positions_m[motion.valid]).all()
    assert np.isnan(motion.positions_m[~motion.valid]).all()
    # feet on the floor: lowest foot marker per frame, median over frames, near z = 0
    foot = motion.positions_m[:, motion.indices(feet), 2]
    seen = np.isfinite(foot).any(axis=1)
    lowest = np.nanmin(foot[seen], axis=1)
    assert abs(np.median(lowest)) < 0.1


def test_c3d_names_and_rig(loaded):
    raw_q, _ = loaded[QUALISYS]
    raw_b, _ = loaded[BTS]
    assert raw_q.rig == "qualisys" and raw_b.rig == "bts"
    assert raw_q.names[:4] == ("L_IAS", "L_IPS", "R_IPS", "R_IAS")
    assert "r asis" in raw_b.names and "l met" in raw_b.names
    assert len(set(raw_q.names)) == len(raw_q.names)


def test_qualisys_left_is_performer_left(loaded):
    """L_ markers lie on the performer's left of the walking direction (Z up)."""
    _, m = loaded[QUALISYS]
    pelvis = m.positions_m[:, m.indices(["L_IAS", "R_IAS"])].mean(axis=1)
    fwd = pelvis[-1] - pelvis[0]
    left = np.cross([0.0, 0.0, 1.0], fwd / np.linalg.norm(fwd))
    side = (m.positions_m[:, m.index("L_IAS")] - m.positions_m[:, m.index("R_IAS")]) @ left
    assert np.median(side) > 0.15


# ---------------------------------------------------------------- synthetic files / helpers
def _write(c3d, path):
    c3d.write(str(path))
    return path


def test_synthetic_gaps_duplicates_units(tmp_path):
    """Residual -1 and exact zeros are gaps; duplicate labels are made unique; units in m."""
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [50.0]
    c["parameters"]["POINT"]["LABELS"]["value"] = ("A", " B ", "A")
    c["parameters"]["POINT"]["UNITS"]["value"] = ["m"]
    rng = np.random.default_rng(0)
    pts = np.ones((4, 3, 6))
    pts[:3] = rng.uniform(0.1, 1.0, (3, 3, 6))
    pts[:3, 1, 2] = 0.0  # zero gap
    c["data"]["points"] = pts
    path = _write(c, tmp_path / "syn.c3d")
    raw = read_c3d(path)
    assert raw.names == ("A", "B", "A_2")
    assert raw.fps == 50.0 and raw.declared_units == "m" and raw.declared_up is None
    assert raw.rig == ""
    assert not raw.valid[2, 1] and raw.valid.sum() == 17
    assert np.isnan(raw.positions[2, 1]).all()
    np.testing.assert_allclose(raw.positions[0, 0], pts[:3, 0, 0])


def test_unique_names():
    assert unique_names(["x", "x", "", "x_2"], 5) == ("x", "x_3", "M003", "x_2", "M005")


def test_screen_up_axis_checked_against_data():
    rng = np.random.default_rng(1)
    # 10 frames x 20 markers spread 1.7 tall along Z (0..1.7), 0.4 wide in X and Y
    pos = rng.uniform([-0.2, -0.2, 0.0], [0.2, 0.2, 1.7], (10, 20, 3))
    valid = np.ones((10, 20), dtype=bool)
    assert screen_up_axis("+Z", pos, valid)[0] == "+Z"
    assert screen_up_axis("-Z", pos, valid)[0] == "+Z"  # sign from the data
    assert screen_up_axis("+Y", pos, valid)[0] is None  # contradicted by the extents
    assert screen_up_axis("bogus", pos, valid)[0] is None
    assert screen_up_axis(None, pos, valid)[0] is None


# ---------------------------------------------------------------- bad input
def test_not_a_c3d(tmp_path):
    bad = tmp_path / "bad.c3d"
    bad.write_bytes(b"definitely not a c3d file " * 20)
    with pytest.raises(MotionFileError, match="bad.c3d.*not a readable C3D"):
        io.load_motion(bad)


def test_empty_file(tmp_path):
    bad = tmp_path / "empty.c3d"
    bad.write_bytes(b"")
    with pytest.raises(MotionFileError, match="empty.c3d"):
        read_c3d(bad)


def test_truncated_c3d(tmp_path, mocap):
    data = mocap(QUALISYS).read_bytes()
    cut = tmp_path / "cut.c3d"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(MotionFileError, match="cut.c3d.*truncated"):
        read_c3d(cut)


# ---------------------------------------------------------------- standard marker set
def test_qualisys_to_standard(loaded):
    markerset = pytest.importorskip("imesh.markerset")
    _, motion = loaded[QUALISYS]
    std = markerset.to_standard(motion)
    assert std.names == markerset.STANDARD_MARKERS
    np.testing.assert_array_equal(std.bones, markerset.STANDARD_BONES)
    table = markerset.load_rig("qualisys")
    for k, name in enumerate(std.names):
        src = motion.indices([s for s, _ in table.markers[name]])
        all_valid = motion.valid[:, src].all(axis=1)
        assert np.isfinite(std.positions_m[all_valid, k]).all(), name
    _check_bone_lengths(std)


def _check_bone_lengths(std):
    """5th-95th percentile bone lengths in plausible adult ranges [m]."""
    ranges = {("hip_l", "knee_l"): (0.3, 0.55), ("hip_r", "knee_r"): (0.3, 0.55),
              ("knee_l", "ankle_l"): (0.3, 0.5), ("knee_r", "ankle_r"): (0.3, 0.5),
              ("shoulder_l", "elbow_l"): (0.2, 0.4), ("shoulder_r", "elbow_r"): (0.2, 0.4)}
    for (a, b), (lo, hi) in ranges.items():
        d = np.linalg.norm(std.positions_m[:, std.index(a)] - std.positions_m[:, std.index(b)],
                           axis=1)
        p5, p95 = np.nanpercentile(d, [5, 95])
        assert lo <= p5 and p95 <= hi, f"{a}-{b}: {p5:.3f}..{p95:.3f} m not in [{lo}, {hi}]"


def test_marker_missing_in_all_frames(tmp_path, mocap):
    """L_FLE gone in every frame: mapping fails naming L_FLE and knee_l."""
    markerset = pytest.importorskip("imesh.markerset")
    c = ezc3d.c3d(str(mocap(QUALISYS)))
    i = list(c["parameters"]["POINT"]["LABELS"]["value"]).index("L_FLE")
    pts = c["data"]["points"]
    pts[:3, i, :] = np.nan
    c["data"]["points"] = pts
    res = c["data"]["meta_points"]["residuals"]
    res[:, i, :] = -1.0
    c["data"]["meta_points"]["residuals"] = res
    copy = _write(c, tmp_path / "no_fle.c3d")
    motion = io.load_motion(copy)
    assert not motion.valid[:, motion.index("L_FLE")].any()
    with pytest.raises(MissingMarkerError, match="L_FLE") as info:
        markerset.to_standard(motion)
    assert "knee_l" in str(info.value)
    assert "L_FLE" in info.value.missing


def test_bts_partial_table(loaded):
    """The BTS protocol has no arms/head: mapping fails listing the standard markers lacking."""
    markerset = pytest.importorskip("imesh.markerset")
    from imesh.errors import MarkerMappingError

    _, motion = loaded[BTS]
    with pytest.raises(MarkerMappingError, match="bts") as info:
        markerset.to_standard(motion)
    assert {"elbow_l", "wrist_r", "head"} <= set(info.value.missing)

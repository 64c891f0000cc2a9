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
    from imesh.human import markerset, rig_tables, standard
    _, motion = loaded[QUALISYS]
    std = standard.to_standard(motion)
    assert std.names == markerset.STANDARD_MARKERS
    np.testing.assert_array_equal(std.bones, markerset.STANDARD_BONES)
    table = rig_tables.load_rig("qualisys")
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
    from imesh.human import standard
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
        standard.to_standard(motion)
    assert "knee_l" in str(info.value)
    assert "L_FLE" in info.value.missing


def test_bts_partial_table(loaded):
    """The BTS protocol has no arms/head: mapping fails listing the standard markers lacking."""
    from imesh.errors import MarkerMappingError
    from imesh.human import standard

    _, motion = loaded[BTS]
    with pytest.raises(MarkerMappingError, match="bts") as info:
        standard.to_standard(motion)
    assert {"elbow_l", "wrist_r", "head"} <= set(info.value.missing)


# ---------------------------------------------------------------- processor formats
def _convert(data: bytes, processor: int) -> bytes:
    """The Intel (84) float-data Qualisys file rewritten for DEC (85) or MIPS (86) processors."""
    out = bytearray(data)

    def fl(k: int) -> None:
        v = np.frombuffer(data, "<f4", 1, k)
        if processor == 86:
            out[k:k + 4] = v.astype(">f4").tobytes()
        else:  # VAX F: 4 x the IEEE value with its 16-bit halves swapped
            w = np.frombuffer((v * 4).astype("<f4").tobytes(), "<u2")[::-1]
            out[k:k + 4] = w.tobytes()

    def i2(k: int) -> None:
        if processor == 86:
            out[k:k + 2] = data[k:k + 2][::-1]

    for k in (2, 4, 6, 8, 10, 16, 18):
        i2(k)
    fl(12)
    fl(20)
    start = (data[0] - 1) * 512
    out[start + 3] = processor
    pos = start + 4
    while True:
        n = abs(int(np.uint8(data[pos]).view(np.int8)))
        gid = int(np.uint8(data[pos + 1]).view(np.int8))
        if n == 0:
            break
        link = pos + 2 + n
        offset = int(np.frombuffer(data, "<i2", 1, link)[0])
        i2(link)
        if gid > 0:
            code = int(np.uint8(data[link + 2]).view(np.int8))
            dims = list(data[link + 4:link + 4 + data[link + 3]])
            first = link + 4 + len(dims)
            for e in range(int(np.prod(dims)) if dims else 1):
                if code == 2:
                    i2(first + 2 * e)
                elif code == 4:
                    fl(first + 4 * e)
        if offset <= 0:
            break
        pos = link + offset
    data_start = (int(np.frombuffer(data, "<u2", 1, 16)[0]) - 1) * 512
    floats = np.frombuffer(data, "<f4", (len(data) - data_start) // 4, data_start)
    if processor == 86:
        body = floats.astype(">f4").tobytes()
    else:
        body = np.frombuffer((floats * 4).astype("<f4").tobytes(), "<u2").reshape(-1, 2)[
            :, ::-1].tobytes()
    out[data_start:data_start + len(body)] = body
    return bytes(out)


@pytest.mark.parametrize("processor", [85, 86])
def test_dec_and_mips_files_read_alike(tmp_path, mocap, processor):
    data = mocap(QUALISYS).read_bytes()
    path = tmp_path / f"proc{processor}.c3d"
    path.write_bytes(_convert(data, processor))
    intel, other = read_c3d(mocap(QUALISYS)), read_c3d(path)
    assert other.names == intel.names and other.fps == intel.fps
    np.testing.assert_array_equal(other.valid, intel.valid)
    np.testing.assert_allclose(other.positions, intel.positions, rtol=1e-6, equal_nan=True)


def test_integer_data_read_alike(tmp_path, mocap):
    """The Qualisys clip stored as int16 x POINT:SCALE 0.1 mm (older Vicon files are)."""
    data = mocap(QUALISYS).read_bytes()
    out = bytearray(data)
    n_points, n_analog = (int(np.frombuffer(data, "<u2", 1, k)[0]) for k in (2, 4))
    first, last = (int(np.frombuffer(data, "<u2", 1, k)[0]) for k in (6, 8))
    out[12:16] = np.float32(0.1).tobytes()
    start = (data[0] - 1) * 512
    scale_at = data.find(b"SCALE", start)  # the POINT:SCALE record: name, link, type, dims
    assert scale_at > 0 and data[scale_at + 7] == 4 and data[scale_at + 8] == 0
    out[scale_at + 9:scale_at + 13] = np.float32(0.1).tobytes()
    data_start = (int(np.frombuffer(data, "<u2", 1, 16)[0]) - 1) * 512
    words = 4 * n_points + n_analog
    table = np.frombuffer(data, "<f4", (last - first + 1) * words, data_start).reshape(-1, words)
    pts = table[:, :4 * n_points].reshape(len(table), n_points, 4)
    ints = np.zeros(table.shape, dtype="<i2")
    ip = ints[:, :4 * n_points].reshape(len(table), n_points, 4)
    ip[..., :3] = np.round(pts[..., :3] / 0.1)
    ip[..., 3] = np.where(pts[..., 3] < 0, -1, 0)
    path = tmp_path / "int.c3d"
    path.write_bytes(bytes(out[:data_start]) + ints.tobytes())
    intel, other = read_c3d(mocap(QUALISYS)), read_c3d(path)
    np.testing.assert_array_equal(other.valid, intel.valid)
    np.testing.assert_allclose(other.positions, intel.positions, atol=0.051, equal_nan=True)

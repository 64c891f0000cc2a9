"""TRC reader: the roboptim clip, synthetic files, bad input with line numbers, mapping."""

from __future__ import annotations

import numpy as np
import pytest

import imesh.io as io
from imesh.errors import MotionFileError
from imesh.io.trc import read_trc

TRC = "roboptim_human_grab_box.trc"
FEET = ["RHEEL", "LHEEL", "RTHUMB", "LTHUMB", "RPINKY", "LPINKY"]
N_HEADER = 6  # 5 header lines and the blank line before the data in this file


@pytest.fixture(scope="module")
def raw(mocap):
    return read_trc(mocap(TRC))


@pytest.fixture(scope="module")
def motion(mocap):
    return io.load_motion(mocap(TRC))


def test_trc_clip_facts(raw, motion):
    assert raw.format == "trc" and raw.rig == "roboptim"
    assert raw.positions.shape == (2387, 35, 3)
    assert raw.fps == 200.0
    assert raw.declared_units == "mm" and raw.declared_up is None
    assert raw.names[:3] == ("HEADF", "HEADR", "HEADL") and raw.names[-1] == "SCAP"
    assert motion.n_frames == 2387 and motion.fps == 200.0
    assert motion.meta["units"] == "mm" and motion.meta["up_axis"] == "+Z"
    assert 1.0 <= motion.height_m <= 2.1
    assert motion.missing_fraction == pytest.approx(0.049, abs=0.005)
    assert np.isfinite(motion.positions_m[motion.valid]).all()
    assert np.isnan(motion.positions_m[~motion.valid]).all()
    foot = motion.positions_m[:, motion.indices(FEET), 2]
    seen = np.isfinite(foot).any(axis=1)
    assert abs(np.median(np.nanmin(foot[seen], axis=1))) < 0.1


def test_trc_first_row_values(raw):
    """Spot check against the text: row 1 HEADF = (46.83710, 768.45087, 1564.42505) mm."""
    np.testing.assert_allclose(raw.positions[0, 0], [46.83710, 768.45087, 1564.42505])
    assert raw.meta["trc_start_time_s"] == 0.0 and raw.meta["trc_first_frame"] == 1.0


# ---------------------------------------------------------------- synthetic files
def _trc_text(rows: list[str], *, names=("A", "B"), num_frames=None, units="mm",
              newline="\n") -> str:
    num_frames = len(rows) if num_frames is None else num_frames
    coords = "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, len(names) + 1))
    head = [
        "PathFileType\t4\t(X/Y/Z)\tsyn.trc",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"100.00\t100.00\t{num_frames}\t{len(names)}\t{units}\t100.00\t1\t{num_frames}",
        "Frame#\tTime\t" + "\t\t\t".join(names) + "\t\t\t",
        "\t\t" + coords + "\t",
        "",
    ]
    return newline.join(head + rows) + newline


ROWS = [
    "1\t0.00\t1.0\t2.0\t3.0\t4.0\t5.0\t6.0\t",
    "2\t0.01\t\t\t\t4.5\t5.5\t6.5",  # A missing, no trailing tab
    "3\t0.02\t1.2\t2.2\t3.2\t\t\t\t",  # B missing at the end, trailing tab
]


@pytest.mark.parametrize("newline", ["\n", "\r\n"])
def test_synthetic_empty_fields_and_trailing_tabs(tmp_path, newline):
    path = tmp_path / "syn.trc"
    path.write_bytes(_trc_text(ROWS, newline=newline).encode())
    raw = read_trc(path)
    assert raw.names == ("A", "B") and raw.fps == 100.0 and raw.rig == ""
    np.testing.assert_array_equal(raw.valid, [[True, True], [False, True], [True, False]])
    np.testing.assert_allclose(raw.positions[0], [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_allclose(raw.positions[1, 1], [4.5, 5.5, 6.5])
    assert np.isnan(raw.positions[1, 0]).all() and np.isnan(raw.positions[2, 1]).all()


def test_units_spelled_out(tmp_path):
    path = tmp_path / "m.trc"
    path.write_text(_trc_text(ROWS, units="meters"))
    assert read_trc(path).declared_units == "m"


# ---------------------------------------------------------------- bad input
def test_truncated_rows(tmp_path, mocap):
    """Fewer rows than NumFrames: error at the line after the last row."""
    lines = mocap(TRC).read_text().splitlines(keepends=True)
    cut = tmp_path / "cut.trc"
    cut.write_text("".join(lines[: N_HEADER + 100]))
    with pytest.raises(MotionFileError, match=r"cut\.trc, line 107: truncated") as info:
        read_trc(cut)
    assert info.value.line == N_HEADER + 100 + 1


def test_truncated_mid_row(tmp_path, mocap):
    text = mocap(TRC).read_text()
    cut = tmp_path / "cut_mid.trc"
    cut.write_text(text[: len(text) // 2])
    with pytest.raises(MotionFileError, match=r"cut_mid\.trc, line \d+: .*columns") as info:
        read_trc(cut)
    assert info.value.line > N_HEADER


def test_non_numeric_value(tmp_path):
    rows = list(ROWS)
    rows[1] = "2\t0.01\t\t\t\t4.5\tabc\t6.5"
    path = tmp_path / "bad.trc"
    path.write_text(_trc_text(rows))
    with pytest.raises(MotionFileError, match=r"bad\.trc, line 8: non-numeric value 'abc'.*"
                                              r"Y of marker B"):
        read_trc(path)


def test_wrong_column_count(tmp_path):
    rows = list(ROWS)
    rows[2] = "3\t0.02\t1.2\t2.2\t3.2\t7\t7\t7\t7\t7"
    path = tmp_path / "cols.trc"
    path.write_text(_trc_text(rows))
    with pytest.raises(MotionFileError, match=r"cols\.trc, line 9: 10 columns, expected 8"):
        read_trc(path)


def test_not_a_trc(tmp_path):
    path = tmp_path / "x.trc"
    path.write_text("hello\nworld\n1\n2\n3\n")
    with pytest.raises(MotionFileError, match=r"x\.trc, line 1"):
        io.load_motion(path)


# ---------------------------------------------------------------- standard marker set
def test_trc_to_standard(motion):
    from imesh.human import markerset, rig_tables, standard
    std = standard.to_standard(motion)
    assert std.names == markerset.STANDARD_MARKERS
    np.testing.assert_array_equal(std.bones, markerset.STANDARD_BONES)
    table = rig_tables.load_rig("roboptim")
    for k, name in enumerate(std.names):
        src = motion.indices([s for s, _ in table.markers[name]])
        all_valid = motion.valid[:, src].all(axis=1)
        assert np.isfinite(std.positions_m[all_valid, k]).all(), name
        np.testing.assert_array_equal(std.valid[:, k], all_valid)
    ranges = {("hip_l", "knee_l"): (0.3, 0.55), ("hip_r", "knee_r"): (0.3, 0.55),
              ("knee_l", "ankle_l"): (0.3, 0.5), ("knee_r", "ankle_r"): (0.3, 0.5),
              ("shoulder_l", "elbow_l"): (0.2, 0.4), ("shoulder_r", "elbow_r"): (0.2, 0.4)}
    for (a, b), (lo, hi) in ranges.items():
        d = np.linalg.norm(std.positions_m[:, std.index(a)] - std.positions_m[:, std.index(b)],
                           axis=1)
        p5, p95 = np.nanpercentile(d, [5, 95])
        assert lo <= p5 and p95 <= hi, f"{a}-{b}: {p5:.3f}..{p95:.3f} m not in [{lo}, {hi}]"


def test_whitespace_separated(tmp_path):
    """Header without tabs: whitespace-separated layout, NaN for missing samples."""
    path = tmp_path / "ws.trc"
    path.write_text("PathFileType 4 (X/Y/Z) ws.trc\n"
                    "DataRate CameraRate NumFrames NumMarkers Units\n"
                    "60 60 2 1 m\n"
                    "Frame# Time A\n"
                    "X1 Y1 Z1\n"
                    "1 0 1 2 3\n"
                    "2 0.0167 NaN NaN NaN\n")
    raw = read_trc(path)
    assert raw.names == ("A",) and raw.fps == 60.0 and raw.declared_units == "m"
    np.testing.assert_array_equal(raw.valid, [[True], [False]])
    np.testing.assert_allclose(raw.positions[0, 0], [1, 2, 3])

"""ASF/AMC reader: the CMU 07_05 clip, Acclaim conventions on synthetic files, bad input."""

from __future__ import annotations

import logging
import shutil
import tomllib
from importlib import resources

import numpy as np
import pytest

import imesh.io as io
from imesh.errors import MotionFileError
from imesh.io.asf_amc import find_asf, read_asf_amc

AMC = "cmu_07_05.amc"
ASF = "cmu_07.asf"
FEET = ["ltibia", "rtibia", "lfoot", "rfoot", "ltoes", "rtoes"]


@pytest.fixture(scope="module")
def raw(mocap):
    return read_asf_amc(mocap(AMC))


@pytest.fixture(scope="module")
def motion(raw):
    return io.finalize(raw)


def test_amc_clip_facts(raw, motion, mocap):
    assert raw.format == "asf/amc" and raw.rig == "cmu_asf"
    assert raw.positions.shape == (517, 31, 3)
    assert raw.fps == 120.0 and raw.meta["fps_default_used"]
    assert raw.declared_units == "cmu" and raw.declared_scale_m == pytest.approx(0.0254 / 0.45)
    assert raw.declared_up == "+Y"
    assert raw.meta["asf"] == str(mocap(ASF))
    assert raw.names[:3] == ("root", "lhipjoint", "lfemur") and len(raw.bones) == 30
    assert np.isfinite(raw.positions).all()
    assert motion.n_frames == 517 and motion.fps == 120.0
    assert motion.meta["units"] == "cmu" and motion.meta["up_axis"] == "+Y"
    assert 1.0 <= motion.height_m <= 2.1
    # MANIFEST: median joint extent 27.00 units = 1.52 m
    assert motion.height_m == pytest.approx(27.00 * 0.0254 / 0.45, rel=0.02)
    assert not np.isnan(motion.positions_m).any()
    lowest = motion.positions_m[:, motion.indices(FEET), 2].min(axis=1)
    assert abs(np.median(lowest)) < 0.1


def test_load_motion_amc(mocap, motion):
    m = io.load_motion(mocap(AMC))
    np.testing.assert_allclose(m.positions_m, motion.positions_m)
    m60 = io.load_motion(mocap(AMC), fps=60, asf=mocap(ASF))
    assert m60.fps == 60.0


def test_bone_lengths_match_asf(raw, mocap):
    """Rigid skeleton: each bone keeps its ASF length in every frame (1e-9)."""
    lengths = np.linalg.norm(raw.positions[:, raw.bones[:, 0]] - raw.positions[:, raw.bones[:, 1]],
                             axis=-1)
    assert (lengths.max(axis=0) - lengths.min(axis=0)).max() < 1e-9
    idx = {n: i for i, n in enumerate(raw.names)}
    np.testing.assert_allclose(lengths[0, idx["lfemur"] - 1], 6.92462, rtol=1e-6)
    np.testing.assert_allclose(lengths[0, idx["head"] - 1], 1.52456, rtol=1e-6)


def test_first_frame_root(raw):
    """Root at ASF position (0) + AMC TX TY TZ of frame 1."""
    np.testing.assert_allclose(raw.positions[0, 0], [7.46593, 15.9937, -36.7321])


def test_left_is_performer_left(motion):
    p = motion.positions_m
    fwd = p[:, motion.index("lfoot")] - p[:, motion.index("ltibia")]
    left = np.cross([0.0, 0.0, 1.0], fwd)
    side = np.sum((p[:, motion.index("lhipjoint")] - p[:, motion.index("rhipjoint")]) * left, 1)
    assert np.mean(side > 0) > 0.95


def test_find_asf(tmp_path, mocap):
    assert find_asf(mocap(AMC)) == mocap(ASF)
    amc = tmp_path / "s_01_02.amc"
    amc.write_text("1\nroot 0 0 0 0 0 0\n")
    with pytest.raises(MotionFileError, match="no skeleton.*none"):
        find_asf(amc)
    (tmp_path / "other.asf").write_text("")
    with pytest.raises(MotionFileError, match="other.asf"):
        find_asf(amc)
    (tmp_path / "s.asf").write_text("")
    (tmp_path / "s_01.asf").write_text("")
    with pytest.raises(MotionFileError, match="several skeletons.*s.asf, s_01.asf"):
        find_asf(amc)


def test_fps_logged(mocap, caplog):
    with caplog.at_level(logging.INFO, logger="imesh.io.asf_amc"):
        read_asf_amc(mocap(AMC))
    assert "120 fps" in caplog.text


# ---------------------------------------------------------------- synthetic files
ASF_TEXT = """# synthetic
:version 1.10
:name test
:units
  mass 1.0
  length 0.45
  angle deg
:documentation
  anything: here
:root
   order TX TY TZ RX RY RZ
   axis XYZ
   position 1 0 0
   orientation 0 0 0
:bonedata
  begin
     id 1
     name arm
     direction 1 0 0
     length 2
     axis 0 0 90 XYZ
    dof rx rz
    limits (-180.0 180.0)
           (-180.0 180.0)
  end
  begin
     id 2
     name hand
     direction 0 1 0
     length 1
     axis 0 0 0 XYZ
  end
:hierarchy
  begin
    root arm
    arm hand
  end
"""


def _amc(frames: list[tuple[str, str]]) -> str:
    body = "".join(f"{i + 1}\nroot {r}\narm {a}\n" for i, (r, a) in enumerate(frames))
    return "#!OML:ASF test.asf\n:FULLY-SPECIFIED\n:DEGREES\n" + body


def _write(tmp_path, amc: str, asf: str = ASF_TEXT):
    (tmp_path / "test.asf").write_text(asf)
    path = tmp_path / "test_01.amc"
    path.write_text(amc)
    return path


def test_synthetic_conventions(tmp_path):
    """Root at position + T; the arm's local rotation acts about its axis frame C:
    D = C L C^T with C = Rz(90): dof rx about the arm's local X = world Y."""
    frames = [("0 0 0 0 0 0", "0 0"), ("0 0 5 0 0 0", "0 90"), ("0 0 0 0 0 0", "90 0")]
    raw = read_asf_amc(_write(tmp_path, _amc(frames)))
    assert raw.names == ("root", "arm", "hand") and raw.fps == 120.0
    assert raw.bones.tolist() == [[0, 1], [1, 2]]
    p = raw.positions
    np.testing.assert_allclose(p[0], [[1, 0, 0], [3, 0, 0], [3, 1, 0]], atol=1e-12)
    # frame 1: arm rz 90 about its local Z (= world Z): arm points +Y, hand -X
    np.testing.assert_allclose(p[1], [[1, 0, 5], [1, 2, 5], [0, 2, 5]], atol=1e-12)
    # frame 2: arm rx 90 about its local X (world +Y): world X -> -Z
    np.testing.assert_allclose(p[2, 1], [1, 0, -2], atol=1e-12)
    # root RZ 90 turns everything about world Z
    frames = [("0 0 0 0 0 90", "0 0")]
    p = read_asf_amc(_write(tmp_path, _amc(frames))).positions
    np.testing.assert_allclose(p[0], [[1, 0, 0], [1, 2, 0], [0, 2, 0]], atol=1e-12)


def test_copied_cmu_pair(tmp_path, mocap):
    """A copy of the real pair in another folder is found and read identically."""
    shutil.copy(mocap(ASF), tmp_path / ASF)
    shutil.copy(mocap(AMC), tmp_path / AMC)
    a = read_asf_amc(tmp_path / AMC, fps=30)
    assert a.fps == 30.0 and not a.meta["fps_default_used"]


def _error(path, **kwargs) -> MotionFileError:
    with pytest.raises(MotionFileError) as info:
        read_asf_amc(path, **kwargs)
    assert type(info.value) is MotionFileError
    assert path.name in str(info.value) or "asf" in str(info.value)
    return info.value


def test_truncated_amc(tmp_path):
    text = _amc([("0 0 0 0 0 0", "0 0")] * 3) + "4\nroot 0 0 0 0 0 0\n"
    err = _error(_write(tmp_path, text))
    assert "bone arm missing" in str(err) and err.frame == 3 and err.line == 13
    assert "test_01.amc, line 13, frame 3" in str(err)


def test_short_line_amc(tmp_path):
    err = _error(_write(tmp_path, _amc([("0 0 0 0 0 0", "0 0"), ("0 0 0 0 0 0", "0")])))
    assert "bone arm: expected 2 numbers, found '0'" in str(err)
    assert err.frame == 1 and err.line == 9


@pytest.mark.parametrize("bad", ["nan", "inf", "abc"])
def test_non_finite_amc(tmp_path, bad):
    err = _error(_write(tmp_path, _amc([("0 0 0 0 0 0", "0 0"), (f"0 {bad} 0 0 0 0", "0 0")])))
    assert err.frame == 1 and err.line == 8 and "root" in str(err)


def test_unknown_bone_amc(tmp_path):
    text = _amc([("0 0 0 0 0 0", "0 0")]) + "lfemur 0 0 0\n"
    err = _error(_write(tmp_path, text))
    assert "unknown bone 'lfemur'" in str(err) and "root, arm, hand" in str(err)


def test_empty_amc(tmp_path):
    err = _error(_write(tmp_path, ":FULLY-SPECIFIED\n:DEGREES\n"))
    assert "no frames" in str(err)


@pytest.mark.parametrize("change,message", [
    (("dof rx rz", "dof rx rz l"), "dof l not supported"),
    (("arm hand\n", "arm foot\n"), "unknown bone 'foot'"),
    (("     length 1\n", ""), "needs a direction and a length"),
    (("axis 0 0 90 XYZ", "axis 0 0 90 XXY"), "bad axis order"),
    (("angle deg", "angle grad"), "unknown angle unit"),
    (("  end\n:hierarchy", ":hierarchy"), "not closed"),
    (("    root arm\n", ""), "not connected to the root"),
])
def test_malformed_asf(tmp_path, change, message):
    asf = ASF_TEXT.replace(*change)
    assert asf != ASF_TEXT
    path = _write(tmp_path, _amc([("0 0 0 0 0 0", "0 0")]), asf)
    with pytest.raises(MotionFileError, match=message) as info:
        read_asf_amc(path)
    assert "test.asf" in str(info.value)


# ---------------------------------------------------------------- rig table
def test_rig_table(raw):
    table = tomllib.loads(resources.files("imesh.data").joinpath("rigs/cmu_asf.toml").read_text())
    assert table["name"] == "cmu_asf" and set(table["detect"]) <= set(raw.names)
    for spec in table["markers"].values():
        assert set(spec) <= set(raw.names)


def test_to_standard(motion):
    from imesh.human import markerset, standard
    std = standard.to_standard(motion)
    assert std.names == markerset.STANDARD_MARKERS and len(std.names) == 21
    assert not np.isnan(std.positions_m).any()
    p = std.positions_m

    def length(a, b):
        return np.median(np.linalg.norm(p[:, std.index(a)] - p[:, std.index(b)], axis=-1))

    for side in "lr":
        assert 0.3 <= length(f"hip_{side}", f"knee_{side}") <= 0.55
        assert 0.3 <= length(f"knee_{side}", f"ankle_{side}") <= 0.55
        assert 0.2 <= length(f"shoulder_{side}", f"elbow_{side}") <= 0.4
        assert 0.05 <= length(f"wrist_{side}", f"hand_{side}") <= 0.15
    z = np.median(p[..., 2], axis=0)
    order = [std.index(n) for n in ("pelvis", "spine", "chest", "neck", "head")]
    assert np.all(np.diff(z[order]) > 0.02)

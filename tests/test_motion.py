"""MarkerMotion invariants: resampling, gap filling, combining performers."""

from __future__ import annotations

import numpy as np
import pytest

from imesh import InvalidMotionError, MarkerMotion, MissingMarkerError, fill_gaps, load_motion


def _linear_motion(n=61, fps=60.0):
    t = np.arange(n) / fps
    pos = np.zeros((n, 2, 3))
    pos[:, 0, 0] = 0.5 * t
    pos[:, 1, 2] = 1.0 + 0.2 * t
    return MarkerMotion(positions_m=pos, fps=fps, names=("a", "b"), valid=np.ones((n, 2), bool))


def test_resample_reproduces_linear_motion():
    m = _linear_motion()
    r = m.resample(30.0)
    assert r.fps == 30.0 and r.n_frames == 31
    t = np.arange(r.n_frames) / 30.0
    np.testing.assert_allclose(r.positions_m[:, 0, 0], 0.5 * t, atol=1e-12)
    up = m.resample(240.0)
    assert up.n_frames == 241
    np.testing.assert_allclose(up.positions_m[:, 1, 2], 1.0 + 0.2 * np.arange(241) / 240,
                               atol=1e-12)


def test_resample_to_a_rate_a_header_rounded_keeps_every_frame(mocap):
    # the Bandai Namco run's header: frame time 0.0333333 s (30.00003 fps), 68 frames
    m = load_motion(mocap("bandai_nc_dataset-2_run_normal_001.bvh"))
    assert m.n_frames == 68 and m.fps == pytest.approx(30.00003, rel=1e-6)
    r = m.resample(30.0)
    assert r.n_frames == 68
    np.testing.assert_allclose(r.positions_m[-1], m.positions_m[-1], atol=1e-4)
    np.testing.assert_allclose(r.positions_m[:5], m.positions_m[:5], atol=1e-4)
    # a real change of rate keeps the frames that fall within the clip, no more
    assert _linear_motion(n=61, fps=60.0).resample(29.0).n_frames == 30


def test_resample_real_clip_keeps_duration(mocap):
    m = load_motion(mocap("cmu_141_16_wave_hello.bvh"))
    r = m.resample(30.0)
    assert r.duration_s == pytest.approx(m.duration_s, abs=1 / 30)
    assert not np.isnan(r.positions_m).any()


def test_fill_gaps_interpolates_and_records(mocap):
    m = load_motion(mocap("roboptim_human_grab_box.trc"))
    assert m.missing_fraction > 0.04
    f = fill_gaps(m)
    assert f.valid.all() and np.isfinite(f.positions_m).all()
    assert f.meta["filled_fraction"] == pytest.approx(m.missing_fraction)
    # measured samples are untouched
    np.testing.assert_array_equal(f.positions_m[m.valid], m.positions_m[m.valid])


def test_fill_gaps_refuses_markers_missing_everywhere():
    m = _linear_motion()
    valid = m.valid.copy()
    valid[:, 1] = False
    with pytest.raises(MissingMarkerError, match="missing in all"):
        fill_gaps(m.replace(valid=valid))


def test_combining_performers_needs_matching_frames():
    a, b = _linear_motion(61), _linear_motion(50)
    with pytest.raises(InvalidMotionError, match="frame count"):
        a.concat_markers(b, "a:", "b:")
    both = a.concat_markers(_linear_motion(61), "a:", "b:")
    assert both.names == ("a:a", "a:b", "b:a", "b:b")


def test_unknown_marker_lists_available():
    with pytest.raises(MissingMarkerError, match="available: a, b"):
        _linear_motion().index("c")

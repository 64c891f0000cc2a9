"""The zero-phase Butterworth low-pass (imesh.human.filtering) against scipy.signal, which it
replaces in the pipeline (scipy.signal and the scipy.stats it imports cost 0.5 s of CPU in every
process), and the imports a retarget's filtering leaves out."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import modules_after

from imesh import load_motion
from imesh.human.filtering import butter_lowpass, filtfilt, lowpass_array
from imesh.morph.adapt import prepare_markers


@pytest.mark.parametrize(("order", "wn"), [(1, 0.5), (2, 0.05), (4, 0.1), (4, 0.4), (6, 0.3)])
def test_butterworth_design_equals_scipy(order, wn):
    from scipy.signal import butter

    b, a = butter_lowpass(order, wn)
    b_ref, a_ref = butter(order, wn)
    np.testing.assert_allclose(b, b_ref, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(a, a_ref, rtol=1e-12, atol=1e-12)
    assert abs(b.sum() / a.sum() - 1.0) < 1e-9  # unit gain at DC


@pytest.mark.parametrize(("order", "wn"), [(2, 0.5), (4, 0.2), (4, 0.05)])
def test_filtfilt_equals_scipy_on_a_random_walk(order, wn):
    from scipy.signal import butter
    from scipy.signal import filtfilt as scipy_filtfilt

    x = np.cumsum(np.random.default_rng(3).normal(size=(400, 5, 3)), axis=0)  # |x| up to ~40
    b, a = butter(order, wn)
    np.testing.assert_allclose(filtfilt(b, a, x), scipy_filtfilt(b, a, x, axis=0),
                               rtol=0, atol=1e-9)
    one = x[:, 0, 0]
    np.testing.assert_allclose(filtfilt(b, a, one), scipy_filtfilt(b, a, one), rtol=0, atol=1e-9)


def test_lowpass_of_a_real_clip_equals_scipy(mocap):
    """The CMU walk's markers (120 fps) at the pipeline's 8 Hz: within 1e-12 m of scipy's; a
    clip too short for the padding is not filtered; a constant stays constant."""
    from scipy.signal import butter
    from scipy.signal import filtfilt as scipy_filtfilt

    motion = prepare_markers(load_motion(mocap("cmu_02_01_walk.bvh")))
    x = motion.positions_m
    b, a = butter(4, 8.0 / (motion.fps / 2))
    ours = lowpass_array(x, motion.fps, 8.0)
    assert np.abs(ours - scipy_filtfilt(b, a, x, axis=0)).max() < 1e-12
    assert np.abs(ours - x).max() > 1e-3  # it did filter (jitter of millimetres)
    assert lowpass_array(x[:15], motion.fps, 8.0) is None  # 3 x 5 samples of padding
    flat = np.full((50, 2, 3), 0.7)
    np.testing.assert_allclose(lowpass_array(flat, 30.0, 5.0), flat, rtol=0, atol=1e-12)


def test_a_retarget_s_filtering_imports_no_scipy_signal():
    """The pipeline and its low-pass load neither scipy.signal nor scipy.stats (nor the arms'
    scipy.optimize or the physics check's scipy.interpolate, which the default run does not
    use)."""
    loaded = modules_after(
        "import numpy as np, imesh.pipeline.retarget, imesh.evaluate.verify; "
        "from imesh.human.filtering import lowpass_array; "
        "lowpass_array(np.zeros((100, 3)), 120.0, 8.0)",
        "m in ('scipy.signal', 'scipy.stats', 'scipy.optimize', 'scipy.interpolate')")
    assert loaded == []

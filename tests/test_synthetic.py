"""Tests of the synthetic walk-and-clap generator (imesh.io.synthetic)."""

from __future__ import annotations

import numpy as np
import pytest

from imesh.core.motion import MarkerMotion
from imesh.errors import OptionError
from imesh.human.markerset import STANDARD_BONES, STANDARD_MARKERS
from imesh.io.synthetic import synthetic_walk_clap

FLOOR_TOL_M = 1e-3  # toe within 1 mm of its floor level = stance


@pytest.fixture(scope="module")
def motion() -> MarkerMotion:
    return synthetic_walk_clap()


def _runs(mask: np.ndarray) -> list[np.ndarray]:
    """Frame indices of the maximal runs of True in ``mask``."""
    edges = np.flatnonzero(np.diff(mask.astype(np.int8))) + 1
    return [r for r in np.split(np.arange(mask.size), edges) if mask[r[0]]]


def _stances(m: MarkerMotion, toe: str) -> tuple[np.ndarray, list[np.ndarray]]:
    p = m.positions_m[:, m.index(toe)]
    floor = p[:, 2].min()
    return p, _runs(p[:, 2] < floor + FLOOR_TOL_M)


def _hand_distance(m: MarkerMotion) -> np.ndarray:
    return np.linalg.norm(m.positions_m[:, m.index("hand_l")] - m.positions_m[:, m.index("hand_r")],
                          axis=-1)


def _local_minima(x: np.ndarray) -> np.ndarray:
    return np.flatnonzero((x[1:-1] < x[:-2]) & (x[1:-1] <= x[2:])) + 1


def test_structure(motion):
    assert motion.names == STANDARD_MARKERS
    assert np.array_equal(motion.bones, STANDARD_BONES)
    assert motion.positions_m.shape == (motion.n_frames, 21, 3)
    assert motion.valid.all()
    assert np.isfinite(motion.positions_m).all()
    assert motion.source == "synthetic:walk_clap"
    assert motion.meta["synthetic"] is True
    assert motion.meta["units"] == "m"
    assert motion.meta["up_axis"] == "+Z"
    assert motion.fps == 60.0
    assert 5.0 < motion.duration_s < 9.0


@pytest.mark.parametrize("fps", [24.0, 60.0, 120.0])
def test_fps_honoured(fps):
    m = synthetic_walk_clap(fps=fps)
    ref = synthetic_walk_clap(fps=60.0)
    assert m.fps == fps
    assert abs(m.duration_s - ref.duration_s) <= 1.0 / fps + 1e-9
    # the same time gives the same pose whatever the sampling rate
    k = int(round(2.0 * fps))
    np.testing.assert_allclose(m.positions_m[k], ref.positions_m[120], atol=1e-9)


@pytest.mark.parametrize("kwargs", [{}, {"steps": 1}, {"steps": 7, "height_m": 1.8},
                                    {"seed": 3}, {"fps": 30.0, "height_m": 0.9}])
def test_bone_lengths_constant(kwargs):
    m = synthetic_walk_clap(**kwargs)
    p = m.positions_m
    lengths = np.linalg.norm(p[:, m.bones[:, 0]] - p[:, m.bones[:, 1]], axis=-1)
    assert np.ptp(lengths, axis=0).max() < 1e-9
    assert lengths.min() > 0.02


@pytest.mark.parametrize("height", [1.0, 1.45, 1.8])
def test_height(height):
    m = synthetic_walk_clap(height_m=height)
    assert abs(m.height_m - height) <= 0.05 * height
    ankle_z = m.positions_m[0, m.index("ankle_l"), 2]
    toe_z = m.positions_m[0, m.index("toe_l"), 2]
    assert 0.04 * height < ankle_z < 0.08 * height
    assert 0.005 * height < toe_z < 0.025 * height


def test_realistic_foot_heights(motion):
    p = motion.positions_m
    for side in "lr":
        toe = p[:, motion.index(f"toe_{side}"), 2]
        ankle = p[:, motion.index(f"ankle_{side}"), 2]
        assert 0.01 < toe.min() < 0.03
        assert 0.06 < ankle.min() < 0.10
    # nothing goes below the floor
    assert p[..., 2].min() > 0.0


@pytest.mark.parametrize("steps", [1, 2, 4, 5])
def test_stance_feet_fixed_and_footfalls(steps):
    m = synthetic_walk_clap(steps=steps)
    footfalls = 0
    for side in "lr":
        p, stances = _stances(m, f"toe_{side}")
        assert stances[0][0] == 0  # standing at the start
        assert stances[-1][-1] == m.n_frames - 1  # and at the end
        footfalls += sum(1 for r in stances if r[0] > 0)
        for r in stances:
            speed = np.linalg.norm(np.diff(p[r, :2], axis=0), axis=1)
            assert speed.size == 0 or speed.max() < 1e-3  # m/frame
            assert p[r, 2].max() < 0.03
        # the toe marker sits exactly still while on the floor (foot flat / heel rise)
        floor = p[:, 2].min()
        exact = _runs(p[:, 2] < floor + 1e-9)
        for r in exact:
            assert np.ptp(p[r], axis=0).max() < 1e-9
    assert footfalls == steps


def test_swing_clearance(motion):
    for side in "lr":
        p, stances = _stances(motion, f"toe_{side}")
        floor = p[:, 2].min()
        for before, after in zip(stances[:-1], stances[1:], strict=True):
            swing = np.arange(before[-1] + 1, after[0])
            assert swing.size > 0.3 * motion.fps  # swing lasts ~0.5 s
            mid = swing[swing.size // 2]
            assert p[mid, 2] - floor >= 0.02
            middle = swing[swing.size // 4: 3 * swing.size // 4]
            assert (p[middle, 2] - floor).min() >= 0.02
            assert (p[middle, 2] - floor).max() < 0.15
            assert p[after[0], 0] > p[before[-1], 0]  # swings move forward


def test_alternating_support(motion):
    """At every frame at least one toe is on the floor (walking, not running)."""
    on_floor = np.zeros(motion.n_frames, dtype=bool)
    for side in "lr":
        _, stances = _stances(motion, f"toe_{side}")
        for r in stances:
            on_floor[r] = True
    assert on_floor.all()


def test_three_claps(motion):
    d = _hand_distance(motion)
    minima = _local_minima(d)
    claps = minima[d[minima] < 0.03]
    assert claps.size == 3
    assert d[claps].max() < 0.02
    t = claps / motion.fps
    assert np.all(t > motion.meta["heel_strike_s"][-1])  # after the walk
    np.testing.assert_allclose(t, motion.meta["clap_s"], atol=1.0 / motion.fps)
    # hands apart between the claps and never touching elsewhere
    assert d[claps[0]: claps[-1]].max() > 0.2
    assert (d < 0.03).sum() < 0.5 * motion.fps
    # in front of the chest
    chest = motion.positions_m[claps, motion.index("chest")]
    hands = 0.5 * (motion.positions_m[claps, motion.index("hand_l")]
                   + motion.positions_m[claps, motion.index("hand_r")])
    assert np.all(hands[:, 0] - chest[:, 0] > 0.15)
    assert np.all(np.abs(hands[:, 2] - chest[:, 2]) < 0.15)


@pytest.mark.parametrize("steps", [2, 4, 6])
def test_forward_progress(steps):
    m = synthetic_walk_clap(steps=steps)
    step = m.meta["step_length_m"]
    assert 0.3 < step / m.height_m < 0.45
    pelvis = m.positions_m[:, m.index("pelvis")]
    progress = pelvis[-1, 0] - pelvis[0, 0]
    # the first step starts and the last step ends with the feet side by side
    assert progress == pytest.approx((steps - 1) * step, rel=0.02)
    assert progress == pytest.approx(m.meta["forward_progress_m"], rel=1e-9)
    assert np.all(np.diff(pelvis[:, 0]) > -1e-9)  # never walks backwards
    assert np.abs(pelvis[:, 1]).max() < 0.06  # sways a little around the line of progression
    for side in "lr":
        assert np.all(np.abs(m.positions_m[:, m.index(f"ankle_{side}"), 1]) > 0.05)


def test_pelvis_bob_and_arm_swing(motion):
    t = np.arange(motion.n_frames) / motion.fps
    strikes = motion.meta["heel_strike_s"]
    walk = (t > strikes[0]) & (t < strikes[-2])
    z = motion.positions_m[walk, motion.index("pelvis"), 2]
    assert 0.005 < np.ptp(z) < 0.05
    rel = (motion.positions_m[walk, motion.index("wrist_l"), 0]
           - motion.positions_m[walk, motion.index("shoulder_l"), 0])
    assert np.ptp(rel) > 0.1
    # arms swing in counter-phase with each other
    rel_r = (motion.positions_m[walk, motion.index("wrist_r"), 0]
             - motion.positions_m[walk, motion.index("shoulder_r"), 0])
    assert np.corrcoef(rel, rel_r)[0, 1] < -0.5


def test_stands_still_at_start_and_end(motion):
    p = motion.positions_m
    n = int(0.45 * motion.fps)
    assert np.ptp(p[:n], axis=0).max() < 1e-9
    assert np.ptp(p[-n:], axis=0).max() < 1e-9


def test_smooth_c1():
    """Second differences shrink like dt^2 (bounded acceleration: no velocity jumps)."""
    a = synthetic_walk_clap(fps=500.0).positions_m
    b = synthetic_walk_clap(fps=1000.0).positions_m
    da = np.abs(np.diff(a, 2, axis=0)).max()
    db = np.abs(np.diff(b, 2, axis=0)).max()
    assert da / db > 3.0
    assert da * 500.0**2 < 100.0  # peak acceleration below 100 m/s^2


def test_deterministic():
    a = synthetic_walk_clap()
    b = synthetic_walk_clap(seed=None)
    assert np.array_equal(a.positions_m, b.positions_m)
    c = synthetic_walk_clap(seed=7)
    d = synthetic_walk_clap(seed=7)
    e = synthetic_walk_clap(seed=8)
    assert np.array_equal(c.positions_m, d.positions_m)
    assert not np.array_equal(c.positions_m, a.positions_m)
    assert not np.array_equal(c.positions_m, e.positions_m)


@pytest.mark.parametrize("seed", range(5))
def test_seeded_variants_keep_invariants(seed):
    m = synthetic_walk_clap(seed=seed)
    p = m.positions_m
    lengths = np.linalg.norm(p[:, m.bones[:, 0]] - p[:, m.bones[:, 1]], axis=-1)
    assert np.ptp(lengths, axis=0).max() < 1e-9
    d = _hand_distance(m)
    minima = _local_minima(d)
    assert (d[minima] < 0.03).sum() == 3
    footfalls = sum(sum(1 for r in _stances(m, f"toe_{s}")[1] if r[0] > 0) for s in "lr")
    assert footfalls == 4


@pytest.mark.parametrize("kwargs", [{"steps": 0}, {"steps": 2.5}, {"steps": True},
                                    {"fps": 0.0}, {"fps": float("nan")},
                                    {"height_m": -1.0}, {"height_m": 10.0}])
def test_invalid_options(kwargs):
    with pytest.raises(OptionError):
        synthetic_walk_clap(**kwargs)

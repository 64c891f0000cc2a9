"""The clip's frame rate checked by the performer's balance (imesh.human.timing)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import mocap_path as mocap

from imesh.errors import MotionFileError, OptionError
from imesh.human.standard import to_standard
from imesh.human.timing import SEGMENTS, TimingConfig, check_timing, off_balance_fraction
from imesh.io import load_motion

SALSA = ("cmu_60_10_salsa_partnerA_sl_scaled.bvh", "cmu_61_10_salsa_partnerB_sl_scaled.bvh")


def test_segment_masses_add_up_to_the_body():
    assert sum(s[3] for s in SEGMENTS) == pytest.approx(100.0, abs=0.01)


@pytest.mark.parametrize("clip", SALSA)
def test_the_salsa_couple_is_read_at_its_capture_rate(clip):
    """The CMU listing gives 60 fps where the headers say 120: at 120 the dancers' ZMP is
    more than 0.3 body heights from both feet in a third or more of the frames."""
    motion = load_motion(mocap(clip))
    assert motion.fps == pytest.approx(120.0048 / 2, rel=1e-6)
    assert motion.meta["header_fps"] == pytest.approx(120.0048, rel=1e-6)
    assert "not the file's" in motion.meta["fps_reason"]
    header = dataclasses.replace(motion, fps=motion.meta["header_fps"])
    check = check_timing(header)
    (rate, at_header), (half, at_half) = check.off_balance
    assert (rate, half) == (header.fps, header.fps / 2)
    assert at_header >= 0.3 and at_half <= 0.07
    assert check.fps == motion.fps


@pytest.mark.parametrize("clip", [
    "cmu_02_01_walk.bvh", "cmu_16_11_walk_veer_left.bvh", "cmu_141_16_wave_hello.bvh",
    "cmu_02_10_wash_self_cc3rig.bvh", "cmu_05_06_dance_pirouettes_jete.bvh",
    "bandai_nc_dataset-1_kick_normal_001.bvh", "bandai_nc_dataset-2_run_normal_001.bvh",
    "cmu_07_05.amc",
])
def test_clips_at_their_capture_rate_keep_it(clip):
    """Walks, a wave, a wash, a leap dance, a kick and a run: the ZMP near the feet (a leap's
    flight frames are not counted), the header's rate kept."""
    motion = load_motion(mocap(clip))
    header = {"cmu_02_10_wash_self_cc3rig.bvh": 60.0}.get(clip, 120.0)
    if clip.startswith("bandai"):
        header = 30.0
    assert motion.fps == pytest.approx(header, rel=1e-3)
    assert "header_fps" not in motion.meta
    fraction = off_balance_fraction(to_standard(motion), motion.fps, TimingConfig())
    assert fraction < 0.15


def test_a_walk_played_twice_as_fast_is_off_balance():
    """The same veer at twice its rate puts the ZMP off the feet in a fifth of the frames (0.4 %
    at its rate): the figure sees speed, and the rule's quarter leaves such a clip alone."""
    veer = to_standard(load_motion(mocap("cmu_16_11_walk_veer_left.bvh")))
    config = TimingConfig()
    assert off_balance_fraction(veer, veer.fps, config) < 0.01
    fast = off_balance_fraction(veer, 2 * veer.fps, config)
    assert 0.15 < fast < config.header_fraction


def test_a_given_rate_replaces_the_header_without_the_check():
    salsa = load_motion(mocap(SALSA[0]), fps=120.0048)
    assert salsa.fps == 120.0048 and "fps_reason" not in salsa.meta
    walk = load_motion(mocap("cmu_02_01_walk.bvh"), fps=60.0)
    assert walk.fps == 60.0
    assert walk.meta["header_fps"] == pytest.approx(120.0, rel=1e-3)
    with pytest.raises(MotionFileError, match="frame rate"):
        load_motion(mocap("cmu_02_01_walk.bvh"), fps=0.0)


def test_short_clips_and_gaps_keep_the_header():
    walk = load_motion(mocap("cmu_02_01_walk.bvh"))
    short = walk.frames(0, int(1.5 * walk.fps))
    assert check_timing(dataclasses.replace(short, fps=2 * walk.fps)).fps == 2 * walk.fps
    valid = np.array(walk.valid)
    valid[10, 0] = False
    gappy = dataclasses.replace(walk, valid=valid)
    assert "gaps" in check_timing(gappy).reason


def test_timing_config_is_validated():
    with pytest.raises(OptionError):
        TimingConfig(factors=(0.5,))
    with pytest.raises(OptionError):
        TimingConfig(reach_fraction=-1.0)

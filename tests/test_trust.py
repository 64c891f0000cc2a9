"""The whole-body SQP's trust region (imesh.solve.trust): the update rules on known steps."""

from __future__ import annotations

import numpy as np
import pytest

from imesh.solve import SqpOptions
from imesh.solve.trust import TrustRegion, nominal_radii


def _region(scale: np.ndarray) -> TrustRegion:
    start = TrustRegion.start(SqpOptions(), *scale.shape)
    return TrustRegion(start.radii, scale, None, start.reversals)


def test_nominal_radii_hold_the_base_translation_tighter():
    radii = nominal_radii(SqpOptions(), 8)
    np.testing.assert_allclose(radii[:3], 0.3 * 0.2)
    np.testing.assert_allclose(radii[3:], 0.3)
    region = TrustRegion.start(SqpOptions(), 4, 8)
    np.testing.assert_allclose(region.radius, np.tile(radii, (4, 1)))
    assert region.largest == 0.3


def test_a_whole_step_doubles_the_radii_up_to_their_nominal_values():
    scale = np.array([[0.25, 0.5, 1.0, 0.75, 0.1, 0.3, 0.6, 0.9]])
    out = _region(scale).follow(np.zeros_like(scale), 1.0, 1e-4, True)
    np.testing.assert_allclose(out.scale, [[0.5, 1.0, 1.0, 1.0, 0.2, 0.6, 1.0, 1.0]])
    np.testing.assert_allclose(out.shrink().scale, 0.25 * out.scale)


def test_a_step_taken_in_part_bounds_the_radii_to_twice_that_part_near_the_footprints():
    """The G1 walk's tail (soles on their footprints): 1/8 of a 0.053 rad step taken; the next
    QP's region is 2/8 of it; so with the soles 4.9 mm off (the JVRC-1 wash's 2 mm). Far from
    the footprints (the G1 veer's first iterations, soles 180 mm off), 5.1 mm off, or with a
    swing foot below its clearance, the part taken bounds nothing."""
    region = _region(np.ones((3, 8)))
    dq = np.zeros((3, 8))
    dq[1, 5] = 0.053
    dq[2, 0] = 0.001  # the base: 1/60 of its radius
    np.testing.assert_allclose(region.follow(dq, 0.125, 1e-4, True).scale,
                               2 * 0.125 * 0.053 / 0.3)
    np.testing.assert_allclose(region.follow(dq, 0.125, 4.9e-3, True).scale,
                               2 * 0.125 * 0.053 / 0.3)
    for sole_error_m, clear in ((0.18, True), (5.1e-3, True), (1e-4, False)):
        np.testing.assert_allclose(region.follow(dq, 0.125, sole_error_m, clear).scale, 1.0)
    # half a step at the radius leaves the region as it was
    dq[1, 5] = 0.3
    np.testing.assert_allclose(region.follow(dq, 0.5, 1e-4, True).scale, 1.0)


def test_a_coordinate_bouncing_between_its_radii_halves_alone():
    """The JVRC-1 veer's knee: +0.3, -0.3, +0.3 rad at the radius on successive iterations
    (half taken each time), and the G1 veer's, 0.17-0.23 rad back and forth: the second
    reversal halves that coordinate of that frame alone. One reversal (an overshoot
    corrected), one reversed at less than half its radius (a joint limit nearer than that)
    and one at its radius in the same direction keep theirs."""
    region = _region(np.ones((2, 8)))
    steps = np.zeros((3, 2, 8))
    steps[:, 0, 6] = 0.3, -0.3, 0.3  # bounced twice
    steps[:, 1, 6] = 0.3, -0.1, 0.1  # reversed at a third of its radius
    steps[:, 1, 5] = 0.17, -0.2, 0.19  # bounced twice at 0.57-0.67 of its radius
    steps[:, 0, 7] = 0.3, 0.3, 0.3  # at its radius, same direction
    steps[:, 1, 7] = 0.3, 0.3, -0.3  # reversed once
    after = []
    for dq in steps:
        region = region.follow(dq, 0.5, 0.18, True)
        after.append(region.scale.copy())
    np.testing.assert_allclose(after[1], 1.0)
    expected = np.ones((2, 8))
    expected[0, 6] = expected[1, 5] = 0.5
    np.testing.assert_allclose(after[2], expected)
    # a third reversal at the halved radius halves it again
    region = region.follow(-0.5 * steps[2], 0.5, 0.18, True)
    assert region.scale[0, 6] == pytest.approx(0.25)
    assert region.reversals[0, 6] == 3


def test_a_frame_in_collision_has_its_radii_capped():
    """``SqpOptions.collision_trust`` (0.1) caps every radius of the frames in self-collision
    (salsa A on G1: the arms of one frame moved 0.12-0.3 rad at every iteration with the hands
    40-56 mm into each other); the base's 0.06 m stay, the other frames keep 0.3 rad, and a
    cap of 0 leaves every radius."""
    region = TrustRegion.start(SqpOptions(), 4, 8)
    frames = np.array([False, True, False, True])
    radius = region.capped(frames, SqpOptions().collision_trust)
    np.testing.assert_allclose(radius[frames][:, :3], 0.06)
    np.testing.assert_allclose(radius[frames][:, 3:], 0.1)
    np.testing.assert_allclose(radius[~frames], region.radius[~frames])
    np.testing.assert_allclose(region.capped(frames, 0.0), region.radius)
    np.testing.assert_allclose(region.radius[:, 3:], 0.3)  # the region itself unchanged

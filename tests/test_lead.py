"""The standing lead-in and lead-out around a clip (imesh.solve.add_lead)."""

from __future__ import annotations

import numpy as np
import pytest

from imesh.solve import add_lead


def _clip(first_down: int, last_down: int, T: int = 20) -> np.ndarray:
    """(T, 2) support: the right foot always down, the left down from ``first_down`` to
    ``last_down`` (inclusive)."""
    support = np.zeros((T, 2), bool)
    support[:, 1] = True
    support[first_down:last_down + 1, 0] = True
    return support


def _lead(support: np.ndarray, land_frames: int):
    T = len(support)
    return add_lead(np.zeros((T, 7)), np.zeros((T, 1, 3)), support, 10, 10, step_frames=4,
                    land_frames=land_frames)


def test_a_swing_ending_at_the_clips_start_stands_through():
    """The left foot lands 2 frames into the clip (the CMU walk): with land_frames >= 2 it
    stands from the lead-in through its landing; both feet carry the robot in every lead
    frame, so no step is taken out of the lead-in."""
    lead = _lead(_clip(2, 19), land_frames=4)
    assert lead.support[:12].all()  # 10 lead-in frames + the 2 clip frames before landing
    assert lead.support[10 + 20:].all()


def test_a_swing_far_from_the_clips_start_steps_out_of_the_lead():
    """The left foot lands 6 frames into the clip, beyond land_frames: it lifts over the
    lead-in's last step_frames (4) frames and swings into the clip as it has it."""
    lead = _lead(_clip(6, 19), land_frames=4)
    left = lead.support[:, 0]
    assert left[:6].all() and not left[6:16].any() and left[16:].all()


@pytest.mark.parametrize("land", [0, 3])
def test_a_lift_at_the_clips_end(land):
    """The left foot lifts 3 frames before the clip's end: with land_frames 3 it stays down
    into the lead-out, with 0 it swings over the lead-out's first 4 frames."""
    lead = _lead(_clip(0, 16), land_frames=land)
    left = lead.support[:, 0]
    if land:
        assert left.all()
    else:
        assert left[:10 + 17].all() and not left[27:34].any() and left[34:].all()

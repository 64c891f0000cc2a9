"""Support-foot constraints for the morph (Nakaoka & Komura 2012, sec. V-B).

During a support phase the foot markers (toe and ankle) get hard positional constraints:

- vertical: the height of the matching robot key point when the robot stands flat (its sole at
  z = 0), reached gradually over the morph steps (hard targets are interpolated from the
  source to these values);
- horizontal: the phase mean of the source foot (no skating), unless the source foot really
  slides during the phase (travel above ``slide_threshold_m``), with the toe-ankle vector
  shortened or lengthened to the robot's foot so the targets agree with the bone. These are
  *soft* targets with a large weight: in double support the robot's legs (other proportions,
  other hip width) cannot always reach two pinned human footprints exactly, and a hard
  constraint there would make the morph infeasible; the weight keeps the slip sub-millimetre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contacts import FOOT_MARKERS, SIDES, Contacts
from .motion import MarkerMotion


@dataclass(frozen=True)
class SupportConfig:
    """Attributes:
        horizontal: also pin the support foot horizontally (no skating).
        slide_threshold_m: a source foot travelling more than this during a support phase is
            sliding for real and keeps its horizontal motion.
        horizontal_weight: weight of the soft horizontal targets (the Laplacian rows weigh ~1).
    """

    horizontal: bool = True
    slide_threshold_m: float = 0.05
    horizontal_weight: float = 1e3


def support_foot_targets(motion: MarkerMotion, contacts: Contacts,
                         foot_heights_m: dict[str, float], foot_lengths_m: dict[str, float],
                         config: SupportConfig | None = None
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positional targets for the support feet.

    Args:
        motion: the (arranged, scaled) source motion with toe_* and ankle_* markers.
        contacts: support phases.
        foot_heights_m: marker name (toe_l, ankle_l, ...) -> height of its robot key point above
            the floor when the robot stands flat [m].
        foot_lengths_m: side -> robot toe-ankle distance [m].
        config: SupportConfig.

    Returns:
        (hard (T, M, 3) vertical targets, soft (T, M, 3) horizontal targets, soft weights
        (T, M)); NaN where free.
    """
    config = config or SupportConfig()
    targets = np.full(motion.positions_m.shape, np.nan)
    soft = np.full(motion.positions_m.shape, np.nan)
    weights = np.zeros(motion.positions_m.shape[:2])
    for side in SIDES:
        toe_name, ankle_name = FOOT_MARKERS[side]
        toe, ankle = motion.index(toe_name), motion.index(ankle_name)
        h_toe, h_ankle = foot_heights_m[toe_name], foot_heights_m[ankle_name]
        horizontal_len = np.sqrt(max(foot_lengths_m[side] ** 2 - (h_toe - h_ankle) ** 2, 0.0))
        for start, stop in contacts.phases(side):
            sl = slice(start, stop)
            targets[sl, toe, 2] = h_toe
            targets[sl, ankle, 2] = h_ankle
            if not config.horizontal:
                continue
            p_toe = motion.positions_m[sl, toe, :2]
            travel = np.linalg.norm(p_toe - p_toe[0], axis=1).max()
            if travel > config.slide_threshold_m:
                continue
            toe_xy = p_toe.mean(axis=0)
            back = motion.positions_m[sl, ankle, :2].mean(axis=0) - toe_xy
            norm = np.linalg.norm(back)
            back = back / norm if norm > 1e-9 else np.array([-1.0, 0.0])
            soft[sl, toe, :2] = toe_xy
            soft[sl, ankle, :2] = toe_xy + horizontal_len * back
            weights[sl, [toe, ankle]] = config.horizontal_weight
    return targets, soft, weights

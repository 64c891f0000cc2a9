"""One world for two people arranged for two robots.

:func:`imesh.human.arrange.arrange_for_robot` scales a person to its robot about the floor
point under the person's centroid at frame 0, by the robot's legs over the person's. Two
partners scaled so, each about its own point and by its own factor, would no longer stand
where they stood relative to each other: their hands would not meet. So both are scaled by one
factor about one point: the geometric mean ``s = sqrt(s_a s_b)`` of the two robots' factors
(for two robots of one model, each one's own factor: the arrangement alone is unchanged but
for the fixed point) about the floor point under the midpoint of the two centroids at frame 0.
The morph then takes each person's bones to its own robot's lengths
(Nakaoka & Komura 2012, eq. 3-4) while the mesh keeps the relations between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..human.arrange import arrange_for_robot


@dataclass(frozen=True)
class SharedWorld:
    """The arrangement's common scale and fixed point of two partners.

    Attributes:
        scale: the human-to-robot factor both people get.
        centre_m: (3,) [m] the fixed point of the scaling (on the floor, z = 0).
        own_scales: (2,) each robot's own factor (its legs over its person's).
    """

    scale: float
    centre_m: np.ndarray
    own_scales: tuple[float, float]


def shared_world(human_a: MarkerMotion, human_b: MarkerMotion, robot_a, robot_b) -> SharedWorld:
    """The common scale and fixed point of two people's working markers (see the module)."""
    own = (arrange_for_robot(human_a, robot_a).scale, arrange_for_robot(human_b, robot_b).scale)
    centre = 0.5 * (human_a.positions_m[0].mean(axis=0) + human_b.positions_m[0].mean(axis=0))
    return SharedWorld(scale=float(np.sqrt(own[0] * own[1])), centre_m=centre * [1.0, 1.0, 0.0],
                       own_scales=own)

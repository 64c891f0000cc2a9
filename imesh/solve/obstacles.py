"""Moving obstacles in the whole-body solve: another robot's capsules (a dance partner,
:mod:`imesh.partners`), given per frame (:class:`imesh.robot.capsules.obstacles.Obstacles`:
their signed distances to the robot's capsules and the distances' gradients).

As props (:mod:`imesh.solve.props`) the samples within the activation distance become rows
``d + grad d . dq_t + s_t >= margin`` elastic with the frame's self-collision slack, and the
merit charges the frame's largest shortfall of any kind.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..robot.capsules.model import CapsuleModel
from ..robot.capsules.obstacles import Obstacles, capsule_obstacle_distances, obstacle_rows


@dataclass(frozen=True, eq=False)
class ObstacleLinearization:
    """The obstacle samples of one iterate (the
    :class:`~imesh.solve.collision.DistanceRows` protocol).

    Attributes:
        frames: (R,) frame of each active sample; capsules, obstacles: (R,) its robot capsule
            and obstacle.
        distance: (R,) [m] signed distance; rows: (R, nv) its gradient in dq_t.
        min_distance: (T,) [m] smallest signed distance per frame (+inf beyond the broad
            phase).
    """

    frames: np.ndarray
    capsules: np.ndarray
    obstacles: np.ndarray
    distance: np.ndarray
    rows: np.ndarray
    min_distance: np.ndarray


def linearize_obstacles(model: CapsuleModel, placements: np.ndarray, jacobians: np.ndarray,
                        obstacles: Obstacles, activation: float) -> ObstacleLinearization:
    """Exact distances of the robot's capsules to the obstacles, and the rows of the samples
    closer than ``activation`` [m] (see the module docstring).

    Args:
        model: the robot's capsules.
        placements: (T, F, 4, 4) world placements of ``model.frames``.
        jacobians: (T, F, 6, nv) their world-aligned Jacobians.
        obstacles: the obstacles over the same T frames.
    """
    T = placements.shape[0]
    tt, cc, oo, dist, n, point = capsule_obstacle_distances(
        model.world_segments(placements), model.radius, obstacles, activation)
    low = np.full(T, np.inf)
    np.minimum.at(low, tt, dist)
    act = dist < activation
    tt, cc, oo, dist, n, point = tt[act], cc[act], oo[act], dist[act], n[act], point[act]
    return ObstacleLinearization(frames=tt, capsules=cc, obstacles=oo, distance=dist,
                                 rows=obstacle_rows(model, placements, jacobians, tt, cc, n,
                                                    point), min_distance=low)

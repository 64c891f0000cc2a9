"""Moving obstacles for a robot's capsules: another robot's capsules (a dance partner,
:mod:`imesh.partners`), given per frame, and their signed distances to the robot's.

An obstacle is a capsule (segment ``a_t - b_t``, radius ``r_o``) whose ends move with the
frame t and do not depend on the robot's configuration. The signed distance of the robot's
capsule c (segment ``p_t(q) - q_t(q)``, radius ``r_c``) to it is

    d_co(q_t) = |x_c - x_o| - r_c - r_o,

with ``x_c``, ``x_o`` the closest points of the two segments (Ericson 5.1.9,
:func:`.model.segment_closest_points`) and ``n = (x_c - x_o) / |x_c - x_o|``. Only the robot's
side moves, so its gradient is the first half of the self-collision row of
:func:`.model.sample_rows`: ``n^T (J_o + J_w x (x_c - o))`` of the capsule's frame (origin o)
(:func:`obstacle_rows`). The whole-body solve makes rows of it (:mod:`imesh.solve.obstacles`),
the initial fit a penalty (:mod:`imesh.fit.collision`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import CapsuleModel, segment_closest_points


@dataclass(frozen=True, eq=False)
class Obstacles:
    """Capsules moving with the frames, in the robot's world.

    Attributes:
        segments_m: (T, O, 2, 3) [m] end points of each obstacle capsule per frame.
        radius_m: (O,) [m] their radii.
        ignored: (T, C, O) bool samples (robot capsule c, obstacle o) not checked at frame t
            (a contact meant to be: two partners' held hands), or None.
    """

    segments_m: np.ndarray
    radius_m: np.ndarray
    ignored: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        return len(self.segments_m)

    def frames(self, start: int, stop: int) -> Obstacles:
        """The frames [start, stop) (a window of the solve, the clip's frames of the fit)."""
        return Obstacles(segments_m=self.segments_m[start:stop], radius_m=self.radius_m,
                         ignored=None if self.ignored is None else self.ignored[start:stop])


def capsule_obstacle_distances(seg_world: np.ndarray, radius: np.ndarray,
                               obstacles: Obstacles, cutoff: float
                               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                          np.ndarray, np.ndarray]:
    """Signed distances of every capsule to every obstacle at every frame whose bounding
    spheres (segment midpoint, half length plus radius) are closer than ``cutoff`` [m].

    Args:
        seg_world: (T, C, 2, 3) [m] the robot's capsule segments; radius: (C,) [m].
        obstacles: the obstacles over the same T frames.

    Returns:
        (tt, cc, oo) (N,) the frame, capsule and obstacle of each computed sample; distance
        (N,) [m]; normal (N, 3) unit, from the obstacle's closest point to the capsule's;
        point (N, 3) [m] the capsule's closest point.
    """
    obs = obstacles.segments_m
    mid_c, mid_o = seg_world.mean(axis=2), obs.mean(axis=2)
    bound_c = np.linalg.norm(seg_world[:, :, 1] - seg_world[:, :, 0], axis=-1) / 2 + radius
    bound_o = np.linalg.norm(obs[:, :, 1] - obs[:, :, 0], axis=-1) / 2 + obstacles.radius_m
    gap = (np.linalg.norm(mid_c[:, :, None] - mid_o[:, None], axis=-1)
           - bound_c[:, :, None] - bound_o[:, None])  # (T, C, O)
    near = gap < cutoff
    if obstacles.ignored is not None:
        near &= ~obstacles.ignored
    tt, cc, oo = np.nonzero(near)
    xc, xo = segment_closest_points(seg_world[tt, cc, 0], seg_world[tt, cc, 1],
                                    obs[tt, oo, 0], obs[tt, oo, 1])
    diff = xc - xo
    norm = np.linalg.norm(diff, axis=-1)
    n = diff / np.maximum(norm, 1e-12)[:, None]
    n[norm < 1e-9] = [0.0, 0.0, 1.0]  # crossing axes: any direction; the next iterate moves
    dist = norm - radius[cc] - obstacles.radius_m[oo]
    return tt, cc, oo, dist, n, xc


def obstacle_rows(model: CapsuleModel, placements: np.ndarray, jacobians: np.ndarray,
                  tt: np.ndarray, cc: np.ndarray, normal: np.ndarray, point: np.ndarray
                  ) -> np.ndarray:
    """(R, nv) gradients ``dd/dv`` of the samples (frame ``tt``, robot capsule ``cc``, unit
    ``normal`` and closest ``point`` from :func:`capsule_obstacle_distances`).

    Args:
        model: the robot's capsules.
        placements: (T, F, 4, 4) world placements of ``model.frames``.
        jacobians: (T, F, 6, nv) their world-aligned Jacobians.
    """
    nv = jacobians.shape[-1]
    f = model.frame_index[cc]
    J = jacobians[tt, f]  # (R, 6, nv)
    lever = np.cross(point - placements[tt, f, :3, 3], normal)  # n . (w x r) = w . (r x n)
    rows = (np.einsum("ra,ran->rn", normal, J[:, :3])
            + np.einsum("ra,ran->rn", lever, J[:, 3:]))
    return rows.reshape(-1, nv)


def robot_obstacles(robot, q: np.ndarray) -> Obstacles:
    """A robot's capsules (:meth:`imesh.robot.Robot.capsule_model`) over its motion ``q``
    (T, nq), as obstacles for another robot's solve."""
    model = robot.capsule_model()
    placements = np.stack([robot.frame_placements(qt, model.frames) for qt in q])
    return Obstacles(segments_m=model.world_segments(placements), radius_m=model.radius.copy())

"""Self-collision in the per-frame fit: a penalty that keeps the robot's capsules apart.

The whole-body solve keeps the capsules apart with rows linearized at its iterate
(:mod:`imesh.solve.collision`), so it keeps the *topology* of the fit it starts from: where the
fit lets one hand pass through the other (the scaled person's hands cross where the robot's,
larger, cannot), the solve's rows at the crossing frame point along the sweep, and moving the
frame back or ahead of its neighbours breaks the acceleration limits; the hands stay through
each other. Fitted frame by frame from a warm start, a penalty instead stops the hand at the
other's surface in the frame the two meet and lets it continue from there, so the fit arrives
at the solve with its frames apart (salsa A on G1: capsule contacts deeper than 5 mm in 21 of
598 fitted frames instead of 546; docs/fitting.md).

Each checked capsule pair (:meth:`imesh.robot.Robot.capsule_model`) closer than ``margin``
adds a residual ``w (margin - d(q))`` to the frame's least squares (eq. 7 of Nakaoka &
Komura 2012 with these rows appended to ``W e``; ``w`` = ``FitConfig.collision_weight``), its
row ``w dd/dq`` the signed distance's gradient (:func:`imesh.robot.capsules.model.sample_rows`).
The penalty is C1 (zero with zero slope at the margin), so the damped Gauss-Newton iteration
of :func:`imesh.fit.dls.solve_frame` converges on it as on the key points.

Moving obstacles (a dance partner's capsules over its solved motion,
:class:`imesh.robot.capsules.obstacles.Obstacles`) get the same penalty: each robot capsule
closer than ``margin`` to an obstacle at the frame adds ``w (margin - d_co(q))``, its row
``w dd_co/dq`` (:func:`imesh.robot.capsules.obstacles.obstacle_rows`). The second robot of a
pair is fitted clear of the first, as the whole-body solve, which keeps the topology of the
fit it starts from, then keeps it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..robot.capsules.model import CapsuleModel, sample_rows
from ..robot.capsules.obstacles import Obstacles, capsule_obstacle_distances, obstacle_rows


@dataclass(frozen=True, eq=False)
class CollisionPenalty:
    """The capsule pairs the fit keeps apart, and the obstacles it keeps the capsules from.

    Attributes:
        robot: the ``imesh.robot.Robot``.
        model: its capsules and checked pairs.
        frame_ids: the robot's frame index of each of ``model.frames``.
        weight: w [weighted-residual units per metre of shortfall].
        margin: [m] the signed distance below which a pair is penalized.
        obstacles: capsules moving over the fitted frames (a partner's), or None.
    """

    robot: Any
    model: CapsuleModel
    frame_ids: list[int]
    weight: float
    margin: float
    obstacles: Obstacles | None = None

    @classmethod
    def build(cls, robot, weight: float, margin: float,
              obstacles: Obstacles | None = None) -> CollisionPenalty | None:
        """The robot's penalty, or None (weight 0, or a robot without checked pairs and no
        obstacles)."""
        if weight <= 0.0:
            return None
        model = robot.capsule_model()
        if not len(model.pairs) and obstacles is None:
            return None
        return cls(robot=robot, model=model,
                   frame_ids=[robot.frame_id(f) for f in model.frames], weight=weight,
                   margin=margin, obstacles=obstacles)

    def residual(self, q: np.ndarray, frame: int | None = None) -> tuple[np.ndarray, tuple]:
        """(R,) residuals ``w (margin - d)`` of the pairs closer than the margin at ``q``
        (nq,), then those of the capsules closer than it to an obstacle at fitted frame
        ``frame`` (None: no obstacle), and what :meth:`rows` needs to differentiate them at
        the same q."""
        placements = self.robot.frame_placements(q, self.frame_ids)[None]
        dist = self.model.distances(placements, cutoff=self.margin)
        tt, pp = np.nonzero(dist.distance < self.margin)
        res = self.weight * (self.margin - dist.distance[tt, pp])
        near = None
        if self.obstacles is not None and frame is not None:
            _, cc, _, d_o, normal, point = capsule_obstacle_distances(
                self.model.world_segments(placements), self.model.radius,
                self.obstacles.frames(frame, frame + 1), self.margin)
            close = d_o < self.margin
            near = (cc[close], normal[close], point[close])
            res = np.concatenate([res, self.weight * (self.margin - d_o[close])])
        return res, (placements, tt, pp, dist, near)

    def rows(self, q: np.ndarray, state: tuple) -> np.ndarray:
        """(R, nv) rows ``w dd/dv`` of :meth:`residual`'s pairs and obstacle samples
        (``state`` from it, same q)."""
        placements, tt, pp, dist, near = state
        n_obs = 0 if near is None else len(near[0])
        if not len(tt) and not n_obs:
            return np.zeros((0, self.robot.nv))
        jacobians = self.robot.frame_jacobians(q, self.frame_ids)[None]
        rows = [sample_rows(self.model, placements, jacobians, tt, pp, dist)]
        if n_obs:
            cc, normal, point = near
            rows.append(obstacle_rows(self.model, placements, jacobians,
                                      np.zeros(n_obs, dtype=np.int64), cc, normal, point))
        return self.weight * np.vstack(rows)

"""Convex hulls of the robot's bodies: a tighter bound of the geometry's distance than the
capsules', which the whole-body solve uses where the capsules come close (docs/collision.md).

A body's hull is the convex hull of the geometry its capsules enclose (the points of
:func:`imesh.robot.capsules.bodies.body_points`, in the body frame). It encloses the geometry, so
for two bodies ``A`` and ``B``

    d_capsules(A, B) <= d_hulls(A, B) <= d_geometry(A, B)

when they are apart (the capsules enclose the same points; ``d_capsules`` is the least over the
bodies' capsule pairs). The first inequality is what a capsule that bulges beyond a box-shaped
link gives away (Talos's hip-yaw housings: -17.5 mm on the capsules in the CMU wash's stance,
+47.6 mm on the meshes, +40.6 mm on the hulls); the second keeps a motion whose hulls are apart
clear on the geometry :func:`imesh.metrics.collision.check_self_collisions` scores. Hulls that
intersect give their penetration depth (GJK/EPA, coal), as the mesh check does for meshes.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from ...core.lazy import optional

if TYPE_CHECKING:  # pragma: no cover - typing only
    from .model import CapsuleModel


def hull_vertices(points: np.ndarray) -> np.ndarray:
    """(V, 3) vertices of the convex hull of (P, 3) points [m] (all of them when they span no
    volume)."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return np.ascontiguousarray(points[ConvexHull(points).vertices])
    except (QhullError, ValueError):
        return np.ascontiguousarray(points)


class BodyHulls:
    """Signed distances between the convex hulls of body pairs (coal GJK/EPA).

    Args:
        vertices: body -> (V, 3) [m] hull vertices in the body's frame (the frame its capsules
            are expressed in).
    """

    def __init__(self, vertices: Mapping[str, np.ndarray]):
        coal = optional("coal", "pip install pin", "the convex-hull distances of the bodies")
        self._coal = coal
        self._request = coal.DistanceRequest()
        self.hulls = {}
        for body, v in vertices.items():
            pts = coal.StdVec_Vec3s()
            pts.extend(np.asarray(v, dtype=float))
            self.hulls[body] = coal.Convex.convexHull(pts, False, "")

    def distances(self, placements_a: np.ndarray, placements_b: np.ndarray,
                  bodies_a: list[str], bodies_b: list[str]) -> np.ndarray:
        """(R,) [m] signed distance of hull ``bodies_a[r]`` placed at ``placements_a[r]`` and
        hull ``bodies_b[r]`` at ``placements_b[r]`` ((R, 4, 4) world placements of the body
        frames); negative: the hulls' penetration depth."""
        coal = self._coal
        out = np.empty(len(bodies_a))
        for r, (Ma, Mb, a, b) in enumerate(zip(placements_a, placements_b, bodies_a, bodies_b,
                                               strict=True)):
            out[r] = coal.distance(self.hulls[a], coal.Transform3s(Ma[:3, :3], Ma[:3, 3]),
                                   self.hulls[b], coal.Transform3s(Mb[:3, :3], Mb[:3, 3]),
                                   self._request, coal.DistanceResult())
        return out

    def pair_distances(self, model: CapsuleModel, placements: np.ndarray, frames: np.ndarray,
                       body_pairs: np.ndarray) -> np.ndarray:
        """(R,) [m] the hull distance of body pair ``model.body_pairs[body_pairs[r]]`` at time
        ``frames[r]`` of ``placements`` ((T, F, 4, 4) world placements of ``model.frames``)."""
        fa, fb = model.body_pair_frames[body_pairs].T
        return self.distances(placements[frames, fa], placements[frames, fb],
                              [model.body_pair_bodies[k][0] for k in body_pairs],
                              [model.body_pair_bodies[k][1] for k in body_pairs])

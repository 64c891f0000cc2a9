"""Signed distances of the URDF's own geometry between the bodies the capsules stand for (coal,
the library pinocchio loads the geometry with), to validate the capsules and to score motions
on the real geometry (:func:`imesh.metrics.collision.check_mesh_collisions`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ...core.lazy import optional
from ..collision import pair_key
from .bodies import robot_bodies
from .model import CapsuleModel
from .pairs import capsule_source

if TYPE_CHECKING:  # pragma: no cover - typing only (the Robot uses this package)
    from ..model import Robot

if TYPE_CHECKING:  # pragma: no cover - typing only (the Robot uses this package)
    pass


class MeshCollisionChecker:
    """Signed distances between the URDF's own geometry of body pairs (coal, the library
    pinocchio loads the geometry with): its collision elements, or its visual meshes for a
    robot whose ``collision_pairs.toml`` says ``source = "visual"`` (HRP-4C). URDF primitives
    are exact. Meshes: the distance between the triangle meshes themselves (coal's BVH
    distance, exact) when they are apart; when they intersect, the penetration depth of their
    convex hulls (GJK/EPA, an upper bound of the meshes' depth). Pairs are the robot's checked
    capsule pairs (same bodies, same ignore list).

    Args:
        robot: an :class:`imesh.robot.Robot`.
        ignored: body pairs not checked (default: the capsules' ignore list).
    """

    def __init__(self, robot: Robot, ignored: set[tuple[str, str]] | None = None):
        self._coal = optional("coal", "pip install pin", "a collision check on the meshes")
        self.robot = robot
        #: the robot's capsule model when its ignore list is used, else None
        self.model: CapsuleModel | None
        if ignored is None:
            self.model = robot.capsule_model()
            ignored = self.model.ignored
        else:
            self.model = None
        links, _ = robot_bodies(robot)
        geometry = robot.link_geometry()
        #: "collision" (the URDF's collision elements) or "visual" (its visual meshes, for a
        #: robot whose capsules are fitted to them: HRP-4C's collision boxes are much larger
        #: than its links and overlap in the standing pose, docs/collision.md)
        self.source = capsule_source(robot)
        # body -> [(link, placement in link, exact geometry, convex geometry)]
        self.items: dict[str, list[tuple[str, np.ndarray, object, object]]] = {}
        for body, members in links.items():
            for link in members:
                for it in geometry[link][self.source] or geometry[link]["collision"]:
                    geo = it.native
                    if geo is None:
                        continue
                    hull = geo
                    if type(geo).__name__.startswith("BVHModel"):
                        if geo.convex is None:
                            geo.buildConvexHull(True, "Qt")
                        hull = geo.convex
                    self.items.setdefault(body, []).append((link, it.placement, geo, hull))
        self.frames = list(dict.fromkeys(i[0] for v in self.items.values() for i in v))
        bodies = sorted(self.items)
        self.pairs = [(a, b) for k, a in enumerate(bodies) for b in bodies[k + 1:]
                      if pair_key(a, b) not in ignored]
        self._request = self._coal.DistanceRequest()

    def distances(self, q: np.ndarray, pairs=None) -> dict[tuple[str, str], float]:
        """Signed distance [m] of each body pair at ``q`` (minimum over their geometry;
        negative = penetration depth)."""
        coal = self._coal
        M = dict(zip(self.frames, self.robot.frame_placements(q, self.frames), strict=True))
        out = {}

        def tf(T):
            return coal.Transform3s(T[:3, :3], T[:3, 3])

        for a, b in (self.pairs if pairs is None else pairs):
            best = np.inf
            for la, Pa, ga, ha in self.items[a]:
                ta = tf(M[la] @ Pa)
                for lb, Pb, gb, hb in self.items[b]:
                    tb = tf(M[lb] @ Pb)
                    d = float(coal.distance(ga, ta, gb, tb, self._request,
                                            coal.DistanceResult()))
                    if d <= 0.0 and (ga is not ha or gb is not hb):  # meshes intersect
                        d = min(0.0, float(coal.distance(ha, ta, hb, tb, self._request,
                                                         coal.DistanceResult())))
                    best = min(best, d)
            out[(a, b)] = best
        return out

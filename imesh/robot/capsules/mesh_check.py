"""Signed distances of the URDF's own geometry between the bodies the capsules stand for (coal,
the library pinocchio loads the geometry with): the geometry self-collisions are scored on
(:func:`imesh.metrics.collision.check_self_collisions`) and the capsules are validated against."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ...core.lazy import optional
from ..collision import pair_key
from .bodies import link_items, robot_bodies
from .model import CapsuleModel
from .pairs import capsule_source

if TYPE_CHECKING:  # pragma: no cover - typing only (the Robot uses this package)
    from ..model import Robot


class MeshCollisionChecker:
    """Signed distances between the URDF's own geometry of body pairs (coal): per link the
    geometry its capsules enclose (:func:`imesh.robot.capsules.bodies.link_items`: its collision
    elements; its visual meshes for a robot whose ``collision_pairs.toml`` says
    ``source = "visual"`` (HRP-4C), for links in ``collision.use_visual`` (G1's feet) and for
    links without collision elements (G1's waist)). URDF primitives are exact. Meshes: the
    distance between the triangle meshes themselves (coal's BVH distance, exact) when they are
    apart; when they intersect, the penetration depth of their convex hulls (GJK/EPA, an upper
    bound of the meshes' depth, and still enclosed by the capsules). Pairs are the robot's
    checked capsule pairs (same bodies, same ignore list).

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
        #: "collision" or "visual" (HRP-4C: its collision boxes are much larger than its links
        #: and overlap in the standing pose, docs/collision.md)
        self.source = capsule_source(robot)
        #: the link frames that carry geometry (the placements :meth:`pair_distance` takes)
        self.frames: list[str] = []
        # body -> [(index in frames, placement in link, exact geometry, convex geometry)]
        self.items: dict[str, list[tuple[int, np.ndarray, object, object]]] = {}
        for body, members in links.items():
            for link in members:
                for it in link_items(robot, link):
                    geo = it.native
                    if geo is None:
                        continue
                    hull = geo
                    if type(geo).__name__.startswith("BVHModel"):
                        if geo.convex is None:
                            geo.buildConvexHull(True, "Qt")
                        hull = geo.convex
                    if link not in self.frames:
                        self.frames.append(link)
                    self.items.setdefault(body, []).append(
                        (self.frames.index(link), it.placement, geo, hull))
        bodies = sorted(self.items)
        #: the body pairs checked (sorted names)
        self.pairs = [(a, b) for k, a in enumerate(bodies) for b in bodies[k + 1:]
                      if pair_key(a, b) not in ignored]
        self._request = self._coal.DistanceRequest()

    def pair_distance(self, placements: np.ndarray, pair: tuple[str, str]) -> float:
        """Signed distance [m] of one body pair (minimum over their geometry; negative =
        penetration depth), with the link frames at ``placements`` ((F, 4, 4) float, world
        placements of :attr:`frames`)."""
        coal = self._coal
        a, b = pair
        best = np.inf
        for fa, Pa, ga, ha in self.items[a]:
            Ma = placements[fa] @ Pa
            ta = coal.Transform3s(Ma[:3, :3], Ma[:3, 3])
            for fb, Pb, gb, hb in self.items[b]:
                Mb = placements[fb] @ Pb
                tb = coal.Transform3s(Mb[:3, :3], Mb[:3, 3])
                d = float(coal.distance(ga, ta, gb, tb, self._request, coal.DistanceResult()))
                if d <= 0.0 and (ga is not ha or gb is not hb):  # meshes intersect
                    d = min(0.0, float(coal.distance(ha, ta, hb, tb, self._request,
                                                     coal.DistanceResult())))
                best = min(best, d)
        return best

    def distances(self, q: np.ndarray, pairs: Sequence[tuple[str, str]] | None = None
                  ) -> dict[tuple[str, str], float]:
        """Signed distance [m] of each body pair at ``q`` ((nq,) float; default every checked
        pair; minimum over their geometry; negative = penetration depth)."""
        placements = self.robot.frame_placements(q, self.frames)
        return {key: self.pair_distance(placements, key)
                for key in (self.pairs if pairs is None else pairs)}

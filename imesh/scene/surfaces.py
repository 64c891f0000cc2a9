"""Support surfaces of a scene: the floor (z = 0) and the props' tops (:func:`surface_heights`;
:class:`SupportSurfaces` for callers that ask at every step).

A point is over a prop's top when the point ``(x, y, top - 1 mm)`` is inside the prop's convex
hull (its face planes, :func:`imesh.scene.prop_planes`); the surface under a point is the
highest top it is over among those not more than ``below_m`` above it (a foot joint a little
below a top's height, as a marker's noise or a joint centre inside the sole can put it, still
stands on it; a point deep under a top is beside the prop or inside it, not on it), else the
floor.
"""

from __future__ import annotations

import numpy as np

from ..metrics.props import signed_distance
from .props import prop_planes
from .scene import Scene

#: A point is over a top when this far below it the top's height is inside the prop [m].
TOP_INSET_M = 1e-3


def scene_planes(scene: Scene) -> list[np.ndarray]:
    """(K_p, 4) outward face planes of each prop's convex hull (``n . p <= d`` inside)."""
    return [prop_planes(p) for p in scene.props]


def surface_heights(scene: Scene, points_m: np.ndarray, below_m: float,
                    planes: list[np.ndarray] | None = None) -> np.ndarray:
    """(...,) [m] height of the surface under each point (..., 3): the highest prop top the
    point is over with ``z >= top - below_m``, else 0 (the floor).

    Args:
        scene: the props, in the points' frame.
        points_m: (..., 3) points [m].
        below_m: how far below a top a point may be and still be on it [m].
        planes: the props' planes (:func:`scene_planes`), if already computed.
    """
    p = np.asarray(points_m, dtype=float)
    planes = scene_planes(scene) if planes is None else planes
    out = np.zeros(p.shape[:-1])
    for prop, pl in zip(scene.props, planes, strict=True):
        top = prop.top_m
        probe = p.copy()
        probe[..., 2] = top - TOP_INSET_M
        over = signed_distance(probe, pl) <= 0.0
        on = over & (p[..., 2] >= top - below_m)
        out = np.where(on, np.maximum(out, top), out)
    return out


class SupportSurfaces:
    """The floor and a scene's prop tops, as the surfaces a foot can stand on: the height of
    the surface under points, with the props' planes computed once (for callers that ask
    many times, such as a controller at every step).

    Args:
        scene: the props (in the points' frame), or None for the floor alone.
        below_m: how far below a top a point may be and still be on it [m]
            (:func:`surface_heights`).
    """

    def __init__(self, scene: Scene | None = None, below_m: float = 0.05):
        self.scene = scene if scene is not None and scene.props else None
        self.below_m = float(below_m)
        self._planes = scene_planes(self.scene) if self.scene is not None else []

    @property
    def flat(self) -> bool:
        """True without props: every surface is the floor, z = 0."""
        return self.scene is None

    def heights(self, points_m: np.ndarray) -> np.ndarray:
        """(...,) [m] height of the surface under each point (..., 3)."""
        p = np.asarray(points_m, dtype=float)
        if self.scene is None:
            return np.zeros(p.shape[:-1])
        return surface_heights(self.scene, p, self.below_m, self._planes)

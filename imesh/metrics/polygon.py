"""The support polygon: the convex hull of the sole corners of the feet in support, and the
2-D geometry the ZMP metrics measure against it (hull, centroid, inside test, distance)."""

from __future__ import annotations

import numpy as np

from ..contacts.phases import SIDES
from .soles import SoleTracks


def convex_hull_2d(points: np.ndarray) -> np.ndarray:
    """(K, 2) float counter-clockwise convex hull of a small 2-D point set (monotone chain)."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    if len(pts) <= 2:
        return pts

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def polygon_centroid(poly: np.ndarray) -> np.ndarray:
    """(2,) float area centroid of a counter-clockwise polygon (vertex mean if degenerate)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    c = x * yn - xn * y
    area = c.sum() / 2
    if abs(area) < 1e-12:
        return poly.mean(axis=0)
    return np.array([((x + xn) * c).sum(), ((y + yn) * c).sum()]) / (6 * area)


def inside_polygon(point: np.ndarray, poly: np.ndarray, margin: float = 0.0) -> bool:
    """Whether a 2-D point lies inside a counter-clockwise convex polygon (``margin`` [m] >= 0
    shrinks the polygon's edges inward)."""
    if len(poly) < 3:
        return False
    edge = np.roll(poly, -1, axis=0) - poly
    rel = point - poly
    cross = edge[:, 0] * rel[:, 1] - edge[:, 1] * rel[:, 0]
    return bool(np.all(cross >= margin * np.linalg.norm(edge, axis=1)))


def support_polygons(soles: SoleTracks, support: np.ndarray) -> list[np.ndarray | None]:
    """Per frame the (K, 2) convex hull of the corners of the feet in support (None in
    flight)."""
    out: list[np.ndarray | None] = []
    for t in range(soles.n_frames):
        pts = [soles.corners[s][t, :, :2] for k, s in enumerate(SIDES) if support[t, k]]
        out.append(convex_hull_2d(np.concatenate(pts)) if pts else None)
    return out


def distance_to_polygon(p: np.ndarray, poly: np.ndarray) -> float:
    """Distance [m] of a 2-D point from the boundary of a polygon (its only vertex if it has
    one)."""
    if len(poly) == 1:
        return float(np.linalg.norm(p - poly[0]))
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                              1e-18), 0, 1)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))

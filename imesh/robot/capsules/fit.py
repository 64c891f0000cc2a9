"""Capsules fitted to a body's geometry: the smallest capsule around points over a few axes
(:func:`fit_capsule`) and greedy splits of a triangle surface into up to ``MAX_CAPSULES``
capsules (:func:`fit_capsules`). Pure geometry: no robot."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...core.lazy import optional
from ..collision import fibonacci_directions
from .model import capsule_volume

#: A body gets two capsules when they enclose its geometry in at most this fraction of the
#: volume of the best single capsule.
SPLIT_GAIN = 0.9
#: ... or when both radii are at most this fraction of the single capsule's (a thick torso:
#: a capsule's excess over the surface grows with its radius).
SPLIT_RADIUS = 0.8
#: Up to this many capsules per body.
MAX_CAPSULES = 3
#: Triangles are subdivided to edges at most this long [m] before a split.
SPLIT_MAX_EDGE_M = 0.03
#: Bump when the fit changes, so capsules cached on disk are fitted again.
FIT_VERSION = 1


def _axes(points: np.ndarray) -> list[np.ndarray]:
    """Candidate capsule axes (3,) for (N, 3) points: the principal axes, then x, y, z."""
    c = points - points.mean(axis=0)
    try:
        _, vecs = np.linalg.eigh(np.cov(c.T))
        axes = [vecs[:, i] for i in range(3)]
    except np.linalg.LinAlgError:
        axes = []
    return axes + [np.eye(3)[i] for i in range(3)]


def _capsule_on_axis(points: np.ndarray, axis: np.ndarray, exact: bool = False
                     ) -> tuple[np.ndarray, np.ndarray, float]:
    """Smallest capsule with direction ``axis`` around ``points``: the axis line through the
    centre of the smallest circle around the projected points (approximate: a few
    Badoiu-Clarkson steps; ``exact``: trimesh's minimum n-sphere), radius the largest distance
    from it, end caps just covering the points."""
    z = axis / np.linalg.norm(axis)
    x = np.cross(z, [1.0, 0.0, 0.0])
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.column_stack([x, y, z])
    local = points @ R
    xy = local[:, :2]
    centre = (xy.min(axis=0) + xy.max(axis=0)) / 2
    for k in range(1, 16):
        far = xy[np.argmax(np.sum((xy - centre) ** 2, axis=1))]
        centre = centre + (far - centre) / (k + 1)
    if exact:
        try:
            trimesh = optional("trimesh", "pip install trimesh", "fitting a capsule")
            centre = np.asarray(trimesh.nsphere.minimum_nsphere(xy)[0], dtype=float)
        except Exception:  # degenerate projections: keep the approximation
            pass
    radial = np.linalg.norm(xy - centre, axis=1)
    r = float(radial.max()) + 1e-6
    reach = np.sqrt(np.maximum(r * r - radial ** 2, 0.0))
    top = float(np.max(local[:, 2] - reach))
    bottom = float(np.min(local[:, 2] + reach))
    if top < bottom:
        top = bottom = (top + bottom) / 2
    a = R @ np.array([centre[0], centre[1], bottom])
    b = R @ np.array([centre[0], centre[1], top])
    return a, b, r


def _hull(points: np.ndarray) -> np.ndarray:
    """The convex hull's vertices of (N, 3) points (the capsule around them is the same)."""
    from scipy.spatial import ConvexHull  # not at import: loading a robot needs no scipy

    try:
        return points[ConvexHull(points).vertices]
    except Exception:  # flat or degenerate point sets
        return points


def fit_capsule(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The smallest capsule (over the principal and coordinate axes) enclosing ``points``.

    Returns:
        (a, b, radius): segment end points (3,) and radius [m] in the points' frame.
    """
    pts = _hull(np.asarray(points, dtype=float))
    best = None
    for axis in _axes(pts):
        a, b, r = _capsule_on_axis(pts, axis)
        v = capsule_volume(r, float(np.linalg.norm(b - a)))
        if best is None or v < best[0]:
            best = (v, axis)
    assert best is not None
    return _capsule_on_axis(pts, best[1], exact=True)


def _vol(c: tuple[np.ndarray, np.ndarray, float]) -> float:
    """[m^3] volume of a capsule given as (a, b, radius)."""
    return capsule_volume(c[2], float(np.linalg.norm(c[1] - c[0])))


def _split(tris: np.ndarray, by_excess: bool = False) -> tuple[float, list, list] | None:
    """The best split of triangles (F, 3, 3) in two along a principal axis by their centroids
    (smallest volume, or with ``by_excess`` smallest :func:`capsule_excess`): (volume, two
    capsules, the two triangle sets), or None. Each capsule encloses whole triangles, so the
    union of the capsules encloses the surface, not only its vertices."""
    best = None
    points = tris.reshape(-1, 3)
    centroids = tris.mean(axis=1)
    for axis in _axes(_hull(points))[:3]:
        s = centroids @ axis
        for qtl in (0.3, 0.5, 0.7):
            cut = np.quantile(s, qtl)
            sides = [tris[s <= cut], tris[s > cut]]
            if min(len(t) for t in sides) < 2:
                continue
            two = [fit_capsule(t.reshape(-1, 3)) for t in sides]
            v = _vol(two[0]) + _vol(two[1])
            score = capsule_excess(two, points) if by_excess else v
            if best is None or score < best[0]:
                best = (score, v, two, sides)
    return None if best is None else best[1:]


def subdivide(tris: np.ndarray, max_edge: float = SPLIT_MAX_EDGE_M) -> np.ndarray:
    """Triangles (F, 3, 3) split in four at their edge midpoints until no edge is longer than
    ``max_edge`` [m] (so a split between capsules can follow the surface)."""
    done = []
    while len(tris):
        edge = np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=-1).max(axis=1)
        done.append(tris[edge <= max_edge])
        big = tris[edge > max_edge]
        if not len(big):
            break
        a, b, c = big[:, 0], big[:, 1], big[:, 2]
        ab, bc, ca = (a + b) / 2, (b + c) / 2, (c + a) / 2
        tris = np.concatenate([np.stack(t, axis=1) for t in
                               ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return np.concatenate(done) if done else np.zeros((0, 3, 3))


def capsule_excess(capsules: Sequence[tuple[np.ndarray, np.ndarray, float]],
                   points: np.ndarray) -> float:
    """Mean over directions of how far the union of ``capsules`` reaches beyond the convex hull
    of ``points`` [m] (difference of their support functions over 200 directions): the room a
    proxy wastes around its body, what keeps two bodies apart that do not touch."""
    dirs = fibonacci_directions(200)
    hull = (np.asarray(points, dtype=float) @ dirs.T).max(axis=0)
    reach = np.max([np.maximum(a @ dirs.T, b @ dirs.T) + r for a, b, r in capsules], axis=0)
    return float(np.mean(reach - hull))


def fit_capsules(points: np.ndarray, max_count: int = MAX_CAPSULES,
                 triangles: np.ndarray | None = None, split_excess: float | None = None
                 ) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Capsules enclosing ``points``: one, then (when the surface ``triangles`` (F, 3, 3) of
    the points is given) greedily split a capsule's triangles in two along a principal axis
    while that shrinks its volume to at most ``SPLIT_GAIN`` of it or both radii to at most
    ``SPLIT_RADIUS`` of its radius (or, with ``split_excess``, its :func:`capsule_excess` over
    its triangles to at most that fraction: a tapered shin whose single capsule is as wide as
    its knee), up to ``max_count`` capsules (flat hands, a torso with its head)."""
    points = np.asarray(points, dtype=float)
    one = fit_capsule(points)
    if triangles is None or max_count < 2 or len(triangles) < 4:
        return [one]
    pieces = [(one, subdivide(np.asarray(triangles, dtype=float)))]

    def thinner(cap, tris, two) -> bool:
        if split_excess is None:
            return False
        pts = tris.reshape(-1, 3)
        return capsule_excess(two, pts) <= split_excess * capsule_excess([cap], pts)

    while len(pieces) < max_count:
        best = None
        for k, (cap, tris) in enumerate(pieces):
            if len(tris) < 4:
                continue
            split = _split(tris, by_excess=split_excess is not None)
            if split is not None and (split[0] <= SPLIT_GAIN * _vol(cap)
                                      or max(c[2] for c in split[1]) <= SPLIT_RADIUS * cap[2]
                                      or thinner(cap, tris, split[1])):
                gain = _vol(cap) - split[0]
                if best is None or gain > best[0]:
                    best = (gain, k, split)
        if best is None:
            break
        _, k, (_, two, sides) = best
        pieces[k:k + 1] = [(two[0], sides[0]), (two[1], sides[1])]
    return [cap for cap, _ in pieces]

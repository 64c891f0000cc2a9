"""The capsule types: :class:`Capsule`, :class:`CapsuleModel` (a robot's capsules and the pairs
checked), signed distances of capsule pairs over frames (:meth:`CapsuleModel.distances`) and
their gradient rows (:func:`sample_rows`); see :mod:`imesh.robot.capsules` for the math."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..collision import pair_key

if TYPE_CHECKING:  # pragma: no cover - typing only (hulls needs coal, imported on use)
    from .hulls import BodyHulls


@dataclass(frozen=True, eq=False)
class Capsule:
    """One capsule rigidly attached to a robot frame.

    Attributes:
        name: unique name (``<body>`` or ``<body>#1``, ``<body>#2``).
        body: the body (link moved by one joint) it belongs to; pairs are keyed by bodies.
        frame: the frame ``a`` and ``b`` are expressed in.
        a, b: (3,) float [m] segment end points in ``frame``.
        radius: [m].
    """

    name: str
    body: str
    frame: str
    a: np.ndarray
    b: np.ndarray
    radius: float

    @property
    def length(self) -> float:
        """[m] the segment's length."""
        return float(np.linalg.norm(self.b - self.a))

    def volume(self) -> float:
        """[m^3] the capsule's volume."""
        return capsule_volume(self.radius, self.length)


def capsule_volume(radius: float, length: float) -> float:
    """[m^3] volume of a capsule of ``radius`` [m] around a segment ``length`` [m] long."""
    return float(np.pi * radius ** 2 * length + 4.0 / 3.0 * np.pi * radius ** 3)


def segment_closest_points(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Closest points of segments ``p1-q1`` and ``p2-q2`` (arrays (..., 3), vectorized;
    Ericson, Real-Time Collision Detection 5.1.9). Returns (c1, c2), each (..., 3)."""
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a = np.sum(d1 * d1, axis=-1)
    e = np.sum(d2 * d2, axis=-1)
    f = np.sum(d2 * r, axis=-1)
    c = np.sum(d1 * r, axis=-1)
    b = np.sum(d1 * d2, axis=-1)
    eps = 1e-12
    a_ok, e_ok = a > eps, e > eps
    a_safe, e_safe = np.where(a_ok, a, 1.0), np.where(e_ok, e, 1.0)
    denom = a * e - b * b
    general = denom > eps * np.maximum(a * e, eps)
    s = np.where(general, np.clip((b * f - c * e) / np.where(general, denom, 1.0), 0.0, 1.0), 0.0)
    t = (b * s + f) / e_safe
    # t outside [0, 1]: clamp it and recompute s
    s = np.where(t < 0.0, np.clip(-c / a_safe, 0.0, 1.0), s)
    s = np.where(t > 1.0, np.clip((b - c) / a_safe, 0.0, 1.0), s)
    t = np.clip(t, 0.0, 1.0)
    # degenerate segments: the second a point (t = 0), the first a point (s = 0)
    s = np.where(~e_ok, np.clip(-c / a_safe, 0.0, 1.0), s)
    t = np.where(~e_ok, 0.0, t)
    t = np.where(~a_ok, np.clip(f / e_safe, 0.0, 1.0), t)
    s = np.where(~a_ok, 0.0, s)
    return p1 + d1 * s[..., None], p2 + d2 * t[..., None]


@dataclass(frozen=True, eq=False)
class PairDistances:
    """Signed distances of capsule pairs over frames.

    Attributes:
        distance: (T, P) float [m] signed distance (negative = penetration depth).
        normal: (T, P, 3) unit direction from the second capsule's closest point to the first's.
        point_a, point_b: (T, P, 3) [m] the closest points (world).
    """

    distance: np.ndarray
    normal: np.ndarray
    point_a: np.ndarray
    point_b: np.ndarray


class CapsuleModel:
    """The capsules of a robot, the pairs checked, and vectorized distances and Jacobians.

    Args:
        capsules: the capsules.
        ignored: body-name pairs (sorted tuples) never checked.
        hulls: body -> (V, 3) [m] vertices of the convex hull of the geometry its capsules
            enclose, in the body's frame (:mod:`imesh.robot.capsules.hulls`); None: not known.
    """

    def __init__(self, capsules: Sequence[Capsule], ignored: set[tuple[str, str]],
                 hulls: Mapping[str, np.ndarray] | None = None):
        self.capsules = list(capsules)
        self.ignored = set(ignored)
        self.hulls = None if hulls is None else dict(hulls)
        self.frames = list(dict.fromkeys(c.frame for c in self.capsules))
        self.frame_index = np.array([self.frames.index(c.frame) for c in self.capsules])
        self.ends = np.stack([np.stack([c.a, c.b]) for c in self.capsules]) if capsules \
            else np.zeros((0, 2, 3))
        self.radius = np.array([c.radius for c in self.capsules])
        pairs = [(i, j) for i in range(len(self.capsules)) for j in range(i + 1, len(capsules))
                 if self.capsules[i].body != self.capsules[j].body
                 and pair_key(self.capsules[i].body, self.capsules[j].body) not in self.ignored]
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.pair_bodies = [pair_key(self.capsules[i].body, self.capsules[j].body)
                            for i, j in pairs]
        #: the body pairs checked, and the index in it of each capsule pair's
        self.body_pairs = list(dict.fromkeys(self.pair_bodies))
        index = {key: k for k, key in enumerate(self.body_pairs)}
        self.pair_body_index = np.array([index[key] for key in self.pair_bodies],
                                        dtype=np.int64)
        # each body pair as its first capsule pair orders it (the bodies' capsules are listed
        # body by body, so every capsule pair of two bodies orders them alike)
        first: dict[int, tuple[int, int]] = {}
        for (i, j), k in zip(pairs, self.pair_body_index, strict=True):
            first.setdefault(int(k), (i, j))
        ends = [first[k] for k in range(len(self.body_pairs))]
        #: (B, 2) the index in ``frames`` of each body pair's two bodies' frame, and their names
        #: in that order
        self.body_pair_frames = np.array([[self.frame_index[i], self.frame_index[j]]
                                          for i, j in ends], dtype=np.int64).reshape(-1, 2)
        self.body_pair_bodies = [(self.capsules[i].body, self.capsules[j].body) for i, j in ends]
        self._body_hulls: BodyHulls | None = None

    def body_hulls(self) -> BodyHulls | None:
        """The bodies' convex hulls as coal shapes (:class:`imesh.robot.capsules.hulls.BodyHulls`,
        built on first use: 60 ms for the G1's), or None without :attr:`hulls`."""
        if self._body_hulls is None and self.hulls:
            from .hulls import BodyHulls

            self._body_hulls = BodyHulls(self.hulls)
        return self._body_hulls

    def world_segments(self, placements: np.ndarray) -> np.ndarray:
        """(T, C, 2, 3) segment end points in the world from (T, F, 4, 4) placements of
        ``frames``."""
        M = placements[:, self.frame_index]  # (T, C, 4, 4)
        return np.einsum("tcij,cej->tcei", M[..., :3, :3], self.ends) + M[:, :, None, :3, 3]

    def distances(self, placements: np.ndarray, pairs: np.ndarray | None = None,
                  cutoff: float | None = None) -> PairDistances:
        """Signed distances of ``pairs`` (default: every checked pair) at every frame.

        ``cutoff`` [m]: a broad phase; samples whose bounding spheres (segment midpoint, half
        length plus radius) are farther apart than this get distance +inf (normal and points
        0) instead of the exact value.
        """
        pairs = self.pairs if pairs is None else pairs
        seg = self.world_segments(placements)
        i, j = pairs[:, 0], pairs[:, 1]
        T, P = len(seg), len(pairs)
        tt: np.ndarray
        pp: np.ndarray
        if cutoff is None:
            grid_t, grid_p = np.meshgrid(np.arange(T), np.arange(P), indexing="ij")
            tt, pp = grid_t.ravel(), grid_p.ravel()
        else:
            mid = seg.mean(axis=2)  # (T, C, 3)
            bound = np.linalg.norm(self.ends[:, 1] - self.ends[:, 0], axis=1) / 2 + self.radius
            gap = np.linalg.norm(mid[:, i] - mid[:, j], axis=-1) - bound[i] - bound[j]
            tt, pp = np.nonzero(gap < cutoff)
        ii, jj = i[pp], j[pp]
        ca, cb = segment_closest_points(seg[tt, ii, 0], seg[tt, ii, 1], seg[tt, jj, 0],
                                        seg[tt, jj, 1])
        diff = ca - cb
        norm = np.linalg.norm(diff, axis=-1)
        n = diff / np.maximum(norm, 1e-12)[..., None]
        bad = norm < 1e-9  # crossing segments: any direction normal to both
        if bad.any():
            da = (seg[tt, ii, 1] - seg[tt, ii, 0])[bad]
            db = (seg[tt, jj, 1] - seg[tt, jj, 0])[bad]
            alt = np.cross(da, db)
            alt[np.linalg.norm(alt, axis=-1) < 1e-12] = [0.0, 0.0, 1.0]
            n[bad] = alt / np.linalg.norm(alt, axis=-1, keepdims=True)
        d = np.full((T, P), np.inf)
        d[tt, pp] = norm - self.radius[ii] - self.radius[jj]
        out = [np.zeros((T, P, 3)) for _ in range(3)]
        for arr, val in zip(out, (n, ca, cb), strict=True):
            arr[tt, pp] = val
        return PairDistances(distance=d, normal=out[0], point_a=out[1], point_b=out[2])


def sample_rows(model: CapsuleModel, placements: np.ndarray, jacobians: np.ndarray,
                frames: np.ndarray, pairs: np.ndarray, dist: PairDistances) -> np.ndarray:
    """(R, nv) gradients ``dd/dv`` of the signed distance of ``model.pairs[pairs[r]]`` at frame
    ``frames[r]`` (``dist`` computed on every checked pair; Jacobians of ``model.frames``)."""
    n = dist.normal[frames, pairs]  # (R, 3)
    out = None
    for side, point in ((0, dist.point_a[frames, pairs]), (1, dist.point_b[frames, pairs])):
        f = model.frame_index[model.pairs[pairs, side]]
        J = jacobians[frames, f]  # (R, 6, nv)
        o = placements[frames, f, :3, 3]
        lever = np.cross(point - o, n)  # n . (w x r) = w . (r x n)
        row = np.einsum("ra,ran->rn", n, J[:, :3]) + np.einsum("ra,ran->rn", lever, J[:, 3:])
        out = row if out is None else out - row
    assert out is not None
    return out

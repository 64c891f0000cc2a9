"""Capsule proxies for self-collision: fitting, pairs to check, signed distances and Jacobians.

Each moving body of the reduced model (the links one joint moves) gets one or two capsules that
enclose its URDF collision geometry (mesh vertices, or the support points of URDF primitives;
the visual mesh for links listed in ``collision.use_visual``). A capsule is a segment ``a-b`` in
its frame plus a radius; the signed distance of two capsules is the distance of their segments
minus both radii (negative = penetration depth), exact and cheap, with an analytic gradient:

    d = |p - q| - r_A - r_B,   n = (p - q) / |p - q|,
    dd/dv = n^T (J_A,lin + [w_A] x (p - o_A)) - n^T (J_B,lin + [w_B] x (q - o_B))

with p, q the closest points and J the world-aligned frame Jacobians (the closest points' motion
along the segments does not change d to first order).

Pairs that are never checked (:func:`ignore_rule`): capsules of the same body, of a body and its
parent body, of both feet (the footprints keep them apart), and pairs closer than
``NOMINAL_CLEARANCE_M`` in the nominal standing pose. ``robots/<name>/collision_pairs.toml``
lists them (``imesh robots NAME --collisions --write`` regenerates it; a test checks that the
file equals the rule's output).
"""

from __future__ import annotations

import hashlib
import logging
import os
import tempfile
import tomllib
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.cache import CACHE_ENV, cache_root

log = logging.getLogger(__name__)

#: Pairs closer than this in the nominal standing pose are ignored (designed to be that close).
NOMINAL_CLEARANCE_M = 0.01
#: A body gets two capsules when they enclose its geometry in at most this fraction of the
#: volume of the best single capsule.
SPLIT_GAIN = 0.9
#: ... or when both radii are at most this fraction of the single capsule's (a thick torso:
#: a capsule's excess over the surface grows with its radius).
SPLIT_RADIUS = 0.8
PAIRS_FILE = "collision_pairs.toml"
#: Up to this many capsules per body.
MAX_CAPSULES = 3
#: Triangles are subdivided to edges at most this long [m] before a split.
SPLIT_MAX_EDGE_M = 0.03
#: Bump when the fit changes, so capsules cached on disk are fitted again.
FIT_VERSION = 1
#: Environment variable naming the folder of fitted capsules (empty: no cache).


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
        return float(np.linalg.norm(self.b - self.a))

    def volume(self) -> float:
        return capsule_volume(self.radius, self.length)


def capsule_volume(radius: float, length: float) -> float:
    return float(np.pi * radius ** 2 * length + 4.0 / 3.0 * np.pi * radius ** 3)


# ----------------------------------------------------------------------------------------------
# fitting


def _axes(points: np.ndarray) -> list[np.ndarray]:
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
            import trimesh

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
    try:
        from scipy.spatial import ConvexHull

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
    from .collision import _fibonacci_directions

    dirs = _fibonacci_directions(200)
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


# ----------------------------------------------------------------------------------------------
# distances


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
    """

    def __init__(self, capsules: Sequence[Capsule], ignored: set[tuple[str, str]]):
        self.capsules = list(capsules)
        self.ignored = set(ignored)
        self.frames = list(dict.fromkeys(c.frame for c in self.capsules))
        self.frame_index = np.array([self.frames.index(c.frame) for c in self.capsules])
        self.ends = np.stack([np.stack([c.a, c.b]) for c in self.capsules]) if capsules \
            else np.zeros((0, 2, 3))
        self.radius = np.array([c.radius for c in self.capsules])
        pairs = [(i, j) for i in range(len(self.capsules)) for j in range(i + 1, len(capsules))
                 if self.capsules[i].body != self.capsules[j].body
                 and body_key(self.capsules[i].body, self.capsules[j].body) not in self.ignored]
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.pair_bodies = [body_key(self.capsules[i].body, self.capsules[j].body)
                            for i, j in pairs]

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


def body_key(a: str, b: str) -> tuple[str, str]:
    """The canonical (sorted) key of a body pair."""
    return (a, b) if a <= b else (b, a)


# ----------------------------------------------------------------------------------------------
# the ignore list


def ignore_rule(model: CapsuleModel, body_parent: dict[str, str | None], feet: Sequence[str],
                nominal_placements: np.ndarray) -> dict[tuple[str, str], str]:
    """Body pairs never checked, with the reason: ``parent`` (a body and its parent body),
    ``feet`` (both feet: their footprints keep them apart), ``nominal`` (capsules closer than
    ``NOMINAL_CLEARANCE_M`` in the nominal pose, distance in mm); :func:`capsule_ignore_rule`
    adds the pairs whose URDF collision geometry touches in the nominal pose.

    Args:
        model: a CapsuleModel built with no ignored pairs.
        body_parent: body -> parent body.
        feet: the two foot bodies.
        nominal_placements: (1, F, 4, 4) placements of ``model.frames`` in the nominal pose.
    """
    out: dict[tuple[str, str], str] = {}
    bodies = list(dict.fromkeys(c.body for c in model.capsules))
    for k, a in enumerate(bodies):
        for b in bodies[k + 1:]:
            if body_parent.get(a) == b or body_parent.get(b) == a:
                out[body_key(a, b)] = "parent"
    if len(feet) == 2 and feet[0] != feet[1]:
        out.setdefault(body_key(*feet), "feet")
    d = model.distances(nominal_placements).distance[0]
    closest: dict[tuple[str, str], float] = {}
    for key, dk in zip(model.pair_bodies, d, strict=True):
        closest[key] = min(closest.get(key, np.inf), float(dk))
    for key, dk in sorted(closest.items()):
        if key not in out and dk < NOMINAL_CLEARANCE_M:
            out[key] = f"nominal {1e3 * dk:.1f} mm"
    return out


def format_pairs_toml(robot_name: str, rule: dict[tuple[str, str], str],
                      source: str = "collision", split_excess: float | None = None) -> str:
    lines = [f"# Body pairs of {robot_name} never checked for self-collision (capsule proxies,",
             "# imesh/robot/capsules.py): a body and its parent, both feet (their footprints",
             f"# keep them apart), pairs closer than {1e3 * NOMINAL_CLEARANCE_M:.0f} mm in the "
             "nominal standing pose",
             "# (capsules) or touching there (the URDF's collision geometry).",
             f"# Generated by `imesh robots {robot_name} --collisions --write`; "
             "tests/test_collision.py checks it",
             "# equals the rule's output.", ""]
    if source != "collision":
        lines += ["# the capsules are fitted to the URDF's visual meshes (its collision geometry "
                  "is too coarse)", f'source = "{source}"', ""]
    if split_excess is not None:
        lines += ["# a capsule is split in two when that cuts its excess over the geometry to "
                  "this fraction", "# (imesh.robot.capsules.fit_capsules)",
                  f"split_excess = {split_excess}", ""]
    lines.append("ignore = [")
    for (a, b), why in sorted(rule.items()):
        lines.append(f'    ["{a}", "{b}"],  # {why}')
    lines.append("]")
    return "\n".join(lines) + "\n"


def read_pairs_toml(path: Path) -> set[tuple[str, str]]:
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    return {body_key(str(a), str(b)) for a, b in data.get("ignore", [])}


# ----------------------------------------------------------------------------------------------
# a robot's capsules


def robot_bodies(robot) -> tuple[dict[str, list[str]], dict[str, str | None]]:
    """The robot's bodies with geometry: body name (its first link) -> links, and body ->
    parent body (the nearest ancestor joint's body that has geometry; None at the root)."""
    model = robot.model
    geometry = robot.link_geometry()
    skip = set(robot.config.collision.skip)
    joint_body: dict[int, str] = {}
    links: dict[str, list[str]] = {}
    for link in geometry:
        if link in skip:
            continue
        jid = int(model.frames[robot.frame_id(link)].parentJoint)
        body = joint_body.setdefault(jid, link)
        links.setdefault(body, []).append(link)
    parent: dict[str, str | None] = {}
    for jid, body in joint_body.items():
        p = int(model.parents[jid])
        while p > 0 and p not in joint_body:
            p = int(model.parents[p])
        parent[body] = joint_body.get(p)
    return links, parent


def _pairs_settings(robot) -> dict:
    path = pairs_file(robot)
    if path.is_file():
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    return {}


def capsule_source(robot) -> str:
    """``collision`` (default) or ``visual``: the geometry the capsules are fitted to, from
    ``source = "visual"`` in the robot's collision_pairs.toml (HRP-4C: its URDF collision
    geometry is a few coarse boxes and cylinders much larger than the links)."""
    return str(_pairs_settings(robot).get("source", "collision"))


def capsule_split_excess(robot) -> float | None:
    """``split_excess`` of the robot's collision_pairs.toml (:func:`fit_capsules`), or None:
    HRP-4C's detailed visual meshes taper (knee to ankle), and single capsules as wide as
    their widest part overlap in stances where the meshes are 30 mm apart."""
    value = _pairs_settings(robot).get("split_excess")
    return None if value is None else float(value)


def _triangles(geo) -> np.ndarray | None:
    """(F, 3) vertex indices of a coal mesh's triangles, or None."""
    n = getattr(geo, "num_tris", 0) if geo is not None else 0
    if not n:
        return None
    return np.array([[geo.tri_indices(i)[k] for k in range(3)] for i in range(n)], dtype=int)


def _body_points(robot, body: str, links: list[str]) -> tuple[np.ndarray, np.ndarray | None]:
    """The body's geometry points in its frame, and its surface triangles (F, 3, 3) when it is
    all meshes (None when it has URDF primitives: such a body gets one capsule)."""
    geometry = robot.link_geometry()
    use_visual = set(robot.config.collision.use_visual)
    if capsule_source(robot) == "visual":
        use_visual |= set(links)
    placements = robot.frame_placements(robot.q_nominal, [body, *links])
    inv = np.linalg.inv(placements[0])
    pts: list[np.ndarray] = []
    tris: list[np.ndarray] | None = []
    for link, M in zip(links, placements[1:], strict=True):
        d = geometry[link]
        items = (d["visual"] if link in use_visual and d["visual"] else
                 d["collision"] or d["visual"])
        T = inv @ M
        for it in items:
            p = it.points_in_frame() @ T[:3, :3].T + T[:3, 3]
            pts.append(p)
            tri = _triangles(it.native) if it.kind == "mesh" else None
            if tris is not None and tri is not None and len(tri) and tri.max() < len(p):
                tris.append(p[tri])
            else:
                tris = None
    if not pts:
        return np.zeros((0, 3)), None
    return np.concatenate(pts), (np.concatenate(tris) if tris else None)


def fit_robot_capsules(robot, cache: bool = True) -> list[Capsule]:
    """Capsules of every body of the robot (:func:`fit_capsules` on its URDF collision
    geometry, in the body's frame).

    The fit takes 1-6 s per robot, so its result is kept on disk (:func:`capsule_cache_dir`),
    keyed by a hash of exactly what it is computed from: every body's name, points and
    triangles, and the fit's settings and ``FIT_VERSION``. Another mesh, URDF origin,
    ``use_visual``/``skip`` list or fit setting gives another key (a robot generated from a
    URDF is cached the same way as a shipped one).

    Args:
        robot: an :class:`imesh.robot.Robot`.
        cache: read and write the cache (when it is enabled).
    """
    links, _ = robot_bodies(robot)
    inputs = [(body, *_body_points(robot, body, members)) for body, members in links.items()]
    inputs = [(body, pts, tris) for body, pts, tris in inputs if len(pts) >= 2]
    split_excess = capsule_split_excess(robot)
    folder = capsule_cache_dir() if cache else None
    path = (folder / f"capsules-{_fit_key(inputs, split_excess)}.npz" if folder is not None
            else None)
    if path is not None and path.is_file():
        try:
            out = _read_capsules(path)
            log.debug("robot %s: capsules read from %s", robot.name, path)
            return out
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
            # a damaged file: fit again
            log.warning("capsule cache %s unreadable (%s): fitting again", path, exc)
    out = []
    for body, pts, tris in inputs:
        fitted = fit_capsules(pts, triangles=tris, split_excess=split_excess)
        for k, (a, b, r) in enumerate(fitted):
            name = body if len(fitted) == 1 else f"{body}#{k + 1}"
            out.append(Capsule(name=name, body=body, frame=body, a=a, b=b, radius=r))
    if path is not None:
        try:
            _write_capsules(path, out)
        except OSError as exc:  # a read-only home: no cache, no failure
            log.warning("capsule cache %s not written: %s", path, exc)
    return out


def capsule_cache_dir() -> Path | None:
    """The folder of fitted capsules: ``capsules/`` in imesh's cache folder
    (:func:`imesh.core.cache.cache_root`); None (no cache) when ``$IMESH_CACHE_DIR`` is set
    empty."""
    env = os.environ.get(CACHE_ENV)
    if env is not None and not env.strip():
        return None
    return cache_root() / "capsules"


def _fit_key(inputs: Sequence[tuple[str, np.ndarray, np.ndarray | None]],
             split_excess: float | None) -> str:
    h = hashlib.sha256(repr((FIT_VERSION, MAX_CAPSULES, SPLIT_GAIN, SPLIT_RADIUS,
                             SPLIT_MAX_EDGE_M, split_excess)).encode())
    for body, pts, tris in inputs:
        h.update(body.encode() + b"\0")
        h.update(np.ascontiguousarray(pts, dtype=np.float64).tobytes())
        h.update(b"\0" if tris is None else
                 np.ascontiguousarray(tris, dtype=np.float64).tobytes())
    return h.hexdigest()[:32]


def _write_capsules(path: Path, capsules: Sequence[Capsule]) -> None:
    """Write atomically (a temporary file in the same folder, then a rename), so concurrent
    processes never read a partial file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.stem, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, name=np.array([c.name for c in capsules]),
                     body=np.array([c.body for c in capsules]),
                     frame=np.array([c.frame for c in capsules]),
                     a=np.array([c.a for c in capsules]).reshape(-1, 3),
                     b=np.array([c.b for c in capsules]).reshape(-1, 3),
                     radius=np.array([c.radius for c in capsules], dtype=float))
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _read_capsules(path: Path) -> list[Capsule]:
    with np.load(path, allow_pickle=False) as z:
        return [Capsule(name=str(n), body=str(b), frame=str(f), a=a.copy(), b=e.copy(),
                        radius=float(r))
                for n, b, f, a, e, r in zip(z["name"], z["body"], z["frame"], z["a"], z["b"],
                                            z["radius"], strict=True)]


def capsule_ignore_rule(robot, capsules: Sequence[Capsule] | None = None
                        ) -> dict[tuple[str, str], str]:
    """:func:`ignore_rule` for a robot (what ``collision_pairs.toml`` must list)."""
    capsules = fit_robot_capsules(robot) if capsules is None else list(capsules)
    model = CapsuleModel(capsules, set())
    _, parent = robot_bodies(robot)
    bodies, _ = robot_bodies(robot)
    feet = []
    for side in ("left", "right"):
        foot = robot.foot_frames[side]
        feet += [b for b, members in bodies.items() if foot in members]
    nominal = robot.frame_placements(robot.q_nominal, model.frames)[None]
    rule = ignore_rule(model, parent, feet, nominal)
    # the URDF's own geometry (as check_mesh_collisions scores it) touching in the nominal
    # pose: never checked either, on either geometry
    from .collision import MeshCollisionChecker

    mesh = MeshCollisionChecker(robot, ignored=set(rule))
    for key, d in sorted(mesh.distances(robot.q_nominal).items()):
        if d < 0.0:
            rule[body_key(*key)] = f"URDF geometry nominal {1e3 * d:.1f} mm"
    return rule


def pairs_file(robot) -> Path:
    """``collision_pairs.toml`` next to the robot's robot.toml."""
    return Path(robot.config.path).parent / PAIRS_FILE


def build_capsule_model(robot) -> CapsuleModel:
    """The robot's capsules with the ignore list of its ``collision_pairs.toml`` (the rule's
    output when the robot has no such file, e.g. a user's URDF)."""
    capsules = fit_robot_capsules(robot)
    path = pairs_file(robot)
    if path.is_file():
        ignored = read_pairs_toml(path)
    else:
        ignored = set(capsule_ignore_rule(robot, capsules))
        log.info("robot %s has no %s: ignoring %d body pairs by rule", robot.name, PAIRS_FILE,
                 len(ignored))
    model = CapsuleModel(capsules, ignored)
    log.info("robot %s: %d capsules on %d bodies, %d pairs checked", robot.name,
             len(capsules), len({c.body for c in capsules}), len(model.pairs))
    return model


def describe_collisions(robot, write: bool = False) -> str:
    """Text for ``imesh robots NAME --collisions``: the capsules, the ignored pairs and their
    reasons, whether ``collision_pairs.toml`` matches the rule (``write``: write it)."""
    capsules = fit_robot_capsules(robot)
    rule = capsule_ignore_rule(robot, capsules)
    path = pairs_file(robot)
    if write:
        path.write_text(format_pairs_toml(robot.name, rule, capsule_source(robot),
                                          capsule_split_excess(robot)))
    model = robot.capsule_model()
    lines = [f"{robot.name}: {len(capsules)} capsules on "
             f"{len({c.body for c in capsules})} bodies, {len(model.pairs)} capsule pairs "
             "checked", "",
             f"{'capsule':<30} {'frame':<28} {'radius mm':>9} {'length mm':>9}"]
    for c in capsules:
        lines.append(f"{c.name:<30} {c.frame:<28} {1e3 * c.radius:>9.1f} {1e3 * c.length:>9.1f}")
    stored = read_pairs_toml(path) if path.is_file() else None
    state = ("written" if write else "matches the rule" if stored == set(rule)
             else "missing: the rule is used" if stored is None else "DIFFERS from the rule")
    lines += ["", f"ignored body pairs ({len(rule)}; {path}: {state}):"]
    for (a, b), why in sorted(rule.items()):
        lines.append(f"  {a} - {b}: {why}")
    return "\n".join(lines)

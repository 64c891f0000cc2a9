"""Primitive collision proxies, sole rectangles and collision queries for robot models.

The URDF's collision geometry (or the visual mesh where a link has none) is turned into simple
primitives: URDF primitives are kept as they are, each link's meshes are replaced by the smallest
of a bounding box, cylinder, sphere and capsule (fitted with trimesh): the ground check and
DART's bodies use them (self-collision: :mod:`imesh.robot.capsules` and the URDF geometry).

Shape conventions (``CollisionShape.dims``, metres; the shape's own frame is ``placement``):

- ``box``: (lx, ly, lz) full side lengths, centred.
- ``cylinder``: (radius, length), axis = local z, centred.
- ``sphere``: (radius,).
- ``capsule``: (radius, length), segment of ``length`` along local z between the two hemisphere
  centres, centred.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..core.cache import read_cached, write_cached
from ..core.lazy import optional
from .config import SoleRectangle
from .errors import RobotConfigError

log = logging.getLogger(__name__)

KINDS = ("box", "cylinder", "sphere", "capsule")

#: A box aligned with the link frame is chosen when its volume is at most this factor times the
#: smallest candidate's.
ALIGNED_BOX_PREFERENCE = 1.15


class CollisionShape(NamedTuple):
    """One primitive collision proxy, rigidly attached to a robot frame.

    Unpacks as ``frame, kind, dims, placement``.

    Attributes:
        frame: the link (frame) name it is attached to.
        kind: one of ``box``, ``cylinder``, ``sphere``, ``capsule``.
        dims: sizes [m] (see the module docstring).
        placement: (4, 4) float pose of the shape in ``frame`` (shape axes and centre).
    """

    frame: str
    kind: str
    dims: tuple[float, ...]
    placement: np.ndarray

    def volume(self) -> float:
        """Volume [m^3]."""
        return _volume(self.kind, self.dims)

    def support_points(self, n_circle: int = 16) -> np.ndarray:
        """(P, 3) float [m] points in ``frame`` whose convex hull is (close to) the shape.

        Boxes give their 8 corners; round shapes give rings of ``n_circle`` points (spheres and
        capsules also their poles and equators), enough for ground-height and sole queries.
        """
        T = self.placement
        if self.kind == "box":
            h = np.asarray(self.dims) / 2
            local = np.array([[sx * h[0], sy * h[1], sz * h[2]]
                              for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        else:
            ang = np.linspace(0, 2 * np.pi, n_circle, endpoint=False)
            ring = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1)
            r = self.dims[0]
            if self.kind == "sphere":
                pts = [ring * r, ring[:, [0, 2, 1]] * r, ring[:, [2, 0, 1]] * r]
                local = np.concatenate(pts)
            else:
                half = self.dims[1] / 2
                if self.kind == "cylinder":
                    local = np.concatenate([ring * r + [0, 0, half], ring * r - [0, 0, half]])
                else:  # capsule: rings at both ends and in between, poles, hemisphere rings
                    cap = []
                    for z in (half, -half):
                        cap.append(ring * r + [0, 0, z])
                        s = np.sign(z) if z != 0 else 1.0
                        cap.append(np.array([[0, 0, z + s * r]]))
                        for a in (np.pi / 4,):
                            cap.append(ring * r * np.cos(a) + [0, 0, z + s * r * np.sin(a)])
                    local = np.concatenate(cap)
        return local @ T[:3, :3].T + T[:3, 3]


def _volume(kind: str, dims: Sequence[float]) -> float:
    if kind == "box":
        return float(np.prod(dims))
    if kind == "sphere":
        return float(4 / 3 * np.pi * dims[0] ** 3)
    if kind == "cylinder":
        return float(np.pi * dims[0] ** 2 * dims[1])
    if kind == "capsule":
        return float(np.pi * dims[0] ** 2 * dims[1] + 4 / 3 * np.pi * dims[0] ** 3)
    raise ValueError(kind)


@dataclass(frozen=True, eq=False)
class GeometryItem:
    """One URDF geometry element expressed in its link frame (input to proxy fitting).

    Attributes:
        frame: link name.
        kind: ``box``, ``cylinder``, ``sphere``, ``capsule`` or ``mesh``.
        dims: primitive sizes (module conventions), () for meshes.
        placement: (4, 4) float pose of the geometry in the link frame.
        vertices: (N, 3) float [m] mesh vertices in the geometry's own frame (scaled), or None.
        source: ``collision`` or ``visual``.
        name: the element's name (for messages).
        native: the coal geometry pinocchio loaded (for exact queries), or None.
        mesh_path: the mesh file it was read from ("" for a primitive).
    """

    frame: str
    kind: str
    dims: tuple[float, ...]
    placement: np.ndarray
    vertices: np.ndarray | None
    source: str
    name: str = ""
    native: object = None
    mesh_path: str = ""

    def points_in_frame(self) -> np.ndarray:
        """(P, 3) float [m] points of the element in the link frame (mesh vertices, or the
        support points of a primitive)."""
        if self.kind == "mesh":
            assert self.vertices is not None
            T = self.placement
            return self.vertices @ T[:3, :3].T + T[:3, 3]
        return CollisionShape(self.frame, self.kind, self.dims, self.placement).support_points()


# ----------------------------------------------------------------------------------------------
# proxy fitting


def fibonacci_directions(k: int) -> np.ndarray:
    """(k, 3) unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    i = np.arange(k) + 0.5
    z = 1 - 2 * i / k
    phi = np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


def _extreme_subset(points: np.ndarray, k: int = 200) -> np.ndarray:
    """The points extreme along ``k`` evenly spread directions (a small stand-in for the convex
    hull, used to search shape orientations quickly; final sizes use all points)."""
    from scipy.spatial import ConvexHull  # not at import: loading a robot needs no scipy

    try:
        points = points[ConvexHull(points).vertices]
    except Exception:  # flat or degenerate point sets: keep them all
        pass
    if len(points) <= k:
        return points
    idx = np.unique(np.argmax(points @ fibonacci_directions(k).T, axis=0))
    return points[idx]


def _box_around(points: np.ndarray, rot: np.ndarray) -> tuple[tuple[float, ...], np.ndarray]:
    """Smallest box with axes ``rot`` (columns) containing ``points``."""
    local = points @ rot
    lo, hi = local.min(axis=0), local.max(axis=0)
    pose = np.eye(4)
    pose[:3, :3] = rot
    pose[:3, 3] = rot @ ((lo + hi) / 2)
    return tuple(float(e) for e in np.maximum(hi - lo, 1e-3)), pose


def _cylinder_around(points: np.ndarray, pose: np.ndarray) -> tuple[tuple[float, ...],
                                                                     np.ndarray]:
    """Smallest cylinder with the axis line of ``pose`` (its z axis through its origin)."""
    local = (points - pose[:3, 3]) @ pose[:3, :3]
    r = float(np.hypot(local[:, 0], local[:, 1]).max())
    lo, hi = local[:, 2].min(), local[:, 2].max()
    out = pose.copy()
    out[:3, 3] = pose[:3, 3] + pose[:3, 2] * (lo + hi) / 2
    return (max(r, 1e-4), float(max(hi - lo, 1e-3))), out


def _axis_pose(center: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """A pose at ``center`` whose z axis is ``axis``."""
    z = axis / np.linalg.norm(axis)
    x = np.cross(z, [1.0, 0.0, 0.0])
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    pose[:3, 3] = center
    return pose


def _capsule_from_axis(points: np.ndarray, pose: np.ndarray
                       ) -> tuple[tuple[float, ...], np.ndarray]:
    """Smallest capsule around ``points`` with the axis line of ``pose`` (z) and the radius of
    the points' largest distance from that line."""
    local = (points - pose[:3, 3]) @ pose[:3, :3]
    radial = np.hypot(local[:, 0], local[:, 1])
    r = float(radial.max()) + 1e-9
    reach = np.sqrt(np.maximum(r * r - radial ** 2, 0.0))
    top = float(np.max(local[:, 2] - reach))
    bottom = float(np.min(local[:, 2] + reach))
    if top < bottom:  # a sphere-like capsule: centre the zero-length segment
        top = bottom = (top + bottom) / 2
    out = pose.copy()
    out[:3, 3] = pose[:3, 3] + pose[:3, 2] * (top + bottom) / 2
    return (max(r, 1e-4), top - bottom), out


def fit_primitive(points: np.ndarray) -> tuple[str, tuple[float, ...], np.ndarray]:
    """The smallest-volume bounding primitive of a point set.

    Candidates: the oriented bounding box (trimesh), the minimum bounding sphere, and cylinders
    and capsules along the box axes and the principal axes.
    Orientations are searched on a few hundred extreme points; the final sizes enclose every
    point. A box aligned with the frame's axes wins when its volume is within
    ``ALIGNED_BOX_PREFERENCE`` of the smallest.

    Args:
        points: (N, 3) float [m] points (mesh vertices) in the link frame.

    Returns:
        (kind, dims, placement): kind in ``box|cylinder|sphere|capsule``, sizes (module
        conventions) and the (4, 4) pose of the primitive in the same frame as ``points``.
    """
    trimesh = optional("trimesh", "pip install trimesh", "fitting a collision proxy")
    points = np.asarray(points, dtype=float)
    sub = _extreme_subset(points)
    candidates: list[tuple[str, tuple[float, ...], np.ndarray]] = []
    try:
        to_origin, _ = trimesh.bounds.oriented_bounds(sub)
        box_rot = np.linalg.inv(to_origin)[:3, :3]
    except Exception:  # degenerate (flat or collinear) point sets
        box_rot = np.eye(3)
    candidates.append(("box", *_box_around(points, box_rot)))
    center = points.mean(axis=0)
    try:
        sphere_c, _ = trimesh.nsphere.minimum_nsphere(sub)
        sphere_c = np.asarray(sphere_c, dtype=float)
    except Exception:
        sphere_c = (points.min(axis=0) + points.max(axis=0)) / 2
    sp = np.eye(4)
    sp[:3, 3] = sphere_c
    candidates.append(("sphere", (float(np.linalg.norm(points - sphere_c, axis=1).max()),), sp))
    axes = [box_rot[:, i] for i in range(3)]
    try:
        _, vecs = np.linalg.eigh(np.cov((points - center).T))
        axes += [vecs[:, i] for i in range(3)]
    except np.linalg.LinAlgError:
        pass
    poses = []
    for axis in axes:
        pose = _axis_pose(center, axis)
        local = (sub - center) @ pose[:3, :3]
        try:  # centre the axis on the smallest circle around the projected points
            c2, _ = trimesh.nsphere.minimum_nsphere(local[:, :2])
            pose[:3, 3] = center + pose[:3, :2] @ np.asarray(c2, dtype=float)
        except Exception:
            pass
        poses.append(pose)
    for pose in poses:
        candidates.append(("cylinder", *_cylinder_around(points, pose)))
        candidates.append(("capsule", *_capsule_from_axis(points, pose)))
    best = min(candidates, key=lambda c: _volume(c[0], c[1]))
    # a box aligned with the link frame is preferred when nearly as small: links are designed in
    # their frames (a foot box stays parallel to its sole, a shank box to its axis)
    aligned = ("box", *_box_around(points, np.eye(3)))
    if _volume(aligned[0], aligned[1]) <= ALIGNED_BOX_PREFERENCE * _volume(best[0], best[1]):
        return aligned
    return best


#: Bump when fit_primitive changes: cached fits of an older version are not used.
PROXY_FIT_VERSION = 1


def _fit_meshes(points: dict[str, np.ndarray]) -> dict[str, tuple[str, tuple[float, ...],
                                                                np.ndarray]]:
    """:func:`fit_primitive` of each frame's mesh points, kept in imesh's cache folder
    (``proxies/``, keyed by a hash of every frame's points): the fits cost about 1 s per robot
    and every command loads a robot."""
    h = hashlib.sha256(f"proxies {PROXY_FIT_VERSION}".encode())
    for frame, pts in points.items():
        h.update(frame.encode() + b"\0")
        h.update(np.ascontiguousarray(pts, dtype=np.float64).tobytes())
    key = h.hexdigest()[:32]
    frames = list(points)
    data = read_cached("proxies", key)
    if data is not None and list(data["frames"]) == frames:
        return {f: (str(k), tuple(float(x) for x in d[:int(n)]), p) for f, k, d, n, p in zip(
            frames, data["kinds"], data["dims"], data["ndims"], data["poses"], strict=True)}
    fits = {f: fit_primitive(points[f]) for f in frames}
    if frames:
        dims = np.zeros((len(frames), 3))
        for i, f in enumerate(frames):
            dims[i, :len(fits[f][1])] = fits[f][1]
        write_cached("proxies", key, frames=np.array(frames), kinds=np.array(
            [fits[f][0] for f in frames]), dims=dims, ndims=np.array(
            [len(fits[f][1]) for f in frames]), poses=np.array([fits[f][2] for f in frames]))
    return fits


def build_proxies(items: Iterable[GeometryItem]) -> list[CollisionShape]:
    """Primitive proxies from geometry elements: primitives kept, each link's meshes merged and
    replaced by one fitted primitive.

    Args:
        items: geometry elements (already chosen per link: collision, or visual where wanted).

    Returns:
        Proxies in the order of the first element of each link.
    """
    shapes: list[CollisionShape] = []
    meshes: dict[str, list[np.ndarray]] = {}
    order: list[str] = []
    for it in items:
        if it.frame not in order:
            order.append(it.frame)
        if it.kind == "mesh":
            if it.vertices is not None and len(it.vertices):
                meshes.setdefault(it.frame, []).append(it.points_in_frame())
        else:
            shapes.append(CollisionShape(it.frame, it.kind, tuple(it.dims), it.placement))
    fitted = _fit_meshes({f: np.concatenate(meshes[f]) for f in order if f in meshes})
    shapes += [CollisionShape(f, *fitted[f]) for f in order if f in fitted]
    rank = {f: i for i, f in enumerate(order)}
    shapes.sort(key=lambda s: rank[s.frame])
    return shapes


# ----------------------------------------------------------------------------------------------
# soles


def derive_sole(items: Sequence[GeometryItem], frame: str, normal: np.ndarray | None = None,
                tolerance: float = 0.003) -> SoleRectangle:
    """The sole rectangle of a foot from its geometry: the lowest face along ``-normal``.

    Points within ``tolerance`` of the lowest point (box corners, mesh vertices, bottoms of
    spheres, rims of cylinders) are projected on the frame's x-y plane; their bounding
    rectangle is the sole.

    Args:
        items: geometry elements of the foot link (expressed in ``frame``).
        frame: foot link name.
        normal: (3,) float up direction of the sole in ``frame``; default (0, 0, 1).
        tolerance: [m] height band above the lowest point that counts as the sole.

    Raises:
        RobotConfigError: the foot has no geometry.
    """
    n = np.array([0.0, 0.0, 1.0]) if normal is None else np.asarray(normal, float)
    n = n / np.linalg.norm(n)
    pts = []
    for it in items:
        if it.kind == "sphere":  # a contact sphere touches the ground at its bottom point
            c = it.placement[:3, 3]
            pts.append((c - it.dims[0] * n)[None])
        else:
            pts.append(it.points_in_frame())
    if not pts:
        raise RobotConfigError(f"foot link {frame!r} has no collision or visual geometry to "
                               "derive its sole from: give [soles.left/right] in robot.toml",
                               key="soles")
    p = np.concatenate(pts)
    h = p @ n
    low = h.min()
    sole = p[h <= low + tolerance]
    # rectangle in the plane spanned by the frame's x and y projected on the sole plane
    lo, hi = sole[:, :2].min(axis=0), sole[:, :2].max(axis=0)
    center = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.0])
    # put the centre on the sole plane n . x = low
    center[2] = (low - n[0] * center[0] - n[1] * center[1]) / n[2]
    half = np.maximum((hi - lo) / 2, 1e-3)
    return SoleRectangle(frame=frame, center=center, half_extents=half, normal=n)


def pair_key(a: str, b: str) -> tuple[str, str]:
    """The canonical (sorted) key of a link or body pair (the capsules' ignore list)."""
    return (a, b) if a <= b else (b, a)

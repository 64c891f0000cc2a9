"""Static props: meshes read from OBJ/STL/PLY files or a URDF of fixed links.

A prop is a closed mesh in world coordinates. The prop metrics (:mod:`imesh.metrics.props`) treat
each prop as a convex polytope given by its face planes (the shared climbing boxes are boxes);
a prop that is not convex is replaced by its convex hull, with a warning.

A URDF is read as a tree of fixed joints from its root link: every ``<collision>`` mesh (or
``<visual>`` when a link has no collision element) is loaded with its ``scale`` and placed by the
chain of joint origins and the element's origin. Box, cylinder and sphere primitives are
supported too. Joints that are not ``fixed`` are refused: a scene does not move.
"""

from __future__ import annotations

import logging
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from ..core.lazy import optional
from ..errors import ImeshError, _listing

log = logging.getLogger(__name__)

__all__ = ["Prop", "PropBox", "SceneFileError", "MESH_EXTENSIONS", "SCENE_EXTENSIONS",
           "load_props", "prop_box", "prop_planes"]

MESH_EXTENSIONS = (".obj", ".stl", ".ply", ".off")
SCENE_EXTENSIONS = MESH_EXTENSIONS + (".urdf",)
#: Largest prop mesh read (faces): a scene prop is a box or a step, not a scan.
MAX_FACES = 200_000


class SceneFileError(ImeshError):
    """A scene file cannot be read or is not a set of static props.

    Attributes:
        path: the file.
        reason: what is wrong.
        valid: what would be valid.
    """

    def __init__(self, path: str | os.PathLike, reason: str, valid: str = ""):
        self.path = str(path)
        self.reason = reason
        self.valid = valid
        super().__init__(f"scene {self.path}: {reason}" + (f"; valid: {valid}" if valid else ""))


@dataclass(frozen=True, eq=False)
class Prop:
    """One static prop.

    Attributes:
        name: the prop's name (file stem, or URDF link name).
        vertices_m: (V, 3) float world vertices [m] (in the frame the scene is expressed in).
        faces: (F, 3) int triangle vertex indices.
        source: the file it was read from.
    """

    name: str
    vertices_m: np.ndarray
    faces: np.ndarray
    source: str = ""

    def transformed(self, rotation: np.ndarray, scale: float, offset_m: np.ndarray) -> Prop:
        """The prop with vertices ``scale * (R @ v) + offset``."""
        v = scale * (self.vertices_m @ np.asarray(rotation, float).T) + np.asarray(offset_m)
        return Prop(self.name, v, self.faces, self.source)

    @property
    def top_m(self) -> float:
        """Highest vertex z [m]."""
        return float(self.vertices_m[:, 2].max())


def prop_planes(prop: Prop) -> np.ndarray:
    """(K, 4) outward face planes ``(n, d)`` of the prop's convex hull, ``n . p <= d`` inside,
    unit normals, coplanar faces merged (a box gives 6)."""
    trimesh = optional("trimesh", "pip install trimesh", "scene props")
    hull = trimesh.Trimesh(prop.vertices_m, prop.faces, process=True).convex_hull
    n = np.asarray(hull.face_normals, dtype=float)
    d = np.einsum("ij,ij->i", n, hull.triangles[:, 0])
    planes = np.column_stack([n, d])
    keyed = np.round(planes, 9)
    _, first = np.unique(keyed, axis=0, return_index=True)
    return planes[np.sort(first)]


@dataclass(frozen=True, eq=False)
class PropBox:
    """A prop that is a box (any orientation).

    Attributes:
        center_m: (3,) float centre [m].
        rotation: (3, 3) float its axes as columns (right-handed).
        size_m: (3,) float its edge lengths along those axes [m].
    """

    center_m: np.ndarray
    rotation: np.ndarray
    size_m: np.ndarray

    @property
    def pose(self) -> np.ndarray:
        """(4, 4) float world pose of the box's centre and axes."""
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = self.rotation, self.center_m
        return T


def prop_box(prop: Prop, tol: float = 1e-6) -> PropBox | None:
    """The box a prop is, or None: its convex hull has six faces in three antiparallel pairs
    whose normals are orthogonal (within ``tol``). Its size and centre are the extent of the
    vertices along those normals."""
    planes = prop_planes(prop)
    if len(planes) != 6:
        return None
    n = planes[:, :3]
    axes, used = [], set()
    for i in range(6):
        if i in used:
            continue
        j = int(np.argmin(n @ n[i]))
        if j in used or n[i] @ n[j] > -1.0 + tol:
            return None
        used |= {i, j}
        axes.append(n[i])
    R = np.array(axes).T
    if len(axes) != 3 or np.abs(R.T @ R - np.eye(3)).max() > tol:
        return None
    if np.linalg.det(R) < 0:
        R[:, 2] *= -1.0
    proj = prop.vertices_m @ R
    lo, hi = proj.min(axis=0), proj.max(axis=0)
    return PropBox(center_m=R @ (0.5 * (lo + hi)), rotation=R, size_m=hi - lo)


def _origin(elem: ET.Element | None) -> np.ndarray:
    T = np.eye(4)
    if elem is None:
        return T
    xyz = [float(v) for v in elem.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in elem.get("rpy", "0 0 0").split()]
    T[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()  # URDF: fixed-axis roll, pitch, yaw
    T[:3, 3] = xyz
    return T


def _read_mesh(path: Path, where: str) -> tuple[np.ndarray, np.ndarray]:
    trimesh = optional("trimesh", "pip install trimesh", "scene props")
    if not path.is_file():
        raise SceneFileError(where, f"mesh file {path} not found",
                             "an existing OBJ, STL, PLY or OFF file")
    try:
        mesh = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:  # noqa: BLE001 - trimesh raises many kinds on a corrupt file
        raise SceneFileError(where, f"cannot read mesh {path} ({type(exc).__name__}: {exc})",
                             "an OBJ, STL, PLY or OFF mesh") from None
    v = np.asarray(getattr(mesh, "vertices", np.zeros((0, 3))), dtype=float)
    f = np.asarray(getattr(mesh, "faces", np.zeros((0, 3))), dtype=np.int64)
    if len(f) == 0 or len(v) < 4:
        raise SceneFileError(where, f"mesh {path} has {len(v)} vertices and {len(f)} faces",
                             "a closed mesh with faces")
    if len(f) > MAX_FACES:
        raise SceneFileError(where, f"mesh {path} has {len(f)} faces",
                             f"at most {MAX_FACES} (a prop, not a scan)")
    if not np.isfinite(v).all():
        raise SceneFileError(where, f"mesh {path} has non-finite vertices", "finite vertices")
    return v, f


def _primitive(geom: ET.Element, where: str) -> tuple[np.ndarray, np.ndarray] | None:
    trimesh = optional("trimesh", "pip install trimesh", "scene props")
    box = geom.find("box")
    if box is not None:
        m = trimesh.creation.box(extents=[float(s) for s in box.get("size", "").split()])
    elif geom.find("cylinder") is not None:
        c = geom.find("cylinder")
        assert c is not None
        m = trimesh.creation.cylinder(radius=float(c.get("radius", 0)),
                                      height=float(c.get("length", 0)), sections=32)
    elif geom.find("sphere") is not None:
        s = geom.find("sphere")
        assert s is not None
        m = trimesh.creation.icosphere(subdivisions=2, radius=float(s.get("radius", 0)))
    else:
        return None
    return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)


def _read_urdf(path: Path) -> list[Prop]:
    where = str(path)
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise SceneFileError(where, f"not a readable URDF ({exc})", "a URDF XML file") from None
    links = {ln.get("name", ""): ln for ln in root.findall("link")}
    joints = root.findall("joint")
    moving = [j.get("name", "") for j in joints if j.get("type") != "fixed"]
    if moving:
        raise SceneFileError(where, f"joints {_listing(moving)} are not fixed",
                             "a URDF of fixed links (a static scene)")
    parent_of = {}
    for j in joints:
        parent, child = j.find("parent"), j.find("child")
        if parent is None or child is None:
            continue
        parent_of[child.get("link", "")] = (parent.get("link", ""), _origin(j.find("origin")))

    def world(link: str, depth: int = 0) -> np.ndarray:
        if link not in parent_of or depth > len(links):
            return np.eye(4)
        parent, T = parent_of[link]
        return world(parent, depth + 1) @ T

    props: list[Prop] = []
    scales = set()
    for name, link in links.items():
        elems = link.findall("collision") or link.findall("visual")
        parts_v, parts_f, n = [], [], 0
        for elem in elems:
            geom = elem.find("geometry")
            if geom is None:
                continue
            mesh = geom.find("mesh")
            if mesh is not None:
                v, f = _read_mesh(path.parent / mesh.get("filename", ""), where)
                scale = np.array([float(s) for s in mesh.get("scale", "1 1 1").split()])
                scales.add(tuple(np.round(scale, 9)))
                v = v * scale
            else:
                prim = _primitive(geom, where)
                if prim is None:
                    continue
                v, f = prim
            T = world(name) @ _origin(elem.find("origin"))
            parts_v.append(v @ T[:3, :3].T + T[:3, 3])
            parts_f.append(f + n)
            n += len(v)
        if parts_v:
            props.append(Prop(name, np.concatenate(parts_v), np.concatenate(parts_f),
                              str(path)))
    if not props:
        raise SceneFileError(where, "no link has collision or visual geometry",
                             "a URDF whose links carry meshes or primitives")
    odd = sorted(s for s in scales if s != (1.0, 1.0, 1.0))
    if odd:
        log.warning("%s: the URDF scales its meshes by %s: the props are taken as the URDF "
                    "places them (give the mesh files instead for their own scale)", path,
                    ", ".join(str(s[0]) if len(set(s)) == 1 else str(s) for s in odd))
    return props


def _split(prop: Prop) -> list[Prop]:
    """A mesh of several disconnected bodies (``multi_boxes.obj``) as one prop per body, named
    ``stem_0``, ``stem_1`` ... in file order."""
    trimesh = optional("trimesh", "pip install trimesh", "scene props")
    labels = trimesh.graph.connected_component_labels(
        trimesh.graph.face_adjacency(prop.faces), node_count=len(prop.faces))
    if labels.max(initial=0) == 0:
        return [prop]
    out = []
    for k in range(int(labels.max()) + 1):
        faces = prop.faces[labels == k]
        used, inverse = np.unique(faces, return_inverse=True)
        out.append(Prop(f"{prop.name}_{k}", prop.vertices_m[used],
                        inverse.reshape(-1, 3).astype(np.int64), prop.source))
    return out


def _warn_concave(prop: Prop) -> None:
    trimesh = optional("trimesh", "pip install trimesh", "scene props")
    mesh = trimesh.Trimesh(prop.vertices_m, prop.faces, process=True)
    hull = mesh.convex_hull.volume
    if not mesh.is_watertight or abs(mesh.volume) < 0.98 * hull:
        log.warning("%s: prop %s is not a closed convex mesh (volume %.4g of its hull's %.4g "
                    "m^3): the prop metrics use its convex hull", prop.source, prop.name,
                    abs(mesh.volume), hull)


def load_props(path: str | os.PathLike) -> list[Prop]:
    """The props of one scene file: a mesh file is one prop (named by its stem); a URDF gives
    one prop per link with geometry.

    Raises:
        SceneFileError: no such file, unknown extension, unreadable or empty mesh, moving joints.
    """
    p = Path(path)
    if not p.is_file():
        raise SceneFileError(p, "no such file", f"an existing {', '.join(SCENE_EXTENSIONS)} file")
    ext = p.suffix.lower()
    if ext == ".urdf":
        props = _read_urdf(p)
    elif ext in MESH_EXTENSIONS:
        v, f = _read_mesh(p, str(p))
        props = _split(Prop(p.stem, v, f, str(p)))
    else:
        raise SceneFileError(p, f"extension {ext!r} is not a scene file",
                             ", ".join(SCENE_EXTENSIONS))
    for prop in props:
        _warn_concave(prop)
    log.info("%s: %d prop(s): %s", p, len(props),
             ", ".join(f"{q.name} (top {q.top_m:.3f})" for q in props))
    return props

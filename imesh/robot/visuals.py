"""A URDF's ``<visual>`` elements for drawing (the viewer's meshes), read with pinocchio so that
the viewer needs no URDF parser of its own and never calls pinocchio itself."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .build import _package_dirs
from .pin import _pinocchio


@dataclass(frozen=True, eq=False)
class VisualElement:
    """One ``<visual>`` of a URDF, for drawing (the viewer), in the frame of its link.

    Attributes:
        link: the link's frame name.
        name: the element's name (for messages).
        kind: ``mesh``, ``box``, ``sphere``, ``cylinder``, ``capsule`` or the unsupported
            geometry's class name.
        placement: (4, 4) float pose of the element in the link frame [m].
        vertices: (N, 3) float mesh vertices in the element's frame [m] (meshes), else None.
        faces: (F, 3) uint32 triangles of ``vertices`` (meshes), else None.
        dims: primitive sizes: box (x, y, z) extents, sphere (radius,), cylinder and capsule
            (radius, length) [m]; () for meshes.
        color: (3,) RGB in [0, 1] of the URDF material.
    """

    link: str
    name: str
    kind: str
    placement: np.ndarray
    vertices: np.ndarray | None
    faces: np.ndarray | None
    dims: tuple[float, ...]
    color: tuple[float, float, float]


def visual_elements(urdf: Path, links: set[str]) -> list[VisualElement]:
    """The ``<visual>`` elements of a URDF that belong to ``links``, as pinocchio loads them
    (meshes with their triangles; primitives by their sizes)."""
    pin = _pinocchio()
    full = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
    geom = pin.buildGeomFromUrdf(full, str(urdf), pin.GeometryType.VISUAL, None,
                                 _package_dirs(urdf))
    out = []
    for g in geom.geometryObjects:
        frame = full.frames[g.parentFrame]
        if frame.name not in links:
            continue
        T = (frame.placement.inverse() * g.placement).homogeneous
        geo = g.geometry
        cls = type(geo).__name__
        verts = faces = None
        dims: tuple[float, ...] = ()
        if cls.startswith("BVHModel") or cls.startswith("Convex"):
            kind = "mesh"
            verts = np.array(geo.vertices(), dtype=float).reshape(-1, 3)
            faces = np.array([[geo.tri_indices(i)[k] for k in range(3)]
                              for i in range(geo.num_tris)], dtype=np.uint32).reshape(-1, 3)
        elif cls == "Box":
            kind, dims = "box", tuple(2 * np.asarray(geo.halfSide))
        elif cls == "Sphere":
            kind, dims = "sphere", (float(geo.radius),)
        elif cls in ("Cylinder", "Capsule"):
            kind, dims = cls.lower(), (float(geo.radius), 2 * float(geo.halfLength))
        else:
            kind = cls
        red, green, blue = (float(c) for c in np.asarray(g.meshColor)[:3])  # RGBA
        out.append(VisualElement(link=frame.name, name=g.name, kind=kind, placement=T,
                                 vertices=verts, faces=faces, dims=dims,
                                 color=(red, green, blue)))
    return out

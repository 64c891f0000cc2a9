"""The URDF's geometry objects (as pinocchio loads them) as imesh :class:`GeometryItem` s.

Each item is expressed in the frame of its link, with the mesh vertices or the primitive's
dimensions, so that collision proxies, soles and capsules can be fitted to it without pinocchio.
"""

from __future__ import annotations

import logging

import numpy as np

from .collision import GeometryItem

log = logging.getLogger(__name__)

#: Collada ``<up_axis>Y_UP``: (4, 4) file coordinates -> z-up coordinates,
#: (x, y, z) -> (x, -z, y).
_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
#: Mesh path -> its Collada up axis: a model names the same mesh file many times.
_UP_AXIS: dict[str, str] = {}


def _collada_up_axis(path: str) -> str:
    """The ``<up_axis>`` a Collada file declares ("" when none or not Collada; cached)."""
    if not path.lower().endswith(".dae"):
        return ""
    if path not in _UP_AXIS:
        try:
            with open(path, "rb") as f:
                head = f.read(65536).decode("utf-8", "replace")
        except OSError:
            head = ""
        i = head.find("<up_axis>")
        _UP_AXIS[path] = head[i + 9:head.find("</up_axis>", i)].strip() if i >= 0 else ""
    return _UP_AXIS[path]


def geometry_items(model, geom_model, source: str) -> list[GeometryItem]:
    """The geometry objects of a pinocchio GeometryModel, each in its link's frame.

    Args:
        model: the pinocchio Model the geometry was built for.
        geom_model: its pinocchio GeometryModel (collision or visual).
        source: ``"collision"`` or ``"visual"``, recorded in the items.

    Returns:
        One item per mesh, box, sphere, cylinder or capsule (other types are logged and left
        out), with its (4, 4) placement [m] in the link frame.
    """
    items = []
    for g in geom_model.geometryObjects:
        frame = model.frames[g.parentFrame]
        T = (frame.placement.inverse() * g.placement).homogeneous
        # A Collada mesh declaring Y_UP is meant to be turned z-up (as ROS viewers and the
        # model's authors show it, e.g. iCub's feet); coal reads the raw coordinates, so the
        # turn goes into the placement (vertices and coal's own geometry stay as loaded).
        up = _collada_up_axis(getattr(g, "meshPath", "") or "")
        if up == "Y_UP":
            T = T @ _Y_UP
        elif up == "X_UP":
            log.warning("%s: Collada X_UP mesh %s used as z-up", source, g.meshPath)
        geo = g.geometry
        cls = type(geo).__name__
        verts = None
        dims: tuple[float, ...]
        if cls.startswith("BVHModel") or cls.startswith("Convex"):
            kind, dims = "mesh", ()
            pts = geo.vertices() if hasattr(geo, "vertices") else geo.points()
            verts = np.array(pts, dtype=float).reshape(-1, 3)
        elif cls == "Box":
            kind, dims = "box", tuple(float(2 * h) for h in geo.halfSide)
        elif cls == "Sphere":
            kind, dims = "sphere", (float(geo.radius),)
        elif cls == "Cylinder":
            kind, dims = "cylinder", (float(geo.radius), float(2 * geo.halfLength))
        elif cls == "Capsule":
            kind, dims = "capsule", (float(geo.radius), float(2 * geo.halfLength))
        else:
            log.warning("%s geometry %s of %s has unsupported type %s: ignored", source, g.name,
                        frame.name, cls)
            continue
        items.append(GeometryItem(frame=frame.name, kind=kind, dims=dims, placement=T,
                                  vertices=verts, source=source, name=g.name, native=geo,
                                  mesh_path=(getattr(g, "meshPath", "") or "")
                                  if kind == "mesh" else ""))
    return items

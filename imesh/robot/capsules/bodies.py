"""A robot's bodies (the links one joint moves) and their geometry, in the body frame, as the
capsules are fitted to it."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .pairs import capsule_source

if TYPE_CHECKING:  # pragma: no cover - typing only (the Robot uses this package)
    from ..model import Robot


def robot_bodies(robot: Robot) -> tuple[dict[str, list[str]], dict[str, str | None]]:
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


def _triangles(geo) -> np.ndarray | None:
    """(F, 3) vertex indices of a coal mesh's triangles, or None."""
    n = getattr(geo, "num_tris", 0) if geo is not None else 0
    if not n:
        return None
    return np.array([[geo.tri_indices(i)[k] for k in range(3)] for i in range(n)], dtype=int)


def _hull_triangles(points: np.ndarray) -> np.ndarray | None:
    """(F, 3) vertex indices of the convex hull's triangles of (P, 3) points, or None when
    they span no volume."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        return ConvexHull(points).simplices
    except (QhullError, ValueError):
        return None


def link_items(robot: Robot, link: str) -> list:
    """The URDF geometry of ``link`` the capsules enclose and the mesh check scores
    (:class:`imesh.robot.collision.GeometryItem` list): its visual elements when the robot's
    capsules are fitted to them (``source = "visual"``) or the link is in
    ``collision.use_visual``, else its collision elements, else (a link without any, e.g. G1's
    waist) its visual ones."""
    d = robot.link_geometry()[link]
    visual = (link in robot.config.collision.use_visual or capsule_source(robot) == "visual")
    return list(d["visual"] if visual and d["visual"] else d["collision"] or d["visual"])


def body_points(robot: Robot, body: str, links: list[str]) -> tuple[np.ndarray, np.ndarray | None]:
    """The body's geometry points in its frame, and its surface triangles (F, 3, 3): a mesh's
    own, a URDF primitive's the convex hull of its support points (so that a body that carries
    a primitive, such as Talos's torso with its IMU box, can still be split into capsules: one
    capsule around it was 235 mm in radius); None when a mesh has no triangles."""
    placements = robot.frame_placements(robot.q_nominal, [body, *links])
    inv = np.linalg.inv(placements[0])
    pts: list[np.ndarray] = []
    tris: list[np.ndarray] | None = []
    for link, M in zip(links, placements[1:], strict=True):
        items = link_items(robot, link)
        T = inv @ M
        for it in items:
            p = it.points_in_frame() @ T[:3, :3].T + T[:3, 3]
            pts.append(p)
            tri = _triangles(it.native) if it.kind == "mesh" else _hull_triangles(p)
            if tris is not None and tri is not None and len(tri) and tri.max() < len(p):
                tris.append(p[tri])
            else:
                tris = None
    if not pts:
        return np.zeros((0, 3)), None
    return np.concatenate(pts), (np.concatenate(tris) if tris else None)

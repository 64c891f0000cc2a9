"""The data of the 3D viewer: robot motions with their meshes, markers and balance overlays,
and the static props around them.

:func:`build_robots_scene` computes everything the viewer page draws, once, in Python, for one
robot or the two robots of a pair (``imesh retarget --partner``) in one world: each robot
model's visual meshes (from its URDF, in link frames, sent once per model), and per robot the
world pose of every link at every frame, the human markers (the adapted markers the robot
fitted, and optionally the source clip beside it), the interaction mesh edges per frame, the
soles, support polygons, desired and actual ZMP, and the self-collisions and joint-limit
violations per frame, and, given a DART check (:class:`imesh.physics.PhysicsResult`), the
simulated robot's link poses beside the reference (:func:`simulation_entry`); the props of a
scene (``OUT.scene.npz``) as static meshes; for a pair, its figures and the robots' distance
per frame (:class:`PairView`). :func:`build_scene` is the one-robot case. The page only plays
it back.

Arrays are sent as base64 of little-endian float32/uint16/uint8 (``{"b64": ..., "dtype": ...,
"shape": ...}``), so a 5 s motion of JVRC-1 is about 1 MB of JSON.
"""

from __future__ import annotations

import base64
import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from ..contacts.phases import SIDES
from ..core.lazy import optional
from ..errors import ImeshError
from ..evaluate.motion_files import arranged_source
from ..evaluate.scoreboard import metric_values
from ..human.arrange import arrange_for_robot
from ..human.markerset import STANDARD_BONE_NAMES
from ..mesh.interaction import tetrahedralize
from ..metrics.collision import SelfCollisions, check_self_collisions
from ..metrics.markers import keypoint_motion
from ..metrics.polygon import support_polygons
from ..metrics.soles import sole_tracks
from ..metrics.support import motion_support
from ..metrics.zmp import zmp_report, zmp_trajectory
from ..robot.capsules.bodies import robot_bodies
from ..robot.visuals import visual_elements

log = logging.getLogger(__name__)

#: Colours (RGB 0-1) of the overlays, also used by the report's figures.
COLORS = {"zmp": (0.85, 0.1, 0.1), "desired": (0.1, 0.45, 0.9), "polygon": (0.1, 0.65, 0.3),
          "markers": (0.1, 0.35, 0.95), "source": (0.55, 0.2, 0.75)}


@dataclass(frozen=True, eq=False)
class VisualMesh:
    """One visual mesh of a robot link.

    Attributes:
        link: the link (frame) name it is attached to.
        vertices: (N, 3) float32 [m] vertices in the link frame.
        faces: (F, 3) uint32 triangle vertex indices.
        color: (3,) float RGB in [0, 1] (the URDF material, or grey).
    """

    link: str
    vertices: np.ndarray
    faces: np.ndarray
    color: tuple[float, float, float]


def visual_meshes(robot, max_faces: int = 40_000, cell_m: float = 0.004) -> list[VisualMesh]:
    """The visual meshes of a robot's URDF, each in the frame of its link.

    URDF primitives (box, sphere, cylinder) are turned into triangle meshes with trimesh.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        max_faces: above this many triangles in all, the meshes are decimated
            (:func:`decimate`) so a page stays small.
        cell_m: the decimation grid [m].

    Returns:
        list of VisualMesh, one per URDF visual element whose link exists in ``robot``.
    """
    out = []
    for element in visual_elements(robot.urdf, set(robot.frame_names)):
        if element.vertices is not None and element.faces is not None:
            verts, faces = element.vertices, element.faces
        else:
            mesh = _primitive(element.kind, element.dims)
            if mesh is None:
                log.info("visual %s of %s: unsupported geometry %s, not drawn", element.name,
                         element.link, element.kind)
                continue
            verts, faces = mesh
        T = element.placement
        verts = verts @ T[:3, :3].T + T[:3, 3]
        color = element.color
        if np.allclose(color, 0.0):
            color = (0.7, 0.7, 0.7)
        out.append(VisualMesh(link=element.link, vertices=verts.astype(np.float32),
                              faces=faces.astype(np.uint32), color=color))
    n_faces = sum(len(m.faces) for m in out)
    if n_faces > max_faces:  # e.g. the G1's 290k triangles: 4 mm clusters keep its look
        small = []
        for m in out:
            v, f = decimate(m.vertices, m.faces, cell_m)
            small.append(VisualMesh(link=m.link, vertices=v, faces=f, color=m.color))
        out = small
        log.info("viewer: %s meshes decimated from %d to %d triangles", robot.name, n_faces,
                 sum(len(m.faces) for m in out))
    return out


def decimate(vertices: np.ndarray, faces: np.ndarray, cell_m: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """Vertex-clustering decimation: vertices in one ``cell_m`` cube merge into their mean, and
    triangles that collapse are dropped (for display only).

    Args:
        vertices: (N, 3) float [m]; faces: (F, 3) int.
        cell_m: the grid size [m].

    Returns:
        (vertices (N', 3) float32, faces (F', 3) uint32).
    """
    vertices = np.asarray(vertices, dtype=float)
    key = np.floor(vertices / cell_m).astype(np.int64)
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    n = int(inv.max()) + 1 if len(inv) else 0
    count = np.bincount(inv, minlength=n).astype(float)
    merged = np.stack([np.bincount(inv, weights=vertices[:, k], minlength=n) for k in range(3)],
                      axis=1) / np.maximum(count, 1)[:, None]
    f = inv[np.asarray(faces, dtype=np.int64)]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return merged.astype(np.float32), f[keep].astype(np.uint32)


def _primitive(kind: str, dims: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray] | None:
    """Triangles of a URDF primitive (:class:`~imesh.robot.visuals.VisualElement` sizes)."""
    trimesh = optional("trimesh", "pip install trimesh", "drawing a URDF primitive")
    if kind == "box":
        m = trimesh.creation.box(extents=np.asarray(dims))
    elif kind == "sphere":
        m = trimesh.creation.icosphere(subdivisions=2, radius=dims[0])
    elif kind == "cylinder":
        m = trimesh.creation.cylinder(radius=dims[0], height=dims[1])
    elif kind == "capsule":
        m = trimesh.creation.capsule(radius=dims[0], height=dims[1])
    else:
        return None
    return np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.uint32)


def encode(array: np.ndarray, dtype: str = "float32") -> dict:
    """An array as ``{"b64", "dtype", "shape"}`` (little-endian ``dtype``) for the page."""
    a = np.ascontiguousarray(np.asarray(array), dtype=np.dtype(dtype).newbyteorder("<"))
    return {"b64": base64.b64encode(a.tobytes()).decode("ascii"), "dtype": dtype,
            "shape": list(a.shape)}


def decode(entry: Mapping) -> np.ndarray:
    """The inverse of :func:`encode`."""
    raw = base64.b64decode(entry["b64"])
    return np.frombuffer(raw, dtype=np.dtype(entry["dtype"]).newbyteorder("<")).reshape(
        entry["shape"])


def lead_frames(markers: np.ndarray) -> tuple[int, int]:
    """(lead-in, lead-out) frames of a retargeted motion: its adapted markers hold the first and
    the last clip frame still over the standing lead-in/out (``imesh.retarget``).

    Args:
        markers: (T, M, 3) float [m] adapted markers, frame-aligned with the motion.
    """
    T = len(markers)
    if T < 3:
        return 0, 0
    same_first = np.all(np.abs(markers - markers[0]) < 1e-9, axis=(1, 2))
    same_last = np.all(np.abs(markers - markers[-1]) < 1e-9, axis=(1, 2))
    a = int(np.argmin(same_first)) if not same_first.all() else 0
    b = int(np.argmin(same_last[::-1])) if not same_last.all() else 0
    return max(a - 1, 0), max(b - 1, 0)


def _bones(names) -> list[list[int]]:
    index = {n: i for i, n in enumerate(names)}
    return [[index[a], index[b]] for a, b in STANDARD_BONE_NAMES if a in index and b in index]


def _marker_entry(positions: np.ndarray, names, label: str) -> dict:
    pos = np.nan_to_num(np.asarray(positions, dtype=float), nan=0.0)
    return {"label": label, "names": list(names), "positions": encode(pos),
            "bones": _bones(names)}


def _mesh_edges(positions: np.ndarray) -> dict:
    """(T, E, 2) uint16 Delaunay edges of every frame, padded with 65535."""
    pos = np.nan_to_num(positions)
    edges = [tetrahedralize(p)[0] for p in pos]
    width = max((len(e) for e in edges), default=0)
    out = np.full((len(edges), width, 2), 65535, dtype=np.uint16)
    for t, e in enumerate(edges):
        out[t, :len(e)] = e
    return encode(out, "uint16")


def link_poses(robot, q: np.ndarray, link_ids: list[int]) -> np.ndarray:
    """(T, L, 7) float32 world poses of the frames ``link_ids`` at every row of ``q`` (T, nq):
    position [m] and quaternion (x, y, z, w)."""
    poses = np.empty((len(q), len(link_ids), 7), dtype=np.float32)
    for t in range(len(q)):
        M = robot.frame_placements(q[t], link_ids)
        poses[t, :, :3] = M[:, :3, 3]
        poses[t, :, 3:] = Rotation.from_matrix(M[:, :3, :3]).as_quat()
    return poses


@dataclass(frozen=True, eq=False)
class SceneRobot:
    """One robot of a viewer scene and what is drawn with it.

    Attributes:
        robot: an :class:`imesh.robot.Robot`.
        motion: its :class:`imesh.core.robot_motion.RobotMotion` (T frames).
        markers: the adapted markers the robot fitted (a MarkerMotion frame-aligned with the
            motion), or None: ``motion.adapted`` (stored in imesh motion files).
        source: the human clip (a path or MarkerMotion), drawn beside the robot: arranged for
            the robot's size, resampled to the motion's fps and shifted by the lead-in.
        label: the robot's name in the page (default: the robot model's name).
        metrics: an :func:`imesh.evaluate.evaluate_motion` report, shown in the page.
        collisions: the motion's :func:`imesh.metrics.collision.check_self_collisions` result
            if already computed; None: computed here (the evaluator's check: same geometry,
            pairs and threshold, so the page marks the frames ``self_collision_frames``
            counts).
        physics: a :class:`imesh.physics.PhysicsResult` of this motion (``simulate_motion``):
            the simulated robot is drawn beside the reference (:func:`simulation_entry`); None:
            not drawn.
        source_scale: the human-to-robot scale to arrange ``source`` with (two partners share
            one: ``OUT.pair.json``'s ``pair.scale``); None: the robot's own.
        source_centre_m: (3,) [m] the fixed point of that scale (``pair.centre_m``); None: the
            floor point under the clip's centroid at its first frame.
    """

    robot: Any
    motion: Any
    markers: Any = None
    source: Any = None
    label: str = ""
    metrics: Mapping | None = None
    collisions: SelfCollisions | None = None
    physics: Any = None
    source_scale: float | None = None
    source_centre_m: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class PairView:
    """What the page shows of two robots together besides the robots (``imesh retarget
    --partner``, docs/partners.md).

    Attributes:
        metrics: the pair's figures (``OUT.pair.json``'s ``pair_metrics``:
            :meth:`imesh.partners.evaluate.PairMetrics.summary`), listed in the page.
        distance_m: (T,) float [m] the robots' smallest capsule distance per frame (negative:
            penetration; +inf beyond the broad phase), or None.
        held: (T,) bool frames of a hand hold of the source, or None.
    """

    metrics: Mapping[str, Any]
    distance_m: np.ndarray | None = None
    held: np.ndarray | None = None


def build_scene(robot, motion, *, markers=None, source=None, title: str | None = None,
                metrics: Mapping | None = None, collisions: SelfCollisions | None = None,
                physics=None, props=None) -> dict:
    """Everything the viewer draws for one robot motion: :func:`build_robots_scene` of one
    :class:`SceneRobot` (the arguments are its fields).

    Args:
        robot, motion, markers, source, metrics, collisions, physics: see :class:`SceneRobot`.
        title: page title.
        props: the static props of the motion (an :class:`imesh.scene.Scene` in the robot's
            world: ``OUT.scene.npz``), drawn as translucent meshes; None: none.
    """
    return build_robots_scene(
        [SceneRobot(robot, motion, markers=markers, source=source, metrics=metrics,
                    collisions=collisions, physics=physics)],
        title=title or f"{robot.name} motion", props=props)


def build_robots_scene(robots: Sequence[SceneRobot], *, title: str, props=None,
                       pair: PairView | None = None) -> dict:
    """Everything the viewer draws for one or more robots in one world, JSON-ready.

    The robots are drawn where their motions put them (two partners share one world: no
    offset). Every robot carries its own overlays: markers, human source, interaction mesh,
    soles, support polygon, ZMP, self-collisions, limits and DART simulation.

    Args:
        robots: the robots (one, or the two of a pair), all with the same frame count and
            frame rate.
        title: page title.
        props: an :class:`imesh.scene.Scene` in the robot's world (its ``props``: name,
            ``vertices_m`` (V, 3) [m], ``faces`` (F, 3)), drawn as static meshes; None: none.
        pair: the pair's figures and per-frame distance (:class:`PairView`), or None.

    Returns:
        dict: ``version`` (2), ``title``, ``fps``, ``frames`` (T), ``beside_m`` (how far the
        markers and the human source are drawn beside the robots [m]), ``models`` (per robot
        model: ``links``, ``root_link``, ``meshes`` in link frames, ``collision_bodies``: the
        bodies of the self-collision check, name and link indices), ``robots`` (one entry per
        robot, :func:`robot_entry`), ``props`` (name, ``vertices`` (V, 3) float32 [m],
        ``faces`` (F, 3) uint32), and with ``pair`` a ``pair`` entry (``metrics``,
        ``distance_mm`` (T,), ``held`` (T,)).

    Raises:
        ImeshError: no robot, or robots whose frame counts or rates differ.
    """
    if not robots:
        raise ImeshError("a viewer scene needs at least one robot motion")
    T, fps = robots[0].motion.n_frames, float(robots[0].motion.fps)
    for r in robots[1:]:
        if r.motion.n_frames != T or abs(float(r.motion.fps) - fps) > 1e-6 * fps:
            raise ImeshError(
                f"viewer: robots of one scene need one timeline: {robots[0].robot.name} has "
                f"{T} frames at {fps:g} fps, {r.robot.name} {r.motion.n_frames} at "
                f"{r.motion.fps:g} fps")
    models: dict[str, dict] = {}
    keys: dict[tuple[str, str], str] = {}  # (name, URDF) -> key: one entry per robot model
    entries = []
    for r in robots:
        model = (r.robot.name, str(getattr(r.robot, "urdf", "")))
        if model not in keys:
            keys[model] = r.robot.name if r.robot.name not in models else \
                f"{r.robot.name}-{len(models)}"
            models[keys[model]] = model_entry(r.robot)
        key = keys[model]
        entries.append(robot_entry(r, models[key], key))
    scene: dict = {"version": 2, "title": title, "fps": fps, "frames": T,
                   "beside_m": _beside_m(entries, models), "models": models, "robots": entries,
                   "props": props_entry(props)}
    if pair is not None:
        scene["pair"] = pair_entry(pair, T)
    return scene


def robot_view(scene: Mapping, index: int = 0) -> dict:
    """Robot ``index`` of a scene with its model's entries (``links``, ``meshes``,
    ``collision_bodies`` ...) merged in: what :func:`build_scene` returned for one robot before
    scenes held several."""
    entry = scene["robots"][index]
    return {**scene["models"][entry["model"]], **entry}


def model_entry(robot) -> dict:
    """The parts of a scene shared by the robots of one model: ``links`` (the links with a
    visual mesh, sorted), ``root_link``, ``meshes`` (vertices [m] in the link frame, faces,
    colour) and ``collision_bodies`` (name and link indices of each body of the self-collision
    check)."""
    meshes = visual_meshes(robot)
    links = sorted({m.link for m in meshes})
    members, _ = robot_bodies(robot)
    return {
        "name": robot.name, "links": links,
        "root_link": robot.waist_frame if robot.waist_frame in links else links[0],
        "meshes": [{"link": links.index(m.link), "color": list(m.color),
                    "vertices": encode(m.vertices), "faces": encode(m.faces, "uint32")}
                   for m in meshes],
        "collision_bodies": [{"name": b, "links": [links.index(m) for m in members[b]
                                                   if m in links]} for b in sorted(members)],
    }


def robot_entry(r: SceneRobot, model: Mapping, key: str) -> dict:
    """One robot of a scene (see :func:`build_robots_scene`).

    Returns:
        dict: ``model`` (the key of its entry in ``models``), ``name``, ``label``,
        ``link_poses`` (T, L, 7: position [m], quaternion x y z w, of the model's ``links``),
        ``markers``, ``source``, ``mesh_edges``, ``soles`` (T, 2, 4, 3), ``support`` (T, 2),
        ``polygons`` (T, 8, 2) with ``polygon_sizes`` (T,), ``zmp`` and ``zmp_desired``
        (T, 2), ``zmp_inside`` (T,), ``collisions`` (per frame the body pairs penetrating
        deeper than 5 mm on the URDF geometry: [body a, body b, depth mm], bodies indexing the
        model's ``collision_bodies``), ``limits`` (per frame the joints outside a limit), with
        ``metrics`` the metric values, and with ``physics`` the ``simulation`` entry.
    """
    robot, motion = r.robot, r.motion
    q = np.asarray(motion.q, dtype=float)
    T, fps = len(q), float(motion.fps)
    links = list(model["links"])
    link_ids = [robot.frame_id(n) for n in links]
    entry: dict = {"model": key, "name": robot.name, "label": r.label or robot.name,
                   "link_poses": encode(link_poses(robot, q, link_ids))}

    markers = r.markers if r.markers is not None else motion.adapted
    lead = (0, 0)
    if markers is not None and markers.n_frames == T:
        entry["markers"] = _marker_entry(markers.positions_m, markers.names,
                                         "adapted markers (the robot's targets)")
        entry["mesh_edges"] = _mesh_edges(markers.positions_m)
        lead = lead_frames(markers.positions_m)
    elif markers is not None:
        log.warning("viewer: %d adapted-marker frames for %d motion frames: not drawn",
                    markers.n_frames, T)
    if r.source is not None:
        try:
            entry["source"] = _source_entry(r.source, robot, fps, T, lead, r.source_scale,
                                            r.source_centre_m)
        except ImeshError as exc:  # the robot motion is still worth showing
            log.warning("viewer: the human source is not drawn: %s", exc)

    # soles, support, ZMP
    soles = sole_tracks(robot, q, fps)
    support = motion_support(soles, motion.contact_modes).support
    zmp = zmp_report(zmp_trajectory(robot, q, fps), soles, support)
    polys = support_polygons(soles, support)
    width = max((len(p) for p in polys if p is not None), default=1)
    poly_arr = np.zeros((T, width, 2), dtype=np.float32)
    sizes = np.zeros(T, dtype=np.uint8)
    for t, p in enumerate(polys):
        if p is not None:
            poly_arr[t, :len(p)] = p
            sizes[t] = len(p)
    entry["soles"] = encode(np.stack([soles.corners[s] for s in SIDES], axis=1))
    entry["support"] = encode(support.astype(np.uint8), "uint8")
    entry["polygons"] = encode(poly_arr)
    entry["polygon_sizes"] = encode(sizes, "uint8")
    entry["zmp"] = encode(np.nan_to_num(zmp.zmp_m))
    entry["zmp_desired"] = encode(np.nan_to_num(zmp.desired_m))
    entry["zmp_inside"] = encode(zmp.inside.astype(np.uint8), "uint8")

    # self-collisions (the evaluator's check) and limits per frame
    collisions = r.collisions if r.collisions is not None else check_self_collisions(robot, q)
    body_index = {b["name"]: i for i, b in enumerate(model["collision_bodies"])}
    entry["collisions"] = [[[body_index[a_], body_index[b_], round(1e3 * d, 1)]
                            for a_, b_, d in hits] for hits in collisions.mesh.frame_hits()]
    entry["limits"] = _limit_frames(robot, q, fps)
    if r.metrics is not None:
        entry["metrics"] = dict(metric_values(r.metrics))
    if r.physics is not None:
        sim = simulation_entry(robot, r.physics, link_ids, T)
        if sim is not None:
            entry["simulation"] = sim
    return entry


def props_entry(props) -> list[dict]:
    """The props of a robot-world :class:`imesh.scene.Scene` for the page: name, vertices
    (V, 3) float32 [m] in the world, faces (F, 3) uint32; [] for None."""
    if props is None:
        return []
    frame = getattr(props, "frame", "robot")
    if frame != "robot":
        log.warning("viewer: props in the %r frame are drawn as they are, not scaled to the "
                    "robot", frame)
    return [{"name": p.name, "vertices": encode(np.asarray(p.vertices_m, dtype=float)),
             "faces": encode(np.asarray(p.faces), "uint32")} for p in props.props]


def pair_entry(pair: PairView, n_frames: int) -> dict:
    """The ``pair`` entry of a scene: ``metrics`` (JSON numbers; NaN as None), ``distance_mm``
    (T,) float32 (+inf: beyond the broad phase) and ``held`` (T,) uint8 when given."""
    def number(v):
        if isinstance(v, float) and not np.isfinite(v):
            return None
        return v

    entry: dict = {"metrics": {k: number(v) for k, v in pair.metrics.items()}}
    for name, arr, dtype, scale in (("distance_mm", pair.distance_m, "float32", 1e3),
                                    ("held", pair.held, "uint8", 1)):
        if arr is None:
            continue
        arr = np.asarray(arr, dtype=float)
        if arr.shape != (n_frames,):
            log.warning("viewer: the pair's %s has %s values for %d frames: not drawn", name,
                        arr.shape, n_frames)
            continue
        entry[name] = encode(arr * scale, dtype)
    return entry


def _beside_m(entries: Sequence[Mapping], models: Mapping[str, Mapping]) -> float:
    """How far beside the robots the markers and the source are drawn [m]: 1 m beside one
    robot, 1 m beyond the robots' sideways (y) spread for several."""
    if len(entries) < 2:
        return 1.0
    ys = []
    for e in entries:
        model = models[e["model"]]
        poses = decode(e["link_poses"])
        ys.append(poses[:, model["links"].index(model["root_link"]), 1])
    ys_all = np.concatenate(ys)
    return float(np.round(1.0 + ys_all.max() - ys_all.min(), 1))


def _limit_frames(robot, q: np.ndarray, fps: float) -> list[list[str]]:
    """Per frame the joints outside their position, velocity or acceleration limit (the
    evaluator's tests, :func:`imesh.metrics.limits.limit_violations`)."""
    qj = q[:, 7:]
    over = (qj > robot.q_upper + 1e-6) | (qj < robot.q_lower - 1e-6)
    if len(qj) > 1:
        over[1:] |= np.abs(np.diff(qj, axis=0)) * fps / robot.v_max > 1.0 + 1e-6
    if len(qj) > 2:
        over[1:-1] |= np.abs(np.diff(qj, n=2, axis=0)) * fps * fps / robot.a_max > 1.0 + 1e-6
    names = robot.joint_names
    return [[names[j] for j in np.flatnonzero(row)] for row in over]


def _source_entry(source, robot, fps: float, T: int, lead: tuple[int, int],
                  scale: float | None = None, centre_m: np.ndarray | None = None) -> dict:
    """The arranged human clip at the motion's rate, frames shifted by the lead-in (held still
    over the lead-in/out); the page draws it beside the robot. With ``scale`` (a pair's shared
    scale about ``centre_m``) ``source`` is the person's standard markers
    (:func:`imesh.pipeline.retarget.working_markers`), arranged with that scale (in the pair's
    world), else it is arranged as :func:`imesh.evaluate.motion_files.arranged_source` does."""
    if scale is None:
        src = arranged_source(source, robot)
    else:
        src = arrange_for_robot(source, robot, scale=scale, centre_m=centre_m).motion
    if abs(src.fps - fps) > 1e-6 * fps:
        src = src.resample(fps)
    pos = src.positions_m
    idx = np.clip(np.arange(T) - lead[0], 0, len(pos) - 1)
    return _marker_entry(pos[idx], src.names, "human source (arranged to the robot's size)")


def held_frames(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The simulated configurations with every frame the simulation did not reach (NaN rows:
    after a fall, or past its end) holding the last simulated one.

    Args:
        q: (T, nq) float configurations, NaN rows where not simulated.

    Returns:
        (q_held (T, nq) float, simulated (T,) bool: the row is the simulation's own). Before the
        first simulated frame (none simulated at all) the first finite row is used; with no
        finite row at all, q_held is all NaN.
    """
    q = np.asarray(q, dtype=float)
    simulated = np.all(np.isfinite(q), axis=1)
    if not simulated.any():
        return q.copy(), simulated
    idx = np.where(simulated, np.arange(len(q)), 0)
    idx = np.maximum.accumulate(idx)
    first = int(np.argmax(simulated))
    idx[:first] = first
    return q[idx], simulated


def simulation_entry(robot, physics, link_ids: list[int], n_frames: int) -> dict | None:
    """The simulated motion of a DART check for the viewer, frame-aligned with the motion.

    Args:
        robot: the :class:`imesh.robot.Robot` of the motion.
        physics: its :class:`imesh.physics.PhysicsResult` (one row per motion frame).
        link_ids: the frame ids of the scene's ``links``.
        n_frames: T, the motion's frames.

    Returns:
        None when the result does not fit the motion (other robot or frame count: logged), else
        a dict: ``controller``, ``fell``, ``fall_reason``, ``survived_s`` [s] (the fall time,
        or the motion's duration), ``duration_s`` [s], ``keypoint_rms_mm`` and
        ``keypoint_max_mm`` (the result's figures, None when NaN), ``ground_offset_m``,
        ``link_poses`` (T, L, 7) float32 world poses of the simulated links at the motion's
        frame times (position [m], quaternion x y z w; a frame the simulation did not reach
        holds the last simulated pose), ``simulated`` (T,) uint8 (1: the simulation's own
        frame, 0: held), ``keypoint_error_mm`` (T,) float32 RMS over the key points of the
        distance between the simulated and the reference key points of each frame [mm] (NaN
        on held frames; absent without markers.toml).
    """
    if physics.robot != robot.name or len(physics.q) != n_frames:
        log.warning("viewer: the DART result (%s, %d frames) does not fit the motion (%s, %d "
                    "frames): not drawn", physics.robot, len(physics.q), robot.name, n_frames)
        return None
    q_held, simulated = held_frames(physics.q)
    if not simulated.any():
        log.warning("viewer: the DART result has no simulated frame: not drawn")
        return None

    def number(x: float) -> float | None:
        return float(x) if np.isfinite(x) else None

    entry: dict = {
        "controller": physics.config.control.controller, "fell": bool(physics.fell),
        "fall_reason": physics.fall_reason, "survived_s": float(physics.survived_s),
        "duration_s": float(physics.duration_s),
        "keypoint_rms_mm": number(physics.keypoint_rms_mm),
        "keypoint_max_mm": number(physics.keypoint_max_mm),
        "ground_offset_m": float(physics.ground_offset_m),
        "link_poses": encode(link_poses(robot, q_held, link_ids)),
        "simulated": encode(simulated.astype(np.uint8), "uint8"),
    }
    if robot.markers is not None:
        ok = np.flatnonzero(simulated)
        err = np.full(n_frames, np.nan, dtype=np.float32)
        sim = keypoint_motion(robot, physics.q[ok], physics.fps).positions_m
        ref = keypoint_motion(robot, physics.q_reference[ok], physics.fps).positions_m
        err[ok] = 1e3 * np.sqrt(np.mean(np.sum((sim - ref) ** 2, axis=-1), axis=-1))
        entry["keypoint_error_mm"] = encode(err)
    return entry

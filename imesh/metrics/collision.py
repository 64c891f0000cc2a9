"""Collision and ground checks of a robot motion.

- Self-collision on the capsules (:func:`check_capsule_collisions`, what the evaluator reports
  as ``self_collision_frames``: the proxies and ignore list the whole-body solve keeps apart,
  docs/collision.md) and on the URDF's own geometry with coal (:func:`check_mesh_collisions`,
  to validate the capsules: its collision elements, or its visual meshes for HRP-4C).
- Self-collision on the primitive proxies (python-fcl, :func:`check_self_collisions`; the
  evaluator's metric before the capsules): every pair of proxies on different links not in
  ``Robot.ignored_pairs``; a pair penetrating deeper than ``depth`` (5 mm) flags the frame;
  a bounding sphere test skips far pairs; agrees with :meth:`imesh.robot.Robot.self_collisions`.
- Ground: the lowest point of all proxies per frame (penetration below z = 0), and floating:
  the lowest point more than ``float_m`` (2 cm) above the ground while a foot is planted.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from ..robot.capsules.mesh_check import MeshCollisionChecker
from ..robot.collision import _fcl as load
from ..robot.collision import fcl_geometry, pair_key

log = logging.getLogger(__name__)

#: Penetration depth that flags a self-collision [m] (DESIGN.md: 5 mm).
SELF_COLLISION_DEPTH_M = 0.005
#: Lowest point above the ground that counts as floating while a foot is planted [m].
FLOAT_M = 0.02


def _fcl():
    return load()


@dataclass(frozen=True)
class PairHit:
    """One colliding frame pair over a motion.

    Attributes:
        frames: (frame_a, frame_b) link names, sorted.
        max_depth_m: deepest penetration [m].
        worst_frame: the frame index of the deepest penetration.
        n_frames: frames where this pair penetrates deeper than the threshold.
        first_frame: first such frame.
    """

    frames: tuple[str, str]
    max_depth_m: float
    worst_frame: int
    n_frames: int
    first_frame: int


@dataclass(frozen=True, eq=False)
class SelfCollisionReport:
    """Self-collisions of a motion.

    Attributes:
        colliding: (T,) bool frames with a pair penetrating deeper than ``depth_m``.
        depth_m: the threshold [m].
        pairs: colliding pairs, deepest first.
        max_depth_m: (T,) float deepest penetration per frame [m] (0 where none is found).
    """

    colliding: np.ndarray
    depth_m: float
    pairs: list[PairHit] = field(default_factory=list)
    max_depth_m: np.ndarray | None = None

    @property
    def n_frames(self) -> int:
        """Frames with a self-collision (DESIGN.md ``self_collision_frames``)."""
        return int(self.colliding.sum())

    def summary(self, top: int = 5) -> dict:
        return {
            "frames": self.n_frames,
            "depth_threshold_mm": 1e3 * self.depth_m,
            "worst_pairs": [{"pair": list(p.frames), "max_depth_mm": round(1e3 * p.max_depth_m, 1),
                             "frames": p.n_frames, "first_frame": p.first_frame,
                             "worst_frame": p.worst_frame} for p in self.pairs[:top]],
        }


class SelfCollisionChecker:
    """Self-collision queries of one robot over many configurations.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        exclude: frame pairs not checked (default ``robot.ignored_pairs``).
    """

    def __init__(self, robot, exclude: set[tuple[str, str]] | None = None):
        fcl = _fcl()
        self.robot = robot
        shapes = robot.collision_shapes
        exclude = robot.ignored_pairs if exclude is None else exclude
        pairs = [(i, j) for i in range(len(shapes)) for j in range(i + 1, len(shapes))
                 if shapes[i].frame != shapes[j].frame
                 and pair_key(shapes[i].frame, shapes[j].frame) not in exclude]
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.keys = [pair_key(shapes[i].frame, shapes[j].frame) for i, j in pairs]
        # bounding sphere of every shape about its own centre (placement origin)
        self.radius = np.array([np.linalg.norm(
            s.support_points(32) - s.placement[:3, 3], axis=1).max() for s in shapes])
        self._objects = [fcl.CollisionObject(fcl_geometry(s), fcl.Transform()) for s in shapes]
        self._request = fcl.DistanceRequest(enable_signed_distance=True)

    def penetrations(self, q: np.ndarray, margin: float = 0.0) -> dict[tuple[str, str], float]:
        """Signed distances [m] of the frame pairs whose bounding spheres overlap at ``q``
        (negative = penetration depth; minimum over the frames' shapes). Pairs farther apart
        than their bounding spheres plus ``margin`` are left out."""
        fcl = _fcl()
        poses = self.robot.shape_poses(q)
        centres = poses[:, :3, 3]
        i, j = self.pairs[:, 0], self.pairs[:, 1]
        gap = np.linalg.norm(centres[i] - centres[j], axis=1) - self.radius[i] - self.radius[j]
        out: dict[tuple[str, str], float] = {}
        placed: set[int] = set()
        for k in np.flatnonzero(gap < margin):
            a, b = int(i[k]), int(j[k])
            for s in (a, b):
                if s not in placed:
                    T = poses[s]
                    self._objects[s].setTransform(fcl.Transform(T[:3, :3], T[:3, 3]))
                    placed.add(s)
            d = fcl.distance(self._objects[a], self._objects[b], self._request,
                             fcl.DistanceResult())
            key = self.keys[k]
            out[key] = min(out.get(key, np.inf), float(d))
        return out

    def collisions(self, q: np.ndarray, depth: float = SELF_COLLISION_DEPTH_M
                   ) -> list[tuple[str, str, float]]:
        """Frame pairs penetrating deeper than ``depth`` [m] at ``q``: (frame_a, frame_b,
        depth [m]), deepest first (as :meth:`imesh.robot.Robot.self_collisions`)."""
        hits = [(a, b, -d) for (a, b), d in self.penetrations(q).items() if -d > depth]
        return sorted(hits, key=lambda h: -h[2])


def check_self_collisions(robot, q: np.ndarray, depth: float = SELF_COLLISION_DEPTH_M,
                          checker: SelfCollisionChecker | None = None) -> SelfCollisionReport:
    """Self-collisions over a motion (DESIGN.md ``self_collision_frames``).

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) float configurations (``RobotMotion.q``).
        depth: penetration threshold [m] (default 5 mm).
        checker: a reusable :class:`SelfCollisionChecker` of this robot.

    Returns:
        SelfCollisionReport: colliding frames and the worst pairs.
    """
    checker = checker or SelfCollisionChecker(robot)
    q = np.asarray(q, dtype=float)
    colliding = np.zeros(len(q), dtype=bool)
    deepest = np.zeros(len(q))
    stats: dict[tuple[str, str], list] = {}
    for t, qt in enumerate(q):
        for a, b, d in checker.collisions(qt, depth):
            colliding[t] = True
            deepest[t] = max(deepest[t], d)
            s = stats.get((a, b))
            if s is None:
                stats[(a, b)] = [d, t, 1, t]
            else:
                if d > s[0]:
                    s[0], s[1] = d, t
                s[2] += 1
    pairs = sorted((PairHit(frames=k, max_depth_m=v[0], worst_frame=v[1], n_frames=v[2],
                            first_frame=v[3]) for k, v in stats.items()),
                   key=lambda p: -p.max_depth_m)
    if pairs:
        log.info("self-collision in %d of %d frames; deepest %s-%s %.1f mm at frame %d",
                 colliding.sum(), len(q), *pairs[0].frames, 1e3 * pairs[0].max_depth_m,
                 pairs[0].worst_frame)
    return SelfCollisionReport(colliding=colliding, depth_m=depth, pairs=pairs,
                               max_depth_m=deepest)


def check_capsule_collisions(robot, q: np.ndarray, depth: float = SELF_COLLISION_DEPTH_M
                             ) -> SelfCollisionReport:
    """Self-collisions over a motion on the robot's capsules (``Robot.capsule_model``: the
    proxies and ignore list the whole-body solve keeps apart; DESIGN.md
    ``self_collision_frames``). Pairs are body pairs.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) float configurations.
        depth: penetration threshold [m] (default 5 mm).
    """
    model = robot.capsule_model()
    q = np.asarray(q, dtype=float)
    T = len(q)
    if not len(model.pairs) or not T:
        return SelfCollisionReport(colliding=np.zeros(T, bool), depth_m=depth,
                                   max_depth_m=np.zeros(T))
    placements = robot.trajectory_kinematics(q, model.frames).placements
    d = model.distances(placements).distance  # (T, P)
    return _report_from_distances(d, model.pair_bodies, depth)


def _report_from_distances(d: np.ndarray, keys: list, depth: float) -> SelfCollisionReport:
    """A SelfCollisionReport from (T, P) signed distances of pairs named ``keys``."""
    T = len(d)
    names = list(dict.fromkeys(keys))
    col = {key: k for k, key in enumerate(names)}
    per_key = np.full((T, len(names)), np.inf)
    for k, key in enumerate(keys):  # a body pair: the minimum over its capsule pairs
        per_key[:, col[key]] = np.minimum(per_key[:, col[key]], d[:, k])
    d = per_key
    pen = np.maximum(-d, 0.0)
    hit = pen > depth
    stats: dict[tuple[str, str], list] = {}
    for k, key in enumerate(names):
        frames = np.flatnonzero(hit[:, k])
        if len(frames):
            worst = int(np.argmax(pen[:, k]))
            stats[key] = [float(pen[worst, k]), worst, len(frames), int(frames[0])]
    pairs = sorted((PairHit(frames=k, max_depth_m=v[0], worst_frame=v[1], n_frames=v[2],
                            first_frame=v[3]) for k, v in stats.items()),
                   key=lambda p: -p.max_depth_m)
    deepest = pen.max(axis=1) if d.shape[1] else np.zeros(T)
    colliding = hit.any(axis=1) if d.shape[1] else np.zeros(T, bool)
    if pairs:
        log.info("self-collision in %d of %d frames; deepest %s-%s %.1f mm at frame %d",
                 colliding.sum(), T, *pairs[0].frames, 1e3 * pairs[0].max_depth_m,
                 pairs[0].worst_frame)
    return SelfCollisionReport(colliding=colliding, depth_m=depth, pairs=pairs,
                               max_depth_m=deepest)


def check_mesh_collisions(robot, q: np.ndarray, depth: float = SELF_COLLISION_DEPTH_M,
                          broad_m: float = 0.05) -> SelfCollisionReport:
    """Self-collisions over a motion on the URDF's own geometry (coal; its collision elements,
    or its visual meshes for a robot whose capsules are fitted to them (HRP-4C); intersecting
    meshes as convex hulls, :class:`imesh.robot.capsules.mesh_check.MeshCollisionChecker`), for
    the body pairs the capsules check. Only pairs whose capsules are closer than ``broad_m`` reach
    coal (the capsules enclose the geometry, so farther pairs cannot touch).
    """
    checker = MeshCollisionChecker(robot)
    model = robot.capsule_model()
    q = np.asarray(q, dtype=float)
    T = len(q)
    keys = checker.pairs
    d = np.full((T, len(keys)), np.inf)
    if T and keys:
        placements = robot.trajectory_kinematics(q, model.frames).placements
        cap = model.distances(placements).distance
        close: dict[tuple[str, str], np.ndarray] = {}
        for k, key in enumerate(model.pair_bodies):
            m = cap[:, k] < broad_m
            close[key] = close[key] | m if key in close else m
        index = {key: k for k, key in enumerate(keys)}
        for t in range(T):
            pairs = [key for key in keys if key in close and close[key][t]]
            if pairs:
                for key, dist in checker.distances(q[t], pairs).items():
                    d[t, index[key]] = dist
    return _report_from_distances(d, keys, depth)


# ----------------------------------------------------------------------------------------------
# ground


class LowestPoint:
    """Vectorized lowest point of a robot's collision proxies (``Robot.lowest_point`` for many
    frames).

    Args:
        robot: an :class:`imesh.robot.Robot`.
    """

    def __init__(self, robot):
        self.robot = robot
        local, owner, lift = [], [], []
        for k, s in enumerate(robot.collision_shapes):
            if s.kind == "sphere":  # exact: centre height minus radius
                pts = np.zeros((1, 3))
                drop = s.dims[0]
            else:
                frame_pts = s.support_points(n_circle=32)
                pts = (frame_pts - s.placement[:3, 3]) @ s.placement[:3, :3]
                drop = 0.0
            local.append(pts)
            owner += [k] * len(pts)
            lift += [drop] * len(pts)
        self.local = np.concatenate(local)
        self.owner = np.asarray(owner)
        self.drop = np.asarray(lift)
        self.frames = [s.frame for s in robot.collision_shapes]

    def heights(self, q: np.ndarray) -> np.ndarray:
        """(S,) float [m] lowest z of every proxy at ``q``."""
        poses = self.robot.shape_poses(q)
        z = (np.einsum("pj,pj->p", poses[self.owner, 2, :3], self.local)
             + poses[self.owner, 2, 3] - self.drop)
        out = np.full(len(poses), np.inf)
        np.minimum.at(out, self.owner, z)
        return out


@dataclass(frozen=True, eq=False)
class GroundReport:
    """Ground contact quality of a motion.

    Attributes:
        lowest_m: (T,) float [m] lowest point of any proxy per frame (negative = below ground).
        lowest_frame: (T,) link owning the lowest point per frame.
        penetration_mm: deepest penetration below z = 0 over the motion [mm] (0 if none).
        worst_frame: frame of the deepest penetration (-1 if none).
        floating: (T,) bool frames whose lowest point is more than ``float_m`` above the ground
            while a foot is planted (None when not checked).
        float_m: the floating threshold [m].
    """

    lowest_m: np.ndarray
    lowest_frame: list[str]
    penetration_mm: float
    worst_frame: int
    floating: np.ndarray | None
    float_m: float = FLOAT_M

    @property
    def penetrating(self) -> np.ndarray:
        """(T,) bool frames with any proxy below z = 0."""
        return self.lowest_m < 0

    def summary(self) -> dict:
        out = {
            "penetration_mm": round(self.penetration_mm, 2),
            "worst_frame": self.worst_frame,
            "worst_link": self.lowest_frame[self.worst_frame] if self.worst_frame >= 0 else None,
            "frames_below_ground": int(self.penetrating.sum()),
            "frames_below_5mm": int((self.lowest_m < -0.005).sum()),
        }
        if self.floating is not None:
            out["floating_frames"] = int(self.floating.sum())
            out["floating_threshold_mm"] = 1e3 * self.float_m
        return out


def check_ground(robot, q: np.ndarray, planted: np.ndarray | None = None,
                 float_m: float = FLOAT_M) -> GroundReport:
    """Ground penetration and floating over a motion (DESIGN.md ``ground_penetration_mm``).

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) float configurations.
        planted: (T, 2) bool feet planted (e.g. :func:`imesh.metrics.support.planted_feet`)
            for the floating check; None skips it.
        float_m: lowest point above this while a foot is planted is floating [m].
    """
    low = LowestPoint(robot)
    q = np.asarray(q, dtype=float)
    lowest = np.empty(len(q))
    owner = []
    for t, qt in enumerate(q):
        h = low.heights(qt)
        k = int(np.argmin(h))
        lowest[t] = h[k]
        owner.append(low.frames[k])
    worst = int(np.argmin(lowest)) if len(q) else -1
    pen = float(max(0.0, -lowest[worst]) * 1e3) if len(q) else 0.0
    if pen == 0.0:
        worst = -1
    floating = None
    if planted is not None:
        floating = (lowest > float_m) & np.asarray(planted, dtype=bool).any(axis=1)
    return GroundReport(lowest_m=lowest, lowest_frame=owner, penetration_mm=pen,
                        worst_frame=worst, floating=floating, float_m=float_m)

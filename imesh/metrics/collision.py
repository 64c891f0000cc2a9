"""Collision and ground checks of a robot motion.

- Self-collision (:func:`check_self_collisions`): scored on the URDF's own geometry (coal; the
  geometry the capsules enclose: its collision elements, or its visual meshes for HRP-4C), for
  the body pairs the whole-body solve keeps apart (its capsules' pairs and ignore list,
  ``robots/<name>/collision_pairs.toml``); the capsules are the broad phase (they enclose the
  geometry, so only pairs whose capsules touch reach coal) and their own figure is reported
  beside the meshes' (docs/collision.md). A pair penetrating deeper than ``depth`` (5 mm) flags
  the frame. The evaluator's ``self_collision_frames`` and the viewer's red links are this one
  result.
- Ground: the lowest point of all proxies per frame (penetration below z = 0), and floating:
  the lowest point more than ``float_m`` (2 cm) above the ground while a foot is planted.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..robot.capsules.mesh_check import MeshCollisionChecker
from ..robot.capsules.pairs import capsule_source

log = logging.getLogger(__name__)

#: Penetration depth that flags a self-collision [m] (DESIGN.md: 5 mm).
SELF_COLLISION_DEPTH_M = 0.005
#: Lowest point above the ground that counts as floating while a foot is planted [m].
FLOAT_M = 0.02
#: Body pairs whose capsules are closer than this [m] in a frame are measured on the URDF
#: geometry (coal); farther ones cannot touch: the capsules enclose the geometry, so its
#: distance is at least theirs (measured: >= capsule distance + 0.27 mm over 20,000 samples
#: within 2 cm on the 12 default outputs of docs/collision.md; tests/test_collision.py).
MESH_BROAD_PHASE_M = 0.001
#: Frames checked at a time (the capsule distances of all pairs: memory grows with it).
BLOCK_FRAMES = 2048


@dataclass(frozen=True)
class PairHit:
    """One colliding body pair over a motion.

    Attributes:
        frames: (body_a, body_b) body (link) names, sorted.
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
    """Self-collisions of a motion on one geometry.

    Attributes:
        colliding: (T,) bool frames with a pair penetrating deeper than ``depth_m``.
        depth_m: the threshold [m].
        pairs: colliding pairs, deepest first.
        max_depth_m: (T,) float deepest penetration per frame [m] (0 where none is found).
        hit_frame: (H,) int frame of every (frame, pair) penetrating deeper than ``depth_m``.
        hit_pair: the H body pairs (sorted names) of those hits.
        hit_depth_m: (H,) float their penetration [m].
        geometry: what was measured: ``capsules``, or ``collision``/``visual`` (the URDF's
            collision elements or visual meshes).
    """

    colliding: np.ndarray
    depth_m: float
    pairs: list[PairHit] = field(default_factory=list)
    max_depth_m: np.ndarray | None = None
    hit_frame: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    hit_pair: tuple[tuple[str, str], ...] = ()
    hit_depth_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    geometry: str = "capsules"

    @property
    def n_frames(self) -> int:
        """Frames with a self-collision (DESIGN.md ``self_collision_frames``)."""
        return int(self.colliding.sum())

    @property
    def deepest_mm(self) -> float:
        """[mm] the deepest penetration over the motion (0 if none)."""
        return 1e3 * float(self.max_depth_m.max(initial=0.0)) if self.max_depth_m is not None \
            else 0.0

    def frame_hits(self) -> list[list[tuple[str, str, float]]]:
        """Per frame the pairs deeper than ``depth_m``: (body_a, body_b, depth [m]), deepest
        first (what the viewer paints red)."""
        out: list[list[tuple[str, str, float]]] = [[] for _ in range(len(self.colliding))]
        for t, key, d in zip(self.hit_frame, self.hit_pair, self.hit_depth_m, strict=True):
            out[int(t)].append((key[0], key[1], float(d)))
        for hits in out:
            hits.sort(key=lambda h: -h[2])
        return out

    def summary(self, top: int = 5) -> dict:
        return {
            "frames": self.n_frames,
            "depth_threshold_mm": 1e3 * self.depth_m,
            "deepest_mm": round(self.deepest_mm, 2),
            "worst_pairs": [{"pair": list(p.frames), "max_depth_mm": round(1e3 * p.max_depth_m, 1),
                             "frames": p.n_frames, "first_frame": p.first_frame,
                             "worst_frame": p.worst_frame} for p in self.pairs[:top]],
        }


@dataclass(frozen=True, eq=False)
class SelfCollisions:
    """Self-collisions of a motion on the URDF's geometry and on the capsules, same body pairs.

    Attributes:
        mesh: on the URDF's own geometry (what ``self_collision_frames`` reports).
        capsules: on the capsules the whole-body solve keeps apart.
        mesh_queries: (frame, pair) samples measured with coal (capsules closer than the
            broad phase).
    """

    mesh: SelfCollisionReport
    capsules: SelfCollisionReport
    mesh_queries: int = 0


def _report(n: int, depth: float, geometry: str, hit_frame: np.ndarray,
            hit_pair: Sequence[tuple[str, str]], hit_depth: np.ndarray,
            max_depth: np.ndarray) -> SelfCollisionReport:
    """A report of ``n`` frames from its hits ((H,) frames, pairs, depths [m] deeper than
    ``depth``) and the (n,) deepest penetration per frame."""
    colliding = np.zeros(n, dtype=bool)
    colliding[hit_frame] = True
    stats: dict[tuple[str, str], list] = {}
    for t, key, d in zip(hit_frame.tolist(), hit_pair, hit_depth.tolist(), strict=True):
        s = stats.get(key)
        if s is None:
            stats[key] = [d, t, 1, t]
            continue
        if d > s[0]:
            s[0], s[1] = d, t
        s[2] += 1
        s[3] = min(s[3], t)
    pairs = sorted((PairHit(frames=k, max_depth_m=v[0], worst_frame=v[1], n_frames=v[2],
                            first_frame=v[3]) for k, v in stats.items()),
                   key=lambda p: -p.max_depth_m)
    return SelfCollisionReport(colliding=colliding, depth_m=depth, pairs=pairs,
                               max_depth_m=max_depth, hit_frame=hit_frame,
                               hit_pair=tuple(hit_pair), hit_depth_m=hit_depth,
                               geometry=geometry)


def _hits(d: np.ndarray, keys: Sequence[tuple[str, str]], depth: float, offset: int
          ) -> tuple[np.ndarray, list[tuple[str, str]], np.ndarray, np.ndarray]:
    """(hit frames + ``offset``, hit pairs, hit depths [m], (T,) deepest penetration [m]) of
    (T, K) signed distances [m] of the pairs ``keys``."""
    pen = np.maximum(-d, 0.0)
    tt, kk = np.nonzero(pen > depth)
    deepest = pen.max(axis=1) if d.shape[1] else np.zeros(len(d))
    return tt + offset, [keys[int(k)] for k in kk], pen[tt, kk], deepest


def _body_distances(model, cap: np.ndarray, keys: Sequence[tuple[str, str]]) -> np.ndarray:
    """(T, K) the least capsule distance [m] of each body pair ``keys`` from (T, P) distances
    of the capsule pairs (``model.pair_bodies``); +inf for a body pair without capsules."""
    col = {key: k for k, key in enumerate(keys)}
    owner = np.array([col.get(key, -1) for key in model.pair_bodies], dtype=np.int64)
    out = np.full((len(cap), len(keys)), np.inf)
    keep = owner >= 0
    if keep.any():
        order = np.argsort(owner[keep], kind="stable")
        cols = owner[keep][order]
        starts = np.flatnonzero(np.r_[True, cols[1:] != cols[:-1]])
        out[:, cols[starts]] = np.minimum.reduceat(cap[:, keep][:, order], starts, axis=1)
    return out


def check_self_collisions(robot, q: np.ndarray, depth: float = SELF_COLLISION_DEPTH_M, *,
                          mesh: bool = True, broad_m: float = MESH_BROAD_PHASE_M,
                          block_frames: int = BLOCK_FRAMES) -> SelfCollisions:
    """Self-collisions over a motion, on the URDF's geometry and on the capsules
    (DESIGN.md ``self_collision_frames``: the mesh figure).

    The capsule distances of every checked pair are computed for all frames at once (numpy, in
    blocks of ``block_frames``); the body pairs whose capsules are closer than ``broad_m`` in a
    frame, and whose convex hulls (:mod:`imesh.robot.capsules.hulls`) are too, are then
    measured on the URDF's geometry with coal
    (:class:`imesh.robot.capsules.mesh_check.MeshCollisionChecker`, same pairs and ignore list).
    The rest cannot touch (the capsules and the hulls enclose the geometry) and count as
    clear.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) float configurations (``RobotMotion.q``).
        depth: penetration threshold [m] (default 5 mm).
        mesh: measure the URDF geometry (False: the capsules only; ``mesh`` is then an empty
            report).
        broad_m: the broad phase [m] (capsule distance below which coal is asked).
        block_frames: frames per block.

    Returns:
        SelfCollisions: the mesh and the capsule reports.
    """
    model = robot.capsule_model()
    # built at the first pair whose capsules touch: a clean motion needs no URDF mesh (G1: 2 s
    # to read them in a new process)
    checker: MeshCollisionChecker | None = None
    q = np.asarray(q, dtype=float)
    T = len(q)
    cap_keys = model.body_pairs
    hulls = model.body_hulls() if mesh else None
    mesh_keys = cap_keys  # the same body pairs (a body without geometry: never measured)
    cap_hits: list = [[], [], [], []]
    mesh_hits: list = [[], [], [], []]
    queries = 0
    for a in range(0, T, max(block_frames, 1)):
        qb = q[a:a + block_frames]
        if len(model.pairs):
            placements = robot.trajectory_kinematics(qb, model.frames).placements
            cap = model.distances(placements).distance  # (Tb, P)
        else:
            cap = np.zeros((len(qb), 0))
        for acc, part in zip(cap_hits, _hits(_body_distances(model, cap, cap_keys), cap_keys,
                                             depth, a), strict=True):
            acc.append(part)
        if not mesh:
            continue
        d = np.full((len(qb), len(mesh_keys)), np.inf)
        near = _body_distances(model, cap, mesh_keys) < broad_m
        if near.any() and hulls is not None:
            # the bodies' convex hulls enclose the geometry too: a pair whose hulls are apart
            # needs no mesh (the solve keeps hulls, not capsules, apart: most capsule overlaps
            # of a solved motion are such pairs)
            tt, kk = np.nonzero(near)
            near[tt, kk] = hulls.pair_distances(model, placements, tt, kk) < broad_m
        if near.any() and checker is None:
            checker = MeshCollisionChecker(robot)
        if checker is not None:  # pairs of bodies with geometry
            near &= np.array([a_ in checker.items and b_ in checker.items
                              for a_, b_ in mesh_keys])
        for t in np.flatnonzero(near.any(axis=1)):
            assert checker is not None
            placements_t = robot.frame_placements(qb[t], checker.frames)
            for k in np.flatnonzero(near[t]):
                d[t, k] = checker.pair_distance(placements_t, mesh_keys[k])
        queries += int(near.sum())
        for acc, part in zip(mesh_hits, _hits(d, mesh_keys, depth, a), strict=True):
            acc.append(part)

    def merged(parts: list, geometry: str) -> SelfCollisionReport:
        if not parts[0]:
            return _report(T, depth, geometry, np.zeros(0, dtype=np.int64), [], np.zeros(0),
                           np.zeros(T))
        return _report(T, depth, geometry, np.concatenate(parts[0]).astype(np.int64),
                       [k for keys in parts[1] for k in keys], np.concatenate(parts[2]),
                       np.concatenate(parts[3]))

    out = SelfCollisions(mesh=merged(mesh_hits, capsule_source(robot) if mesh else "none"),
                         capsules=merged(cap_hits, "capsules"), mesh_queries=queries)
    for r in (out.mesh, out.capsules):
        if r.pairs:
            log.info("self-collision on %s in %d of %d frames; deepest %s-%s %.1f mm at frame "
                     "%d", r.geometry, r.n_frames, T, *r.pairs[0].frames,
                     1e3 * r.pairs[0].max_depth_m, r.pairs[0].worst_frame)
    return out


def check_capsule_collisions(robot, q: np.ndarray, depth: float = SELF_COLLISION_DEPTH_M
                             ) -> SelfCollisionReport:
    """Self-collisions over a motion on the capsules alone (``check_self_collisions(...,
    mesh=False).capsules``: no coal).

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) float configurations.
        depth: penetration threshold [m] (default 5 mm).
    """
    return check_self_collisions(robot, q, depth, mesh=False).capsules


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

"""What a motion does to static props (boxes, steps): penetration, contacts, skid on any surface.

Props are convex polytopes given by their outward face planes, ``(K, 4)`` rows ``(n, d)`` with
``n . p <= d`` inside (:func:`imesh.scene.prop_planes`). The signed distance of a point is
``max_k (n_k . p - d_k)``: inside, minus the depth to the nearest face (exact); outside, the
distance to the farthest face plane (exact above a face, a lower bound near edges and corners).

- **Robot penetration** (:func:`prop_penetration`): the robot's collision proxies
  (``robot.collision_shapes``, the geometry of the ground check and the DART bodies), sampled by
  their support points (box corners; rings on round shapes; spheres exact) and posed at every
  frame; a prop's depth at a frame is the deepest proxy point inside it. Frames deeper than
  10 mm are counted as OmniRetarget's evaluation counts penetration below -10 mm.
- **Human contacts** (:func:`human_contacts`): an effector marker (toes, hands, knees) in
  contact with a prop when its signed distance is within a threshold (the markers are joint
  centres: a planted toe joint sits 2-4 cm above the surface, a kneeling knee 7-10 cm).
- **Contact preservation** (:func:`contact_preservation`): a human contact is kept when the
  robot link carrying that marker's key point (with the links rigidly attached to it) is within
  20 mm of the same prop's surface at the same frame: at most 20 mm away, and not sunk more
  than 20 mm into it (a link deep inside a box does not keep a contact with its top).
- **Skid on any surface** (:func:`surface_skid`): DESIGN.md's ``foot_skid_mm_per_frame`` (the
  mean horizontal slide per 1/30 s of a supporting sole) with each sample on its surface. The
  support is the one the flat-ground figure takes: the motion's planned contact modes when it
  carries them (each support sample on the surface nearest to the sole; planned slides and
  pivots apart), else the evaluator's detection with the height taken from each surface
  (lowest corner within 10 mm of it, at most 10 mm into a prop, centre slower than 0.5 m/s,
  hysteresis).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..contacts.phases import SIDES, Contacts
from .skid import SKID_THRESHOLD_MM, near_slides
from .soles import sole_tracks
from .support import SupportDetection

log = logging.getLogger(__name__)

__all__ = ["PENETRATION_COUNT_M", "CONTACT_KEPT_M", "HUMAN_CONTACT_M",
           "signed_distance", "ProxyPoints", "PropPenetration", "prop_penetration",
           "human_contacts", "HumanContacts", "link_distances", "contact_preservation",
           "ContactPreservation", "surface_skid", "SurfaceSkid", "top_contacts"]

#: Penetration deeper than this counts a frame [m] (OmniRetarget: frames below -10 mm).
PENETRATION_COUNT_M = 0.010
#: A human contact is kept when the robot's link is within this of the prop [m].
CONTACT_KEPT_M = 0.020
#: Human contact thresholds per effector marker [m]: signed distance of the joint centre.
HUMAN_CONTACT_M: Mapping[str, float] = {
    "toe_l": 0.06, "toe_r": 0.06, "hand_l": 0.06, "hand_r": 0.06, "knee_l": 0.10,
    "knee_r": 0.10}
#: A prop face supports a sole when its normal's z exceeds this (up to ~45 deg slopes).
UPWARD_NZ = 0.7
#: Frames posed at a time.
BLOCK_FRAMES = 256
#: Frame rate the skid is reported at (as :data:`imesh.metrics.skid.SKID_FPS`).
SKID_FPS = 30.0


def signed_distance(points: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """(...,) signed distance [m] of points (..., 3) to a convex prop ``planes`` (K, 4):
    negative inside (minus the depth to the nearest face)."""
    return np.max(points @ planes[:, :3].T - planes[:, 3], axis=-1)


@dataclass(frozen=True, eq=False)
class ProxyPoints:
    """The robot's collision proxies as points in their frames.

    Attributes:
        frames: (F,) frame names the points are attached to.
        local_m: (N, 3) points in their frame [m].
        owner: (N,) index into ``frames``.
        radius_m: (N,) radius to subtract from a point's distance (spheres: the centre with
            the radius; 0 for surface points).
        shape: (N,) index of the collision shape each point belongs to.
    """

    frames: tuple[str, ...]
    local_m: np.ndarray
    owner: np.ndarray
    radius_m: np.ndarray
    shape: np.ndarray

    @classmethod
    def of(cls, robot, n_circle: int = 16) -> ProxyPoints:
        """The support points of every ``robot.collision_shapes`` proxy."""
        frames = list(dict.fromkeys(s.frame for s in robot.collision_shapes))
        local, owner, radius, shape = [], [], [], []
        for k, s in enumerate(robot.collision_shapes):
            if s.kind == "sphere":
                pts, r = s.placement[:3, 3][None, :], s.dims[0]
            else:
                pts, r = s.support_points(n_circle=n_circle), 0.0
            local.append(pts)
            owner += [frames.index(s.frame)] * len(pts)
            radius += [r] * len(pts)
            shape += [k] * len(pts)
        return cls(tuple(frames), np.concatenate(local), np.asarray(owner),
                   np.asarray(radius, float), np.asarray(shape))

    def world(self, robot, q: np.ndarray) -> np.ndarray:
        """(T, N, 3) world points [m] at configurations q (T, nq)."""
        q = np.atleast_2d(np.asarray(q, float))
        out = np.empty((len(q), len(self.local_m), 3))
        for a in range(0, len(q), BLOCK_FRAMES):
            poses = robot.trajectory_kinematics(q[a:a + BLOCK_FRAMES], list(self.frames)
                                                ).placements  # (Tb, F, 4, 4)
            P = poses[:, self.owner]  # (Tb, N, 4, 4)
            out[a:a + BLOCK_FRAMES] = (np.einsum("tnij,nj->tni", P[..., :3, :3], self.local_m)
                                       + P[..., :3, 3])
        return out


@dataclass(frozen=True, eq=False)
class PropPenetration:
    """Robot links inside props.

    Attributes:
        names: (P,) prop names.
        depth_m: (T, P) deepest penetration of any proxy into each prop per frame [m] (0 clear).
        link: (T, P) the frame (link) of the deepest proxy, "" when clear.
        count_m: the depth that counts a frame [m].
    """

    names: tuple[str, ...]
    depth_m: np.ndarray
    link: np.ndarray
    count_m: float = PENETRATION_COUNT_M

    @property
    def deepest_mm(self) -> float:
        return float(1e3 * self.depth_m.max(initial=0.0))

    @property
    def frames_over(self) -> int:
        """Frames where some prop is penetrated deeper than ``count_m``."""
        return int((self.depth_m > self.count_m).any(axis=1).sum())

    def summary(self) -> dict:
        per = {}
        for k, n in enumerate(self.names):
            d = self.depth_m[:, k]
            t = int(np.argmax(d)) if len(d) else 0
            per[n] = {"deepest_mm": float(1e3 * d.max(initial=0.0)),
                      "frames_over_10mm": int((d > self.count_m).sum()),
                      "worst_frame": t, "worst_link": str(self.link[t, k]) if len(d) else ""}
        return {"prop_penetration_mm": self.deepest_mm,
                "prop_penetration_frames": self.frames_over, "props": per}


def prop_penetration(robot, q: np.ndarray, planes: Sequence[np.ndarray],
                     names: Sequence[str], *, points: ProxyPoints | None = None,
                     count_m: float = PENETRATION_COUNT_M) -> PropPenetration:
    """Penetration of the robot's collision proxies into each prop at every frame.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) configurations.
        planes: per prop, (K, 4) outward face planes.
        names: (P,) prop names.
        points: the proxies' points (default :meth:`ProxyPoints.of`).
        count_m: depth that counts a frame [m].
    """
    points = points or ProxyPoints.of(robot)
    world = points.world(robot, q)  # (T, N, 3)
    T = len(world)
    depth = np.zeros((T, len(planes)))
    link = np.full((T, len(planes)), "", dtype=object)
    frames = np.array(points.frames, dtype=object)
    for k, pl in enumerate(planes):
        inside = np.maximum(points.radius_m - signed_distance(world, pl), 0.0)  # (T, N)
        j = np.argmax(inside, axis=1)
        depth[:, k] = inside[np.arange(T), j]
        link[:, k] = np.where(depth[:, k] > 0, frames[points.owner[j]], "")
    out = PropPenetration(tuple(names), depth, link, count_m)
    if out.deepest_mm > 0:
        s = out.summary()["props"]
        worst = max(s, key=lambda n: s[n]["deepest_mm"])
        log.info("props: deepest penetration %.1f mm (%s in %s at frame %d), %d frames deeper "
                 "than %.0f mm", out.deepest_mm, s[worst]["worst_link"], worst,
                 s[worst]["worst_frame"], out.frames_over, 1e3 * count_m)
    return out


@dataclass(frozen=True, eq=False)
class HumanContacts:
    """Contacts of a person's effector markers with props.

    Attributes:
        effectors: (E,) marker names.
        names: (P,) prop names.
        contact: (T, E, P) bool.
        distance_m: (T, E, P) signed distances [m].
    """

    effectors: tuple[str, ...]
    names: tuple[str, ...]
    contact: np.ndarray
    distance_m: np.ndarray

    def frames(self) -> dict[str, dict[str, int]]:
        """prop -> effector -> contact frames (effectors without contact left out)."""
        n = self.contact.sum(axis=0)
        return {p: {e: int(n[i, k]) for i, e in enumerate(self.effectors) if n[i, k]}
                for k, p in enumerate(self.names)}


def human_contacts(positions_m: np.ndarray, names: Sequence[str], planes: Sequence[np.ndarray],
                   prop_names: Sequence[str],
                   thresholds_m: Mapping[str, float] = HUMAN_CONTACT_M) -> HumanContacts:
    """Effector-prop contacts of a person: the marker within its threshold of the prop.

    Args:
        positions_m: (T, M, 3) markers [m] (in the props' frame).
        names: (M,) marker names; effectors are ``thresholds_m``'s keys found among them.
        planes: per prop, (K, 4) outward face planes.
        prop_names: (P,) prop names.
        thresholds_m: effector marker -> contact distance [m].
    """
    effectors = tuple(e for e in thresholds_m if e in names)
    idx = [list(names).index(e) for e in effectors]
    pts = np.asarray(positions_m, float)[:, idx]  # (T, E, 3)
    dist = np.stack([signed_distance(pts, pl) for pl in planes], axis=-1) if len(planes) else \
        np.zeros(pts.shape[:2] + (0,))
    limit = np.array([thresholds_m[e] for e in effectors])[None, :, None]
    contact = np.isfinite(dist) & (dist <= limit)
    return HumanContacts(effectors, tuple(prop_names), contact, dist)


def top_contacts(points_m: np.ndarray, planes: np.ndarray, max_height_m: float = 0.15
                 ) -> np.ndarray:
    """(T,) bool: points (T, 3) at most ``max_height_m`` above a prop's top face (its upward
    faces' highest plane) and inside its footprint (every side face's plane), the count the
    shared data's MANIFEST gives per effector."""
    up = planes[:, 2] > 0.9
    side = np.abs(planes[:, 2]) < 0.1
    top = float((planes[up, 3] / planes[up, 2]).max())
    inside = (points_m @ planes[side, :3].T - planes[side, 3] <= 0.0).all(axis=-1)
    h = points_m[..., 2] - top
    return inside & (h >= 0.0) & (h <= max_height_m)


def link_distances(robot, q: np.ndarray, frames: Sequence[str], planes: Sequence[np.ndarray],
                   *, points: ProxyPoints | None = None) -> np.ndarray:
    """(T, L, P) least signed distance [m] of each robot frame's proxies (with the frames
    rigidly attached to it, ``robot.rigid_links``) to each prop; +inf for a frame without
    proxies."""
    points = points or ProxyPoints.of(robot)
    world = points.world(robot, q)
    out = np.full((len(world), len(frames), len(planes)), np.inf)
    for i, f in enumerate(frames):
        rigid = set(robot.rigid_links(f)) | {f}
        sel = np.flatnonzero([points.frames[o] in rigid for o in points.owner])
        if not sel.size:
            continue
        for k, pl in enumerate(planes):
            out[:, i, k] = (signed_distance(world[:, sel], pl) - points.radius_m[sel]).min(axis=1)
    return out


@dataclass(frozen=True, eq=False)
class ContactPreservation:
    """Human prop contacts kept by the robot.

    Attributes:
        effectors: (E,) marker names; names: (P,) prop names.
        human: (T, E, P) the human's contacts on the robot's frames.
        robot_distance_m: (T, E, P) the robot link's signed distance to the prop [m].
        kept_m: the distance that keeps a contact [m].
    """

    effectors: tuple[str, ...]
    names: tuple[str, ...]
    human: np.ndarray
    robot_distance_m: np.ndarray
    kept_m: float = CONTACT_KEPT_M

    @property
    def kept(self) -> np.ndarray:
        """(T, E, P) human contacts the robot's link keeps: neither farther than ``kept_m`` from
        the prop nor sunk deeper than ``kept_m`` into it."""
        return self.human & (np.abs(self.robot_distance_m) <= self.kept_m)

    @property
    def fraction(self) -> float:
        """Kept contact samples over human contact samples (NaN without any)."""
        n = int(self.human.sum())
        return float(self.kept.sum() / n) if n else float("nan")

    def summary(self) -> dict:
        per: dict = {}
        for k, p in enumerate(self.names):
            for i, e in enumerate(self.effectors):
                n = int(self.human[:, i, k].sum())
                if n:
                    d = self.robot_distance_m[:, i, k][self.human[:, i, k]]
                    per.setdefault(p, {})[e] = {
                        "human_frames": n, "kept_frames": int(self.kept[:, i, k].sum()),
                        "robot_distance_p50_mm": float(1e3 * np.median(d))}
        return {"prop_contacts_kept": self.fraction,
                "prop_contact_samples": int(self.human.sum()), "props": per}


def contact_preservation(robot, q: np.ndarray, human: HumanContacts,
                         keypoint_frames: Mapping[str, str], planes: Sequence[np.ndarray],
                         *, start: int = 0, points: ProxyPoints | None = None,
                         kept_m: float = CONTACT_KEPT_M) -> ContactPreservation:
    """Which human contacts the robot keeps: the link of each effector's key point within
    ``kept_m`` of the same prop at the same frame.

    Args:
        robot: the robot; q: (T, nq) its motion.
        human: the human's contacts on the robot's frame rate, (Th, E, P), Th <= T - start.
        keypoint_frames: effector marker -> robot frame carrying its key point.
        planes: per prop (K, 4) planes, in the robot's world (scaled).
        start: the robot frame of the human's first frame (the lead-in).
    """
    Th = len(human.contact)
    qh = np.asarray(q)[start:start + Th]
    frames = [keypoint_frames[e] for e in human.effectors]
    dist = link_distances(robot, qh, frames, planes, points=points)
    out = ContactPreservation(human.effectors, human.names, human.contact[:len(qh)], dist,
                              kept_m)
    log.info("props: %d human contact samples, %.1f %% kept by the robot within %.0f mm",
             int(out.human.sum()), 100 * out.fraction, 1e3 * kept_m)
    return out


@dataclass(frozen=True)
class SurfaceSkid:
    """Sole slide while supporting on any surface (floor or prop): DESIGN.md's
    ``foot_skid_mm_per_frame`` with each support sample on its surface.

    Attributes:
        mean_mm: mean horizontal slide of a supporting sole's centre [mm per 1/30 s] (NaN
            without samples): the figure, as ``foot_skid_mm_per_frame`` on flat ground.
        max_mm: the largest slide; p95_mm: its 95th percentile.
        fraction_over_10mm: share of the samples sliding more than 10 mm per 1/30 s.
        samples: (foot, frame) samples supporting on one surface at the frame and the
            previous one.
        surfaces: surface name -> samples on it.
        max_by_surface_mm, mean_by_surface_mm: surface name -> largest / mean slide on it
            (surfaces with samples).
        planned: the support is the motion's planned contact modes (else detected).
        slide_mm: mean motion of the planned slides and pivots on the surfaces, counted apart
            (NaN without).
    """

    mean_mm: float
    max_mm: float
    p95_mm: float
    fraction_over_10mm: float
    samples: int
    surfaces: dict = field(default_factory=dict)
    max_by_surface_mm: dict = field(default_factory=dict)
    mean_by_surface_mm: dict = field(default_factory=dict)
    planned: bool = False
    slide_mm: float = float("nan")


def _surface_heights(corners: np.ndarray, planes: Sequence[np.ndarray], height_m: float
                     ) -> np.ndarray:
    """(T, 1 + P) [m] a sole's height above the floor (its lowest corner) and above each prop
    (the signed distance of its corner nearest to the prop, where that corner is over an
    upward face and not sunk more than ``height_m`` into it; inf elsewhere)."""
    heights = [corners[..., 2].min(axis=1)]
    t = np.arange(len(corners))
    for pl in planes:
        d = corners @ pl[:, :3].T - pl[:, 3]  # (T, 4, K) each corner against each face
        sd = d.max(axis=-1)  # (T, 4)
        # on a prop: the corner nearest to the prop is over one of its upward faces (a sole
        # on the floor inside a box sits at the box's bottom face, not on the box)
        lowest = np.argmin(sd, axis=1)
        upward = pl[np.argmax(d[t, lowest], axis=-1), 2] > UPWARD_NZ
        h = sd[t, lowest]
        heights.append(np.where(upward & (h >= -height_m), h, np.inf))
    return np.stack(heights, axis=1)


def surface_skid(robot, q: np.ndarray, fps: float, planes: Sequence[np.ndarray],
                 names: Sequence[str], detection: SupportDetection | None = None,
                 contact_modes: np.ndarray | None = None) -> SurfaceSkid:
    """Horizontal slide of each sole while it supports on the floor (z = 0) or on a prop, at a
    frame and the previous one: DESIGN.md's ``foot_skid_mm_per_frame`` (the mean) on every
    surface, with the support the flat-ground figure takes
    (:func:`imesh.metrics.support.motion_support`).

    Args:
        contact_modes: (T, 2) the motion's planned contact modes
            (``RobotMotion.contact_modes``): a planned support sample is on the surface
            nearest to the sole, and planned slides and pivots are counted apart
            (``slide_mm``), as ``foot_skid_mm_per_frame`` counts them. None: the support on each
            surface is the evaluator's detection
            (:func:`imesh.metrics.support.detect_support`: the sole's lowest corner within
            10 mm and its centre slower than 0.5 m/s, with hysteresis and a minimum phase of
            0.05 s) with the height measured from that surface (a sole sunk more than
            ``height_m`` into a prop is not on it).
    """
    detection = detection or SupportDetection()
    soles = sole_tracks(robot, np.asarray(q, float), fps)
    labels = ("floor", *names)
    planned = contact_modes is not None
    modes = None if contact_modes is None else Contacts.from_modes(contact_modes, soles.fps)
    steps, slides = [], []
    by: dict[str, list] = {n: [] for n in labels}
    for k, side in enumerate(SIDES):
        heights = _surface_heights(soles.corners[side], planes, detection.height_m)
        step = np.linalg.norm(np.diff(soles.centers[side][:, :2], axis=0), axis=1)
        mm = step * 1e3 * fps / SKID_FPS
        if modes is None:
            speed = soles.speed(side)
            support = np.stack([detection.phases.support(h, speed, detection.height_m,
                                                         detection.speed_mps, soles.fps)
                                for h in heights.T], axis=1)  # (T, 1 + P)
            moving = np.zeros(len(support), dtype=bool)
        else:
            nearest = np.argmin(np.abs(heights), axis=1)  # the floor is always finite
            support = (np.arange(heights.shape[1]) == nearest[:, None]) \
                & modes.support[:, k, None]
            moving = near_slides(modes.moving[:, k])
        both = support[1:] & support[:-1]  # on the same surface at both frames
        slide = both.any(axis=1) & moving[1:]
        both &= ~moving[1:, None]
        for j, n in enumerate(labels):
            by[n].append(mm[both[:, j]])
        steps.append(mm[both.any(axis=1)])
        slides.append(mm[slide])
    s, sl = np.concatenate(steps), np.concatenate(slides)
    per = {n: np.concatenate(v) for n, v in by.items()}
    nan = float("nan")
    return SurfaceSkid(
        mean_mm=float(s.mean()) if s.size else nan, max_mm=float(s.max()) if s.size else nan,
        p95_mm=float(np.percentile(s, 95)) if s.size else nan,
        fraction_over_10mm=float(np.mean(s > SKID_THRESHOLD_MM)) if s.size else nan,
        samples=int(s.size), surfaces={n: int(v.size) for n, v in per.items()},
        max_by_surface_mm={n: float(v.max()) for n, v in per.items() if v.size},
        mean_by_surface_mm={n: float(v.mean()) for n, v in per.items() if v.size},
        planned=planned, slide_mm=float(sl.mean()) if sl.size else nan)

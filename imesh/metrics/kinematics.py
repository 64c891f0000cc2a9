"""Kinematic metrics of a robot motion: support phases from the soles, multibody ZMP against the
support polygon and the desired ZMP, foot skid and joint-limit violations.

Everything here works on a plain :class:`~imesh.core.robot_motion.RobotMotion` (no source markers),
so motions from other retargeting tools are scored on the same terms. Support phases come from
the robot's own soles: a foot is in support while the lowest corner of its sole is within
``SupportDetection.height_m`` of the ground (z = 0) and its sole centre is slow, with hysteresis
and a minimum phase duration (as :func:`imesh.contacts.phases.detect_contacts` does for markers).

Velocities and accelerations follow pinocchio's convention (``v = [base linear velocity in the
base frame, base angular velocity in the base frame, joint rates]``, ``a = dv/dt``), computed
by central differences at the motion's frame rate (numpy and scipy only).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from ..contacts.phases import SIDES, Contacts, drop_short, hysteresis, runs
from ..core.checks import require_finite
from ..errors import OptionError

log = logging.getLogger(__name__)

#: Frame rate the foot skid is reported at (DESIGN.md: mm per frame at 30 fps).
SKID_FPS = 30.0
#: A support frame skids when its sole centre moves more than this per 30-fps frame [mm].
SKID_THRESHOLD_MM = 10.0


# ----------------------------------------------------------------------------------------------
# derivatives


def motion_derivatives(q: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocities and accelerations of a configuration trajectory (pinocchio convention).

    Central differences inside, one-sided at the ends. The base twist is expressed in the base
    frame: linear ``R_t^T (p_{t+1} - p_{t-1}) / 2h``, angular ``log(R_{t-1}^T R_{t+1}) / 2h``
    (both base-frame quantities at frame t to second order).

    Args:
        q: (T, nq) float configurations ``[x, y, z, qx, qy, qz, qw, joints...]``.
        fps: frame rate [1/s].

    Returns:
        (v, a): (T, nv) float velocities and (T, nv) float accelerations, nv = nq - 1.
    """
    q = np.asarray(q, dtype=float)
    T = len(q)
    h = 1.0 / fps
    v = np.zeros((T, q.shape[1] - 1))
    if T < 2:
        return v, np.zeros_like(v)
    rot = Rotation.from_quat(q[:, 3:7])  # scipy order x, y, z, w: as pinocchio
    prev = np.r_[0, np.arange(T - 1)]
    nxt = np.r_[np.arange(1, T), T - 1]
    span = (nxt - prev) * h
    R = rot.as_matrix()
    dp = (q[nxt, :3] - q[prev, :3]) / span[:, None]
    v[:, :3] = np.einsum("tji,tj->ti", R, dp)  # R^T dp
    v[:, 3:6] = (rot[prev].inv() * rot[nxt]).as_rotvec() / span[:, None]
    v[:, 6:] = np.gradient(q[:, 7:], h, axis=0)
    a = np.gradient(v, h, axis=0)
    return v, a


# ----------------------------------------------------------------------------------------------
# soles and support


@dataclass(frozen=True)
class SupportDetection:
    """Thresholds of the sole-based support detection of a robot motion.

    Attributes:
        height_m: a foot can enter support when the lowest corner of its sole is within this
            height of the ground [m].
        speed_mps: ... and its sole centre moves slower than this [m/s].
        hysteresis: to leave support the height/speed must exceed the thresholds times this.
        min_phase_s: support and swing phases shorter than this are merged into their
            neighbours [s].
    """

    height_m: float = 0.01
    speed_mps: float = 0.5
    hysteresis: float = 1.5
    min_phase_s: float = 0.05

    def __post_init__(self) -> None:
        require_finite(self, ("height_m", "speed_mps", "min_phase_s"), positive=True)
        if not self.hysteresis >= 1.0:
            raise OptionError("hysteresis", self.hysteresis, "a number >= 1")


@dataclass(frozen=True, eq=False)
class SoleTracks:
    """World positions of both soles over a motion.

    Attributes:
        corners: side -> (T, 4, 3) float [m] sole corners.
        centers: side -> (T, 3) float [m] sole centres.
        fps: frame rate [1/s].
    """

    corners: dict[str, np.ndarray]
    centers: dict[str, np.ndarray]
    fps: float

    @property
    def n_frames(self) -> int:
        return len(self.centers[SIDES[0]])

    def lowest(self, side: str) -> np.ndarray:
        """(T,) float [m] height of the lowest corner of a sole."""
        return self.corners[side][..., 2].min(axis=1)

    def support_heights(self, support: np.ndarray) -> np.ndarray:
        """(N,) float [m] |lowest corner z| of each sole in each of its support frames
        (left's frames, then right's); ``support`` is (T, 2) bool [left, right]."""
        return np.concatenate([np.abs(self.lowest(s)[support[:, k]])
                               for k, s in enumerate(SIDES)])

    def speed(self, side: str) -> np.ndarray:
        """(T,) float [m/s] speed of a sole centre (central differences)."""
        if self.n_frames < 2:
            return np.zeros(self.n_frames)
        return np.linalg.norm(np.gradient(self.centers[side], 1.0 / self.fps, axis=0), axis=1)


def sole_tracks(robot, q: np.ndarray, fps: float) -> SoleTracks:
    """Sole corners and centres of both feet at every frame.

    Args:
        robot: an :class:`imesh.robot.Robot`.
        q: (T, nq) float configurations.
        fps: frame rate [1/s].
    """
    q = np.asarray(q, dtype=float)
    corners = {s: np.empty((len(q), 4, 3)) for s in SIDES}
    centers = {s: np.empty((len(q), 3)) for s in SIDES}
    frames: list[str] = []
    points: list[np.ndarray] = []
    for s in SIDES:
        sole = robot.soles[s]
        frames += [sole.frame] * 5
        points += [*sole.corners(), sole.center]
    offsets = np.asarray(points)
    for t, qt in enumerate(q):
        pts = robot.frame_positions(qt, frames, offsets)
        for k, s in enumerate(SIDES):
            corners[s][t] = pts[5 * k:5 * k + 4]
            centers[s][t] = pts[5 * k + 4]
    return SoleTracks(corners=corners, centers=centers, fps=fps)


def detect_support(soles: SoleTracks, config: SupportDetection | None = None) -> Contacts:
    """Support phases of both feet of a robot motion from its soles.

    Args:
        soles: :func:`sole_tracks` of the motion.
        config: thresholds.

    Returns:
        Contacts with the (T, 2) [left, right] support mask.
    """
    config = config or SupportDetection()
    T = soles.n_frames
    support = np.zeros((T, 2), dtype=bool)
    min_frames = max(1, int(round(config.min_phase_s * soles.fps)))
    for k, side in enumerate(SIDES):
        low, speed = soles.lowest(side), soles.speed(side)
        enter = (low < config.height_m) & (speed < config.speed_mps)
        stay = ((low < config.height_m * config.hysteresis)
                & (speed < config.speed_mps * config.hysteresis))
        support[:, k] = drop_short(hysteresis(enter, stay), min_frames)
    return Contacts(support=support, fps=soles.fps)


def planted_feet(soles: SoleTracks, config: SupportDetection | None = None) -> np.ndarray:
    """(T, 2) bool feet that are *kinematically* planted whatever their height: slow and the
    lower foot (or within ``height_m`` of it). Used to tell a robot floating above the ground
    from a robot in a flight phase."""
    config = config or SupportDetection()
    lows = np.stack([soles.lowest(s) for s in SIDES], axis=1)
    speeds = np.stack([soles.speed(s) for s in SIDES], axis=1)
    lowest = lows.min(axis=1, keepdims=True)
    return (speeds < config.speed_mps) & (lows < lowest + config.height_m)


# ----------------------------------------------------------------------------------------------
# support polygon and ZMP


def convex_hull_2d(points: np.ndarray) -> np.ndarray:
    """(K, 2) float counter-clockwise convex hull of a small 2-D point set (monotone chain)."""
    pts = np.unique(np.asarray(points, dtype=float).reshape(-1, 2), axis=0)
    if len(pts) <= 2:
        return pts

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list = []
    for p in pts[::-1]:
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def polygon_centroid(poly: np.ndarray) -> np.ndarray:
    """(2,) float area centroid of a counter-clockwise polygon (vertex mean if degenerate)."""
    x, y = poly[:, 0], poly[:, 1]
    xn, yn = np.roll(x, -1), np.roll(y, -1)
    c = x * yn - xn * y
    area = c.sum() / 2
    if abs(area) < 1e-12:
        return poly.mean(axis=0)
    return np.array([((x + xn) * c).sum(), ((y + yn) * c).sum()]) / (6 * area)


def inside_polygon(point: np.ndarray, poly: np.ndarray, margin: float = 0.0) -> bool:
    """Whether a 2-D point lies inside a counter-clockwise convex polygon (``margin`` [m] >= 0
    shrinks the polygon's edges inward)."""
    if len(poly) < 3:
        return False
    edge = np.roll(poly, -1, axis=0) - poly
    rel = point - poly
    cross = edge[:, 0] * rel[:, 1] - edge[:, 1] * rel[:, 0]
    return bool(np.all(cross >= margin * np.linalg.norm(edge, axis=1)))


def support_polygons(soles: SoleTracks, support: np.ndarray) -> list[np.ndarray | None]:
    """Per frame the (K, 2) convex hull of the corners of the feet in support (None in
    flight)."""
    out: list[np.ndarray | None] = []
    for t in range(soles.n_frames):
        pts = [soles.corners[s][t, :, :2] for k, s in enumerate(SIDES) if support[t, k]]
        out.append(convex_hull_2d(np.concatenate(pts)) if pts else None)
    return out


def desired_zmp(soles: SoleTracks, support: np.ndarray, transition_s: float = 0.1
                ) -> np.ndarray:
    """(T, 2) float [m] desired ZMP: the sole centre in single support, the centre of the convex
    hull of both soles in double support, smooth between phases; flight frames are
    interpolated from their neighbours. All NaN when no frame has support.

    The transitions happen inside the double-support phases, so the desired ZMP never leaves
    the support polygon: over the first ``transition_s`` of a double-support phase it moves
    (smoothstep) from the previous single-support sole centre to the hull centre, over the
    last ``transition_s`` to the next single-support sole centre (for a phase shorter than
    ``2 transition_s``: half of it each). Every value is a convex combination of points of the
    polygon.
    """
    T = soles.n_frames
    raw = np.full((T, 2), np.nan)
    polys = support_polygons(soles, support)
    n_support = support.sum(axis=1)
    single = n_support == 1
    side = np.argmax(support, axis=1)
    for k, s in enumerate(SIDES):
        sel = single & (side == k)
        raw[sel] = soles.centers[s][sel, :2]
    width = max(1, int(round(transition_s * soles.fps)))
    for a, b in runs(n_support == 2):
        centres = []
        for frame in range(a, b):
            poly = polys[frame]
            assert poly is not None  # double support: both soles' corners
            centres.append(polygon_centroid(poly))
        centre = np.array(centres)
        t = np.arange(a, b)
        w = max(1.0, min(width, (b - a) / 2.0))
        d = centre
        if a > 0 and single[a - 1]:
            u = np.clip((t - a + 0.5) / w, 0.0, 1.0)[:, None]
            d = raw[a - 1] + u * u * (3 - 2 * u) * (d - raw[a - 1])
        if b < T and single[b]:
            u = np.clip((b - t - 0.5) / w, 0.0, 1.0)[:, None]
            d = raw[b] + u * u * (3 - 2 * u) * (d - raw[b])
        raw[a:b] = d
    ok = ~np.isnan(raw[:, 0])
    if not ok.any():
        return raw
    idx = np.arange(T)
    return np.stack([np.interp(idx, idx[ok], raw[ok, k]) for k in range(2)], axis=1)


def zmp_trajectory(robot, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                   ground_z: float = 0.0) -> np.ndarray:
    """(T, 2) float [m] multibody ZMP of every frame (``Robot.zmp``)."""
    return np.array([robot.zmp(q[t], v[t], a[t], ground_z) for t in range(len(q))])


@dataclass(frozen=True, eq=False)
class ZmpReport:
    """Multibody ZMP of a motion against its support.

    Attributes:
        zmp_m: (T, 2) float [m] multibody ZMP.
        desired_m: (T, 2) float [m] desired ZMP (NaN when the motion has no support frame).
        inside: (T,) bool ZMP inside the support polygon (False in flight).
        support_frames: (T,) bool frames with at least one foot in support.
        inside_fraction: fraction of support frames whose ZMP is inside (NaN if none).
        error_mm: RMS distance [mm] between ZMP and desired ZMP over support frames.
        max_outside_mm: largest distance [mm] of an outside ZMP from its support polygon.
        polygons: per frame the (K, 2) support polygon (None in flight).
    """

    zmp_m: np.ndarray
    desired_m: np.ndarray
    inside: np.ndarray
    support_frames: np.ndarray
    inside_fraction: float
    error_mm: float
    max_outside_mm: float
    polygons: list = field(default_factory=list)


def _distance_to_polygon(p: np.ndarray, poly: np.ndarray) -> float:
    if len(poly) == 1:
        return float(np.linalg.norm(p - poly[0]))
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab),
                                                              1e-18), 0, 1)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))


def zmp_report(zmp: np.ndarray, soles: SoleTracks, support: np.ndarray,
               transition_s: float = 0.1) -> ZmpReport:
    """Compare a ZMP trajectory with the support polygons and the desired ZMP.

    Args:
        zmp: (T, 2) float [m] ZMP.
        soles: the motion's soles.
        support: (T, 2) bool feet in support.
        transition_s: blending time of the desired ZMP between phases [s].
    """
    polys = support_polygons(soles, support)
    T = len(zmp)
    inside = np.zeros(T, dtype=bool)
    worst = 0.0
    for t, poly in enumerate(polys):
        if poly is None:
            continue
        inside[t] = inside_polygon(zmp[t], poly)
        if not inside[t]:
            worst = max(worst, _distance_to_polygon(zmp[t], poly))
    sup = np.asarray(support.any(axis=1))
    desired = desired_zmp(soles, support, transition_s)
    if sup.any():
        err = np.linalg.norm(zmp[sup] - desired[sup], axis=1)
        error_mm = float(1e3 * np.sqrt(np.mean(err ** 2)))
        fraction = float(inside[sup].mean())
    else:
        error_mm = fraction = float("nan")
    return ZmpReport(zmp_m=zmp, desired_m=desired, inside=inside, support_frames=sup,
                     inside_fraction=fraction, error_mm=error_mm, max_outside_mm=1e3 * worst,
                     polygons=polys)


# ----------------------------------------------------------------------------------------------
# foot skid and limits


@dataclass(frozen=True)
class SkidReport:
    """Horizontal sole motion during support.

    Attributes:
        mean_mm_per_frame: mean horizontal motion of a support sole centre per frame [mm],
            scaled to 30 fps (NaN without support frames).
        fraction_over_10mm: fraction of support samples moving more than 10 mm per 30-fps frame.
        max_mm_per_frame: largest such motion [mm per 30-fps frame].
        samples: number of (foot, frame) samples (frames where the foot is in support at both
            the frame and the previous one).
    """

    mean_mm_per_frame: float
    fraction_over_10mm: float
    max_mm_per_frame: float
    samples: int


def foot_skid(soles: SoleTracks, support: np.ndarray) -> SkidReport:
    """Foot skid of the support feet (DESIGN.md ``foot_skid_mm_per_frame``)."""
    values = []
    for k, side in enumerate(SIDES):
        both = support[1:, k] & support[:-1, k]
        step = np.linalg.norm(np.diff(soles.centers[side][:, :2], axis=0), axis=1)
        values.append(step[both] * 1e3 * soles.fps / SKID_FPS)
    d = np.concatenate(values) if values else np.zeros(0)
    if d.size == 0:
        return SkidReport(float("nan"), float("nan"), float("nan"), 0)
    return SkidReport(mean_mm_per_frame=float(d.mean()),
                      fraction_over_10mm=float(np.mean(d > SKID_THRESHOLD_MM)),
                      max_mm_per_frame=float(d.max()), samples=int(d.size))


@dataclass(frozen=True)
class SoleDeviation:
    """How far supporting soles leave their footprints.

    Attributes:
        deviation_mm: largest distance of a support sole centre from its footprint (the median
            centre of its support phase, on z = 0) [mm].
        tilt_deg: largest angle between a supporting sole's normal and the vertical [deg].
        samples: (foot, frame) support samples.
    """

    deviation_mm: float
    tilt_deg: float
    samples: int


def sole_deviation(soles: SoleTracks, support: np.ndarray) -> SoleDeviation:
    """Sole deviation and tilt over the support phases (DESIGN.md ``sole_deviation_mm``,
    ``sole_tilt_deg``)."""
    dev, tilt, n = 0.0, 0.0, 0
    for k, side in enumerate(SIDES):
        c = soles.corners[side]
        normal = np.cross(c[:, 1] - c[:, 0], c[:, 3] - c[:, 0])
        cos = np.abs(normal[:, 2]) / np.maximum(np.linalg.norm(normal, axis=1), 1e-12)
        angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        for a, b in runs(support[:, k]):
            centre = soles.centers[side][a:b]
            foot = np.r_[np.median(centre[:, :2], axis=0), 0.0]
            dev = max(dev, float(np.linalg.norm(centre - foot, axis=1).max()))
            tilt = max(tilt, float(angle[a:b].max()))
            n += b - a
    return SoleDeviation(deviation_mm=1e3 * dev, tilt_deg=tilt, samples=n)


@dataclass(frozen=True, eq=False)
class LimitReport:
    """Joint-limit violations of a motion.

    Attributes:
        position: (T,) bool frames with a joint outside its position limits.
        velocity: (T,) bool frames with a joint faster than its velocity limit (backward
            differences; frame 0 never).
        acceleration: (T,) bool frames with a joint's second difference over its acceleration
            limit (central: frame t from t-1, t, t+1; first and last frame never).
        position_joints: joint -> frames outside its position limits (violating joints only).
        velocity_joints: joint -> frames above its velocity limit (violating joints only).
        worst_position_rad: largest excursion beyond a position limit [rad].
        worst_velocity_ratio: largest |velocity| / limit.
    """

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    position_joints: dict[str, int]
    velocity_joints: dict[str, int]
    acceleration_joints: dict[str, int]
    worst_position_rad: float
    worst_velocity_ratio: float
    worst_acceleration_ratio: float

    @property
    def any(self) -> np.ndarray:
        """(T,) bool frames with any violation."""
        return self.position | self.velocity | self.acceleration


def limit_violations(robot, q: np.ndarray, fps: float, position_tol: float = 1e-6,
                     velocity_tol: float = 1e-6) -> LimitReport:
    """Frames with joints outside their position limits or above their velocity or
    acceleration limits (one tolerance: ``velocity_tol`` is relative to both rate limits).

    Args:
        robot: the robot (``q_lower``, ``q_upper``, ``v_max``, ``joint_names``).
        q: (T, nq) float configurations.
        fps: frame rate [1/s].
        position_tol: [rad] tolerance on the position limits.
        velocity_tol: relative tolerance on the velocity limits.
    """
    qj = np.asarray(q, dtype=float)[:, 7:]
    over = np.maximum(qj - robot.q_upper, robot.q_lower - qj)
    pos = over > position_tol
    vel_ratio = np.zeros_like(qj)
    if len(qj) > 1:
        vel_ratio[1:] = np.abs(np.diff(qj, axis=0)) * fps / robot.v_max
    vel = vel_ratio > 1.0 + velocity_tol
    acc_ratio = np.zeros_like(qj)
    if len(qj) > 2:
        acc_ratio[1:-1] = np.abs(np.diff(qj, n=2, axis=0)) * fps * fps / robot.a_max
    acc = acc_ratio > 1.0 + velocity_tol
    names = robot.joint_names

    def per_joint(mask):
        return {names[j]: int(mask[:, j].sum()) for j in np.flatnonzero(mask.any(0))}

    return LimitReport(
        position=pos.any(axis=1), velocity=np.asarray(vel.any(axis=1)),
        acceleration=np.asarray(acc.any(axis=1)),
        position_joints=per_joint(pos), velocity_joints=per_joint(vel),
        acceleration_joints=per_joint(acc),
        worst_position_rad=float(max(over.max(initial=0.0), 0.0)),
        worst_velocity_ratio=float(vel_ratio.max(initial=0.0)),
        worst_acceleration_ratio=float(acc_ratio.max(initial=0.0)))

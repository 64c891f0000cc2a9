"""Footprints: one flat sole placement on the ground per support phase.

For support phase s of foot f the sole keeps one pose F_s for the whole phase (DESIGN.md,
"Whole-body spacetime solve"): the sole centre on z = 0, the sole level (its normal along world
z), and x, y, yaw from the initial trajectory: the median sole centre and the circular mean of
the yaw over the middle half of the phase (the ends of a phase carry the heel strike and toe-off
of the fit).

A sliding (or pivoting) foot keeps its sole flat on the ground but moves along it: every frame
of a slide is its own one-frame footprint, level on z = 0 at the initial trajectory's sole
centre and yaw of that frame (the fit follows the human's slide), so the sole rows, the support
polygon (the ZMP inside the sliding sole) and the desired ZMP move with it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from ..contacts.phases import SIDES, runs
from ..contacts.support import middle_half
from ..metrics.polygon import convex_hull_2d
from ..metrics.soles import SoleTracks


@dataclass(frozen=True, eq=False)
class Footprint:
    """The ground placement of one sole over one support phase.

    Attributes:
        side: ``"left"`` or ``"right"``.
        start, stop: the frames [start, stop) of the phase.
        frame_pose: (4, 4) float world pose the sole *frame* keeps (so the sole rectangle lies
            on z = 0, level).
        center_m: (3,) float [m] world sole centre (z = 0).
        corners_m: (4, 3) float [m] world sole corners (z = 0).
        polygon_m: (4, 3) float [m] world corners of the part of the sole the ZMP may use: the
            sole rectangle clipped to where the ankle can hold the largest planned load (see
            :func:`ankle_reach`).
        sliding: the sole slides (or pivots) through this one-frame placement.
    """

    side: str
    start: int
    stop: int
    frame_pose: np.ndarray
    center_m: np.ndarray
    corners_m: np.ndarray
    polygon_m: np.ndarray
    sliding: bool = False


#: Tilt [rad] of a sole from level beyond which its heading is taken as the twist of
#: :func:`_yaw` rather than its x axis's.
TWIST_TILT_RAD = np.pi / 4


def _yaw(rot: np.ndarray) -> np.ndarray:
    """(N,) yaw [rad] of sole rotations (N, 3, 3) relative to level: the heading of their x
    axis, or, for a sole tilted more than ``TWIST_TILT_RAD`` from level, that of the shortest
    rotation laying it level (the twist about the vertical in ``R = swing twist``,
    ``2 atan2(q_z, q_w)`` of its quaternion, which is ``atan2(R_10 - R_01, R_00 + R_11)``).

    The two agree for pure pitch or roll and differ by about pitch x roll / 2 otherwise; the
    x axis's turns over where the sole pitches past 90 degrees: a run's first frame has the
    rear foot kicked up behind the body, pitched 109 degrees, its x axis pointing back, 150
    degrees off its twist (and off the other foot), and the lead put that foot down turned
    round (:func:`level_placement`, :mod:`.lead`)."""
    x_heading = np.arctan2(rot[:, 1, 0], rot[:, 0, 0])
    twist = np.arctan2(rot[:, 1, 0] - rot[:, 0, 1], rot[:, 0, 0] + rot[:, 1, 1])
    return np.where(rot[:, 2, 2] < np.cos(TWIST_TILT_RAD), twist, x_heading)


def _rz(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


#: A re-step of :func:`split_pivots` lands for at least this long [s], and lifts off at least
#: this long after the foot landed; a shorter landing is merged into the swing.
MIN_RESTEP_S = 0.1


def level_placement(sole, rot_level: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """(4, 4) the sole frame's pose that lays a sole level on z = 0 where ``poses`` have it.

    The sole centre goes to the median of the poses' centres in x, y and to z = 0; the heading
    is the circular mean of their yaw relative to the level orientation.

    Args:
        sole: the sole rectangle (:class:`imesh.robot.config.SoleRectangle`).
        rot_level: (3, 3) the sole frame's rotation when the sole is level (the nominal pose's).
        poses: (N, 4, 4) world poses of the sole frame.
    """
    centers = poses[:, :3, :3] @ sole.center + poses[:, :3, 3]
    # yaw of the sole relative to its level orientation in the nominal pose
    yaw = _yaw(poses[:, :3, :3] @ rot_level.T)
    psi = float(np.arctan2(np.sin(yaw).mean(), np.cos(yaw).mean()))
    R = _rz(psi) @ rot_level
    c = np.array([*np.median(centers[:, :2], axis=0), 0.0])
    pose = np.eye(4)
    pose[:3, :3] = R
    pose[:3, 3] = c - R @ sole.center
    return pose


def split_pivots(robot, sole_poses: dict[str, np.ndarray], support: np.ndarray, fps: float,
                 yaw_tol_rad: float = 0.15, move_tol_m: float = 0.04, gap_s: float = 0.3,
                 pivots: np.ndarray | None = None, pivot_rad: float = 0.8,
                 slide_m: float = 0.1) -> np.ndarray:
    """Turn a support foot that pivots or slides into steps.

    A human foot turns on its heel or slides while it carries weight; a robot sole that must
    keep one footprint cannot. Where the initial trajectory's sole leaves the start of its
    support run by more than ``yaw_tol_rad`` of yaw or ``move_tol_m``, the run is cut there and
    the foot gets a swing of ``gap_s`` to re-place itself, provided the other foot supports
    during the whole gap. Otherwise, where the sole goes on to turn by more than ``pivot_rad``
    or to move more than ``slide_m`` (a pirouette on one foot, a slide the detector took for
    a planted foot: no other foot to stand on while this one re-steps) the foot turns or
    slides on the ground: the frames from there to the end of the run are marked in ``pivots``
    (when given), which the plan makes one footprint per frame (a pivot,
    :func:`plan_footprints`), instead of one footprint 100-180 degrees off the fitted sole
    (CMU 05_06's pirouettes on G1); smaller turns and drifts keep one footprint.

    Args:
        robot: the robot (``soles``, ``q_nominal``).
        sole_poses: side -> (T, 4, 4) sole frame poses along the initial trajectory.
        support: (T, 2) bool planned support.
        fps: frame rate [1/s].
        pivots: (T, 2) bool, filled in place with the frames that pivot on the ground
            (None: such runs keep one footprint).
        pivot_rad: the turn [rad] from which an unsplittable run pivots ...
        slide_m: ... and the travel [m] from which it slides.

    Returns:
        (T, 2) bool support with the re-steps cut out (a re-step that would land less than
        ``MIN_RESTEP_S`` before the run ends lifts the foot to the run's end instead; one that
        would lift off less than that after the foot landed, from a swing or a re-step, keeps
        the foot up from there).
    """
    out = np.array(support, dtype=bool)
    gap = max(2, int(round(gap_s * fps)))
    min_run = int(round(MIN_RESTEP_S * fps))
    level = robot.frame_rotations(robot.q_nominal, [robot.soles[s].frame for s in SIDES])
    for k, side in enumerate(SIDES):
        poses = sole_poses[side]
        centre = poses[:, :3, :3] @ robot.soles[side].center + poses[:, :3, 3]
        yaw = np.unwrap(_yaw(poses[:, :3, :3] @ level[k].T))
        for start, stop in runs(support[:, k]):
            a = start
            t = start + 1
            landed = start if start else None  # where the foot last landed
            while t < stop:
                moved = np.linalg.norm(centre[t, :2] - centre[a, :2])
                if abs(yaw[t] - yaw[a]) > yaw_tol_rad or moved > move_tol_m:
                    lo, hi = max(t - gap // 2, a + 1), min(t + gap - gap // 2, stop - 1)
                    if stop - hi < min_run:
                        # a re-step landing for a frame or two before the run's own lift-off
                        # is a tap, not a step (HRP-4C's walk: the sole put down for one frame
                        # at the clip's toe-off): the foot lifts at the cut instead
                        hi = stop
                    if landed is not None and lo - landed < min_run:
                        # ... and so is one between two re-steps or between a landing and
                        # a re-step (the salsa's turning foot: down for one frame, where the
                        # plan pulled the swing sole 100 mm to that frame's footprint and
                        # back): one longer swing instead
                        lo = landed
                    if hi - lo >= 2 and out[lo:hi, 1 - k].all():
                        out[lo:hi, k] = False
                        a, t, landed = hi, hi + 1, hi
                        continue
                    far = np.linalg.norm(centre[t:stop, :2] - centre[a, :2], axis=1).max()
                    if pivots is not None and (np.abs(yaw[t:stop] - yaw[a]).max() > pivot_rad
                                               or far > slide_m):
                        pivots[max(t - 1, a):stop, k] = True
                        break
                t += 1
    return out


def hold_poses(poses: np.ndarray, support: np.ndarray, inferred: np.ndarray,
               base_yaw: np.ndarray | None = None, twist_rad: float = 0.5) -> np.ndarray:
    """(T, 4, 4) one foot's sole poses with each run of ``inferred`` support frames given the
    pose of the foot's support frame just before the run (else just after it): the foot holds
    still where it last stood while the person's foot is in the air (``Contacts.inferred``).

    A held foot still turns where the body turns on it more than a leg twists: with
    ``base_yaw``, the sole turns about its frame's origin (the ankle) by the part of the
    base's yaw change since the held frame beyond ``twist_rad``,
    ``psi_t = sign(d_t) max(|d_t| - twist_rad, 0)``, ``d_t = yaw_t - yaw_held``. A dancer's
    turn on the ball of the foot (CMU 05_06: the right foot carries a 4.3 rad pirouette
    with its toe marker 0.1-0.2 m up, the left a 2.9 rad one) is then a pivot
    (:func:`split_pivots`) instead of one footprint 100-280 degrees off the fitted sole; the
    salsa's hop (the base turns 0.26 rad) keeps its held pose.

    Args:
        poses: (T, 4, 4) sole frame poses along the initial trajectory.
        support: (T,) bool the foot's planned support.
        inferred: (T,) bool its inferred support frames.
        base_yaw: (T,) [rad] the base's yaw along the initial trajectory, or None (held
            feet do not turn).
        twist_rad: [rad] the body's turn a held foot takes in its leg.
    """
    out = np.array(poses)
    inferred = inferred & support
    for a, b in runs(inferred):
        if a > 0 and support[a - 1] and not inferred[a - 1]:
            src = a - 1
        elif b < len(poses) and support[b]:
            src = b
        else:
            continue
        out[a:b] = poses[src]
        if base_yaw is None:
            continue
        lo, hi = min(a, src), max(b, src + 1)
        turn = np.unwrap(base_yaw[lo:hi])
        d = turn - turn[src - lo]
        psi = (np.sign(d) * np.maximum(np.abs(d) - twist_rad, 0.0))[a - lo:b - lo]
        out[a:b, :3, :3] = Rotation.from_euler("z", psi[:, None]).as_matrix() @ poses[src, :3, :3]
    return out


def ankle_reach(robot, side: str, load: float = 1.0) -> float:
    """[m] how far from the ankle (the sole frame's origin) the centre of pressure may go with
    ``load`` times the whole weight on one foot: the weaker of the two ankle joints' effort
    limit over ``load m g``. G1's 35 Nm ankles hold its 33 kg 0.107 m from the ankle (0.082 m
    at the solve's largest normal force, 1.3 m g); its sole reaches 0.12 m ahead, so a ZMP at
    the toe asks 1.1-1.6x the ankle's limit (measured on the G1 walk before this bound)."""
    joints = robot.supporting_joints(robot.soles[side].frame)[-2:]
    return float(np.min(robot.effort_max[joints]) / (load * robot.mass * 9.81))


def plan_footprints(robot, sole_poses: dict[str, np.ndarray], support: np.ndarray,
                    load: float = 1.0, margin: float = 0.0,
                    sliding: np.ndarray | None = None, reach_m: float = np.inf,
                    slide_step_m: float = np.inf) -> list[Footprint]:
    """One level footprint on z = 0 per support phase of each foot, and one per frame of a
    slide.

    A slide frame in which the initial trajectory's sole centre is higher than ``reach_m`` is
    one the robot's legs did not follow (the fit is held back by the joint velocity and
    acceleration limits: CMU 60_10's right foot taps 170 mm per frame at 30 fps, and the fit's
    sole flies 0.2-0.5 m up): its footprint is that of the nearest frame of the same slide
    that was followed, so the sole holds still there (planted) instead of being asked for the
    human's 5 m/s.

    Args:
        robot: the robot (``soles``, ``q_nominal`` give the level sole orientation).
        sole_poses: side -> (T, 4, 4) float world poses of the sole frames along the initial
            trajectory.
        support: (T, 2) bool [left, right] planned support.
        load: the largest normal force on one foot, times the weight (the polygon is clipped
            to :func:`ankle_reach` at this load).
        margin: fraction of the sole's half sizes kept free of the ZMP (the polygon is the
            sole rectangle shrunk about its centre by it, then clipped to the ankle's reach).
        sliding: (T, 2) bool support frames in which the sole slides or pivots (None: none).
        reach_m: slide frames whose initial sole centre is higher than this [m] hold the
            nearest followed frame's footprint.
        slide_step_m: a slide frame's footprint centre moves at most this far [m] from the
            footprint of the frame before it (when that frame is a support frame of the same
            foot): where the initial sole moves faster, the footprint follows it at this
            speed (``FootOptions.slide_speed_m_s`` over the frame rate).

    Returns:
        Footprints of both feet, in order of side then time.
    """
    out = []
    level = robot.frame_rotations(robot.q_nominal,
                                  [robot.soles[s].frame for s in SIDES])  # soles level there
    support = np.asarray(support, dtype=bool)
    sliding = np.zeros_like(support) if sliding is None else np.asarray(sliding, bool) & support
    for k, side in enumerate(SIDES):
        sole = robot.soles[side]
        rot_level = level[k]
        poses = sole_poses[side]
        reach = ankle_reach(robot, side, load)
        # in the sole frame (the ankle is its origin): the rectangle shrunk about its centre
        local = sole.center + (1.0 - margin) * (sole.corners() - sole.center)
        local[:, :2] = np.clip(local[:, :2], -reach, reach)
        # a planted phase: its middle half's placement; a slide: every frame's own
        spans: list[tuple[int, int, int, int, bool]] = [
            (start, stop, *middle_half(start, stop), False)
            for start, stop in runs(support[:, k] & ~sliding[:, k])]
        source = np.arange(len(poses))  # the frame whose sole places each slide frame
        height = (poses[:, :3, :3] @ sole.center + poses[:, :3, 3])[:, 2]
        for a0, b0 in runs(sliding[:, k]):
            ok = np.flatnonzero(height[a0:b0] <= reach_m) + a0
            if len(ok) and len(ok) < b0 - a0:
                t = np.arange(a0, b0)
                source[a0:b0] = ok[np.argmin(np.abs(t[:, None] - ok[None, :]), axis=1)]
        spans += [(int(t), int(t) + 1, int(source[t]), int(source[t]) + 1, True)
                  for t in np.flatnonzero(sliding[:, k])]
        previous = None
        for start, stop, a, b, slide in sorted(spans):
            pose = level_placement(sole, rot_level, poses[a:b])
            R, c = pose[:3, :3], pose[:3, :3] @ sole.center + pose[:3, 3]
            if slide and previous is not None and previous.stop == start:
                step = c[:2] - previous.center_m[:2]
                length = float(np.linalg.norm(step))
                if length > slide_step_m:  # a loaded sole dragged faster than the leg follows
                    pose[:2, 3] -= step * (1.0 - slide_step_m / length)
                    c = pose[:3, :3] @ sole.center + pose[:3, 3]
            corners = sole.corners() @ R.T + pose[:3, 3]
            previous = Footprint(side=side, start=int(start), stop=int(stop), frame_pose=pose,
                                 center_m=c, corners_m=corners,
                                 polygon_m=local @ R.T + pose[:3, 3], sliding=slide)
            out.append(previous)
    return out


def _shifted(f: Footprint, shift: np.ndarray) -> Footprint:
    """The footprint translated by ``shift`` (2,) [m] along the ground."""
    d = np.array([shift[0], shift[1], 0.0])
    pose = f.frame_pose.copy()
    pose[:3, 3] += d
    return dataclasses.replace(f, frame_pose=pose, center_m=f.center_m + d,
                               corners_m=f.corners_m + d, polygon_m=f.polygon_m + d)


def raised(f: Footprint, height_m: float) -> Footprint:
    """The footprint lifted by ``height_m`` [m]: level on a surface at that height (a prop's
    top) instead of z = 0."""
    d = np.array([0.0, 0.0, height_m])
    pose = f.frame_pose.copy()
    pose[:3, 3] += d
    return dataclasses.replace(f, frame_pose=pose, center_m=f.center_m + d,
                               corners_m=f.corners_m + d, polygon_m=f.polygon_m + d)


def _axes(f: Footprint) -> np.ndarray:
    """(2, 2) the level sole's forward and left axes (columns) in the ground plane."""
    R = f.frame_pose[:2, :2]
    return R / np.linalg.norm(R, axis=0, keepdims=True)


def _contact_groups(footprints: list[Footprint], gap_frames: int) -> list[list[int]]:
    """Indices of each foot's consecutive footprints (a planted phase, the slides it runs into,
    those after a swing of at most ``gap_frames``), in time order."""
    order = sorted(range(len(footprints)), key=lambda i: (footprints[i].side,
                                                          footprints[i].start))
    groups: list[list[int]] = []
    for i in order:
        prev = groups[-1][-1] if groups else None
        if (prev is not None and footprints[prev].side == footprints[i].side
                and footprints[i].start - footprints[prev].stop <= gap_frames):
            groups[-1].append(i)
        else:
            groups.append([i])
    return groups


def place_under_zmp(footprints: list[Footprint], support: np.ndarray, zmp_m: np.ndarray,
                    min_frames: int = 3, gap_frames: int = 6, stance_m: float = 0.0,
                    smooth_frames: int = 5, only_slides: bool = False,
                    static: np.ndarray | None = None) -> tuple[list[Footprint], list[dict]]:
    """Move a foot's ground contact under the ZMP it has to carry alone.

    A foot that carries the body alone must hold the ZMP inside its sole. Where the initial
    trajectory's multibody ZMP (``zmp_m``) lies outside the part of the sole the ZMP may use
    (``Footprint.polygon_m``) in frames where this foot is the only support, the contact is
    moved by the shortest vector that brings it inside, as a person places a foot under the
    body: a planted footprint as a whole (by the mean over its single-support frames), a slide
    frame by frame (smoothed over ``smooth_frames``; interpolated between single-support
    frames, so the slide stays continuous), each foot's consecutive footprints (also across
    swings of at most ``gap_frames``, a shuffle that barely leaves the floor) as one contact.
    The human's own foot placement is kept wherever it balances. (MakeHuman's zombie walk is
    an in-place cycle: it stands on one foot with the body 200-270 mm to the side of it, and
    slides that foot 250 mm back under a body that does not move; no sole carries that, and
    moving the trunk instead moves every upper-body key point.)

    Args:
        footprints: :func:`plan_footprints`.
        support: (T, 2) bool planned support.
        zmp_m: (T, 2) [m] the initial trajectory's ZMP.
        min_frames: contacts with fewer single-support frames are kept where they are.
        gap_frames: footprints of a foot separated by a swing this short move together (a
            foot re-placed by different shifts would have to jump between them).
        stance_m: in the frames where both feet support, the moves keep the sole centres at
            least this far apart [m] (or as far as the human's, if nearer): every move is
            scaled down by one factor until they do (the feet must not meet).
        smooth_frames: width of the moving average of a slide's shifts.
        only_slides: move only contacts with a slide (the human's placement of a sliding foot
            is an animator's, not the floor's; planted feet stay where the human put them).
        static: (T,) bool the frames whose ZMP counts (None: all): the quasi-static ones, whose
            ZMP is under the CoM (a dynamic frame's ZMP is the dynamics' business, and a fast
            clip's initializer, CMU 60_10 at its header's 120 fps, has it 0.2-0.6 m away).

    Returns:
        (the footprints, one dict per moved contact: side, frames, shift_m: the largest move).
    """
    out = list(footprints)
    T = len(support)
    alone = support & ~support[:, ::-1]
    if static is not None:
        alone &= np.asarray(static, dtype=bool)[:, None]
    shift = np.zeros((len(out), 2))
    moved: list[dict] = []
    for group in _contact_groups(out, gap_frames):
        if only_slides and not any(out[i].sliding for i in group):
            continue
        k = SIDES.index(out[group[0]].side)
        t_mid, need = [], []  # per footprint: its middle frame and its demand (NaN: none)
        for i in group:
            f = out[i]
            axes = _axes(f)
            only = np.flatnonzero(alone[f.start:f.stop, k])
            poly = (f.polygon_m[:, :2] - f.center_m[:2]) @ axes
            if len(only):
                local = ((zmp_m[f.start + only] - f.center_m[:2]) @ axes).mean(axis=0)
                excess = local - np.clip(local, poly.min(axis=0), poly.max(axis=0))
                need.append(axes @ excess)
            else:
                need.append(np.full(2, np.nan))
            t_mid.append(0.5 * (f.start + f.stop - 1))
        demand = np.array(need)
        n_single = sum(int(alone[out[i].start:out[i].stop, k].sum()) for i in group)
        have = np.isfinite(demand[:, 0])
        if n_single < min_frames or not np.any(demand[have]):
            continue
        t = np.array(t_mid)
        # between single-support frames interpolated, towards the human's placement (no
        # move) at the contact's ends
        t_a = np.r_[out[group[0]].start - 1, t[have], out[group[-1]].stop]
        for a in range(2):
            demand[:, a] = np.interp(t, t_a, np.r_[0.0, demand[have, a], 0.0])
        slides = np.array([out[i].sliding for i in group])
        for a0, b0 in runs(slides):  # a slide's frames: a moving average
            if b0 - a0 > 1 and smooth_frames > 1:
                w = min(smooth_frames, b0 - a0)
                pad = np.pad(demand[a0:b0], ((w // 2, w - 1 - w // 2), (0, 0)), mode="edge")
                kernel = np.ones(w) / w
                demand[a0:b0] = np.stack([np.convolve(pad[:, a], kernel, mode="valid")
                                          for a in range(2)], axis=1)
        shift[group] = demand
        big = int(np.argmax(np.linalg.norm(demand, axis=1)))
        moved.append({"side": out[group[0]].side,
                      "frames": (out[group[0]].start, out[group[-1]].stop),
                      "shift_m": demand[big]})
    if not moved:
        return out, moved
    centre = np.full((T, 2, 2), np.nan)
    shift_of = np.zeros((T, 2, 2))
    for i, f in enumerate(out):
        centre[f.start:f.stop, SIDES.index(f.side)] = f.center_m[:2]
        shift_of[f.start:f.stop, SIDES.index(f.side)] = shift[i]
    # where both feet support, the largest factor of both moves (per frame) that keeps them
    # apart; each footprint takes the smallest factor of its frames
    both = support.all(axis=1) & np.isfinite(centre).all(axis=(1, 2))
    apart = np.linalg.norm(centre[:, 0] - centre[:, 1], axis=1)
    need_m = np.minimum(np.where(both, apart, 0.0), stance_m)
    factor = np.zeros(T)
    for alpha in np.linspace(0.0, 1.0, 21):  # ascending: the largest that holds
        c = centre + alpha * shift_of
        ok = ~both | (np.linalg.norm(c[:, 0] - c[:, 1], axis=1) >= need_m - 1e-9)
        factor = np.where(ok, alpha, factor)
    for i, f in enumerate(out):
        shift[i] *= factor[f.start:f.stop].min()
    for m in moved:
        a, b = m["frames"]
        sel = [i for i, f in enumerate(out) if f.side == m["side"] and a <= f.start < b]
        m["shift_m"] = shift[sel[int(np.argmax(np.linalg.norm(shift[sel], axis=1)))]]
    out = [_shifted(f, shift[i]) if np.any(shift[i]) else f for i, f in enumerate(out)]
    return out, moved


def footprint_tracks(footprints: list[Footprint], n_frames: int, fps: float) -> SoleTracks:
    """Sole tracks of the planned support: the footprints' corners and centres in their phases,
    NaN elsewhere (for :func:`imesh.metrics.zmp.desired_zmp` and the polygons)."""
    corners = {s: np.full((n_frames, 4, 3), np.nan) for s in SIDES}
    centers = {s: np.full((n_frames, 3), np.nan) for s in SIDES}
    for f in footprints:
        corners[f.side][f.start:f.stop] = f.corners_m
        centers[f.side][f.start:f.stop] = f.center_m
    return SoleTracks(corners=corners, centers=centers, fps=fps)


def support_halfplanes(footprints: list[Footprint], support: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The support polygon of every supported frame as half-planes ``n . p >= b``: the convex
    hull of the supporting footprints' usable parts (``Footprint.polygon_m``).

    Args:
        footprints: the planned footprints.
        support: (T, 2) bool planned support.

    Returns:
        (frame (R,) int, normal (R, 2) unit inward normals, offset (R,) [m]) over all edges of
        all supported frames' convex hulls.
    """
    T = len(support)
    phase_of = {s: np.full(T, -1) for s in SIDES}
    for i, f in enumerate(footprints):
        phase_of[f.side][f.start:f.stop] = i
    frames, normals, offsets = [], [], []
    cache: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
    for t in np.flatnonzero(support.any(axis=1)):
        key = (int(phase_of["left"][t]), int(phase_of["right"][t]))
        if key not in cache:  # the polygon only changes with the phases: one hull per pair
            pts = np.concatenate([footprints[i].polygon_m[:, :2] for i in key if i >= 0])
            hull = convex_hull_2d(pts)  # counter-clockwise
            edge = np.roll(hull, -1, axis=0) - hull
            n = np.stack([-edge[:, 1], edge[:, 0]], axis=1)  # inward for counter-clockwise
            n /= np.linalg.norm(n, axis=1, keepdims=True)
            cache[key] = (n, np.sum(n * hull, axis=1))
        n, b = cache[key]
        frames.append(np.full(len(n), t))
        normals.append(n)
        offsets.append(b)
    if not frames:
        return np.zeros(0, dtype=int), np.zeros((0, 2)), np.zeros(0)
    return np.concatenate(frames), np.concatenate(normals), np.concatenate(offsets)

"""The reference a simulation tracks: the motion placed on the ground, its derivatives, support
phases and planned (multibody) ZMP. numpy/scipy and the Robot only (no dartpy)."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..contacts.phases import SIDES
from ..metrics.collision import LowestPoint
from ..metrics.derivatives import motion_derivatives
from ..metrics.soles import SoleTracks, sole_tracks
from ..metrics.support import SupportDetection, motion_support
from ..metrics.zmp import zmp_trajectory

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

    from ..scene.surfaces import SupportSurfaces

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class Reference:
    """A robot motion prepared for tracking.

    Attributes:
        q: (T, nq) float configurations, base raised by ``ground_offset_m``.
        v: (T, nv) float velocities (pinocchio convention).
        a: (T, nv) float accelerations (pinocchio convention).
        fps: frame rate [1/s].
        support: (T, 2) bool [left, right] feet in support (planned, or detected from the
            soles).
        moving: (T, 2) bool the support frames in which the plan slides or pivots the foot
            (``RobotMotion.contact_modes``; all False without them).
        soles: sole tracks of ``q``.
        zmp_m: (T, 2) float [m] planned multibody ZMP of ``q``.
        ground_offset_m: [m] added to the base height so that the lowest point of the first
            frame (soles and non-foot proxies) sits ``GroundConfig.start_clearance_m`` above
            the ground.
    """

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    fps: float
    support: np.ndarray
    moving: np.ndarray
    soles: SoleTracks
    zmp_m: np.ndarray
    ground_offset_m: float

    @property
    def n_frames(self) -> int:
        return len(self.q)

    @property
    def duration_s(self) -> float:
        return (self.n_frames - 1) / self.fps


def first_frame_height(robot, q0: np.ndarray, surfaces: SupportSurfaces | None = None
                       ) -> float:
    """[m] lowest point of a configuration over the sole rectangles and the collision proxies of
    the non-foot links (the shapes the DART world collides with). With ``surfaces`` (a scene's
    prop tops) a sole corner counts from the surface under it (the other proxies from the
    floor)."""
    soles = sole_tracks(robot, q0[None], 30.0)
    corners = np.concatenate([soles.corners[s][0] for s in SIDES])  # (8, 3)
    under = surfaces.heights(corners) if surfaces is not None else np.zeros(len(corners))
    low = float((corners[:, 2] - under).min())
    lp = LowestPoint(robot)
    feet = {robot.soles[s].frame for s in robot.soles} | set(robot.foot_frames.values())
    heights = lp.heights(q0)
    others = [h for h, f in zip(heights, lp.frames, strict=True) if f not in feet]
    return min([low, *others])


def build_reference(robot, q: np.ndarray, fps: float, *, clearance_m: float = 0.001,
                    place_on_ground: bool = True,
                    support_config: SupportDetection | None = None,
                    contact_modes: np.ndarray | None = None,
                    surfaces: SupportSurfaces | None = None) -> Reference:
    """Prepare a motion for tracking: ground placement, derivatives, support, planned ZMP.

    Args:
        robot: the robot.
        q: (T, nq) float configurations.
        fps: frame rate [1/s].
        clearance_m: height of the first frame's lowest point above the ground [m].
        place_on_ground: shift the base height (all frames alike); False keeps the motion as is.
        support_config: thresholds of the sole-based support detection.
        contact_modes: (T, 2) int planned contact modes (``RobotMotion.contact_modes``): the
            support phases tracked; None: detected from the soles.
        surfaces: the prop tops the soles may stand on (the first frame's soles are placed
            on the surfaces under them); None: the floor.
    """
    q = np.array(q, dtype=float)
    offset = 0.0
    if place_on_ground:
        offset = clearance_m - first_frame_height(robot, q[0], surfaces)
        q[:, 2] += offset
        if abs(offset) > 0.01:
            log.info("%s: motion placed on the ground: base raised by %+.1f mm", robot.name,
                     1e3 * offset)
    v, a = motion_derivatives(q, fps)
    soles = sole_tracks(robot, q, fps)
    contacts = motion_support(soles, contact_modes, support_config)
    zmp = zmp_trajectory(robot, q, fps)
    return Reference(q=q, v=v, a=a, fps=fps, support=contacts.support, moving=contacts.moving,
                     soles=soles, zmp_m=zmp, ground_offset_m=float(offset))


def joint_splines(q: np.ndarray, fps: float) -> CubicSpline | None:
    """Cubic spline of the joint angles q[:, 7:] over frame times (None for a single frame)."""
    from scipy.interpolate import CubicSpline  # imported by the physics check only

    if len(q) < 2:
        return None
    t = np.arange(len(q)) / fps
    return CubicSpline(t, q[:, 7:], axis=0, bc_type="natural" if len(q) < 4 else "not-a-knot")


def sample_frames(values: np.ndarray, times: np.ndarray, fps: float) -> np.ndarray:
    """Linear interpolation of per-frame rows (T, ...) at ``times`` [s] (clamped to the clip)."""
    T = len(values)
    x = np.clip(np.asarray(times) * fps, 0.0, T - 1)
    i = np.minimum(np.floor(x).astype(np.int64), max(T - 2, 0))
    w = (x - i).reshape(-1, *([1] * (values.ndim - 1)))
    if T == 1:
        return np.repeat(values[:1], len(x), axis=0)
    return values[i] * (1 - w) + values[i + 1] * w

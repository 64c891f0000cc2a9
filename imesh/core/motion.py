"""MarkerMotion: marker (or joint) trajectories in metres, world Z up.

The one type every reader produces and every solver consumes. Arrays are frame-major:
``positions_m[t, j]`` is marker ``j`` at frame ``t``. Missing samples are NaN in ``positions_m`` and
False in ``valid``; the two always agree.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..errors import (
    ImplausibleMotionError,
    InvalidMotionError,
    MissingMarkerError,
    OptionError,
    TooFewFramesError,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class MarkerMotion:
    """Marker trajectories of one or more performers.

    Attributes:
        positions_m: (T, M, 3) float64 [m], world frame, Z up, X forward when known. NaN where
            a sample is missing.
        fps: frames per second [1/s].
        names: (M,) marker names, unique.
        valid: (T, M) bool, True where the sample was measured.
        bones: (B, 2) int marker index pairs (parent, child) of the skeleton, when known; empty for
            raw marker sets without a skeleton.
        source: where the motion came from (file path, or a generator name).
        meta: read-only decisions taken while loading (``units``, ``unit_scale_m``, ``up_axis``,
            ``floor_offset_m``, rig name, ...), for reports and ``imesh inspect``.
    """

    positions_m: np.ndarray
    fps: float
    names: tuple[str, ...]
    valid: np.ndarray
    bones: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    source: str = ""
    meta: Mapping[str, object] = field(default_factory=dict)

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions_m, dtype=np.float64)
        if pos.ndim != 3 or pos.shape[2] != 3:
            raise InvalidMotionError(
                f"{self.source or 'motion'}: positions_m must have shape (T, M, 3), got {pos.shape}"
            )
        n_frames, n_markers, _ = pos.shape
        if n_frames < 1 or n_markers < 1:
            raise InvalidMotionError(
                f"{self.source or 'motion'}: motion needs at least one frame and one marker, "
                f"got {n_frames} frames x {n_markers} markers"
            )
        names = tuple(str(n) for n in self.names)
        if len(names) != n_markers:
            raise InvalidMotionError(
                f"{self.source or 'motion'}: {len(names)} names for {n_markers} markers"
            )
        if len(set(names)) != len(names):
            dup = sorted({n for n in names if names.count(n) > 1})
            raise InvalidMotionError(f"{self.source or 'motion'}: duplicate marker names {dup}")
        if not (np.isfinite(self.fps) and self.fps > 0):
            raise InvalidMotionError(f"{self.source or 'motion'}: fps must be > 0, got {self.fps}")
        valid = np.asarray(self.valid, dtype=bool)
        if valid.shape != (n_frames, n_markers):
            raise InvalidMotionError(
                f"{self.source or 'motion'}: valid must have shape {(n_frames, n_markers)}, "
                f"got {valid.shape}"
            )
        finite = np.isfinite(pos).all(axis=2)
        valid = valid & finite
        if not (_frozen(pos) and valid.all()):  # a frozen array with nothing missing is kept
            pos = np.where(valid[..., None], pos, np.nan)
        bones = np.asarray(self.bones, dtype=np.int64).reshape(-1, 2)
        if bones.size and (bones.min() < 0 or bones.max() >= n_markers):
            raise InvalidMotionError(
                f"{self.source or 'motion'}: bone indices must lie in [0, {n_markers})"
            )
        pos.setflags(write=False)
        valid.setflags(write=False)
        bones.setflags(write=False)
        object.__setattr__(self, "positions_m", pos)
        object.__setattr__(self, "valid", valid)
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "fps", float(self.fps))
        object.__setattr__(self, "bones", bones)
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))

    # ------------------------------------------------------------------ sizes
    @property
    def n_frames(self) -> int:
        return self.positions_m.shape[0]

    @property
    def n_markers(self) -> int:
        return self.positions_m.shape[1]

    @property
    def duration_s(self) -> float:
        return (self.n_frames - 1) / self.fps

    @property
    def missing_fraction(self) -> float:
        """Fraction of (frame, marker) samples that are missing."""
        return float(1.0 - self.valid.mean())

    @property
    def height_m(self) -> float:
        """Body height [m]: median over frames of the vertical extent of the valid markers.

        Frames with fewer than half of the markers valid are ignored. Joint-centre rigs
        understate stature by 10-20 % (the skull top and the soles are not joints).
        """
        z = self.positions_m[..., 2]
        enough = self.valid.sum(axis=1) >= max(2, self.n_markers // 2)
        if not enough.any():
            return float("nan")
        zz = z[enough]
        extent = np.nanmax(zz, axis=1) - np.nanmin(zz, axis=1)
        return float(np.median(extent))

    # ------------------------------------------------------------------ lookup
    def index(self, name: str) -> int:
        """Index of marker ``name``; raises MissingMarkerError listing the available names."""
        try:
            return self.names.index(name)
        except ValueError:
            raise MissingMarkerError(
                f"{self.source or 'motion'}: no marker {name!r}", [name], self.names
            ) from None

    def indices(self, names: Iterable[str]) -> np.ndarray:
        names = list(names)
        missing = [n for n in names if n not in self.names]
        if missing:
            raise MissingMarkerError(f"{self.source or 'motion'}: unknown markers", missing,
                                     self.names)
        lookup = {n: i for i, n in enumerate(self.names)}
        return np.array([lookup[n] for n in names], dtype=np.int64)

    def bone_names(self) -> list[tuple[str, str]]:
        return [(self.names[a], self.names[b]) for a, b in self.bones]

    # ------------------------------------------------------------------ derived motions
    def replace(self, **changes) -> MarkerMotion:
        """A copy with some fields replaced (validated again)."""
        return dataclasses.replace(self, **changes)

    def with_positions(self, positions_m: np.ndarray, **changes) -> MarkerMotion:
        """Same names, bones and fps with new positions (validity follows finiteness)."""
        positions_m = np.asarray(positions_m, dtype=np.float64)
        valid = np.isfinite(positions_m).all(axis=2)
        return dataclasses.replace(self, positions_m=positions_m, valid=valid, **changes)

    def subset(self, names: Sequence[str]) -> MarkerMotion:
        """The markers ``names`` (in that order); bones between kept markers are kept."""
        idx = self.indices(names)
        remap = -np.ones(self.n_markers, dtype=np.int64)
        remap[idx] = np.arange(len(idx))
        bones = remap[self.bones] if self.bones.size else self.bones
        bones = bones[(bones >= 0).all(axis=1)] if bones.size else bones
        return dataclasses.replace(
            self, positions_m=self.positions_m[:, idx], valid=self.valid[:, idx],
            names=tuple(names), bones=bones,
        )

    def frames(self, start: int, stop: int | None = None) -> MarkerMotion:
        """Frames ``start:stop`` (Python slice semantics)."""
        sl = slice(start, stop)
        pos = self.positions_m[sl]
        if pos.shape[0] == 0:
            raise OptionError("frame range", (start, stop),
                              f"a non-empty range within 0..{self.n_frames}")
        return dataclasses.replace(self, positions_m=pos, valid=self.valid[sl])

    def resample(self, fps: float) -> MarkerMotion:
        """Resample to ``fps`` by linear interpolation in time (per marker, gaps stay gaps).

        A new sample is valid only when both neighbouring source samples are valid.
        """
        if not (np.isfinite(fps) and fps > 0):
            raise OptionError("fps", fps, "a positive number")
        if abs(fps - self.fps) < 1e-9 * self.fps:
            return self
        t_src = np.arange(self.n_frames) / self.fps
        # a frame short of the end by a rounding of the header's frame time still counts (a
        # 30 fps BVH's 0.0333333 s is 30.00003 fps: 67.99993 frames at 30 fps, not 67; the
        # last one's time is clipped to the source's end)
        n_new = int(np.floor(self.duration_s * fps + 1e-3)) + 1
        t_new = np.arange(n_new) / fps
        s = np.clip(t_new * self.fps, 0, self.n_frames - 1)
        i0 = np.floor(s).astype(np.int64)
        i1 = np.minimum(i0 + 1, self.n_frames - 1)
        a = (s - i0)[:, None, None]
        p0 = self.positions_m[i0]
        p1 = self.positions_m[i1]
        pos = (1 - a) * p0 + a * p1
        valid = self.valid[i0] & (self.valid[i1] | (a[..., 0] == 0))
        pos = np.where(valid[..., None], pos, np.nan)
        log.info("resampled %s from %.3f to %.3f fps (%d -> %d frames)", self.source or "motion",
                 self.fps, fps, self.n_frames, n_new)
        del t_src
        return dataclasses.replace(self, positions_m=pos, valid=valid, fps=float(fps))

    def concat_markers(self, other: MarkerMotion, prefix_self: str = "", prefix_other: str = ""
                       ) -> MarkerMotion:
        """Markers of two performers in one motion (same world frame, same fps and frame count).

        Names are prefixed to stay unique; bones of both are kept.
        """
        if other.n_frames != self.n_frames or abs(other.fps - self.fps) > 1e-6 * self.fps:
            raise InvalidMotionError(
                f"cannot combine {self.source} ({self.n_frames} frames at {self.fps:g} fps) with "
                f"{other.source} ({other.n_frames} frames at {other.fps:g} fps): frame count and "
                "fps must match"
            )
        names = tuple(prefix_self + n for n in self.names) + tuple(
            prefix_other + n for n in other.names)
        bones = np.concatenate([self.bones, other.bones + self.n_markers]).reshape(-1, 2)
        meta = dict(self.meta)
        meta["people"] = [self.source, other.source]
        return MarkerMotion(
            positions_m=np.concatenate([self.positions_m, other.positions_m], axis=1),
            fps=self.fps, names=names,
            valid=np.concatenate([self.valid, other.valid], axis=1), bones=bones,
            source=f"{self.source}+{other.source}", meta=meta,
        )

    def summary(self) -> dict:
        """The ``imesh inspect --json`` object."""
        return {
            "frames": self.n_frames,
            "fps": self.fps,
            **({"fps_reason": self.meta["fps_reason"]} if "fps_reason" in self.meta else {}),
            "markers": list(self.names),
            "height_m": self.height_m,
            "units": self.meta.get("units", "m"),
            "up_axis": self.meta.get("up_axis", "+Z"),
            "missing_fraction": self.missing_fraction,
        }


def _frozen(a: np.ndarray) -> bool:
    """No one can write to ``a``: it and every array it is a view of are read-only (so a
    MarkerMotion may keep it without a copy: a 30-minute clip's positions are 200 MB)."""
    view: object = a  # the bases: arrays, then whatever owns the memory (bytes, mmap, None)
    while isinstance(view, np.ndarray):
        if view.flags.writeable:
            return False
        view = view.base
    return True


# ---------------------------------------------------------------------------------------------
# plausibility: is this a recording of a person? (checked once, when a file is loaded)

#: Largest plausible |coordinate| of a marker [m] (floor-shifted world frame): capture volumes
#: are tens of metres; beyond this the numbers are garbage (or the units are wrong).
PLAUSIBLE_POSITION_M = 1000.0
#: Plausible body height [m] (median vertical extent of the markers; joint rigs understate it).
PLAUSIBLE_HEIGHT_M = (0.3, 3.0)
#: Fastest plausible marker speed between two consecutive samples [m/s]. Body parts peak near
#: 30 m/s; marker glitches in good clips reach 69 m/s (CMU salsa foot end site at its header's
#: 120 fps); a corrupted sample jumps far beyond.
MAX_MARKER_SPEED_M_S = 100.0
#: Plausible frame rates [1/s].
PLAUSIBLE_FPS = (1.0, 10000.0)


def check_plausible(motion: MarkerMotion) -> None:
    """Raise unless ``motion`` can be a recording of a person (vectorized; cheap).

    Checks, in order: the frame rate lies in :data:`PLAUSIBLE_FPS`; some marker is present in
    some frame; the body height (:attr:`MarkerMotion.height_m`) can be measured and lies in
    :data:`PLAUSIBLE_HEIGHT_M`; every present coordinate is within
    :data:`PLAUSIBLE_POSITION_M`; no marker moves faster than :data:`MAX_MARKER_SPEED_M_S`
    between two consecutive present samples (a corrupted sample, named by frame).

    Raises:
        ImplausibleMotionError: naming the file, the check, the frame and marker where one
            applies, and the valid range.
    """
    src = motion.source or "motion"
    lo, hi = PLAUSIBLE_FPS
    if not lo <= motion.fps <= hi:
        raise ImplausibleMotionError(src, "frame rate", f"frame rate {motion.fps:.6g} fps",
                                     valid=f"{lo:g} to {hi:g} fps", value=motion.fps)
    if not motion.valid.any():
        raise ImplausibleMotionError(
            src, "missing markers", f"all {motion.n_markers} markers are missing in all "
            f"{motion.n_frames} frames", valid="a clip with markers present")
    height = motion.height_m
    lo, hi = PLAUSIBLE_HEIGHT_M
    if not np.isfinite(height):
        need = max(2, motion.n_markers // 2)
        best = int(motion.valid.sum(axis=1).max())
        raise ImplausibleMotionError(
            src, "missing markers", f"no frame has {need} of the {motion.n_markers} markers "
            f"present (at most {best}), so the body height cannot be measured",
            valid=f"frames with at least {need} markers present")
    if not lo <= height <= hi:
        units = motion.meta.get("units")
        hint = f" (units {units}: wrong units? pass --units)" if units else ""
        raise ImplausibleMotionError(src, "height", f"body height {height:.4g} m{hint}",
                                     valid=f"{lo:g} to {hi:g} m", value=height)
    pos, valid = motion.positions_m, motion.valid
    # in blocks of frames: a 30-minute clip's (T, M, 3) temporaries would be 200 MB each
    for a in range(0, motion.n_frames, _CHECK_BLOCK):
        p_, v_ = pos[a:a + _CHECK_BLOCK], valid[a:a + _CHECK_BLOCK]
        far = v_ & (np.abs(np.where(v_[..., None], p_, 0.0)) > PLAUSIBLE_POSITION_M).any(axis=2)
        if far.any():
            t, j = (int(i[0]) for i in np.nonzero(far))
            t += a
            n_far = int(sum((valid[b:b + _CHECK_BLOCK] & (np.abs(np.where(
                valid[b:b + _CHECK_BLOCK, :, None], pos[b:b + _CHECK_BLOCK], 0.0))
                > PLAUSIBLE_POSITION_M).any(axis=2)).sum()
                for b in range(a, motion.n_frames, _CHECK_BLOCK)))
            value = float(np.abs(pos[t, j]).max())
            raise ImplausibleMotionError(
                src, "position range", f"coordinate {value:.4g} m ({n_far} samples beyond "
                f"{PLAUSIBLE_POSITION_M:g} m)", valid=f"|coordinate| <= {PLAUSIBLE_POSITION_M:g} m",
                frame=t, marker=motion.names[j], value=value)
    if motion.n_frames < 2:
        return

    def speeds(a: int, b: int) -> np.ndarray:  # (b - a, M) [m/s] of the steps t -> t+1
        both = valid[a + 1:b + 1] & valid[a:b]
        step = np.linalg.norm(np.diff(pos[a:b + 1], axis=0), axis=2)
        return np.where(both, step, 0.0) * motion.fps

    n_steps = motion.n_frames - 1
    for a in range(0, n_steps, _CHECK_BLOCK):
        speed = speeds(a, min(a + _CHECK_BLOCK, n_steps))
        fast = speed > MAX_MARKER_SPEED_M_S
        if not fast.any():
            continue
        k = int(np.flatnonzero(fast.any(axis=1))[0])  # first step t -> t+1 too fast
        t = a + k
        j = int(np.flatnonzero(speed[k] >= 0.99 * speed[k].max())[0])  # root before its kids
        others = int(fast[k].sum()) - 1
        # out and back: sample t+1 is corrupt
        spike = t + 1 < n_steps and bool(speeds(t + 1, t + 2)[0, j] > MAX_MARKER_SPEED_M_S)
        frame = t + 1 if spike else t
        also = f" (and {others} other markers)" if others else ""
        what = ("jumps there and back" if spike else
                f"jumps between frames {t} and {t + 1}")
        step_m = speed[k, j] / motion.fps
        raise ImplausibleMotionError(
            src, "marker speed", f"corrupted sample: the marker {what}{also}, "
            f"{step_m:.3g} m in one frame = {speed[k, j]:.3g} m/s",
            valid=f"at most {MAX_MARKER_SPEED_M_S:g} m/s between frames", frame=frame,
            marker=motion.names[j], value=float(speed[k, j]))


#: Frames checked at a time by :func:`check_plausible`.
_CHECK_BLOCK = 16384


def require_frames(motion: MarkerMotion, needed: int, method: str) -> None:
    """Raise :class:`~imesh.errors.TooFewFramesError` unless ``motion`` has ``needed`` frames.

    Args:
        motion: the motion.
        needed: frames the method needs.
        method: what needs them, for the message ("the retarget pipeline (...)").
    """
    if motion.n_frames < needed:
        raise TooFewFramesError(motion.source or "motion", motion.n_frames, needed, method)

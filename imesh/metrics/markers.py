"""Marker-level quality metrics (names as in DESIGN.md): ``close_pair_error`` and
``marker_rms_mm``, plus the robot key points as a marker motion so a robot motion can be scored
against human markers."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import InvalidMotionError, MissingMarkerError

CLOSE_PAIR_FRACTION = 0.15


def non_adjacent_pairs(n_markers: int, bones: np.ndarray) -> np.ndarray:
    """(P, 2) marker pairs i < j not joined by a bone."""
    i, j = np.triu_indices(n_markers, k=1)
    adjacent = np.zeros((n_markers, n_markers), dtype=bool)
    if len(bones):
        adjacent[bones[:, 0], bones[:, 1]] = True
        adjacent[bones[:, 1], bones[:, 0]] = True
    keep = ~adjacent[i, j]
    return np.stack([i[keep], j[keep]], axis=1)


def close_pair_error(source: MarkerMotion, adapted: MarkerMotion,
                     fraction: float = CLOSE_PAIR_FRACTION,
                     pairs: np.ndarray | None = None) -> float:
    """Mean abs change of height-normalized distance of close non-adjacent marker pairs.

    For every frame t and non-adjacent pair (a, b) with source distance d < fraction * H
    (H = source height), the error is | d'/H' - d/H | with d' the adapted distance and H' the
    adapted height; the metric is the mean over those (frame, pair) samples (0 if none).

    Args:
        source: the source motion.
        adapted: the adapted motion, same markers, frames and bones.
        fraction: closeness threshold relative to the body height (DESIGN.md: 15 %).
        pairs: (P, 2) the marker pairs judged (None: every non-adjacent pair); two partners'
            inter-person pairs (:func:`imesh.partners.evaluate.evaluate_pair`).
    """
    if pairs is None:
        pairs = non_adjacent_pairs(source.n_markers, source.bones)
    h, h2 = source.height_m, adapted.height_m
    d = np.linalg.norm(source.positions_m[:, pairs[:, 0]] - source.positions_m[:, pairs[:, 1]],
                       axis=2)
    d2 = np.linalg.norm(adapted.positions_m[:, pairs[:, 0]] - adapted.positions_m[:, pairs[:, 1]],
                        axis=2)
    close = d < fraction * h
    if not close.any():
        return 0.0
    return float(np.mean(np.abs(d2[close] / h2 - d[close] / h)))


def keypoint_motion(robot, q: np.ndarray, fps: float, names: Sequence[str] | None = None,
                    bones: np.ndarray | None = None, source: str = "") -> MarkerMotion:
    """The robot's key points (markers.toml) over a motion, as a marker motion.

    Args:
        robot: an :class:`imesh.robot.Robot` with a markers.toml.
        q: (T, nq) float configurations.
        fps: frame rate [1/s].
        names: key points to keep, in this order (default: all, markers.toml order); names the
            robot has no key point for are an error.
        bones: (B, 2) int marker index pairs (in ``names`` order) for the result.
        source: a label for the result.

    Returns:
        MarkerMotion (T, K, 3) [m] of the key points.

    Raises:
        MissingMarkerError: a name has no key point on this robot.
    """
    all_names, frame_ids, offsets, _ = robot.keypoint_arrays()
    names = tuple(all_names if names is None else names)
    missing = [n for n in names if n not in all_names]
    if missing:
        raise MissingMarkerError(f"robot {robot.name!r} has no key point for these markers",
                                 missing, all_names)
    idx = [all_names.index(n) for n in names]
    fids, offs = frame_ids[idx], offsets[idx]
    pos = np.empty((len(q), len(names), 3))
    for t, qt in enumerate(np.asarray(q, dtype=float)):
        pos[t] = robot.frame_positions(qt, fids, offs)
    return MarkerMotion(positions_m=pos, fps=fps, names=names,
                        valid=np.ones(pos.shape[:2], dtype=bool),
                        bones=np.zeros((0, 2), np.int64) if bones is None else bones,
                        source=source or f"keypoints:{robot.name}")


def _matched(keypoints: MarkerMotion, markers: MarkerMotion
             ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(common names, (T, K) squared distances [m^2], (T, K) validity) of the markers both
    motions have."""
    common = [n for n in keypoints.names if n in markers.names]
    if not common:
        raise InvalidMotionError(f"no common marker names between the robot key points "
                                 f"({', '.join(keypoints.names)}) and the markers "
                                 f"({', '.join(markers.names)})")
    if keypoints.n_frames != markers.n_frames:
        raise InvalidMotionError(f"robot motion has {keypoints.n_frames} frames, the markers "
                                 f"{markers.n_frames}")
    a = keypoints.positions_m[:, keypoints.indices(common)]
    b = markers.positions_m[:, markers.indices(common)]
    return common, np.sum((a - b) ** 2, axis=2), markers.valid[:, markers.indices(common)]


def marker_rms_by_name_mm(keypoints: MarkerMotion, markers: MarkerMotion) -> dict[str, float]:
    """RMS distance [mm] over the frames of each key point from its marker (the body parts of
    :func:`marker_rms_mm`), worst first; a marker invalid in every frame is left out.

    Args:
        keypoints: (T, K, 3) robot key points (:func:`keypoint_motion`).
        markers: (T, M, 3) the markers they fit.

    Raises:
        InvalidMotionError: different frame counts or no common marker name.
    """
    common, d2, valid = _matched(keypoints, markers)
    out = {n: float(1e3 * np.sqrt(d2[valid[:, k], k].mean()))
           for k, n in enumerate(common) if valid[:, k].any()}
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))


def marker_rms_worst_window(keypoints: MarkerMotion, markers: MarkerMotion, frames: int
                            ) -> tuple[int, int, float]:
    """The ``frames`` consecutive frames farthest from the markers: ``[start, stop)`` and their
    RMS distance [mm] (the when of :func:`marker_rms_mm`, as :func:`marker_rms_by_name_mm` is
    its where).

    The RMS of a window is ``sqrt(sum_t sum_k d_tk^2 / n)`` over its valid (frame, marker)
    samples; windows are compared by it (a motion shorter than ``frames`` is one window).

    Args:
        keypoints: (T, K, 3) robot key points (:func:`keypoint_motion`).
        markers: (T, M, 3) the markers they fit.
        frames: window length (>= 1).

    Raises:
        InvalidMotionError: different frame counts or no common marker name.
    """
    _, d2, valid = _matched(keypoints, markers)
    T = len(d2)
    w = int(min(max(frames, 1), T))
    # windowed sums from cumulative sums over frames: (T - w + 1,) per window
    total = np.concatenate([[0.0], np.cumsum(np.where(valid, d2, 0.0).sum(axis=1))])
    count = np.concatenate([[0], np.cumsum(valid.sum(axis=1))])
    sums, counts = total[w:] - total[:-w], count[w:] - count[:-w]
    rms = np.sqrt(sums / np.maximum(counts, 1))
    start = int(np.argmax(np.where(counts > 0, rms, -1.0)))
    return start, start + w, float(1e3 * rms[start])


def marker_rms_mm(keypoints: MarkerMotion, markers: MarkerMotion) -> float:
    """RMS distance [mm] between robot key points and the markers they fit.

    Markers are matched by name (the names both motions have); frames one to one.

    Args:
        keypoints: (T, K, 3) robot key points (:func:`keypoint_motion`).
        markers: (T, M, 3) the markers (adapted markers, or an arranged source).

    Raises:
        InvalidMotionError: different frame counts or no common marker name.
    """
    _, d2, valid = _matched(keypoints, markers)
    d2 = d2[valid]
    return float(1e3 * np.sqrt(d2.mean())) if d2.size else float("nan")

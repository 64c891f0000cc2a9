"""World positions of a robot's soles over a motion: the corners and centres that the support
detection, the support polygons, the ZMP and the skid metrics read."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..contacts.phases import SIDES


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

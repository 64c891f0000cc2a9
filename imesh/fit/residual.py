"""The rows of the fitting objective (Nakaoka & Komura 2012, eq. 8): the weighted error ``W e``
and its Jacobian ``W J``.

``e`` stacks the key-point position errors ``p_marker - p_robot`` [m] (rows of ``J``:
world-aligned point Jacobians) and the direction errors ``d - u`` of unit vectors
(``u = R_frame axis``, ``d`` the unit human direction ``to - from``; rows ``[J_omega] x u``, so
only the two DOF that tilt ``u`` count, and ``|d - u|`` is the angle for small errors). ``W`` is
diagonal: per-entry weights times FitConfig.position_weight / direction_weight, 0 on the rows of
a marker missing in the frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from .config import FitConfig
from .kinematics import cross_columns
from .targets import CompiledTargets


@dataclass(frozen=True, eq=False)
class FrameRows:
    """The targets of one frame and the weights of their rows.

    Attributes:
        target_p: (K, 3) key-point targets (marker positions) [m].
        ok_p: (K,) the key point's marker is present.
        w_p: (3K,) row weights of the key points [1/m] (0 where missing).
        target_d: (D, 3) unit target directions.
        ok_d: (D,) both markers of the direction are present.
        w_d: (3D,) row weights of the directions [1/rad] (0 where missing).
    """

    target_p: np.ndarray
    ok_p: np.ndarray
    w_p: np.ndarray
    target_d: np.ndarray
    ok_d: np.ndarray
    w_d: np.ndarray

    @property
    def empty(self) -> bool:
        """No marker of the frame is present: nothing to fit."""
        return not (self.ok_p.any() or self.ok_d.any())

    def residual(self, points: np.ndarray, axes: np.ndarray) -> np.ndarray:
        """(3K + 3D,) weighted error ``W e`` of the robot's (K, 3) key points [m] and (D, 3) unit
        axes: key-point rows, then direction rows."""
        e_p = np.where(self.ok_p[:, None], self.target_p - points, 0.0).reshape(-1) * self.w_p
        if axes.shape[0] == 0:
            return e_p
        return np.concatenate([e_p, (self.target_d - axes).reshape(-1) * self.w_d])

    def jacobian(self, jp: np.ndarray, jw: np.ndarray, axes: np.ndarray, nv: int) -> np.ndarray:
        """(3K + 3D, nv) weighted Jacobian ``W J`` of :meth:`residual`'s rows, from the (K, 3, nv)
        key-point Jacobians, the (D, 3, nv) angular Jacobians and the (D, 3) axes."""
        a_rows = jp.reshape(-1, nv) * self.w_p[:, None]
        if axes.shape[0]:
            jd = cross_columns(jw, axes)  # d u = omega x u
            a_rows = np.concatenate([a_rows, jd.reshape(-1, nv) * self.w_d[:, None]])
        return a_rows


@dataclass(frozen=True, eq=False)
class FrameTargets:
    """The targets of every frame of a fit (built once, shared by both passes of the frame loop).

    Missing markers are kept in the arrays and marked in ``kp_ok`` / ``dir_ok``; directions are
    the unit vectors ``to - from`` of the human markers (zero where either is missing).
    """

    kp_pos: np.ndarray  # (T, K, 3) [m]
    kp_ok: np.ndarray  # (T, K)
    kp_w_rows: np.ndarray  # (3K,)
    dir_target: np.ndarray  # (T, D, 3) unit
    dir_ok: np.ndarray  # (T, D)
    dir_w_rows: np.ndarray  # (3D,)

    @classmethod
    def build(cls, markers: MarkerMotion, targets: CompiledTargets,
              config: FitConfig) -> FrameTargets:
        """From the marker motion, the compiled targets and the weights of ``config``."""
        n_frames = markers.n_frames
        kp_pos = markers.positions_m[:, targets.kp_markers]
        kp_ok = markers.valid[:, targets.kp_markers]
        if len(targets.dir_frame_ids):
            tail = markers.positions_m[:, targets.dir_from]
            head = markers.positions_m[:, targets.dir_to]
            vec = head - tail
            norm = np.linalg.norm(vec, axis=2)
            dir_ok = (markers.valid[:, targets.dir_from] & markers.valid[:, targets.dir_to]
                      & (norm > 1e-9))
            dir_target = np.where(dir_ok[..., None],
                                  vec / np.where(dir_ok, norm, 1.0)[..., None], 0.0)
        else:
            dir_ok = np.zeros((n_frames, 0), dtype=bool)
            dir_target = np.zeros((n_frames, 0, 3))
        return cls(kp_pos=kp_pos, kp_ok=kp_ok,
                   kp_w_rows=np.repeat(config.position_weight * targets.kp_weights, 3),
                   dir_target=dir_target, dir_ok=dir_ok,
                   dir_w_rows=np.repeat(config.direction_weight * targets.dir_weights, 3))

    def rows(self, t: int) -> FrameRows:
        """The targets of frame ``t``; a missing marker gets weight 0 on its rows."""
        ok_p, ok_d = self.kp_ok[t], self.dir_ok[t]
        return FrameRows(target_p=self.kp_pos[t], ok_p=ok_p,
                         w_p=np.where(np.repeat(ok_p, 3), self.kp_w_rows, 0.0),
                         target_d=self.dir_target[t], ok_d=ok_d,
                         w_d=np.where(np.repeat(ok_d, 3), self.dir_w_rows, 0.0))

    def errors(self, t: int, points: np.ndarray, axes: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """Key-point distances (K,) [m] and direction angles (D,) [deg] of frame ``t`` for the
        robot's (K, 3) key points [m] and (D, 3) unit axes; NaN where the marker is missing."""
        kp = np.where(self.kp_ok[t], np.linalg.norm(self.kp_pos[t] - points, axis=1), np.nan)
        cosang = np.clip(np.einsum("di,di->d", axes, self.dir_target[t]), -1.0, 1.0)
        return kp, np.where(self.dir_ok[t], np.degrees(np.arccos(cosang)), np.nan)

"""Self-collision rows of the whole-body solve (docs/collision.md).

At every SQP iterate the signed distance of every checked capsule pair
(:class:`imesh.robot.capsules.model.CapsuleModel`) is computed exactly at every frame; the samples
closer than the activation distance become linearized rows ``d + J dq_t + s_t >= margin``,
elastic with one slack ``s_t >= 0`` per frame priced as an exact L1 penalty (as the sole and
ground rows). The merit charges the same price on the exact violations, so the line search
re-checks the nonlinear distances after each step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import scipy.sparse as sp

from ..robot.capsules.model import CapsuleModel, sample_rows


@dataclass(frozen=True, eq=False)
class CollisionLinearization:
    """The self-collision samples of one iterate.

    Attributes:
        frames: (R,) frame of each active sample (closer than the activation distance).
        pairs: (R,) index into ``model.pairs``.
        distance: (R,) [m] signed distance of each sample.
        rows: (R, nv) its gradient with respect to the tangent update of its frame.
        min_distance: (T,) [m] smallest signed distance of any checked pair per frame (+inf
            where no pair is within the activation distance).
    """

    frames: np.ndarray
    pairs: np.ndarray
    distance: np.ndarray
    rows: np.ndarray
    min_distance: np.ndarray


def linearize_collisions(model: CapsuleModel, placements: np.ndarray, jacobians: np.ndarray,
                         activation: float) -> CollisionLinearization:
    """Exact distances of every checked pair within the activation distance at every frame
    (bounding-sphere broad phase), and the rows of the active ones.

    Args:
        model: the robot's capsules.
        placements: (T, F, 4, 4) world placements of ``model.frames``.
        jacobians: (T, F, 6, nv) their world-aligned Jacobians.
        activation: [m] samples closer than this get a row.
    """
    T, nv = placements.shape[0], jacobians.shape[-1]
    if not len(model.pairs):
        z = np.zeros(0, dtype=np.int64)
        return CollisionLinearization(z, z, np.zeros(0), np.zeros((0, nv)), np.full(T, np.inf))
    dist = model.distances(placements, cutoff=activation)
    tt, pp = np.nonzero(dist.distance < activation)
    rows = sample_rows(model, placements, jacobians, tt, pp, dist)
    return CollisionLinearization(frames=tt, pairs=pp, distance=dist.distance[tt, pp],
                                  rows=rows, min_distance=dist.distance.min(axis=1))


class DistanceRows(Protocol):
    """Linearized distances sharing the frame's collision slack: the robot's capsule pairs
    (:class:`CollisionLinearization`) and its links against props
    (:class:`imesh.solve.props.PropLinearization`)."""

    @property
    def frames(self) -> np.ndarray: ...  # (R,) frame of each row
    @property
    def distance(self) -> np.ndarray: ...  # (R,) signed distance [m]
    @property
    def rows(self) -> np.ndarray: ...  # (R, nv) gradient of the distance in dq_t
    @property
    def min_distance(self) -> np.ndarray: ...  # (T,) smallest signed distance per frame [m]


def collision_qp_rows(lin: DistanceRows, n_frames: int, stride: int, slack: int,
                      margin: float) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray]:
    """``rows_r dq_t + s_t >= margin - d_r`` over x = (x_0, ..., x_{T-1}), x_t of size
    ``stride`` with dq_t first and the frame's collision slack at offset ``slack``.

    Returns:
        (G, lower, upper) of the rows.
    """
    R, nv = lin.rows.shape
    cols = lin.frames[:, None] * stride + np.arange(nv)
    G = sp.csr_matrix((np.c_[lin.rows, np.ones(R)].ravel(),
                       (np.repeat(np.arange(R), nv + 1),
                        np.c_[cols, lin.frames * stride + slack].ravel())),
                      shape=(R, n_frames * stride))
    return G, margin - lin.distance, np.full(R, np.inf)


def collision_violation(lin: CollisionLinearization | None, margin: float) -> float:
    """Sum over frames of the largest shortfall of a distance below ``margin`` [m] (what the
    per-frame slacks would have to cover)."""
    if lin is None:
        return 0.0
    return float(np.sum(np.maximum(margin - lin.min_distance, 0.0)))


def colliding_frames(lin: DistanceRows | None, n_frames: int, margin: float) -> np.ndarray:
    """(T,) bool the frames whose smallest distance is more than 1 mm inside ``margin`` [m]:
    the SQP caps their trust radii (``SqpOptions.collision_trust``) and does not stop while
    one is left (the self-collision's, the props' or the obstacles' distances)."""
    if lin is None or not len(lin.min_distance):
        return np.zeros(n_frames, dtype=bool)
    return lin.min_distance < margin - 1e-3

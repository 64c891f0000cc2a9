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

from ..robot.capsules.hulls import BodyHulls
from ..robot.capsules.model import CapsuleModel, sample_rows


@dataclass(frozen=True, eq=False)
class HullShift:
    """How much farther apart the bodies' convex hulls are than each of their capsule pairs,
    per (frame, capsule pair) of one iterate: ``max(0, d_hull(A, B) - d_caps)``.

    Attributes:
        keys: (K,) int sorted ``frame * n_capsule_pairs + capsule pair``.
        shift: (K,) [m] the shift of each.
    """

    keys: np.ndarray
    shift: np.ndarray

    def at(self, keys: np.ndarray) -> np.ndarray:
        """(R,) [m] the shift of each of ``keys`` (0 for a sample this iterate did not have:
        its capsules alone, the conservative bound)."""
        if not len(self.keys):
            return np.zeros(len(keys))
        i = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        return np.where(self.keys[i] == keys, self.shift[i], 0.0)


@dataclass(frozen=True, eq=False)
class CollisionLinearization:
    """The self-collision samples of one iterate.

    Attributes:
        frames: (R,) frame of each active sample (capsules closer than the activation distance).
        pairs: (R,) index into ``model.pairs``.
        distance: (R,) [m] signed distance of each sample: its capsules', raised to its
            bodies' convex hulls' where that is larger (:func:`linearize_collisions`).
        rows: (R, nv) its gradient with respect to the tangent update of its frame.
        min_distance: (T,) [m] smallest signed distance of any checked pair per frame (+inf
            where no pair is within the activation distance).
        capsule_distance: (R,) [m] the capsules' own distance of each sample.
        shift: the hull shift the distances were raised by (None: capsules alone).
        placements: (T, F, 4, 4) the capsule frames' placements (to evaluate the hulls again:
            :func:`refresh_hull_shift`), or None without hulls.
    """

    frames: np.ndarray
    pairs: np.ndarray
    distance: np.ndarray
    rows: np.ndarray
    min_distance: np.ndarray
    capsule_distance: np.ndarray | None = None
    shift: HullShift | None = None
    placements: np.ndarray | None = None


def linearize_collisions(model: CapsuleModel, placements: np.ndarray, jacobians: np.ndarray,
                         activation: float, hulls: BodyHulls | None = None,
                         shift: HullShift | None = None) -> CollisionLinearization:
    """Distances of every checked pair within the activation distance at every frame
    (bounding-sphere broad phase), and the rows of the active ones.

    The capsules bound the geometry's distance from below, by 20-115 mm where a capsule bulges
    beyond a box-shaped link (Talos's hip housings, docs/collision.md). With ``hulls``, each
    active sample r, a capsule pair of bodies A and B, is raised to the bodies' convex hulls'
    distance where that is larger,

        d_r = d_caps,r + max(0, d_hull(A, B) - d_caps,r),

    so the least row of a body pair is the larger of its two lower bounds of the geometry's
    distance (the hulls enclose the geometry too). The rows keep the capsules' gradient: a
    hull's distance is only piecewise smooth (its closest features jump between faces), and
    its linearization carried the HRP-4C walk's legs 5 mm into each other in steps the QP
    predicted clear. The shift is frozen over an SQP iteration: the line search's
    linearizations take the iterate's (``shift``), so along a step the distance is the
    capsules' plus a constant, and :func:`refresh_hull_shift` evaluates it again at the
    accepted point.

    Args:
        model: the robot's capsules.
        placements: (T, F, 4, 4) world placements of ``model.frames``.
        jacobians: (T, F, 6, nv) their world-aligned Jacobians.
        activation: [m] samples whose capsules are closer than this get a row.
        hulls: the bodies' convex hulls (:class:`imesh.robot.capsules.hulls.BodyHulls`), or
            None for the capsules alone.
        shift: the hull shift to use (default: evaluated at these placements).
    """
    T, nv = placements.shape[0], jacobians.shape[-1]
    if not len(model.pairs):
        z = np.zeros(0, dtype=np.int64)
        return CollisionLinearization(z, z, np.zeros(0), np.zeros((0, nv)), np.full(T, np.inf))
    dist = model.distances(placements, cutoff=activation)
    tt, pp = np.nonzero(dist.distance < activation)
    caps = dist.distance[tt, pp]
    rows = sample_rows(model, placements, jacobians, tt, pp, dist)
    if hulls is None:
        return CollisionLinearization(frames=tt, pairs=pp, distance=caps, rows=rows,
                                      min_distance=_least(T, tt, caps))
    if shift is None:
        shift = hull_shift(model, hulls, placements, tt, pp, caps)
    return _shifted(model, tt, pp, caps, rows, shift, placements)


def refresh_hull_shift(lin: CollisionLinearization, model: CapsuleModel,
                       hulls: BodyHulls) -> CollisionLinearization:
    """``lin`` with its hull shift evaluated at its own placements (an accepted SQP step)."""
    assert lin.capsule_distance is not None and lin.placements is not None
    shift = hull_shift(model, hulls, lin.placements, lin.frames, lin.pairs,
                       lin.capsule_distance)
    return _shifted(model, lin.frames, lin.pairs, lin.capsule_distance, lin.rows, shift,
                    lin.placements)


def _shifted(model: CapsuleModel, tt: np.ndarray, pp: np.ndarray, caps: np.ndarray,
             rows: np.ndarray, shift: HullShift, placements: np.ndarray
             ) -> CollisionLinearization:
    d = caps + shift.at(_keys(model, tt, pp))
    return CollisionLinearization(frames=tt, pairs=pp, distance=d, rows=rows,
                                  min_distance=_least(len(placements), tt, d),
                                  capsule_distance=caps, shift=shift, placements=placements)


def hull_shift(model: CapsuleModel, hulls: BodyHulls, placements: np.ndarray,
               tt: np.ndarray, pp: np.ndarray, caps: np.ndarray) -> HullShift:
    """The :class:`HullShift` of the samples (tt, pp) whose capsule distances are ``caps``:
    one hull distance per (frame, body pair)."""
    bp = model.pair_body_index[pp]
    body, inverse = np.unique(tt * len(model.body_pairs) + bp, return_inverse=True)
    d_hull = hulls.pair_distances(model, placements, body // len(model.body_pairs),
                                  body % len(model.body_pairs))
    keys = _keys(model, tt, pp)
    order = np.argsort(keys)
    return HullShift(keys=keys[order],
                     shift=np.maximum(d_hull[inverse] - caps, 0.0)[order])


def _keys(model: CapsuleModel, tt: np.ndarray, pp: np.ndarray) -> np.ndarray:
    return tt * len(model.pairs) + pp


def _least(n_frames: int, tt: np.ndarray, d: np.ndarray) -> np.ndarray:
    low = np.full(n_frames, np.inf)
    np.minimum.at(low, tt, d)
    return low


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

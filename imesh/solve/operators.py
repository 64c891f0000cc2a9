"""Sparse building blocks of the whole-body QP and where each unknown sits in it.

The unknowns are ordered frame by frame, x = (x_0, ..., x_{T-1}), so the QP is banded;
:class:`Layout` names the offsets inside one frame's block x_t, and :class:`Rows` collects
inequality rows in the order the QP lists them (the order is part of the result: the solver's
path depends on it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

#: The unknowns after dq_t in one frame's block, in order, and how many of each: the CoM
#: update dc_t (x, y, z), the horizontal centroidal angular momentum update dk_t (x, y), then
#: the slacks of the elastic rows: ZMP polygon, normal force and friction; the two soles'
#: footprint rows [left, right]; the swing feet's and leg proxies' ground rows; the joint
#: acceleration rows; the ZMP's excess over its dead band (x, y); the torque rows; the
#: self-collision rows.
AUXILIARIES: tuple[tuple[str, int], ...] = (
    ("com", 3), ("momentum", 2), ("zmp_slack", 1), ("sole_slack", 2), ("ground_slack", 1),
    ("accel_slack", 1), ("band_excess", 2), ("torque_slack", 1), ("collision_slack", 1))
#: Appended with contact wrench cone rows (:mod:`imesh.solve.cwc`): the update of the vertical
#: centroidal angular momentum, whose rate is a moment the cone bounds (the ZMP rows do not
#: need it, so a plan without cones keeps the layout above and its solution bit for bit).
CONE_AUXILIARIES: tuple[tuple[str, int], ...] = (("momentum_z", 1),)


@dataclass(frozen=True)
class Layout:
    """Where each unknown of one frame sits in its block x_t = (dq_t (nv), auxiliaries).

    ``dq_t`` is the tangent update; ``dc_t = J_c dq_t`` and ``dk_t`` are auxiliaries that keep
    the ZMP rows sparse (written in dq they would couple whole 35-column blocks over 9 frames);
    the slacks are ``>= 0`` and priced linearly (an exact L1 penalty). :data:`AUXILIARIES`
    lists them; ``offset[name]`` is the first index of one inside x_t.

    Attributes:
        n_frames: T.
        nv: tangent dimension of the robot.
        cone: with :data:`CONE_AUXILIARIES` after :data:`AUXILIARIES`.
        offset: name of :data:`AUXILIARIES` -> its offset in x_t.
        nx: unknowns per frame; n: unknowns of the QP (T nx).
    """

    n_frames: int
    nv: int
    cone: bool = False
    offset: dict[str, int] = field(init=False)
    nx: int = field(init=False)
    n: int = field(init=False)

    def __post_init__(self) -> None:
        offset, end = {}, self.nv
        for name, width in AUXILIARIES + (CONE_AUXILIARIES if self.cone else ()):
            offset[name] = end
            end += width
        object.__setattr__(self, "offset", offset)
        object.__setattr__(self, "nx", end)
        object.__setattr__(self, "n", self.n_frames * end)

    def rows(self, frames: np.ndarray, values: np.ndarray, first: int = 0) -> sp.csr_matrix:
        """:func:`rows_at` in this layout: row r is ``values[r]`` at frame ``frames[r]``'s
        unknowns from offset ``first``."""
        return rows_at(frames, values, self.nx, self.n_frames, first)

    def pick(self, offset: int) -> sp.csr_matrix:
        """(T, N) selects the unknown at ``offset`` of every frame."""
        T = self.n_frames
        return sp.csr_matrix((np.ones(T), (np.arange(T), np.arange(T) * self.nx + offset)),
                             shape=(T, self.n))


@dataclass
class Rows:
    """Inequality rows ``lower <= G x <= upper``, block by block in the QP's order."""

    blocks: list = field(default_factory=list)
    lower: list = field(default_factory=list)
    upper: list = field(default_factory=list)

    def add(self, G: sp.spmatrix, lower: np.ndarray, upper: np.ndarray) -> None:
        self.blocks.append(G)
        self.lower.append(lower)
        self.upper.append(upper)


def gradient_operator(n: int, h: float) -> sp.csr_matrix:
    """(n, n) sparse matrix of ``numpy.gradient`` with spacing h (central inside, one-sided
    first order at the ends), so ``D @ x == np.gradient(x, h)``."""
    if n < 2:
        return sp.csr_matrix((n, n))
    rows = np.r_[0, 0, np.repeat(np.arange(1, n - 1), 2), n - 1, n - 1]
    cols = np.r_[0, 1, np.stack([np.arange(0, n - 2), np.arange(2, n)], 1).ravel(), n - 2, n - 1]
    vals = np.r_[-1.0, 1.0, np.tile([-0.5, 0.5], n - 2), -1.0, 1.0] / h
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, n))


def difference_operator(n: int, order: int) -> sp.csr_matrix:
    """((n - order), n) sparse forward difference of the given order (1 or 2)."""
    stencil = {1: [-1.0, 1.0], 2: [1.0, -2.0, 1.0]}[order]
    m = n - order
    rows = np.repeat(np.arange(m), len(stencil))
    cols = (np.arange(m)[:, None] + np.arange(len(stencil))).ravel()
    return sp.csr_matrix((np.tile(stencil, m), (rows, cols)), shape=(m, n))


def block_diagonal(blocks: np.ndarray) -> sp.csr_matrix:
    """(T*r, T*c) sparse block diagonal of dense blocks (T, r, c), from index arrays."""
    T, r, c = blocks.shape
    rows = (np.arange(T)[:, None, None] * r + np.arange(r)[None, :, None]) + 0 * np.arange(c)
    cols = (np.arange(T)[:, None, None] * c + np.arange(c)[None, None, :]) + 0 * rows
    return sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(T * r, T * c))


def rows_at(frames: np.ndarray, rows: np.ndarray, stride: int, n_frames: int,
            first: int = 0) -> sp.csr_matrix:
    """(R, T*stride) sparse matrix whose row r is ``rows[r]`` (w,) at the columns
    ``frames[r] * stride + first + [0, w)``."""
    R, w = rows.shape
    cols = frames[:, None] * stride + first + np.arange(w)
    return sp.csr_matrix((rows.ravel(), (np.repeat(np.arange(R), w), cols.ravel())),
                         shape=(R, n_frames * stride))


def log3(R: np.ndarray) -> np.ndarray:
    """(N, 3) rotation vectors of rotation matrices (N, 3, 3)."""
    return Rotation.from_matrix(R).as_rotvec()

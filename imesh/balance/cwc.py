"""The contact wrench cone (CWC): balance with contacts that are not coplanar.

Caron, Pham & Nakamura, "Leveraging Cone Double Description for Multi-contact Stability of
Humanoids with Applications to Statics and Dynamics", RSS 2015 (its gravito-inertial wrench
cone, GIWC). The paper is not in the project's shared papers: the terms below are the paper's
(span and face forms, span matrix V, face matrix U), its equation numbers are not cited
because they could not be checked here. The contact
forces ``f_i`` at points ``p_i`` (each in its friction cone, here the pyramid with edges
``n_i +- mu' t_1``, ``n_i +- mu' t_2``, ``mu' = mu / sqrt 2`` inside the cone, as
:mod:`imesh.solve.forces` uses it) sum to a contact wrench about a reference point ``o``

    w_c = sum_i [f_i; (p_i - o) x f_i],

and the motion is feasible with these contacts iff the Newton-Euler equations of the whole
body can be met by such forces: the gravito-inertial wrench, written here as the wrench the
contacts must supply per unit mass,

    w = [c'' - g; (c - o) x (c'' - g) + Ld_G / m]     (g = (0, 0, -9.81)),

lies in the cone ``CWC = {sum_j lambda_j v_j, lambda >= 0}`` spanned by the generators ``v_j``
of every contact's pyramid edges (the span form, V-representation). The face form
(H-representation) ``CWC = {w : U w <= 0}`` is what a QP can use; the paper gets it
from the span form by the double description method (cdd). Here the same conversion is a
convex hull: every generator has a positive vertical force (contacts on the floor and on prop
tops, ``n_z > 0``), so the cone is pointed and its slice ``w_z = 1`` is the polytope
``conv{v_j / v_jz}`` in the other five coordinates; the hull's facets ``a . x + b <= 0``
(scipy's Qhull) lift to faces ``a . w_rest + b w_z <= 0`` of the cone. When the generators span
less than six dimensions (two hands alone cannot resist a moment about the line through them)
the hull is taken in their span and the cone gets equality rows ``E w = 0`` for the rest.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..errors import ImeshError

#: Friction coefficient of the contacts (the solve's ``ForceOptions.friction``, the evaluator's
#: ``friction_ratio_max``).
FRICTION = 0.7
#: Standard gravity [m/s^2], as the ZMP and the force rows use it.
GRAVITY = 9.81
#: Relative singular value below which a direction of the slice is not spanned.
RANK_TOLERANCE = 1e-9
#: Contacts with the same normal this close are one contact [m].
SAME_CONTACT_M = 1e-6

log = logging.getLogger(__name__)


def sole_wrench_cone(half_x: float, half_y: float, mu: float) -> np.ndarray:
    """(16, 6) float ``C`` with ``C w <= 0`` for a wrench ``w = (f, m)`` of a rectangular sole
    of half sizes X, Y (its frame: x forward, z the normal; the moment about its centre) inside
    the sole's contact wrench cone (the paper's closed form for a rectangle, a friction pyramid
    ``|f_x|, |f_y| <= mu f_z`` at each corner), ``f_z >= 0`` included:

        |f_x|, |f_y| <= mu f_z,   |m_x| <= Y f_z,   |m_y| <= X f_z   (centre of pressure inside),
        -mu (X + Y) f_z + |Y f_x - mu m_x| + |X f_y - mu m_y|
            <= m_z <= mu (X + Y) f_z - |Y f_x + mu m_x| - |X f_y + mu m_y|   (yaw).

    Rows: friction (4), centre of pressure (4), yaw moment (8); ``-f_z <= 0`` is the last row.
    """
    X, Y = half_x, half_y
    rows = [
        [1, 0, -mu, 0, 0, 0], [-1, 0, -mu, 0, 0, 0],
        [0, 1, -mu, 0, 0, 0], [0, -1, -mu, 0, 0, 0],
        [0, 0, -Y, 1, 0, 0], [0, 0, -Y, -1, 0, 0],
        [0, 0, -X, 0, 1, 0], [0, 0, -X, 0, -1, 0],
    ]
    for s1 in (1, -1):
        for s2 in (1, -1):
            rows.append([s1 * Y, s2 * X, -mu * (X + Y), s1 * mu, s2 * mu, 1])
            rows.append([s1 * Y, s2 * X, -mu * (X + Y), -s1 * mu, -s2 * mu, -1])
    rows.append([0, 0, -1, 0, 0, 0])
    return np.array(rows, dtype=float)


def sole_yaw_ratio(wrench: np.ndarray, half_x: float, half_y: float, mu: float) -> np.ndarray:
    """(...) float the share of a rectangular sole's yaw friction a wrench needs: the larger
    side of :func:`sole_wrench_cone`'s yaw rows over their friction term,

        max(m_z + |Y f_x + mu m_x| + |X f_y + mu m_y|, -m_z + |Y f_x - mu m_x| + |X f_y - mu m_y|)
            / (mu (X + Y) f_z),

    at most 1 exactly on and inside the cone's yaw faces (``inf`` where ``f_z <= 0``). A pure
    yaw moment on a centred load reads ``|m_z| / (mu (X + Y) f_z)``; horizontal forces and an
    off-centre pressure use part of the same friction.

    Args:
        wrench: (..., 6) float ``(f, m)`` in the sole frame, the moment about its centre.
    """
    w = np.asarray(wrench, dtype=float)
    fx, fy, fz, mx, my, mz = np.moveaxis(w, -1, 0)
    X, Y = half_x, half_y
    need = np.maximum(mz + np.abs(Y * fx + mu * mx) + np.abs(X * fy + mu * my),
                      -mz + np.abs(Y * fx - mu * mx) + np.abs(X * fy - mu * my))
    hold = mu * (X + Y) * fz
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(fz > 0, need / np.where(fz > 0, hold, 1.0), np.inf)


class ConeError(ImeshError):
    """A contact set whose wrench cone cannot be built (a contact force not pushing upward)."""

    def __init__(self, message: str, normals: np.ndarray):
        super().__init__(message)
        self.normals = normals


@dataclass(frozen=True, eq=False)
class WrenchCone:
    """The face form of a contact wrench cone about ``ref_m``.

    Attributes:
        faces: (F, 6) unit rows U: ``U w <= 0`` inside (w = (force, moment about ref_m)).
        equalities: (Q, 6) unit rows E: ``E w = 0`` inside (Q = 6 - the cone's dimension).
        ref_m: (3,) the moments' reference point [m].
    """

    faces: np.ndarray
    equalities: np.ndarray
    ref_m: np.ndarray

    def violation(self, wrench: np.ndarray) -> np.ndarray:
        """(...,) how far wrenches (..., 6) about ``ref_m`` are outside the cone: the largest
        face value ``U w`` or ``|E w|`` (<= 0 inside; the units of w per unit row)."""
        out = np.einsum("fa,...a->...f", self.faces, wrench).max(axis=-1)
        if len(self.equalities):
            out = np.maximum(out, np.abs(np.einsum("qa,...a->...q", self.equalities,
                                                   wrench)).max(axis=-1))
        return out


def pyramid_generators(points_m: np.ndarray, normals: np.ndarray, ref_m: np.ndarray,
                       mu: float = FRICTION) -> np.ndarray:
    """(4 N, 6) the wrenches about ``ref_m`` of the edges of each contact's friction pyramid
    (the span form's columns): ``v = [u; (p - o) x u]`` with
    ``u = n +- mu' t_1``, ``n +- mu' t_2``, ``mu' = mu / sqrt 2``.

    Args:
        points_m: (N, 3) contact points [m]; normals: (N, 3) unit normals into the robot.
        ref_m: (3,) reference point [m]; mu: friction coefficient.
    """
    p = np.asarray(points_m, float)
    n = np.asarray(normals, float)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    # tangents: any orthonormal pair perpendicular to n
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    m = mu / np.sqrt(2.0)
    u = np.stack([n + m * t1, n - m * t1, n + m * t2, n - m * t2], axis=1).reshape(-1, 3)
    lever = np.repeat(p - ref_m, 4, axis=0)
    return np.concatenate([u, np.cross(lever, u)], axis=1)


def _distinct_contacts(points_m: np.ndarray, normals: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """The contacts with those within ``SAME_CONTACT_M`` of an earlier one with the same
    normal (to 1e-9) left out: one contact listed twice (two proxy points of a link at one
    place, 1e-7 m apart on JVRC-1's hand in the holosoma climb) gives two equal pyramids, whose
    generators Qhull cannot always merge (a "dupridge" topology error)."""
    near = np.linalg.norm(points_m[:, None] - points_m[None], axis=-1) <= SAME_CONTACT_M
    same = near & (np.abs(normals[:, None] - normals[None]).max(axis=-1) <= 1e-9)
    keep = ~np.triu(same, 1).any(axis=0)  # not a repeat of an earlier contact
    return points_m[keep], normals[keep]


def _hull_equations(y: np.ndarray) -> np.ndarray:
    """(F, r + 1) facet equations of the convex hull of points ``y`` (K, r); nearly degenerate
    input that Qhull's default merging cannot handle is hulled again with joggled input (``QJ``:
    the points moved by about 1e-11 of their extent, every facet simplicial)."""
    try:
        return ConvexHull(y).equations
    except QhullError:
        log.debug("contact wrench cone: Qhull's merge failed on %d generators; joggled", len(y))
        return ConvexHull(y, qhull_options="QJ").equations


def contact_wrench_cone(points_m: np.ndarray, normals: np.ndarray, ref_m: np.ndarray | None = None,
                        mu: float = FRICTION) -> WrenchCone:
    """The face form of the CWC of point contacts (see the module docstring).

    Args:
        points_m: (N, 3) contact points [m] (a sole: its corners); normals: (N, 3) their
            normals (into the robot, upward: ``n_z > 0``).
        ref_m: the moments' reference point [m]; None: the points' centroid (well scaled).
        mu: friction coefficient.

    Raises:
        ConeError: a normal does not point upward (``n_z <= 0.1``).
    """
    p = np.asarray(points_m, float).reshape(-1, 3)
    n = np.asarray(normals, float).reshape(-1, 3)
    if (n[:, 2] / np.linalg.norm(n, axis=1) <= 0.1).any():
        raise ConeError("contact wrench cone: every contact normal must point upward (n_z > "
                        "0.1): the cone is built on its slice of unit vertical force", n)
    ref = p.mean(axis=0) if ref_m is None else np.asarray(ref_m, float)
    v = pyramid_generators(*_distinct_contacts(p, n), ref, mu)
    rest = [0, 1, 3, 4, 5]
    x = v[:, rest] / v[:, 2:3]  # the slice w_z = 1
    mean = x.mean(axis=0)
    _, sv, vt = np.linalg.svd(x - mean, full_matrices=True)
    r = int((sv > RANK_TOLERANCE * max(sv.max(initial=0.0), 1.0)).sum())
    basis, comp = vt[:r].T, vt[r:].T  # (5, r), (5, 5 - r)
    y = (x - mean) @ basis
    if r >= 2:
        eq = _hull_equations(y)  # (F, r + 1): a . y + b <= 0 inside
        a, b = eq[:, :r], eq[:, r]
    elif r == 1:
        a, b = np.array([[1.0], [-1.0]]), np.array([-y.max(), y.min()])
    else:
        a, b = np.zeros((0, 0)), np.zeros(0)
    # lift: a . B^T (w_rest / w_z - mean) + b <= 0, times w_z > 0
    faces = np.zeros((len(a), 6))
    ab = a @ basis.T if r else np.zeros((0, 5))
    faces[:, rest] = ab
    faces[:, 2] = b - ab @ mean
    faces = np.vstack([faces, [[0, 0, -1.0, 0, 0, 0]]])  # w_z >= 0 (the slice's side)
    faces /= np.linalg.norm(faces, axis=1, keepdims=True)
    faces = np.unique(np.round(faces, 12), axis=0)
    equalities = np.zeros((comp.shape[1], 6))
    equalities[:, rest] = comp.T
    equalities[:, 2] = -comp.T @ mean
    if len(equalities):
        equalities /= np.linalg.norm(equalities, axis=1, keepdims=True)
    return WrenchCone(faces=faces, equalities=equalities, ref_m=ref)


def required_wrench(com_m: np.ndarray, com_acceleration: np.ndarray,
                    angular_momentum_rate: np.ndarray, mass: float, ref_m: np.ndarray
                    ) -> np.ndarray:
    """(..., 6) the wrench per unit mass the contacts must supply about ``ref_m`` (the negated
    gravito-inertial wrench, module docstring): ``[c'' - g; (c - o) x (c'' - g) + Ld_G / m]``.

    Args:
        com_m: (..., 3) CoM [m]; com_acceleration: (..., 3) [m/s^2];
        angular_momentum_rate: (..., 3) rate of the centroidal angular momentum [N m];
        mass: [kg]; ref_m: (..., 3) or (3,) reference point [m].
    """
    f = np.asarray(com_acceleration, float) + np.array([0.0, 0.0, GRAVITY])
    m = np.cross(np.asarray(com_m, float) - ref_m, f) + np.asarray(angular_momentum_rate) / mass
    return np.concatenate([f, m], axis=-1)

"""Bend planes: the direction in which a middle marker sits off the segment of two others.

The morph's Laplacian energy (Nakaoka & Komura 2012, eq. 2) keeps each marker's position
relative to its mesh neighbours, and the bone rows (eq. 3) keep lengths. Neither holds where a
marker sits *around* the segment of two others, and when the robot's proportions differ much
from the human's the morph turns it there to meet the lengths cheaply. Measured on the CMU walk
arranged for G1 (hips 0.10 -> 0.23 m apart, pelvis-to-chest 0.18 -> 0.29 m): the pelvis marker
swung 40-85 deg forward about the hip axis (15 deg arranged, 57-101 deg morphed), and both knees
went 25-35 mm inside their hip-ankle lines (2-9 mm outside in the arranged markers). A robot
cannot follow either (its pelvis triangle is rigid; a 6-DOF leg's knee is set by its hip and
foot), so the initial fit paid 31 mm RMS of key-point error.

A bend plane holds that direction. For a chain (a, m, b) with the segment axis
``e = (p_a - p_b) / |p_a - p_b|`` and a reference direction r (world up, or from one marker to
another), the middle marker's angle about e is

    theta = atan2(e . (r_perp x v), r_perp . v),   v = p_m - (p_a + p_b) / 2,
    r_perp = normalize(r - (r . e) e),

and the plane of the chain at its source angle theta_0 has the normal
``n = e x (r_perp cos theta_0 + (e x r_perp) sin theta_0)``. The morph adds the soft term

    w_P s / 2 [ (n . (p_m - p_a))^2 + (n . (p_m - p_b))^2 ]

with n taken at the current iterate (re-linearized every step, like the bones), whose minimum
puts m in the plane (n is perpendicular to e, so both rows vanish together). The weight scale s
fades the term where the source's middle marker is within ``straight_fraction`` of the
segment's length from the axis: there theta is noise (a straight knee), and holding it would
bend the chain in a random direction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Marker names of the standard bend planes: (end a, middle, end b, reference); the reference
#: is None (the world's up, +z) or a pair of markers (from the second to the first).
STANDARD_PLANES: tuple[tuple[str, str, str, tuple[str, str] | None], ...] = (
    ("hip_l", "pelvis", "hip_r", None),                    # the pelvis about the hip axis
    ("hip_l", "knee_l", "ankle_l", ("hip_l", "hip_r")),    # each knee about its hip-ankle line
    ("hip_r", "knee_r", "ankle_r", ("hip_l", "hip_r")),
)
#: Below this distance from the a-b axis, as a fraction of |p_a - p_b|, the source's bend
#: direction is not held (weights fade linearly to 0 at the axis).
STRAIGHT_FRACTION = 0.05


@dataclass(frozen=True, eq=False)
class BendPlanes:
    """Chains whose middle marker keeps its source direction about the segment of its ends.

    Attributes:
        markers: (H, 3) marker indices (end a, middle, end b) of each chain.
        references: (H, 2) marker indices (i, j) of each chain's reference direction p_i - p_j,
            or (-1, -1) for the world's up axis.
    """

    markers: np.ndarray
    references: np.ndarray

    def __post_init__(self) -> None:
        m = np.asarray(self.markers, dtype=np.int64).reshape(-1, 3)
        r = np.asarray(self.references, dtype=np.int64).reshape(-1, 2)
        if len(m) != len(r):
            raise ValueError(f"{len(m)} chains but {len(r)} references")
        object.__setattr__(self, "markers", m)
        object.__setattr__(self, "references", r)

    def __len__(self) -> int:
        return len(self.markers)

    def shifted(self, offset: int) -> BendPlanes:
        """The same chains on markers numbered from ``offset`` (a second person's block)."""
        return BendPlanes(self.markers + offset,
                          np.where(self.references < 0, -1, self.references + offset))

    @staticmethod
    def concat(*planes: BendPlanes) -> BendPlanes:
        """All chains of several sets (already on one marker numbering)."""
        return BendPlanes(np.concatenate([p.markers for p in planes]),
                          np.concatenate([p.references for p in planes]))


NO_PLANES = BendPlanes(np.zeros((0, 3), np.int64), np.zeros((0, 2), np.int64))


def standard_planes(names) -> BendPlanes:
    """The :data:`STANDARD_PLANES` whose markers are all in ``names`` (a marker model without
    a pelvis or knees simply has fewer)."""
    index = {n: i for i, n in enumerate(names)}
    markers, refs = [], []
    for a, m, b, ref in STANDARD_PLANES:
        if all(n in index for n in (a, m, b, *(ref or ()))):
            markers.append((index[a], index[m], index[b]))
            refs.append((-1, -1) if ref is None else (index[ref[0]], index[ref[1]]))
    if not markers:
        return NO_PLANES
    return BendPlanes(np.array(markers), np.array(refs))


def _frames(positions_m: np.ndarray, planes: BendPlanes
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per frame and chain: (axis e, reference r_perp, offset v, usable) (T, H, 3) x3, (T, H).

    ``usable`` is False where the reference is parallel to the axis (r_perp undefined)."""
    a, m, b = (positions_m[:, planes.markers[:, k]] for k in range(3))
    e = a - b
    e = e / np.maximum(np.linalg.norm(e, axis=-1, keepdims=True), 1e-12)
    ref = planes.references
    up = np.broadcast_to([0.0, 0.0, 1.0], e.shape)
    i, j = np.maximum(ref[:, 0], 0), np.maximum(ref[:, 1], 0)
    r = np.where((ref[:, 0] < 0)[None, :, None], up, positions_m[:, i] - positions_m[:, j])
    r = r - np.sum(r * e, axis=-1, keepdims=True) * e
    norm = np.linalg.norm(r, axis=-1)
    usable = norm > 1e-6 * np.maximum(np.linalg.norm(positions_m[:, planes.markers[:, 0]], axis=-1),
                                      1.0)
    r = r / np.maximum(norm, 1e-12)[..., None]
    v = m - 0.5 * (a + b)
    return e, r, v, usable


def bend_angles(positions_m: np.ndarray, planes: BendPlanes) -> np.ndarray:
    """(T, H) angle [rad] of each chain's middle marker about its axis, from its reference.

    Args:
        positions_m: (T, M, 3) markers [m].
        planes: the chains.
    """
    e, r, v, _ = _frames(positions_m, planes)
    return np.arctan2(np.sum(np.cross(r, v) * e, axis=-1), np.sum(r * v, axis=-1))


def bend_weights(positions_m: np.ndarray, planes: BendPlanes,
                 straight_fraction: float = STRAIGHT_FRACTION) -> np.ndarray:
    """(T, H) weight scale in [0, 1] of each chain's plane term: its middle marker's distance
    from the axis over ``straight_fraction`` x the segment's length, capped at 1; 0 where the
    reference is parallel to the axis.

    Args:
        positions_m: (T, M, 3) source markers [m].
        planes: the chains.
        straight_fraction: distance (fraction of |p_a - p_b|) from which the weight is full.
    """
    e, _, v, usable = _frames(positions_m, planes)
    off = np.linalg.norm(v - np.sum(v * e, axis=-1, keepdims=True) * e, axis=-1)
    length = np.linalg.norm(positions_m[:, planes.markers[:, 0]]
                            - positions_m[:, planes.markers[:, 2]], axis=-1)
    scale = np.clip(off / np.maximum(straight_fraction * length, 1e-12), 0.0, 1.0)
    return np.where(usable, scale, 0.0)


def plane_normals(positions_m: np.ndarray, planes: BendPlanes, angles_rad: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Each chain's plane at ``angles_rad`` through its current axis.

    Args:
        positions_m: (T, M, 3) current markers [m].
        planes: the chains.
        angles_rad: (T, H) the angles to hold (the source's, :func:`bend_angles`).

    Returns:
        (normals n (T, H, 3) unit, gaps (T, H) = -n . v [m]): the linearized rows
        ``n . (dp_m - dp_a) = gap`` (and with b) put the middle marker in the plane.
    """
    e, r, v, usable = _frames(positions_m, planes)
    c, s = np.cos(angles_rad)[..., None], np.sin(angles_rad)[..., None]
    n = np.cross(e, r * c + np.cross(e, r) * s)
    n = np.where(usable[..., None], n, 0.0)
    return n, -np.sum(n * v, axis=-1)

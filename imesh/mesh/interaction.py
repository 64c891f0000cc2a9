"""The interaction mesh: per-frame Delaunay tetrahedralization and the Laplacian operator.

Nakaoka & Komura 2012, sec. III (after Ho, Komura & Tai 2010): markers of frame i are connected
by the edges of their Delaunay tetrahedralization; the Laplacian coordinate of marker j is

    L(p_j) = p_j - sum_{l in N_j} w_l^j p_l                                    (eq. 1)

with weights inversely proportional to the edge length in the source frame, normalized to sum 1
(uniform weights as an option). The mesh and weights come from the *source* motion so the
Laplacian operator, and hence the Hessian of the morph, stays fixed over all morph steps.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from itertools import combinations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import Delaunay, QhullError

from ..errors import InvalidMotionError, OptionError

log = logging.getLogger(__name__)

WEIGHTINGS = ("inverse_distance", "uniform")
_TET_EDGES = np.array(list(combinations(range(4), 2)))  # 6 edges of a tetrahedron


@dataclass(frozen=True, eq=False)
class InteractionMesh:
    """Edges and Laplacian operator of every frame.

    Attributes:
        n_frames: T.
        n_markers: M.
        edges: list of T arrays (E_i, 2), undirected edges (j < l) of frame i.
        laplacian: (T*M, T*M) CSR, block diagonal; block i is L_i = I - W_i (M x M) acting on one
            coordinate of frame i (frame-major, marker-minor ordering).
        weighting: "inverse_distance" or "uniform".
        degenerate_frames: frames whose markers were (nearly) coplanar; meshed with joggle.
    """

    n_frames: int
    n_markers: int
    edges: list
    laplacian: sp.csr_matrix
    weighting: str
    degenerate_frames: tuple[int, ...]

    def edge_count(self) -> np.ndarray:
        return np.array([len(e) for e in self.edges])


def tetrahedralize(points: np.ndarray) -> tuple[np.ndarray, bool]:
    """Undirected Delaunay edges (E, 2) of points (M, 3), and whether the set was degenerate.

    Coplanar or collinear sets (a flat pose, fewer than 5 markers) cannot be tetrahedralized
    exactly; they are meshed with Qhull's joggle option ("QJ"), and below 5 points fully
    connected, so every marker still has neighbours.
    """
    m = len(points)
    if m < 5:
        pairs = np.array(list(combinations(range(m), 2)), dtype=np.int64).reshape(-1, 2)
        return pairs, True
    degenerate = False
    try:
        simplices = Delaunay(points).simplices
    except QhullError:
        degenerate = True
        simplices = Delaunay(points, qhull_options="QJ Qbb Qc").simplices
    e = simplices[:, _TET_EDGES].reshape(-1, 2)
    # unique undirected edges via one integer key per edge (much faster than unique(axis=0))
    key = np.unique(np.minimum(e[:, 0], e[:, 1]) * m + np.maximum(e[:, 0], e[:, 1]))
    e = np.stack([key // m, key % m], axis=1)
    if len(np.unique(e)) < m:  # a marker left out (duplicate point): connect it to its nearest
        degenerate = True
        missing = np.setdiff1d(np.arange(m), np.unique(e))
        d = np.linalg.norm(points[missing, None] - points[None], axis=2)
        d[np.arange(len(missing)), missing] = np.inf
        near = np.argmin(d, axis=1)
        extra = np.sort(np.stack([missing, near], axis=1), axis=1)
        e = np.unique(np.concatenate([e, extra]), axis=0)
    return e, degenerate


def build_interaction_mesh(positions_m: np.ndarray, *, weighting: str = "inverse_distance",
                           min_edge_m: float = 1e-4) -> InteractionMesh:
    """Tetrahedralize each frame of the source motion and assemble the Laplacian operator.

    Args:
        positions_m: (T, M, 3) source marker positions [m], no NaN (fill gaps first).
        weighting: "inverse_distance" (w_l proportional to 1/|p_j - p_l|, normalized) or
            "uniform" (w_l = 1/|N_j|).
        min_edge_m: lengths below this are clamped in the inverse-distance weights, so
            coincident markers do not take all the weight.

    Returns:
        The InteractionMesh; ``laplacian`` is assembled from index arrays in one sparse call.
    """
    if weighting not in WEIGHTINGS:
        raise OptionError("Laplacian weighting", weighting, WEIGHTINGS)
    pos = np.asarray(positions_m, dtype=np.float64)
    if not np.isfinite(pos).all():
        t = int(np.argwhere(~np.isfinite(pos))[0][0])
        raise InvalidMotionError(f"interaction mesh: positions are not finite at frame {t}; "
                                 "fill gaps before meshing")
    n_frames, n_markers, _ = pos.shape
    edges, degenerate = [], []
    for i in range(n_frames):  # Qhull is per point set; ~0.5 ms per frame at 30 markers
        e, deg = tetrahedralize(pos[i])
        edges.append(e)
        if deg:
            degenerate.append(i)
    if degenerate:
        log.info("interaction mesh: %d degenerate (coplanar) frames meshed with joggle, first %d",
                 len(degenerate), degenerate[0])

    # Directed neighbour pairs over all frames, as global indices i*M + j.
    counts = np.array([len(e) for e in edges])
    frame_of_edge = np.repeat(np.arange(n_frames), counts)
    all_e = np.concatenate(edges) if edges else np.zeros((0, 2), dtype=np.int64)
    src = np.concatenate([all_e[:, 0], all_e[:, 1]])
    dst = np.concatenate([all_e[:, 1], all_e[:, 0]])
    fr = np.concatenate([frame_of_edge, frame_of_edge])
    if weighting == "inverse_distance":
        dist = np.linalg.norm(pos[fr, src] - pos[fr, dst], axis=1)
        w = 1.0 / np.maximum(dist, min_edge_m)
    else:
        w = np.ones(len(src))
    rows = fr * n_markers + src
    cols = fr * n_markers + dst
    total = np.bincount(rows, weights=w, minlength=n_frames * n_markers)
    w = w / total[rows]
    size = n_frames * n_markers
    diag = np.arange(size)
    lap = sp.csr_matrix(
        (np.concatenate([np.ones(size), -w]),
         (np.concatenate([diag, rows]), np.concatenate([diag, cols]))),
        shape=(size, size),
    )
    return InteractionMesh(n_frames=n_frames, n_markers=n_markers, edges=edges, laplacian=lap,
                           weighting=weighting, degenerate_frames=tuple(degenerate))

"""Bone lengths, their linearization (paper eq. 3) and tree utilities."""

from __future__ import annotations

import numpy as np

from ..errors import ConstraintError


def bone_lengths(positions_m: np.ndarray, bones: np.ndarray) -> np.ndarray:
    """Lengths (T, B) [m] of the bones (B, 2) in positions (T, M, 3)."""
    d = positions_m[:, bones[:, 0]] - positions_m[:, bones[:, 1]]
    return np.linalg.norm(d, axis=2)


def bone_directions(positions_m: np.ndarray, bones: np.ndarray) -> np.ndarray:
    """Unit vectors (T, B, 3) from child to parent: u = (p_a - p_b) / |p_a - p_b|.

    The linearization of |p_a - p_b| = l at the current positions is u . (p'_a - p'_b) = l
    (B_i V'_i = l_i, Nakaoka & Komura 2012 eq. 3): exact to first order, and one Newton step of
    the nonlinear constraint when re-linearized at every morph step.
    """
    d = positions_m[:, bones[:, 0]] - positions_m[:, bones[:, 1]]
    n = np.linalg.norm(d, axis=2, keepdims=True)
    return d / np.maximum(n, 1e-300)


def check_target_lengths(lengths_m: np.ndarray, bones: np.ndarray, names: tuple[str, ...],
                         n_frames: int) -> np.ndarray:
    """Validate target lengths: shape (T, B) or (B,), finite and > 0.

    Raises:
        ConstraintError naming the first offending bone and frame.
    """
    lengths = np.asarray(lengths_m, dtype=np.float64)
    if lengths.ndim == 1:
        lengths = np.broadcast_to(lengths, (n_frames, lengths.shape[0]))
    if lengths.shape != (n_frames, len(bones)):
        raise ConstraintError(
            f"target bone lengths must have shape ({n_frames}, {len(bones)}) or ({len(bones)},), "
            f"got {lengths.shape}"
        )
    bad = ~(np.isfinite(lengths) & (lengths > 1e-6))
    if bad.any():
        t, b = np.argwhere(bad)[0]
        a, c = bones[b]
        raise ConstraintError(
            f"target length of bone {names[a]}-{names[c]} at frame {t} is {lengths[t, b]!r}; "
            "bone lengths must be finite and > 1e-6 m"
        )
    return lengths


def ancestry_matrix(bones: np.ndarray, n_markers: int) -> tuple[np.ndarray, np.ndarray]:
    """Path matrix of a forest of bones.

    Returns:
        roots: (M,) int, the root marker of each marker's tree.
        path: (M, B) float, path[j, b] = 1 when bone b lies on the path root -> j, so that
            p_j = p_root(j) + path[j] @ (p_child - p_parent) over bones.

    Raises:
        ConstraintError: a marker has two parents or the bones contain a cycle.
    """
    parent = -np.ones(n_markers, dtype=np.int64)
    parent_bone = -np.ones(n_markers, dtype=np.int64)
    for k, (a, b) in enumerate(bones):
        if parent[b] >= 0:
            raise ConstraintError(f"marker {b} has two parent bones: not a tree")
        parent[b] = a
        parent_bone[b] = k
    path = np.zeros((n_markers, len(bones)))
    roots = np.arange(n_markers)
    for j in range(n_markers):  # setup only: depth of a skeleton tree is small
        node, seen = j, 0
        while parent[node] >= 0:
            path[j, parent_bone[node]] = 1.0
            node = parent[node]
            seen += 1
            if seen > n_markers:
                raise ConstraintError("bones contain a cycle")
        roots[j] = node
    return roots, path


def scale_bones_naive(positions_m: np.ndarray, bones: np.ndarray,
                      target_lengths_m: np.ndarray) -> np.ndarray:
    """Per-bone scaling without the mesh: the baseline the interaction mesh is compared with.

    Each bone vector keeps its direction and takes its target length; roots stay in place:
    p'_j = p_root + sum_{b on path} (p_child_b - p_parent_b) * l'_b / l_b.

    Args:
        positions_m: (T, M, 3) source positions [m].
        bones: (B, 2) a forest (each marker at most one parent).
        target_lengths_m: (T, B) or (B,) target lengths [m].

    Returns:
        (T, M, 3) scaled positions [m].
    """
    roots, path = ancestry_matrix(bones, positions_m.shape[1])
    vec = positions_m[:, bones[:, 1]] - positions_m[:, bones[:, 0]]  # parent -> child
    lengths = np.linalg.norm(vec, axis=2, keepdims=True)
    target = np.broadcast_to(np.asarray(target_lengths_m, dtype=float), lengths.shape[:2])
    scaled = vec * (target[..., None] / np.maximum(lengths, 1e-300))
    return positions_m[:, roots] + np.einsum("mb,tbc->tmc", path, scaled)

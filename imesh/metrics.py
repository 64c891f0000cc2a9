"""Quality metrics of adapted motions (names as in DESIGN.md)."""

from __future__ import annotations

import numpy as np

from .motion import MarkerMotion

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
                     fraction: float = CLOSE_PAIR_FRACTION) -> float:
    """Mean abs change of height-normalized distance of close non-adjacent marker pairs.

    For every frame t and non-adjacent pair (a, b) with source distance d < fraction * H
    (H = source height), the error is | d'/H' - d/H | with d' the adapted distance and H' the
    adapted height; the metric is the mean over those (frame, pair) samples (0 if none).

    Args:
        source: the source motion.
        adapted: the adapted motion, same markers, frames and bones.
        fraction: closeness threshold relative to the body height (DESIGN.md: 15 %).
    """
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

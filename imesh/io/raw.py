"""RawMotion: what a file reader returns before units, up axis and floor are settled.

Readers only parse; :func:`imesh.io.finalize` converts a RawMotion to a :class:`MarkerMotion` in
metres, Z up, floor at z = 0, logging each decision it takes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True, eq=False)
class RawMotion:
    """Parsed motion in the file's own units and axes.

    Attributes:
        positions: (T, M, 3) float64 in file units and file axes; NaN where missing.
        fps: frames per second as declared by the file (or its documented default).
        names: (M,) marker / joint names.
        valid: (T, M) bool.
        bones: (B, 2) int (parent, child) index pairs when the file has a skeleton.
        path: the file read.
        format: "bvh", "asf/amc", "c3d" or "trc".
        declared_units: unit named by the file ("mm", "cm", "m", "in") or None when the format
            has no such field (BVH).
        declared_scale_m: metres per file unit when the file states it numerically (ASF
            ``:units length 0.45`` -> 0.0254 / 0.45), else None.
        declared_up: up axis stated or implied by the file ("+Y", "+Z", ...) or None.
        rig: skeleton / marker-set family recognised by the reader (e.g. "cmu_cgspeed", "cc3",
            "second_life", "reactidle", "cmu_asf", "qualisys", "bts", "roboptim"), or "".
        meta: anything else worth reporting.
    """

    positions: np.ndarray
    fps: float
    names: tuple[str, ...]
    valid: np.ndarray
    path: str
    format: str
    bones: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    declared_units: str | None = None
    declared_scale_m: float | None = None
    declared_up: str | None = None
    rig: str = ""
    meta: dict = field(default_factory=dict)


def is_float(word: str) -> bool:
    """Whether a word of a text motion file is a number (Python's float syntax)."""
    try:
        float(word)
    except ValueError:
        return False
    return True

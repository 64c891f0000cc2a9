"""Any clip onto the 21 standard markers (:mod:`imesh.human.markerset`).

A skeleton (BVH, ASF/AMC) is mapped by recognizing the human body in its tree
(:mod:`imesh.human.rig`), whatever its joint names; a marker set (C3D, TRC) by its rig table
(:mod:`imesh.human.rig_tables`). A table given explicitly (``rig=``, ``--rig``) overrides the
recognition.
"""

from __future__ import annotations

import logging
import os

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import MarkerMappingError, MissingMarkerError
from .markerset import STANDARD_BONES, STANDARD_MARKERS
from .rig import recognize_motion
from .rig_tables import detect_rig, load_rig

log = logging.getLogger(__name__)


def to_standard(motion: MarkerMotion, rig: str | os.PathLike | None = None) -> MarkerMotion:
    """Map a motion onto the 21 standard markers with the standard skeleton.

    A standard marker is valid in a frame only when all of its source markers are.

    Args:
        motion: any loaded motion.
        rig: built-in rig name or a .toml table (overrides the recognition). When None, a
            skeleton is recognized from its tree and motion, and a marker set's table is found
            by its marker names.

    Returns:
        MarkerMotion with ``names == STANDARD_MARKERS`` and ``bones == STANDARD_BONES``;
        ``meta['rig_table']`` names the mapping used ("recognized" or the table).

    Raises:
        RigRecognitionError: a skeleton whose body parts cannot all be found (the message
            names the part and prints the tree).
        MarkerMappingError: the table lacks standard markers, or names source markers the motion
            does not have (listing the available ones).
        MissingMarkerError: a needed source marker is missing in every frame.
    """
    if tuple(motion.names) == STANDARD_MARKERS:
        return motion
    recognized = rig is None and len(motion.bones) > 0
    if recognized:
        body, unit_scale_m = recognize_motion(motion)
        table = body.table(unit_scale_m)
    else:
        table = detect_rig(motion) if rig is None else load_rig(rig)
    lacking = [m for m in STANDARD_MARKERS if m not in table.markers]
    if lacking:
        raise MarkerMappingError(
            f"{motion.source}: rig table {table.name!r} cannot give every standard marker",
            missing=lacking, available=motion.names,
        )
    unknown = sorted(s for s in table.sources() if s not in motion.names)
    if unknown:
        raise MarkerMappingError(
            f"{motion.source}: rig table {table.name!r} needs markers this motion lacks",
            missing=unknown, available=motion.names,
        )
    # One sparse-free weight matrix (21 x M) applied to all frames at once.
    weights = np.zeros((len(STANDARD_MARKERS), motion.n_markers))
    lookup = {n: i for i, n in enumerate(motion.names)}
    for k, std in enumerate(STANDARD_MARKERS):
        for src, w in table.markers[std]:
            weights[k, lookup[src]] += w
    never = [motion.names[j] for j in np.flatnonzero(~motion.valid.any(axis=0))
             if np.any(weights[:, j] != 0)]
    if never:
        needers = [STANDARD_MARKERS[k] for k in range(len(STANDARD_MARKERS))
                   if any(weights[k, lookup[n]] != 0 for n in never)]
        raise MissingMarkerError(
            f"{motion.source}: marker(s) {', '.join(never)} missing in all {motion.n_frames} "
            f"frames, needed for standard marker(s) {', '.join(needers)}",
            missing=never, available=[n for n in motion.names if n not in never],
        )
    used = weights != 0
    # valid where none of the used sources is missing: a count by one product, not a
    # (T, 21, M) mask (370 MB on a 30-minute clip); no copy when nothing is missing
    missing = ~motion.valid
    valid = (missing.astype(np.float32) @ used.T.astype(np.float32)) == 0
    filled = (np.where(motion.valid[..., None], motion.positions_m, 0.0) if missing.any()
              else motion.positions_m)
    pos = np.einsum("km,tmc->tkc", weights, filled)
    pos[~valid] = np.nan
    meta = dict(motion.meta)
    meta["rig"] = (motion.meta.get("rig") or table.name) if recognized else table.name
    meta["rig_table"] = table.name
    log.info("%s: mapped %d markers of rig %s to the standard set (%.1f %% samples valid)",
             motion.source, motion.n_markers, table.name, 100 * valid.mean())
    return MarkerMotion(positions_m=pos, fps=motion.fps, names=STANDARD_MARKERS, valid=valid,
                        bones=STANDARD_BONES, source=motion.source, meta=meta)

"""The standard human marker set and the rig tables that map file rigs onto it.

A skeleton (BVH, ASF/AMC) is mapped by recognizing the human body in its tree
(:mod:`imesh.human.rig`), whatever its joint names. A marker set (C3D, TRC) has no tree: its
protocol is found by name in the TOML tables of ``imesh/data/rigs/``. In a table each standard
marker is an affine combination of the rig's markers (a list = equal-weight mean; an inline
table = explicit weights summing to 1). A table given explicitly (a built-in name or a .toml
file, ``--rig``) overrides the recognition; ``imesh rig`` writes the recognized mapping in the
same format, to edit and reuse.
"""

from __future__ import annotations

import json
import logging
import os
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import MarkerMappingError, MissingMarkerError, OptionError

log = logging.getLogger(__name__)

#: The 21 standard human markers (joint centres), in this order.
STANDARD_MARKERS: tuple[str, ...] = (
    "pelvis", "hip_l", "hip_r", "knee_l", "knee_r", "ankle_l", "ankle_r", "toe_l", "toe_r",
    "spine", "chest", "neck", "head", "shoulder_l", "shoulder_r", "elbow_l", "elbow_r",
    "wrist_l", "wrist_r", "hand_l", "hand_r",
)

#: The standard skeleton as (parent, child) name pairs: a tree rooted at the pelvis.
STANDARD_BONE_NAMES: tuple[tuple[str, str], ...] = (
    ("pelvis", "hip_l"), ("hip_l", "knee_l"), ("knee_l", "ankle_l"), ("ankle_l", "toe_l"),
    ("pelvis", "hip_r"), ("hip_r", "knee_r"), ("knee_r", "ankle_r"), ("ankle_r", "toe_r"),
    ("pelvis", "spine"), ("spine", "chest"), ("chest", "neck"), ("neck", "head"),
    ("chest", "shoulder_l"), ("shoulder_l", "elbow_l"), ("elbow_l", "wrist_l"),
    ("wrist_l", "hand_l"),
    ("chest", "shoulder_r"), ("shoulder_r", "elbow_r"), ("elbow_r", "wrist_r"),
    ("wrist_r", "hand_r"),
)
STANDARD_BONES: np.ndarray = np.array(
    [[STANDARD_MARKERS.index(a), STANDARD_MARKERS.index(b)] for a, b in STANDARD_BONE_NAMES],
    dtype=np.int64,
)

#: Bone groups for ``--scale GROUP=FACTOR`` (child marker names of the standard bones).
BONE_GROUPS: dict[str, tuple[str, ...]] = {
    "arms": ("elbow_l", "wrist_l", "hand_l", "elbow_r", "wrist_r", "hand_r"),
    "forearms": ("wrist_l", "wrist_r"),
    "legs": ("knee_l", "ankle_l", "knee_r", "ankle_r"),
    "spine": ("spine", "chest", "neck"),
    "all": tuple(b for _, b in STANDARD_BONE_NAMES),
}


@dataclass(frozen=True)
class RigTable:
    """How one rig's markers give the standard markers.

    Attributes:
        name: rig name (file stem of the table).
        description: human-readable description.
        detect: names that must all be present for the rig to be recognised.
        markers: standard marker -> ((source name, weight), ...), weights summing to 1.
        path: the table file.
    """

    name: str
    description: str
    detect: tuple[str, ...]
    markers: dict[str, tuple[tuple[str, float], ...]]
    path: str

    def sources(self) -> set[str]:
        return {s for combo in self.markers.values() for s, _ in combo}


def _parse_table(path: str, text: str) -> RigTable:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise OptionError("rig table", path, f"valid TOML ({exc})") from None
    markers: dict[str, tuple[tuple[str, float], ...]] = {}
    for std, spec in dict(data.get("markers", {})).items():
        if isinstance(spec, str):
            spec = [spec]
        if isinstance(spec, list):
            combo = tuple((str(s), 1.0 / len(spec)) for s in spec)
        elif isinstance(spec, dict):
            combo = tuple((str(s), float(w)) for s, w in spec.items())
        else:
            raise OptionError(f"rig table {path} marker {std}", spec,
                              "a list of names or a table name = weight")
        total = sum(w for _, w in combo)
        if not combo or abs(total - 1.0) > 1e-6:
            raise OptionError(f"rig table {path} marker {std} weights", total,
                              "weights summing to 1")
        markers[std] = combo
    return RigTable(name=str(data.get("name", Path(path).stem)),
                    description=str(data.get("description", "")),
                    detect=tuple(data.get("detect", ())), markers=markers, path=path)


@cache
def builtin_rigs() -> dict[str, RigTable]:
    """The rig tables shipped in ``imesh/data/rigs`` by name."""
    rigs = {}
    for entry in sorted(resources.files("imesh.data").joinpath("rigs").iterdir(),
                        key=lambda e: e.name):
        if entry.name.endswith(".toml"):
            table = _parse_table(f"imesh/data/rigs/{entry.name}", entry.read_text())
            rigs[table.name] = table
    return rigs


def load_rig(rig: str | os.PathLike) -> RigTable:
    """A built-in rig by name, or a user table from a .toml path."""
    if isinstance(rig, os.PathLike) or str(rig).endswith(".toml"):
        path = Path(rig)
        if not path.is_file():
            raise OptionError("rig table", str(path), "an existing .toml file")
        return _parse_table(str(path), path.read_text())
    rigs = builtin_rigs()
    if rig not in rigs:
        raise OptionError("rig", rig, sorted(rigs))
    return rigs[rig]


def rig_toml(table: RigTable, comments: list[str] | tuple[str, ...] = ()) -> str:
    """A rig table as TOML text in the format of ``imesh/data/rigs/*.toml`` (readable by
    :func:`load_rig`), with ``comments`` as a header."""
    def key(name: str) -> str:
        return json.dumps(name)  # a TOML basic string: quotes names with dots, spaces ...

    lines = [f"# {c}" if c else "#" for c in comments]
    lines += [f"name = {key(table.name)}", f"description = {key(table.description)}",
              f"detect = [{', '.join(key(d) for d in table.detect)}]", "", "[markers]"]
    for marker in STANDARD_MARKERS:
        combo = table.markers.get(marker)
        if combo is None:
            continue
        weights = [w for _, w in combo]
        if np.allclose(weights, 1.0 / len(combo)):
            lines.append(f"{marker} = [{', '.join(key(n) for n, _ in combo)}]")
        else:
            pairs = ", ".join(f"{key(n)} = {w:.6g}" for n, w in combo)
            lines.append(f"{marker} = {{ {pairs} }}")
    return "\n".join(lines) + "\n"


def rig_of(names: Sequence[str]) -> str:
    """The name of the first built-in rig table (by file name) whose ``detect`` names are all in
    ``names`` (a file's joint or marker names), or "". The one place rigs are told by their
    names: the readers record it as ``rig``, :func:`detect_rig` falls back on it."""
    present = set(names)
    for table in builtin_rigs().values():
        if table.detect and set(table.detect) <= present:
            return table.name
    return ""


def detect_rig(motion: MarkerMotion) -> RigTable:
    """The rig named by the reader (``motion.meta['rig']``) or the first whose ``detect`` names
    are all present (:func:`rig_of`); MarkerMappingError when none fits."""
    rigs = builtin_rigs()
    named = str(motion.meta.get("rig", ""))
    if named in rigs:
        return rigs[named]
    found = rig_of(motion.names)
    if found:
        return rigs[found]
    raise MarkerMappingError(
        f"{motion.source}: no built-in rig table recognises this marker set (pass rig= a .toml "
        f"table; built-in rigs: {', '.join(sorted(rigs))})",
        missing=["a rig table"], available=motion.names,
    )


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
        from .rig import recognize_motion

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

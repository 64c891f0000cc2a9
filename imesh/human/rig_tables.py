"""Rig tables: how one rig's markers give the standard markers, in TOML.

A marker set (C3D, TRC) has no tree: its protocol is found by name in the TOML tables of
``imesh/data/rigs/`` (:func:`rig_of`, the one place rigs are told by their names). In a table
each standard marker is an affine combination of the rig's markers (a list = equal-weight mean;
an inline table = explicit weights summing to 1). A table given explicitly (a built-in name or
a .toml file, ``--rig``) overrides the recognition; ``imesh rig`` writes the recognized mapping
in the same format (:func:`rig_toml`), to edit and reuse.
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
from ..errors import MarkerMappingError, OptionError
from .markerset import STANDARD_MARKERS

log = logging.getLogger(__name__)


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

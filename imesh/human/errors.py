"""Errors of the human-body model: a skeleton that is not recognized, a length unit that cannot
be told from the body's size."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ..errors import ImeshError, MarkerMappingError


class RigRecognitionError(MarkerMappingError):
    """A part of the human body could not be found in a skeleton tree.

    Attributes:
        source: the motion's file (or name).
        part: the body part that could not be found (e.g. "legs", "left/right arms", "toe_l").
        reason: why, in words.
        tree: the skeleton tree as printed in the message (names and bone lengths).
        missing: ``[part]`` (MarkerMappingError interface).
        available: the skeleton's joint names.
    """

    def __init__(self, source: str, part: str, reason: str, tree: str,
                 names: Sequence[str] = ()):
        self.source = str(source)
        self.part = part
        self.reason = reason
        self.tree = tree
        self.missing = [part]
        self.available = list(names)
        ImeshError.__init__(
            self, f"{self.source}: cannot recognize a human skeleton: no {part} ({reason}); "
            f"pass a rig table (--rig FILE, see `imesh rig`). Skeleton tree (joint, bone "
            f"length):\n{tree}")


class UnitsError(ImeshError):
    """The length unit of a file cannot be told from the performer's size.

    Raised when no candidate unit, or more than one, puts the standing height in the human
    range; the message lists what every unit would give and asks for ``--units``.

    Attributes:
        path: the file.
        height_units: the standing height in file units.
        heights_m: unit name -> standing height [m] it would give.
        plausible: the units whose height is humanly possible (empty when none is).
        valid: the unit names ``--units`` accepts.
    """

    def __init__(self, path: str, height_units: float, heights_m: Mapping[str, float],
                 plausible: Sequence[str], valid: Sequence[str], *, what: str, limits_m: tuple):
        self.path = str(path)
        self.height_units = float(height_units)
        self.heights_m = dict(heights_m)
        self.plausible = list(plausible)
        self.valid = list(valid)
        lo, hi = limits_m
        options = ", ".join(f"{u} -> {h:.3g} m" for u, h in self.heights_m.items())
        if self.plausible:
            choices = " and ".join(f"{u} ({self.heights_m[u]:.3g} m)" for u in self.plausible)
            every = "both" if len(self.plausible) == 2 else "all"
            problem = (f"ambiguous length unit: {choices} {every} give a possible {what} "
                       f"({lo:g}-{hi:g} m), none an adult one")
        else:
            problem = f"no length unit gives a human {what} ({lo:g}-{hi:g} m)"
        super().__init__(
            f"{self.path}: {problem}: the {what} is {self.height_units:.4g} file units "
            f"({options}); pass --units with one of {', '.join(self.valid)} or the metres "
            f"per file unit")

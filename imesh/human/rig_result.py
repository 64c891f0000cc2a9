"""The result of a rig recognition: the joints of each body part of a skeleton, and the 21
standard markers they give (:meth:`Recognition.markers`, as a rig table by
:meth:`Recognition.table`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .markerset import STANDARD_MARKERS
from .rig_tables import RigTable

#: Name of the rig table a recognition gives.
RECOGNIZED = "recognized"
#: Chest marker: this far below the shoulder line (along the trunk), on the arm-branch -> neck
#: bone [m].
CHEST_BELOW_SHOULDERS_M = 0.065


@dataclass(frozen=True)
class Leg:
    """Joint indices of one leg."""

    side: str
    hip: int
    knee: int
    ankle: int
    toe: int


@dataclass(frozen=True)
class Arm:
    """Joint indices of one arm; ``hand`` is the hand marker as (joint, weight) pairs (one joint,
    a point towards a fingertip, or extrapolated from the forearm)."""

    side: str
    clavicle: int | None
    shoulder: int
    elbow: int
    wrist: int
    hand: tuple[tuple[int, float], ...]


@dataclass(frozen=True, eq=False)
class Recognition:
    """A skeleton read as a human body.

    Attributes:
        names: joint names of the skeleton.
        parents: parent index per joint (-1 for roots).
        source: the file (or motion) recognized.
        pelvis: joint the legs branch from.
        spine: the spine marker as (joint, weight) pairs.
        chest_branch: joint the arms branch from.
        neck: first spine point above the arm branch.
        head: the head joint (top of the neck).
        legs: left and right leg.
        arms: left and right arm.
        up: (3,) body up in the file's axes (unit vector).
        up_axis: the file axis ("+Y", "-Z", ...) along body up, None when the body is not within
            30 deg of an axis.
        shoulder_height: the shoulder line above the arm branch, along the trunk (pelvis -> arm
            branch), median over frames [file units].
        neck_height: the neck above the arm branch, along the trunk [file units].
        height: standing height, head joint above the lowest foot point [file units].
        confidence: part -> margin in [0, 1] (1 = unambiguous).
        notes: decisions worth reporting (names that disagreed, extrapolations, ...).
        ignored: how many joints no standard marker uses (fingers, twist, face, props ...).
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    source: str
    pelvis: int
    spine: tuple[tuple[int, float], ...]
    chest_branch: int
    neck: int
    head: int
    legs: tuple[Leg, Leg]
    arms: tuple[Arm, Arm]
    up: tuple[float, float, float]
    up_axis: str | None
    shoulder_height: float
    neck_height: float
    height: float
    confidence: dict
    notes: tuple[str, ...]
    ignored: int

    @property
    def overall_confidence(self) -> float:
        """The smallest part confidence."""
        return float(min(self.confidence.values()))

    def chest_weights(self, unit_scale_m: float) -> tuple[tuple[int, float], ...]:
        """The chest marker as (joint, weight) pairs for a length unit [m per file unit]."""
        target = self.shoulder_height - CHEST_BELOW_SHOULDERS_M / unit_scale_m
        t = float(np.clip(np.round(target / max(self.neck_height, 1e-12), 1), 0.0, 0.9))
        if t == 0.0:
            return ((self.chest_branch, 1.0),)
        return ((self.chest_branch, round(1.0 - t, 1)), (self.neck, t))

    def markers(self, unit_scale_m: float = 1.0) -> dict[str, tuple[tuple[str, float], ...]]:
        """Standard marker -> ((joint name, weight), ...) for a length unit [m per file unit]."""
        n = self.names
        left_leg, right_leg = self.legs
        left_arm, right_arm = self.arms
        out: dict[str, tuple[tuple[str, float], ...]] = {
            "pelvis": ((n[self.pelvis], 1.0),),
            "spine": tuple((n[j], w) for j, w in self.spine),
            "chest": tuple((n[j], w) for j, w in self.chest_weights(unit_scale_m)),
            "neck": ((n[self.neck], 1.0),),
            "head": ((n[self.head], 1.0),),
        }
        for leg in (left_leg, right_leg):
            s = leg.side
            out[f"hip_{s}"] = ((n[leg.hip], 1.0),)
            out[f"knee_{s}"] = ((n[leg.knee], 1.0),)
            out[f"ankle_{s}"] = ((n[leg.ankle], 1.0),)
            out[f"toe_{s}"] = ((n[leg.toe], 1.0),)
        for arm in (left_arm, right_arm):
            s = arm.side
            out[f"shoulder_{s}"] = ((n[arm.shoulder], 1.0),)
            out[f"elbow_{s}"] = ((n[arm.elbow], 1.0),)
            out[f"wrist_{s}"] = ((n[arm.wrist], 1.0),)
            out[f"hand_{s}"] = tuple((n[j], w) for j, w in arm.hand)
        return {m: out[m] for m in STANDARD_MARKERS}

    def table(self, unit_scale_m: float = 1.0, name: str = RECOGNIZED) -> RigTable:
        """The recognized mapping as a rig table (what ``imesh rig`` writes)."""
        return RigTable(
            name=name,
            description=f"recognized from the skeleton of {self.source} (confidence "
                        f"{self.overall_confidence:.2f})",
            detect=(), markers=self.markers(unit_scale_m), path=self.source)

    def describe(self, unit_scale_m: float = 1.0) -> list[str]:
        """Human-readable lines: each standard marker, its joints and the confidences."""
        lines = []
        for marker, combo in self.markers(unit_scale_m).items():
            if len(combo) == 1:
                text = combo[0][0]
            else:
                text = " + ".join(f"{w:g} {j}" for j, w in combo)
            lines.append(f"{marker:>10} = {text}")
        conf = ", ".join(f"{k} {v:.2f}" for k, v in self.confidence.items())
        lines.append(f"confidence {self.overall_confidence:.2f} ({conf}); {self.ignored} joints "
                     "unused (fingers, twist, face, props ...)")
        lines.extend(f"note: {note}" for note in self.notes)
        return lines

"""Adapting human marker motion to new body proportions with the interaction mesh.

``adapt_motion`` is the marker-level pipeline: standard markers -> gap filling -> (optionally a
second performer in the same mesh) -> target bone lengths -> spacetime morph. It also computes
the naive per-bone scaling on the same targets, the baseline the mesh must beat.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import OptionError
from ..human.gaps import fill_gaps
from ..human.markerset import BONE_GROUPS, STANDARD_MARKERS
from ..human.standard import to_standard
from ..mesh.bones import bone_lengths, scale_bones_naive
from ..metrics import close_pair_error
from .problem import MorphConfig, build_morph_problem
from .solver import MorphResult, MorphStepReport, solve_morph

log = logging.getLogger(__name__)

PERSON_PREFIXES = ("a:", "b:")


@dataclass(frozen=True, eq=False)
class AdaptResult:
    """Adapted markers with the evidence.

    Attributes:
        source: the standard-marker source motion that was adapted (gaps filled).
        adapted: the adapted motion (same names, bones, fps).
        naive: per-bone scaling of the source to the same targets, for comparison.
        morph: the spacetime solver's result (residuals, per-step reports, timings).
        seconds: wall time of the whole adaptation [s].
    """

    source: MarkerMotion
    adapted: MarkerMotion
    naive: MarkerMotion
    morph: MorphResult
    seconds: float

    def report(self) -> dict:
        """The ``imesh adapt --json`` report."""
        return {
            "frames": self.source.n_frames,
            "markers": self.source.n_markers,
            "bone_residual_m": self.morph.bone_residual_m,
            "position_residual_m": self.morph.position_residual_m,
            "close_pair_error": close_pair_error(self.source, self.adapted),
            "naive_close_pair_error": close_pair_error(self.source, self.naive),
            "morph_steps": self.morph.morph_steps,
            "windows": self.morph.windows,
            "seconds": self.seconds,
            "seconds_by_stage": self.morph.timings,
        }


def group_factors(motion: MarkerMotion, scales: dict[str, float]) -> np.ndarray:
    """(B,) length factor per bone from group scales (factors of overlapping groups multiply).

    Bone groups (BONE_GROUPS) are named by the child marker of each standard bone; markers of a
    second performer carry a "b:" prefix, which is ignored for grouping.
    """
    factor = np.ones(len(motion.bones))
    children = [motion.names[b].split(":")[-1] for _, b in motion.bones]
    for group, value in scales.items():
        if group not in BONE_GROUPS:
            raise OptionError("bone group", group, BONE_GROUPS)
        if not (np.isfinite(value) and value > 0):
            raise OptionError(f"scale of {group}", value, "a positive number")
        hit = np.array([c in BONE_GROUPS[group] for c in children])
        if not hit.any():
            raise OptionError("bone group", group,
                              f"a group with bones in this motion (bone children: {children})")
        factor[hit] *= value
    return factor


def _standardize(motion: MarkerMotion) -> MarkerMotion:
    """The standard marker set, or the motion itself when it is already standard or is a
    skeleton of an unknown rig (then its own joints and bones are morphed)."""
    if motion.names == STANDARD_MARKERS or (len(motion.bones) and not motion.meta.get("rig")):
        return fill_gaps(motion)
    return fill_gaps(to_standard(motion))


def prepare_markers(motion: MarkerMotion, people: MarkerMotion | None = None) -> MarkerMotion:
    """Standard markers, gaps filled; with ``people``, both performers in one motion
    (names prefixed "a:" and "b:")."""
    std = _standardize(motion)
    if people is None:
        return std
    return std.concat_markers(_standardize(people), *PERSON_PREFIXES)


def adapt_motion(motion: MarkerMotion, *, scales: dict[str, float] | None = None,
                 target_lengths_m: np.ndarray | None = None,
                 hard_positions_m: np.ndarray | None = None,
                 soft_positions_m: np.ndarray | None = None,
                 people: MarkerMotion | None = None, config: MorphConfig | None = None,
                 progress: Callable[[MorphStepReport], None] | None = None) -> AdaptResult:
    """Adapt a human motion to new bone lengths, keeping spatial relationships.

    Args:
        motion: any loaded motion (mapped to the standard marker set unless it already is one
            with bones).
        scales: bone group -> factor (arms, forearms, legs, spine, all); ignored when
            ``target_lengths_m`` is given.
        target_lengths_m: (T, B) or (B,) explicit target lengths of the motion's bones [m].
        hard_positions_m: (T, M, 3) hard positional targets [m], NaN where free.
        soft_positions_m: (T, M, 3) soft positional targets [m], NaN where free.
        people: a second performer recorded in the same world frame, adapted in the same mesh.
        config: MorphConfig.
        progress: called after every morph step (for progress bars).

    Returns:
        AdaptResult (adapted and naive motions, solver residuals, timings).
    """
    t0 = time.perf_counter()
    src = prepare_markers(motion, people)
    pairs = src.bones
    if target_lengths_m is None:
        target_lengths_m = bone_lengths(src.positions_m, pairs) * group_factors(src, scales or {})
    problem = build_morph_problem(src, pairs=pairs, target_lengths_m=target_lengths_m,
                                  hard_positions_m=hard_positions_m,
                                  soft_positions_m=soft_positions_m, config=config)
    result = solve_morph(problem, progress=progress)
    adapted = src.with_positions(result.positions_m, source=f"adapted:{src.source}")
    naive = src.with_positions(scale_bones_naive(src.positions_m, src.bones,
                                                 problem.target_lengths_m),
                               source=f"naive:{src.source}")
    seconds = time.perf_counter() - t0
    return AdaptResult(source=src, adapted=adapted, naive=naive, morph=result, seconds=seconds)

"""Reading the human clip of ``imesh inspect``, ``rig``, ``adapt`` and ``retarget`` with the
options of :func:`imesh.cli.parsers._add_load_options`."""

from __future__ import annotations

import argparse

from ..core.motion import MarkerMotion, require_frames
from ..io.clip import parse_units, read_clip
from ..io.floor import ground_together

__all__ = ["PIPELINE_MIN_FRAMES", "load_clip", "load_pair", "parse_units"]

#: Frames the adapt/retarget pipeline needs. Every clip is low-passed before the solve
#: (:mod:`imesh.human.filtering`: Butterworth order 4, run forwards and backwards, whose edge
#: padding is 3 x 5 coefficients = 15 frames, so it needs at least 16); a shorter clip would be
#: solved unfiltered, and capture jitter then dominates the accelerations the solve limits. The
#: clip can still be inspected and its rig recognized (``imesh inspect``, ``imesh rig``).
PIPELINE_MIN_FRAMES = 16
_WHY = ("its zero-phase low-pass filter pads 15 frames at each end; a shorter clip would be "
        "solved unfiltered, its capture jitter dominating the accelerations; imesh inspect and "
        "imesh rig read it")


def load_clip(args, *, apply_rig: bool = True, ground: str = "auto") -> MarkerMotion:
    """The clip ``args.clip`` read with the parsed options: units, up axis, frame rates, ASF
    skeleton, body model (AMASS), resampled to ``--fps`` and mapped by ``--rig`` (when
    ``apply_rig``); the options are recorded in the motion (:func:`imesh.io.clip.read_clip`)
    for the retarget's provenance.

    Raises:
        ImeshError: an unreadable clip; for adapt and retarget, fewer than
            :data:`PIPELINE_MIN_FRAMES` frames.
    """
    motion = read_clip(args.clip, {
        "units": args.units, "up_axis": args.up_axis, "source_fps": args.source_fps,
        "asf": getattr(args, "asf", None), "fps": getattr(args, "fps", None),
        "rig": getattr(args, "rig", None) if apply_rig else None,
        "body_model": getattr(args, "body_model", None),
        "joints": getattr(args, "joints", None)}, ground=ground)
    if args.command in ("adapt", "retarget"):
        require_frames(motion, PIPELINE_MIN_FRAMES, f"imesh {args.command} ({_WHY})")
    return motion


def load_pair(args, other: str) -> tuple[MarkerMotion, MarkerMotion]:
    """``args.clip`` and ``other`` (a second performer captured with it) read with the same
    options as :func:`load_clip`, each as the file has it, then put on one floor together
    (:func:`imesh.io.floor.ground_together`), as :func:`imesh.io.clip.read_pair` does.

    Raises:
        ImeshError: as :func:`load_clip`.
    """
    a = load_clip(args, ground="none")
    b = load_clip(argparse.Namespace(**{**vars(args), "clip": other}), ground="none")
    a, b = ground_together([a, b])
    return a, b

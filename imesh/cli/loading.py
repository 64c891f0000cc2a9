"""Reading the human clip of ``imesh inspect``, ``rig``, ``adapt`` and ``retarget`` with the
options of :func:`imesh.cli.parsers._add_load_options`."""

from __future__ import annotations

from ..core.motion import MarkerMotion, require_frames
from ..io.clip import parse_units, read_clip

__all__ = ["PIPELINE_MIN_FRAMES", "load_clip", "parse_units"]

#: Frames the adapt/retarget pipeline needs: its zero-phase low-pass (order 4, run forwards and
#: backwards) pads 3 x 5 coefficients, and contacts, velocities and the acceleration energy need
#: neighbouring frames.
PIPELINE_MIN_FRAMES = 16


def load_clip(args, *, apply_rig: bool = True) -> MarkerMotion:
    """The clip ``args.clip`` read with the parsed options: units, up axis, frame rates, ASF
    skeleton, resampled to ``--fps`` and mapped by ``--rig`` (when ``apply_rig``); the options
    are recorded in the motion (:func:`imesh.io.clip.read_clip`) for the retarget's provenance.

    Raises:
        ImeshError: an unreadable clip; for adapt and retarget, fewer than
            :data:`PIPELINE_MIN_FRAMES` frames.
    """
    motion = read_clip(args.clip, {
        "units": args.units, "up_axis": args.up_axis, "source_fps": args.source_fps,
        "asf": getattr(args, "asf", None), "fps": getattr(args, "fps", None),
        "rig": getattr(args, "rig", None) if apply_rig else None})
    if args.command in ("adapt", "retarget"):
        require_frames(motion, PIPELINE_MIN_FRAMES, f"imesh {args.command} (its low-pass filter, "
                       "contact and acceleration terms)")
    return motion

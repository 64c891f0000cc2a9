"""Reading the human clip of ``imesh inspect``, ``rig``, ``adapt`` and ``retarget`` with the
options of :func:`imesh.cli.parsers._add_load_options`."""

from __future__ import annotations

from ..core.motion import MarkerMotion, require_frames
from ..human.standard import to_standard
from ..io import load_motion

#: Frames the adapt/retarget pipeline needs: its zero-phase low-pass (order 4, run forwards and
#: backwards) pads 3 x 5 coefficients, and contacts, velocities and the acceleration energy need
#: neighbouring frames.
PIPELINE_MIN_FRAMES = 16


def load_clip(args, *, apply_rig: bool = True) -> MarkerMotion:
    """The clip ``args.clip`` read with the parsed options: units, up axis, frame rates, ASF
    skeleton, resampled to ``--fps`` and mapped by ``--rig`` (when ``apply_rig``).

    Raises:
        ImeshError: an unreadable clip; for adapt and retarget, fewer than
            :data:`PIPELINE_MIN_FRAMES` frames.
    """
    motion = load_motion(args.clip, units=parse_units(args.units), up_axis=args.up_axis,
                         fps=args.source_fps, asf=getattr(args, "asf", None))
    if getattr(args, "fps", None):
        motion = motion.resample(args.fps)
    if apply_rig and getattr(args, "rig", None):
        motion = to_standard(motion, rig=args.rig)
    if args.command in ("adapt", "retarget"):
        require_frames(motion, PIPELINE_MIN_FRAMES, f"imesh {args.command} (its low-pass filter, "
                       "contact and acceleration terms)")
    return motion


def parse_units(text: str | None) -> str | float | None:
    """A unit name, or metres per file unit given as a number (``--units``)."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return text

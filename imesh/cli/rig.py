"""``imesh rig CLIP -o TABLE.toml``: the human rig of a clip as a rig table to edit and pass
back with ``--rig``."""

from __future__ import annotations

from pathlib import Path

from ..human.rig import recognize_motion
from ..human.rig_tables import detect_rig, rig_toml
from ..io.atomic import atomic_path
from .loading import load_clip


def run(args) -> int:
    """Write the rig table (recognized from the skeleton, or the built-in table of a marker
    set as a starting point), print what was recognized; returns the exit status."""
    motion = load_clip(args, apply_rig=False)
    name = args.name or Path(args.output).stem
    head = [f"Rig table for {Path(args.clip).name}, written by `imesh rig` (units "
            f"{motion.meta.get('units', 'm')}, up axis {motion.meta.get('up_axis', '+Z')}).",
            "Each standard marker = a joint, a list (equal-weight mean) or name = weight pairs",
            "(summing to 1). Edit it and pass it back with --rig FILE."]
    if len(motion.bones):
        body, scale = recognize_motion(motion)
        table = body.table(scale, name=name)
        head.append(f"Recognized from the skeleton, confidence {body.overall_confidence:.2f} ("
                    + ", ".join(f"{k} {v:.2f}" for k, v in body.confidence.items()) + ").")
        head += [f"Note: {note}" for note in body.notes]
        lines = body.describe(scale)
    else:  # a marker set: its table found by the marker names, as a starting point
        found = detect_rig(motion)
        table = type(found)(name=name, description=found.description, detect=found.detect,
                            markers=found.markers, path=args.output)
        head.append(f"Marker set: copied from the built-in table {found.name!r}.")
        lines = []
    with atomic_path(args.output) as tmp:
        tmp.write_text(rig_toml(table, [*head, ""]))
    for line in lines:
        print(line)
    print(f"wrote rig table {name!r} -> {args.output}")
    return 0

"""``imesh inspect CLIP``: a summary of a motion file and what maps it to the standard markers."""

from __future__ import annotations

import json

from ..errors import MarkerMappingError
from ..human.rig import recognize_motion
from ..human.rig_tables import detect_rig, load_rig
from .loading import load_clip


def run(args) -> int:
    """Print the clip's summary and its rig mapping (one JSON object with ``--json``); returns
    the exit status."""
    motion = load_clip(args, apply_rig=False)
    summary = motion.summary()
    rig = _rig_mapping(motion, args.rig)
    if args.json:
        summary["rig"] = {k: v for k, v in rig.items() if k != "lines"}
        print(json.dumps(summary))
        return 0
    for key, value in summary.items():
        if key == "markers":
            value = f"{len(value)}: " + ", ".join(value)
        print(f"{key:>17}: {value}")
    if rig.get("error"):
        print(f"{'rig':>17}: not recognized: {rig['error']}")
        return 0
    if "lines" in rig:
        print(f"{'rig':>17}: recognized from the skeleton (confidence "
              f"{rig['confidence']:.2f}), standing height {rig['standing_height_m']:.3f} m")
        lines = rig["lines"]
    else:
        print(f"{'rig':>17}: table {rig['table']} ({rig['source']})")
        lines = [f"{m:>10} = " + " + ".join(f"{w:g} {n}" if len(c) > 1 else n for n, w in c)
                 for m, c in rig["markers"].items()]
    for line in lines:
        print(f"{'':>19}{line}")
    return 0


def _rig_mapping(motion, rig: str | None) -> dict:
    """What maps the motion to the standard markers: a table given with --rig, the recognized
    skeleton, or a marker-set table found by name; ``error`` otherwise."""

    def combos(markers: dict) -> dict:
        return {m: [[n, w] for n, w in c] for m, c in markers.items()}

    try:
        if rig:
            table = load_rig(rig)
            return {"table": table.name, "source": table.path, "markers": combos(table.markers)}
        if len(motion.bones):
            body, scale = recognize_motion(motion)
            return {"table": "recognized", "confidence": body.overall_confidence,
                    "confidence_by_part": dict(body.confidence),
                    "standing_height_m": body.height * scale,
                    "markers": combos(body.markers(scale)), "notes": list(body.notes),
                    "lines": body.describe(scale)}
        table = detect_rig(motion)
        return {"table": table.name, "source": table.path, "markers": combos(table.markers)}
    except MarkerMappingError as exc:
        return {"table": None, "error": str(exc)}

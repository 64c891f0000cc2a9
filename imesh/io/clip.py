"""A human clip read with the options of the command line (``--units``, ``--up-axis``,
``--source-fps``, ``--asf``, ``--fps``, ``--rig``, ``--body-model``), the options recorded in
the motion, so that a retarget's provenance (:mod:`imesh.core.provenance`) can read the clip
again the same way (``imesh evaluate --source``)."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from typing import Any

from ..core.motion import MarkerMotion
from ..core.provenance import LOAD_OPTION_KEYS
from ..errors import OptionError
from . import load_motion
from .floor import ground_together


def parse_units(text: str | float | None) -> str | float | None:
    """A unit name, or metres per file unit given as a number (``--units``)."""
    if text is None or isinstance(text, float):
        return text
    try:
        return float(text)
    except ValueError:
        return text


def read_clip(path: str | os.PathLike, options: Mapping[str, object] | None = None, *,
              ground: str = "auto") -> MarkerMotion:
    """Read a human clip with reading options and record them in ``meta["load_options"]``.

    Args:
        path: the clip (BVH, ASF/AMC, C3D, TRC, AMASS .npz).
        options: keys of :data:`imesh.core.provenance.LOAD_OPTION_KEYS`: ``units`` (a unit
            name or metres per unit), ``up_axis`` (e.g. ``"+Y"``), ``source_fps`` (frame rate of
            formats that store none [1/s]), ``asf`` (the skeleton of an .amc), ``fps`` (resample
            to this rate [1/s]), ``rig`` (a rig table: .toml path or built-in name),
            ``body_model`` (the body-model folder of an AMASS file, recorded as an absolute
            path), ``joints`` (the joint-names file of a joint-position array, recorded as an
            absolute path); None values are the defaults.
        ground: ``"auto"`` (the clip levelled and put on its floor) or ``"none"`` (as the file
            has it: :func:`read_pair` grounds two people together); not recorded (the floor is
            a rigid motion of the clip, which the source-based metrics do not see).

    Returns:
        The motion (metres, Z up), resampled and mapped by the rig as asked.

    Raises:
        OptionError: an unknown option name (lists the valid ones).
        ImeshError: an unreadable clip (see :func:`imesh.io.load_motion`).
    """
    given: dict[str, Any] = {k: v for k, v in (options or {}).items() if v is not None}
    unknown = sorted(set(given) - set(LOAD_OPTION_KEYS))
    if unknown:
        raise OptionError("clip reading option", unknown[0], LOAD_OPTION_KEYS)
    motion = load_motion(path, units=parse_units(given.get("units")),
                         up_axis=given.get("up_axis"), ground=ground,
                         fps=given.get("source_fps"),
                         asf=given.get("asf"), body_model=given.get("body_model"),
                         joints=given.get("joints"))
    if given.get("fps"):
        motion = motion.resample(float(given["fps"]))
    if given.get("rig"):
        from ..human.standard import to_standard

        motion = to_standard(motion, rig=str(given["rig"]))
    if not given:
        return motion
    if given.get("body_model"):  # read again from elsewhere (imesh evaluate --source)
        given["body_model"] = os.path.abspath(given["body_model"])
    if given.get("joints"):
        given["joints"] = os.path.abspath(given["joints"])
    recorded = {k: (str(v) if k in ("asf", "rig") else v) for k, v in given.items()}
    return dataclasses.replace(motion, meta={**motion.meta, "load_options": recorded})


def read_pair(path_a: str | os.PathLike, path_b: str | os.PathLike,
              options_a: Mapping[str, object] | None = None,
              options_b: Mapping[str, object] | None = None
              ) -> tuple[MarkerMotion, MarkerMotion]:
    """Two people captured together, each read as :func:`read_clip` reads a clip, then put on
    one floor (:func:`imesh.io.floor.ground_together`: one plane fitted to both people's
    planted feet, one rotation, one vertical shift), so that they keep their relative place.

    Raises:
        ImeshError: as :func:`read_clip`.
    """
    a = read_clip(path_a, options_a, ground="none")
    b = read_clip(path_b, options_b, ground="none")
    a, b = ground_together([a, b])
    return a, b

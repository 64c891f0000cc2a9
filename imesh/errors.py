"""Exception hierarchy of imesh.

Every error imesh raises on bad input is an :class:`ImeshError` subclass whose message says what
was wrong, where (file, frame, marker, joint) and what would have been valid. The command line
prints the message on one line and exits with status 2; library users can catch the specific
subclass and read the structured fields it carries. ``docs/errors.md`` lists every class.

Exit statuses of the command line: 0 success, 2 bad input or usage (any ImeshError), 3 reserved
for an output that was written but failed its verification.
"""

from __future__ import annotations

import os
from collections.abc import Iterable


def _listing(options: Iterable[str], limit: int = 40) -> str:
    """Comma-separated listing of valid options, shortened past ``limit`` entries."""
    items = [str(o) for o in options]
    if len(items) > limit:
        return ", ".join(items[:limit]) + f", ... ({len(items) - limit} more)"
    return ", ".join(items)


def _located(path: object, **where: object) -> str:
    """``"walk.bvh, line 12, frame 3"``: the path and each part of ``where`` that is not None,
    in the order given."""
    return ", ".join([str(path), *(f"{k} {v}" for k, v in where.items() if v is not None)])


class ImeshError(Exception):
    """Root of every error imesh raises on bad input or infeasible problems."""


class MotionFileError(ImeshError):
    """A motion file cannot be read: unknown format, truncated, malformed or non-finite data.

    Attributes:
        path: the file.
        line: 1-based line number where the problem was found (text formats), or None.
        frame: 0-based frame index, or None.
    """

    def __init__(self, path: str, message: str, *, line: int | None = None,
                 frame: int | None = None):
        super().__init__(f"{_located(path, line=line, frame=frame)}: {message}")
        self.path = str(path)
        self.line = line
        self.frame = frame


class UnsupportedFormatError(MotionFileError):
    """The file extension is not one imesh reads."""


class MissingMarkerError(ImeshError):
    """A marker or joint needed by a mapping is absent (or missing in every frame).

    Attributes:
        missing: names that were needed and not found.
        available: names that are available.
    """

    def __init__(self, message: str, missing: Iterable[str], available: Iterable[str]):
        self.missing = list(missing)
        self.available = list(available)
        super().__init__(
            f"{message}: missing {_listing(self.missing)}; available: {_listing(self.available)}"
        )


class MarkerMappingError(MissingMarkerError):
    """No standard-marker-set mapping fits the rig, or a mapping is incomplete."""


class InvalidMotionError(ImeshError):
    """Motion arrays have the wrong shape, non-finite values, or inconsistent names."""


class ConstraintError(ImeshError):
    """Morph targets or constraints are invalid (e.g. zero bone length, unknown marker index)."""


class SolverError(ImeshError):
    """A solve failed to meet its residual tolerance or produced non-finite values.

    Attributes:
        residual: the residual reached.
        tolerance: the tolerance asked for.
    """

    def __init__(self, message: str, residual: float = float("nan"),
                 tolerance: float = float("nan")):
        self.residual = residual
        self.tolerance = tolerance
        super().__init__(message)


class QpInfeasibleError(SolverError):
    """A QP solver certified that no point meets the QP's constraints: another solver will not
    find one either (the whole-body solve relaxes its speed rows instead)."""


class OptionError(ImeshError):
    """A user option (CLI flag, config value) is invalid; the message lists valid values."""

    def __init__(self, name: str, value: object, valid: Iterable[str] | str):
        self.name = name
        self.value = value
        valid_text = valid if isinstance(valid, str) else _listing(valid)
        self.valid = valid_text
        super().__init__(f"invalid {name} {value!r}; valid: {valid_text}")


class ImplausibleMotionError(InvalidMotionError):
    """A motion file parses but its content cannot be a recording of a person.

    Raised by the plausibility checks at load time (:func:`imesh.core.motion.check_plausible`):
    positions beyond the plausible range, a body height outside the plausible range, a marker
    that jumps faster than any body part moves (a corrupted sample), every marker missing, or a
    clip shorter than the method needs.

    Attributes:
        path: the file (or motion source).
        check: which check failed ("position range", "height", "marker speed", "missing
            markers", "frames", "frame rate", "non-finite").
        frame: 0-based frame of the first offending sample, or None.
        marker: name of the offending marker or joint, or None.
        value: the offending value (metres, metres/second, frames...), or None.
        valid: what would have been valid, as text.
    """

    def __init__(self, path: str, check: str, message: str, *, valid: str,
                 frame: int | None = None, marker: str | None = None,
                 value: float | None = None):
        super().__init__(f"{_located(path, frame=frame, marker=marker)}: {message}; "
                         f"valid: {valid}")
        self.path = str(path)
        self.check = check
        self.frame = frame
        self.marker = marker
        self.value = value
        self.valid = valid


class TooFewFramesError(ImplausibleMotionError):
    """A clip has fewer frames than the method needs.

    Attributes:
        frames: frames in the clip.
        needed: frames the method needs.
    """

    def __init__(self, path: str, frames: int, needed: int, method: str):
        super().__init__(path, "frames", f"{frames} frame{'s' if frames != 1 else ''}, too "
                         f"short for {method}", valid=f"at least {needed} frames",
                         value=float(frames))
        self.frames = frames
        self.needed = needed


class OutputPathError(ImeshError):
    """An output path cannot be written: wrong extension, missing or unwritable folder, a parent
    that is a file. Raised before any computation starts (and if writing fails anyway).

    Attributes:
        path: the output path.
        option: the option that named it (``-o``, ``--json``, ``--plots``...), or "".
        reason: what is wrong.
        valid: what would be valid.
    """

    def __init__(self, path: str | os.PathLike, reason: str, *, option: str = "",
                 valid: str = ""):
        what = f"output {option} {str(path)!r}" if option else f"output {str(path)!r}"
        text = f"{what}: {reason}"
        if valid:
            text += f"; valid: {valid}"
        super().__init__(text)
        self.path = str(path)
        self.option = option
        self.reason = reason
        self.valid = valid


class SourceMismatchError(ImeshError):
    """Two motions that must describe the same take disagree (frame count, frame rate, or the
    clip file's SHA-256 that a motion's provenance records).

    Attributes:
        what: the quantity that differs ("frames", "fps" or "sha256").
        expected: the value of the reference motion.
        found: the value of the other motion.
    """

    def __init__(self, message: str, *, what: str, expected: float | str,
                 found: float | str):
        super().__init__(message)
        self.what = what
        self.expected = expected
        self.found = found


class MissingDependencyError(ImeshError):
    """An optional dependency a feature needs is not installed (:func:`imesh.core.lazy.optional`).

    Attributes:
        module: the module that could not be imported.
        pip: the command that installs it.
        feature: what needs it.
    """

    def __init__(self, module: str, pip: str, feature: str):
        super().__init__(f"{feature} needs {module}: {pip}")
        self.module = module
        self.pip = pip
        self.feature = feature


class VerificationError(ImeshError):
    """The motion was computed but failed the robot's gates (:mod:`imesh.evaluate.verify`): nothing
    was written (unless ``--force``). The command line exits with status 3.

    Attributes:
        failed: metric -> (value, gate text) of every failed gate.
    """

    exit_status = 3

    def __init__(self, what: str, failed: dict):
        self.failed = dict(failed)
        items = "; ".join(f"{k} = {v[0]:.4g} (gate {v[1]})" if isinstance(v[0], (int, float))
                          else f"{k} = {v[0]} (gate {v[1]})" for k, v in failed.items())
        super().__init__(f"{what} failed verification: {items}; nothing written (--force writes "
                         "it anyway, marked failed in the report)")

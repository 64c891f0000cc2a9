"""Exception hierarchy of imesh.

Every error imesh raises on bad input is an :class:`ImeshError` subclass whose message says what
was wrong, where (file, frame, marker, joint) and what would have been valid. The command line
prints the message on one line and exits with status 2; library users can catch the specific
subclass and read the structured fields it carries.
"""

from __future__ import annotations

from collections.abc import Iterable


def _listing(options: Iterable[str], limit: int = 40) -> str:
    """Comma-separated listing of valid options, shortened past ``limit`` entries."""
    items = [str(o) for o in options]
    if len(items) > limit:
        return ", ".join(items[:limit]) + f", ... ({len(items) - limit} more)"
    return ", ".join(items)


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
        where = str(path)
        if line is not None:
            where += f", line {line}"
        if frame is not None:
            where += f", frame {frame}"
        super().__init__(f"{where}: {message}")
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


class OptionError(ImeshError):
    """A user option (CLI flag, config value) is invalid; the message lists valid values."""

    def __init__(self, name: str, value: object, valid: Iterable[str] | str):
        self.name = name
        self.value = value
        valid_text = valid if isinstance(valid, str) else _listing(valid)
        self.valid = valid_text
        super().__init__(f"invalid {name} {value!r}; valid: {valid_text}")

"""Errors of joint fitting."""

from __future__ import annotations

from collections.abc import Iterable

from ..errors import ImeshError, _listing


class FitError(ImeshError):
    """Joint fitting cannot start or proceed: infeasible limits, bad initial pose, bad table.

    Attributes:
        joint: the joint concerned, or None.
        lower: its lower position limit [rad], or None.
        upper: its upper position limit [rad], or None.
        value: the offending value [rad], or None.
        frame: 0-based motion frame, or None.
    """

    def __init__(self, message: str, *, joint: str | None = None, lower: float | None = None,
                 upper: float | None = None, value: float | None = None,
                 frame: int | None = None):
        super().__init__(message)
        self.joint = joint
        self.lower = lower
        self.upper = upper
        self.value = value
        self.frame = frame


class UnknownFrameError(FitError):
    """A key point or direction names a robot frame the model does not have.

    Attributes:
        missing: the unknown frame names.
        available: frame names of the robot (when the robot can list them).
    """

    def __init__(self, message: str, missing: Iterable[str], available: Iterable[str]):
        self.missing = list(missing)
        self.available = list(available)
        listing = _listing(self.available, limit=200) if self.available else "(not listed)"
        super().__init__(f"{message}: unknown {_listing(self.missing)}; valid frames: {listing}")

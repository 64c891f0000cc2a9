"""Errors of the arm imitation."""

from __future__ import annotations

from ..errors import ImeshError


class ArmsError(ImeshError):
    """The arm imitation cannot start or proceed: a missing marker or hand point, an unknown
    arm joint, inconsistent limits or a bad setting. The message names the arm (side), the
    joint, frame or marker concerned and what would be valid."""

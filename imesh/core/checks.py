"""Checks of configuration values shared by the settings dataclasses (``__post_init__``).

Each raises :class:`imesh.errors.OptionError` naming the first field that fails, with the
same wording everywhere, so a setting reads the same whichever stage rejects it.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import fields
from typing import Any, ClassVar

import numpy as np

from ..errors import OptionError


def require_finite(config: object, names: Iterable[str], *, positive: bool) -> None:
    """Every field ``names`` of ``config`` is a finite number, > 0 (``positive``) or >= 0.

    Raises:
        OptionError: the first field that is not ("a positive number" or "a non-negative
            number").
    """
    for name in names:
        value = getattr(config, name)
        if not (np.isfinite(value) and (value > 0 if positive else value >= 0)):
            raise OptionError(name, value,
                              "a positive number" if positive else "a non-negative number")


class NonNegative:
    """Base of a frozen settings dataclass whose ``float`` fields are all finite and >= 0: it
    checks them when built, so a part of a configuration that only holds weights, margins or
    heights needs no ``__post_init__`` of its own (a subclass with more rules calls this one
    first).

    Raises:
        OptionError: the first such field that is negative or not finite.
    """

    # set by @dataclass on the subclass; declared so that type checkers see a dataclass
    __dataclass_fields__: ClassVar[dict[str, Any]]

    def __post_init__(self) -> None:
        require_finite(self, [f.name for f in fields(self)
                              if f.type in ("float", float)], positive=False)


def require_count(config: object, names: Iterable[str], *, minimum: int = 1) -> None:
    """Every field ``names`` of ``config`` is an ``int`` (not a bool) of at least ``minimum``:
    an iteration, step or frame count.

    Raises:
        OptionError: the first field that is not ("an integer >= minimum").
    """
    for name in names:
        value = getattr(config, name)
        if type(value) is not int or value < minimum:
            raise OptionError(name, value, f"an integer >= {minimum}")

"""Checks of configuration values shared by the settings dataclasses (``__post_init__``).

Each raises :class:`imesh.errors.OptionError` naming the first field that fails, with the
same wording everywhere, so a setting reads the same whichever stage rejects it.
"""

from __future__ import annotations

from collections.abc import Iterable

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

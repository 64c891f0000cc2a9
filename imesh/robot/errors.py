"""The robot package's error and its name suggestions.

:class:`RobotConfigError` is raised for every invalid robot configuration file, robot model file
or robot name; :func:`closest_first` orders the valid options its messages list, the likeliest
meant first.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Iterable

from ..errors import ImeshError, _listing


class RobotConfigError(ImeshError):
    """A robot configuration, robot model file or robot name is invalid.

    The message says which file and key (or argument) was wrong and lists the valid options.

    Attributes:
        path: the file concerned, or None.
        key: the TOML key (dotted) or argument concerned, or None.
        valid: the valid options listed in the message (possibly shortened), or None.
    """

    def __init__(self, message: str, *, path: str | os.PathLike | None = None,
                 key: str | None = None, valid: Iterable[str] | None = None):
        self.path = None if path is None else str(path)
        self.key = key
        self.valid = None if valid is None else list(valid)
        where = ""
        if self.path is not None:
            where = self.path
        if key is not None:
            where = f"{where} [{key}]" if where else f"[{key}]"
        text = f"{where}: {message}" if where else message
        if self.valid is not None:
            text += f"; valid: {_listing(self.valid)}"
        super().__init__(text)


def closest_first(name: str, options: Iterable[str]) -> list[str]:
    """``options`` with the ones closest to ``name`` first (difflib ratio), the rest in order."""
    opts = list(dict.fromkeys(options))
    close = difflib.get_close_matches(name, opts, n=5, cutoff=0.5)
    lowered = [o for o in opts if name.lower() in o.lower() and o not in close]
    head = close + lowered
    return head + [o for o in opts if o not in head]

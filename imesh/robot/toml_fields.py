"""Readers of TOML values for the robot files (robot.toml, markers.toml).

Each reader checks one value's type and range and raises
:class:`~imesh.robot.errors.RobotConfigError` naming the file and the dotted key, so that every
loader reports a wrong value the same way.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .errors import RobotConfigError, closest_first


def read_toml(path: Path) -> dict[str, Any]:
    """The parsed TOML file.

    Raises:
        RobotConfigError: the file is missing, not UTF-8 or not valid TOML.
    """
    if not path.is_file():
        raise RobotConfigError("file not found", path=path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise RobotConfigError(f"not valid TOML: {exc}", path=path) from None
    except UnicodeDecodeError as exc:
        raise RobotConfigError(f"not UTF-8 text: {exc}", path=path) from None


def check_keys(path: Path, tab: Mapping[str, Any], where: str, valid: Iterable[str]) -> None:
    """Raise on the first key of ``tab`` (the table at dotted key ``where``) not in ``valid``."""
    valid = list(valid)
    for key in tab:
        if key not in valid:
            k = f"{where}.{key}" if where else key
            raise RobotConfigError(f"unknown key {key!r}", path=path, key=k,
                                   valid=closest_first(key, valid))


def table(path: Path, data: Mapping[str, Any], key: str, required: bool = False) -> dict:
    """The sub-table ``data[key]``, {} when absent and not ``required``."""
    value = data.get(key)
    if value is None:
        if required:
            raise RobotConfigError("missing table", path=path, key=key)
        return {}
    if not isinstance(value, dict):
        raise RobotConfigError(f"must be a table, got {type(value).__name__}", path=path, key=key)
    return value


def table_array(path, value, key: str, allowed) -> list[tuple[str, dict]]:
    """Validated ``[[key]]`` array of tables: [(``key[i]``, table), ...]."""
    if not isinstance(value, list):
        raise RobotConfigError(f"must be an array of tables [[{key}]]", path=path, key=key)
    out = []
    for i, tab in enumerate(value):
        where = f"{key}[{i}]"
        if not isinstance(tab, dict):
            raise RobotConfigError("must be a table", path=path, key=where)
        check_keys(path, tab, where, allowed)
        out.append((where, tab))
    return out


def string(path: Path, data: Mapping[str, Any], key: str, where: str,
           required: bool = True, default: str = "") -> str:
    """The string ``data[key]`` (the table at dotted key ``where``): non-empty when ``required``,
    else ``default`` when absent."""
    value = data.get(key)
    full = f"{where}.{key}" if where else key
    if value is None:
        if required:
            raise RobotConfigError("missing key (a string)", path=path, key=full)
        return default
    if not isinstance(value, str) or (required and not value):
        raise RobotConfigError(f"must be a non-empty string, got {value!r}", path=path, key=full)
    return value


def number(path: Path, value: Any, key: str, positive: bool = False) -> float:
    """``value`` as a finite float (and > 0 when ``positive``); booleans are not numbers."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RobotConfigError(f"must be a number, got {value!r}", path=path, key=key)
    x = float(value)
    if not math.isfinite(x) or (positive and x <= 0):
        raise RobotConfigError(f"must be a finite{' positive' if positive else ''} number, "
                               f"got {value!r}", path=path, key=key)
    return x


def vector(path: Path, value: Any, key: str, n: int) -> np.ndarray:
    """``value``, a list of ``n`` numbers, as an (n,) float array."""
    if not isinstance(value, list) or len(value) != n:
        raise RobotConfigError(f"must be a list of {n} numbers, got {value!r}", path=path, key=key)
    return np.array([number(path, v, f"{key}[{i}]") for i, v in enumerate(value)], dtype=float)


def name_list(path: Path, value: Any, key: str) -> tuple[str, ...]:
    """``value``, a list of non-empty strings, as a tuple."""
    if not isinstance(value, list) or not all(isinstance(v, str) and v for v in value):
        raise RobotConfigError(f"must be a list of names, got {value!r}", path=path, key=key)
    return tuple(value)


def name_pairs(path: Path, value: Any, key: str) -> tuple[tuple[str, str], ...]:
    """``value``, a list of [name, name] pairs of two different names, as a tuple of pairs."""
    if not isinstance(value, list):
        raise RobotConfigError(f"must be a list of [name, name] pairs, got {value!r}",
                               path=path, key=key)
    out = []
    for i, pair in enumerate(value):
        if (not isinstance(pair, list) or len(pair) != 2
                or not all(isinstance(v, str) and v for v in pair) or pair[0] == pair[1]):
            raise RobotConfigError(f"must be a pair of two different names, got {pair!r}",
                                   path=path, key=f"{key}[{i}]")
        out.append((pair[0], pair[1]))
    return tuple(out)


def joint_numbers(path: Path, tab: Mapping[str, Any], key: str,
                  positive: bool = False) -> dict[str, float]:
    """``tab``, a table joint = number, as a dict of floats (each checked by :func:`number`)."""
    if not isinstance(tab, dict):
        raise RobotConfigError("must be a table joint = number", path=path, key=key)
    return {j: number(path, v, f"{key}.{j}", positive=positive) for j, v in tab.items()}


def flag(path: Path, value, key: str) -> bool:
    """``value``, which must be a TOML boolean."""
    if not isinstance(value, bool):
        raise RobotConfigError(f"{key} must be true or false, got {value!r}", path=path, key=key)
    return value

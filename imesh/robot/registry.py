"""Which robots imesh knows: the folders of ``robots/`` and paths to user robot.toml files."""

from __future__ import annotations

import importlib.util
import logging
import os
from importlib import metadata
from pathlib import Path

from .config import ROBOTS_DIR, RobotConfig, load_robot_config
from .errors import RobotConfigError

log = logging.getLogger(__name__)


def robot_names() -> list[str]:
    """Names of the robots shipped with imesh (folders of ``ROBOTS_DIR`` with a robot.toml)."""
    if not ROBOTS_DIR.is_dir():
        return []
    return sorted(p.name for p in ROBOTS_DIR.iterdir() if (p / "robot.toml").is_file())


def resolve_robot_toml(name_or_toml: str | os.PathLike) -> Path:
    """The robot.toml for a robot name, a robot folder or a robot.toml path.

    Raises:
        RobotConfigError: unknown name (listing the valid names) or missing file.
    """
    text = os.fspath(name_or_toml)
    path = Path(text)
    looks_like_path = isinstance(name_or_toml, os.PathLike) or text.endswith(".toml") \
        or os.sep in text or (os.altsep is not None and os.altsep in text)
    if looks_like_path or (path.exists() and text not in robot_names()):
        if path.is_dir():
            path = path / "robot.toml"
        if not path.is_file():
            raise RobotConfigError("robot configuration file not found", path=path,
                                   valid=robot_names())
        return path
    names = robot_names()
    if text not in names:
        raise RobotConfigError(f"unknown robot {text!r} (give a robot name or a path to a "
                               "robot.toml)", key="robot", valid=names)
    return ROBOTS_DIR / text / "robot.toml"


def package_available(config: RobotConfig) -> bool:
    """Whether the package holding the model of a ``source = "package"`` robot is installed."""
    m = config.model
    if m.source != "package":
        return False
    if m.package and importlib.util.find_spec(m.package) is not None:
        return True
    if m.distribution:
        try:
            metadata.distribution(m.distribution)
            return True
        except metadata.PackageNotFoundError:
            return False
    return False


def list_robots() -> list[dict]:
    """The shipped robots, for ``imesh robots``: fast, without loading any model.

    Returns:
        One dict per robot: ``name``, ``dof`` (declared in robot.toml, checked at load),
        ``licence``, ``source`` (``"package <name>"`` or ``"user --urdf <file>"``),
        ``available`` (True when the model can be loaded without further arguments),
        ``install`` (how to install a missing package, or ""), ``description``.
    """
    out = []
    for name in robot_names():
        try:
            cfg = load_robot_config(ROBOTS_DIR / name / "robot.toml")
        except RobotConfigError as exc:
            log.warning("skipping robot %s: %s", name, exc)
            continue
        m = cfg.model
        if m.source == "package":
            source = f"package {m.package or m.distribution}"
        else:
            source = f"user --urdf {m.urdf}"
        available = package_available(cfg)
        out.append({"name": cfg.name, "dof": cfg.dof, "licence": cfg.licence, "source": source,
                    "available": available,
                    "install": "" if available or m.source == "user" else m.install,
                    "description": cfg.description})
    return out

"""Humanoid robot models for imesh: configuration files, reduced pinocchio models, collision
proxies and soles.

Robots live in ``robots/<name>/`` (``robot.toml`` + ``markers.toml``); models come from installed
packages (JVRC-1: jvrc-description; Unitree G1: example-robot-data,
``pip install imesh-retarget[g1]``) or from a URDF the user passes (HRP-4C). Only this
subpackage imports pinocchio, lazily.

Example:
    >>> robot = load_robot("jvrc1")
    >>> q = robot.q_nominal
    >>> robot.frame_positions(q, [robot.frame_id("L_KNEE_S")])
"""

from .build import resolve_urdf
from .collision import CollisionShape, fit_primitive
from .config import ROBOTS_DIR, RobotConfig, SoleRectangle, load_robot_config
from .errors import RobotConfigError
from .markers_config import AddedMarker, Direction, Keypoint, MarkerConfig, load_markers_config
from .model import Robot, load_robot
from .registry import list_robots, resolve_robot_toml, robot_names

__all__ = [
    "ROBOTS_DIR",
    "AddedMarker",
    "CollisionShape",
    "Direction",
    "Keypoint",
    "MarkerConfig",
    "Robot",
    "RobotConfig",
    "RobotConfigError",
    "SoleRectangle",
    "fit_primitive",
    "list_robots",
    "load_markers_config",
    "load_robot",
    "load_robot_config",
    "resolve_robot_toml",
    "resolve_urdf",
    "robot_names",
]

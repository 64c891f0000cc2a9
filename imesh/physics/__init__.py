"""The DART dynamics check: does the robot keep its balance while tracking a motion?

Example:
    >>> from imesh.physics import PhysicsConfig, simulate_motion
    >>> result = simulate_motion(robot, motion, config=PhysicsConfig())
    >>> result.metrics()     # physics_fell, physics_survived_s, tracking_rms_rad, torque_ratio_max
    >>> from imesh.viz.physics import plot_physics
    >>> plot_physics(result, "run.png")      # its figure

Every dartpy call of imesh lives in this package; dartpy is imported when a world is built, so
``import imesh.physics`` works without it (``simulate_motion`` then says ``pip install dartpy``).
See ``docs/checking.md``.
"""

from .config import ControlConfig, FallConfig, GroundConfig, PhysicsConfig, TimingConfig
from .result import PHYSICS_METRICS, PhysicsResult
from .simulate import feedforward, simulate_motion
from .world import DartRobot, PhysicsError

__all__ = [
    "PHYSICS_METRICS", "ControlConfig", "DartRobot", "FallConfig", "GroundConfig", "PhysicsConfig",
    "PhysicsError", "PhysicsResult", "TimingConfig", "feedforward", "simulate_motion",
]

"""Quality metrics of adapted motions and robot motions (names as in DESIGN.md).

- :mod:`imesh.metrics.markers`: ``close_pair_error``, ``marker_rms_mm`` (marker level) and the
  robot's key points as a marker motion.
- :mod:`imesh.metrics.derivatives`: velocities and accelerations of a robot motion (pinocchio
  convention, central differences).
- :mod:`imesh.metrics.soles`: the soles' corners and centres over a motion.
- :mod:`imesh.metrics.support`: support phases of a robot motion from its soles.
- :mod:`imesh.metrics.polygon`: the support polygon and its 2-D geometry.
- :mod:`imesh.metrics.zmp`: the multibody ZMP against the support polygon and the desired ZMP.
- :mod:`imesh.metrics.skid`: foot skid and sole deviation of the support feet.
- :mod:`imesh.metrics.limits`: joint position, velocity and acceleration limit violations.
- :mod:`imesh.metrics.collision`: self-collision on the URDF's own geometry (coal;
  ``self_collision_frames``), with the capsules the whole-body solve keeps apart as its broad
  phase and reported beside it (docs/collision.md); ground penetration / floating.

:func:`imesh.evaluate.evaluate_motion` computes all of them for one robot motion.
"""

from .collision import (
    SELF_COLLISION_DEPTH_M,
    GroundReport,
    SelfCollisionReport,
    SelfCollisions,
    check_capsule_collisions,
    check_ground,
    check_self_collisions,
)
from .derivatives import motion_derivatives
from .limits import limit_violations
from .markers import (
    CLOSE_PAIR_FRACTION,
    close_pair_error,
    keypoint_motion,
    marker_rms_by_name_mm,
    marker_rms_mm,
    non_adjacent_pairs,
)
from .skid import foot_skid
from .soles import sole_tracks
from .support import SupportDetection, detect_support
from .zmp import desired_zmp, zmp_report, zmp_trajectory

__all__ = [
    "CLOSE_PAIR_FRACTION", "SELF_COLLISION_DEPTH_M", "GroundReport", "SelfCollisionReport",
    "SelfCollisions", "SupportDetection", "check_capsule_collisions", "check_ground",
    "check_self_collisions",
    "close_pair_error", "desired_zmp", "detect_support", "foot_skid", "keypoint_motion",
    "limit_violations", "marker_rms_by_name_mm", "marker_rms_mm", "motion_derivatives",
    "non_adjacent_pairs", "sole_tracks", "zmp_report", "zmp_trajectory",
]

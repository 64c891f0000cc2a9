"""Quality metrics of adapted motions and robot motions (names as in DESIGN.md).

- :mod:`imesh.metrics.markers`: ``close_pair_error``, ``marker_rms_mm`` (marker level) and the
  robot's key points as a marker motion.
- :mod:`imesh.metrics.kinematics`: support phases of a robot motion from its soles, the
  multibody ZMP against the support polygon and the desired ZMP, foot skid, joint limits.
- :mod:`imesh.metrics.collision`: self-collision on the capsules the whole-body solve keeps
  apart (``self_collision_frames``; docs/collision.md), on the URDF's own geometry (coal) and
  on the primitive proxies (python-fcl), ground penetration / floating.

:func:`imesh.evaluate.evaluate_motion` computes all of them for one robot motion.
"""

from .collision import (
    SELF_COLLISION_DEPTH_M,
    GroundReport,
    SelfCollisionChecker,
    SelfCollisionReport,
    check_capsule_collisions,
    check_ground,
    check_mesh_collisions,
    check_self_collisions,
)
from .kinematics import (
    SupportDetection,
    desired_zmp,
    detect_support,
    foot_skid,
    limit_violations,
    motion_derivatives,
    sole_tracks,
    zmp_report,
    zmp_trajectory,
)
from .markers import (
    CLOSE_PAIR_FRACTION,
    close_pair_error,
    keypoint_motion,
    marker_rms_mm,
    non_adjacent_pairs,
)

__all__ = [
    "CLOSE_PAIR_FRACTION", "SELF_COLLISION_DEPTH_M", "GroundReport", "SelfCollisionChecker",
    "SelfCollisionReport", "SupportDetection", "check_capsule_collisions", "check_ground",
    "check_mesh_collisions", "check_self_collisions",
    "close_pair_error", "desired_zmp", "detect_support", "foot_skid", "keypoint_motion",
    "limit_violations", "marker_rms_mm", "motion_derivatives", "non_adjacent_pairs",
    "sole_tracks", "zmp_report", "zmp_trajectory",
]

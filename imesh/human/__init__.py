"""The human body behind a motion file: recognition of its skeleton (no name tables) and the
errors of that reading."""

from .errors import RigRecognitionError, UnitsError
from .rig import RECOGNIZED, Arm, Leg, Recognition, recognize, recognize_motion, skeleton_tree

__all__ = ["RECOGNIZED", "Arm", "Leg", "Recognition", "RigRecognitionError", "UnitsError",
           "recognize", "recognize_motion", "skeleton_tree"]

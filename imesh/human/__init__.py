"""The human body behind a motion file, as the 21 standard markers, arranged for a robot.

    markerset    the standard markers, the standard skeleton, the --scale bone groups
    rig          recognition of a skeleton's body parts, whatever its joint names: the five
                 steps, over rig_tree (the joint tree), rig_parts (the part finders),
                 rig_geometry (units, up axis, sides) and rig_result (Recognition)
    rig_tables   marker-set protocols (TOML tables) told by their marker names
    standard     any clip onto the standard markers (recognition or a table)
    gaps         gap filling of marker trajectories
    filtering    zero-phase low-pass of marker trajectories
    arrange      the marker model arranged for a robot (Nakaoka & Komura 2012, sec. IV-A)
"""

from .errors import RigRecognitionError, UnitsError
from .rig import recognize, recognize_motion
from .rig_result import RECOGNIZED, Arm, Leg, Recognition
from .rig_tree import skeleton_tree

__all__ = ["RECOGNIZED", "Arm", "Leg", "Recognition", "RigRecognitionError", "UnitsError",
           "recognize", "recognize_motion", "skeleton_tree"]

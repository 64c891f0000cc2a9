"""The standard human marker set: 21 joint centres, the standard skeleton over them and the
bone groups of ``--scale``. Every clip is mapped onto it (:mod:`imesh.human.standard`).
"""

from __future__ import annotations

import numpy as np

#: The 21 standard human markers (joint centres), in this order.
STANDARD_MARKERS: tuple[str, ...] = (
    "pelvis", "hip_l", "hip_r", "knee_l", "knee_r", "ankle_l", "ankle_r", "toe_l", "toe_r",
    "spine", "chest", "neck", "head", "shoulder_l", "shoulder_r", "elbow_l", "elbow_r",
    "wrist_l", "wrist_r", "hand_l", "hand_r",
)

#: The standard skeleton as (parent, child) name pairs: a tree rooted at the pelvis.
STANDARD_BONE_NAMES: tuple[tuple[str, str], ...] = (
    ("pelvis", "hip_l"), ("hip_l", "knee_l"), ("knee_l", "ankle_l"), ("ankle_l", "toe_l"),
    ("pelvis", "hip_r"), ("hip_r", "knee_r"), ("knee_r", "ankle_r"), ("ankle_r", "toe_r"),
    ("pelvis", "spine"), ("spine", "chest"), ("chest", "neck"), ("neck", "head"),
    ("chest", "shoulder_l"), ("shoulder_l", "elbow_l"), ("elbow_l", "wrist_l"),
    ("wrist_l", "hand_l"),
    ("chest", "shoulder_r"), ("shoulder_r", "elbow_r"), ("elbow_r", "wrist_r"),
    ("wrist_r", "hand_r"),
)
STANDARD_BONES: np.ndarray = np.array(
    [[STANDARD_MARKERS.index(a), STANDARD_MARKERS.index(b)] for a, b in STANDARD_BONE_NAMES],
    dtype=np.int64,
)

#: Bone groups for ``--scale GROUP=FACTOR`` (child marker names of the standard bones).
BONE_GROUPS: dict[str, tuple[str, ...]] = {
    "arms": ("elbow_l", "wrist_l", "hand_l", "elbow_r", "wrist_r", "hand_r"),
    "forearms": ("wrist_l", "wrist_r"),
    "legs": ("knee_l", "ankle_l", "knee_r", "ankle_r"),
    "spine": ("spine", "chest", "neck"),
    "all": tuple(b for _, b in STANDARD_BONE_NAMES),
}

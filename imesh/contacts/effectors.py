"""Hands and knees on prop tops: the person's contacts that carry weight besides the soles.

A person climbing a box pulls up on its top by the hands and kneels on it; the soles are not
the only contacts that carry the body (docs/terrain.md). An effector marker (hand, knee) is on
a prop's top at a frame when it is over the top (the point ``(x, y, top - 1 mm)`` inside the
prop, as :mod:`imesh.scene.surfaces` judges a foot) and its height above the top is at most
:data:`SUPPORT_REACH_M` for that marker (joint centres, at the person's scale) times the
scene's scale. Runs shorter than ``min_s`` are dropped (a hand brushing past a top carries
nothing).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..metrics.props import HUMAN_CONTACT_M, signed_distance
from ..scene.scene import Scene
from ..scene.surfaces import TOP_INSET_M, scene_planes
from .phases import runs

log = logging.getLogger(__name__)

#: The effector markers that can carry weight on a top besides the feet.
EFFECTOR_MARKERS = ("hand_l", "hand_r", "knee_l", "knee_r")
#: Height of an effector's joint centre above a top at which it rests on it [m, person's
#: scale]: the hands as the evaluator counts them (6 cm); the knees at the MANIFEST's 15 cm,
#: not the evaluator's 10 cm: a kneeling knee's joint centre sits above the kneecap and the
#: shin (holosoma seq_1, source frames 536-728, the right knee 12-14 cm above box1's top while
#: the feet hang: with 10 cm the hanging frames had the hands alone, and no pose of the body
#: under two hands is in their wrench cone).
SUPPORT_REACH_M = {"hand_l": HUMAN_CONTACT_M["hand_l"], "hand_r": HUMAN_CONTACT_M["hand_r"],
                   "knee_l": 0.15, "knee_r": 0.15}


@dataclass(frozen=True, eq=False)
class EffectorContacts:
    """Effector markers on prop tops.

    Attributes:
        effectors: (E,) marker names.
        prop: (T, E) int index of the prop whose top the marker is on, -1 where none.
        top_m: (T, E) [m] that top's height (NaN where none).
        fps: frame rate [1/s].
    """

    effectors: tuple[str, ...]
    prop: np.ndarray
    top_m: np.ndarray
    fps: float

    @property
    def contact(self) -> np.ndarray:
        """(T, E) bool the marker is on a top."""
        return self.prop >= 0

    def padded(self, before: int, after: int) -> EffectorContacts:
        """The contacts with ``before`` and ``after`` frames without contact around them (the
        solve's lead-in and lead-out)."""
        pad = ((before, after), (0, 0))
        return EffectorContacts(self.effectors, np.pad(self.prop, pad, constant_values=-1),
                                np.pad(self.top_m, pad, constant_values=np.nan), self.fps)


def detect_effector_contacts(motion: MarkerMotion, scene: Scene, min_s: float = 0.1
                             ) -> EffectorContacts:
    """The frames each effector marker of ``motion`` is on a top of ``scene`` (both in the
    robot's world; see the module docstring).

    Args:
        motion: the arranged markers (the person at the robot's scale).
        scene: the props in the same world (``scene.scale`` maps the person's thresholds).
        min_s: shortest contact kept [s].
    """
    planes = scene_planes(scene)
    effectors = tuple(e for e in EFFECTOR_MARKERS if e in motion.names)
    T = motion.n_frames
    prop = np.full((T, len(effectors)), -1)
    top = np.full((T, len(effectors)), np.nan)
    shortest = max(1, int(round(min_s * motion.fps)))
    for i, e in enumerate(effectors):
        p = motion.positions_m[:, motion.index(e)]
        reach = SUPPORT_REACH_M[e] * scene.scale
        for k, (pr, pl) in enumerate(zip(scene.props, planes, strict=True)):
            probe = p.copy()
            probe[:, 2] = pr.top_m - TOP_INSET_M
            height = p[:, 2] - pr.top_m
            on = (signed_distance(probe, pl) <= 0.0) & (height <= reach) & (height >= -reach)
            higher = on & ~(top[:, i] > pr.top_m)  # the highest top wins
            prop[higher, i] = k
            top[higher, i] = pr.top_m
        for a, b in runs(prop[:, i] >= 0):
            if b - a < shortest:
                prop[a:b, i] = -1
                top[a:b, i] = np.nan
    found = EffectorContacts(effectors, prop, top, motion.fps)
    log.info("scene: effectors on prop tops (frames): %s", ", ".join(
        f"{e} {int(found.contact[:, i].sum())}" for i, e in enumerate(effectors)))
    return found


def effector_targets(motion: MarkerMotion, contacts: EffectorContacts, weight: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Soft morph targets that hold each effector marker still on its top while it rests there:
    at every frame of a contact run, the marker's median position over the run, no lower than
    the top (as the support feet's horizontal pins, :func:`imesh.contacts.support.
    support_foot_targets`, keep a planted foot from skating).

    Without them the morph (bone lengths scaled to the robot, the feet pinned on their tops)
    moved the hands of holosoma seq_1 0.1-0.3 m down into box1 while the person's rest on its
    top, and the fit followed: the whole-body solve started with its held points that far off.

    Args:
        motion: the arranged markers; contacts: their effectors on tops (same frames).
        weight: the targets' weight (``SupportConfig.horizontal_weight``).

    Returns:
        (soft (T, M, 3) targets, NaN where free; weights (T, M)).
    """
    soft = np.full(motion.positions_m.shape, np.nan)
    weights = np.zeros(motion.positions_m.shape[:2])
    for i, e in enumerate(contacts.effectors):
        m = motion.index(e)
        for a, b in runs(contacts.contact[:, i]):
            target = np.median(motion.positions_m[a:b, m], axis=0)
            target[2] = max(target[2], float(contacts.top_m[a, i]))
            soft[a:b, m] = target
            weights[a:b, m] = weight
    return soft, weights

"""Foot contacts on any surface: the floor and the tops of a scene's props (docs/terrain.md).

The contact detection (:func:`imesh.contacts.phases.detect_contacts`) and the morph's support
targets (:func:`imesh.contacts.support.support_foot_targets`) measure a foot's height from the
floor. With props, each foot's markers are first lowered by the height of the surface under the
foot (:func:`foot_surface_heights`), so a foot standing on a box top reads as a foot standing on
the floor, within the same threshold; the support phases found there carry their surface's
height (:func:`phase_heights`), which the support targets and the footprints add back.
"""

from __future__ import annotations

import logging

import numpy as np

from ..core.motion import MarkerMotion
from ..scene.scene import Scene
from ..scene.surfaces import scene_planes, surface_heights
from .phases import FOOT_MARKERS, SIDES, ContactConfig, Contacts, runs

log = logging.getLogger(__name__)


def foot_surface_heights(motion: MarkerMotion, scene: Scene,
                         config: ContactConfig | None = None) -> np.ndarray:
    """(T, 2) [m] [left, right] height of the surface under each foot at every frame: the
    higher of the surfaces under its toe and ankle markers
    (:func:`imesh.scene.surfaces.surface_heights`, a marker at most the detection's height
    threshold, ``height_fraction`` times the body height, below a top being on it)."""
    config = config or ContactConfig()
    below = config.height_fraction * motion.height_m
    planes = scene_planes(scene)
    out = np.zeros((motion.n_frames, 2))
    for k, side in enumerate(SIDES):
        idx = [motion.index(m) for m in FOOT_MARKERS[side]]
        out[:, k] = surface_heights(scene, motion.positions_m[:, idx], below, planes).max(axis=1)
    return out


def lowered_feet(motion: MarkerMotion, heights_m: np.ndarray) -> MarkerMotion:
    """The motion with each foot's markers (toe, ankle) lowered by ``heights_m`` (T, 2) [m]:
    their heights above the surface under them."""
    pos = motion.positions_m.copy()
    for k, side in enumerate(SIDES):
        for m in FOOT_MARKERS[side]:
            pos[:, motion.index(m), 2] -= heights_m[:, k]
    return motion.with_positions(pos)


def phase_heights(support: np.ndarray, heights_m: np.ndarray) -> np.ndarray:
    """(T, 2) [m] one surface height per support phase of each foot (the median of
    ``heights_m`` over it), held into the swings around it up to their middle (where the
    support targets ramp in and out: they stand on the phase's surface); a foot that never
    supports reads the floor."""
    T = len(support)
    out = np.zeros((T, 2))
    for k in range(2):
        phases = runs(support[:, k])
        if not phases:
            continue
        level = [float(np.median(heights_m[a:b, k])) for a, b in phases]
        bounds = [0] + [(phases[i][1] + phases[i + 1][0]) // 2 for i in range(len(phases) - 1)]
        bounds.append(T)
        for i, h in enumerate(level):
            out[bounds[i]:bounds[i + 1], k] = h
    return out


def split_at_surface_changes(contacts: Contacts, heights_m: np.ndarray, gap_s: float = 0.1,
                             step_m: float = 0.01) -> Contacts:
    """The contacts with every support run cut where its foot's surface changes height by more
    than ``step_m`` [m] between two frames (``heights_m`` (T, 2), :func:`foot_surface_heights`):
    ``gap_s`` [s] either side of the change become swing.

    On lowered feet (:func:`lowered_feet`) a foot carried from one top to a higher one in a few
    frames reads as a foot that never left the ground; one support phase over two surfaces
    would pin it to one height (seq_1 of the holosoma climbs: the left foot from box2 onto
    box1, pinned to box2's top, pulled the morphed body 0.6 m down into box1).
    """
    support = contacts.support.copy()
    n = max(1, int(round(gap_s * contacts.fps)))
    for k in range(2):
        for t in np.flatnonzero(np.abs(np.diff(heights_m[:, k])) > step_m) + 1:
            support[max(t - n, 0):t + n, k] = False
    return contacts.within(support)


def drop_hanging(contacts: Contacts, lowered: MarkerMotion, above_m: float) -> Contacts:
    """The contacts without the support frames in which the foot is more than ``above_m`` [m]
    above the surface under it (``lowered``: :func:`lowered_feet`; the lower of its toe and
    ankle markers, each above its own 5th percentile over the clip, as the detection measures
    a lift).

    The detection gives a frame with no foot on the ground and no free fall to the lower foot
    (:func:`imesh.contacts.phases.detect_contacts`); on a climb those are the frames in which
    the person hangs on the hands (holosoma seq_1: both toes 0.5 m above box2's top, against
    box1's side), and a foot pinned to the surface under it pulls the morphed body down into
    the box (0.6 m). Without it the frames are planned as flight (nothing in the model carries
    the hands' load).
    """
    lift = np.stack([np.min([lowered.positions_m[:, lowered.index(m), 2]
                             - np.percentile(lowered.positions_m[:, lowered.index(m), 2], 5)
                             for m in FOOT_MARKERS[side]], axis=0) for side in SIDES], axis=1)
    keep = contacts.support & ~(lift > above_m)
    dropped = int((contacts.support & ~keep).sum())
    if dropped:
        log.info("scene: %d support frames more than %.0f mm above any surface dropped (the "
                 "person hangs on the hands there)", dropped, 1e3 * above_m)
    return contacts.within(keep)

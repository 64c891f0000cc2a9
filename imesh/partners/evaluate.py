"""Scoring a retargeted pair (docs/partners.md).

* every single-robot metric of each robot (:func:`imesh.evaluate.scoreboard.evaluate_motion`);
* ``inter_close_pair_error``: ``close_pair_error`` (DESIGN.md) over the pairs of markers from
  different people closer than 15 % of the body height in the source: for every clip frame t
  and such pair (i of a, j of b), ``|d'_ij / H' - d_ij / H|`` with d the people's distance and
  d' the robots' key points' (both people's markers in one motion, H and H' its height: the
  vertical extent of both bodies), averaged;
* ``robot_penetration_mm``: the deepest penetration of a capsule of one robot into a capsule
  of the other over all output frames, and the frames deeper than 5 mm; the held hands'
  capsules around a hold are a contact, not counted (:func:`~.holds.held_pairs`);
* ``hold_error_mm``: in the source's hand holds (:mod:`.holds`), ``| |X_a - X_b| - s d_src |``
  of the held hands' key points against the source distance scaled by the shared scale s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..evaluate.scoreboard import evaluate_motion
from ..metrics.markers import CLOSE_PAIR_FRACTION, close_pair_error, keypoint_motion
from ..morph.adapt import PERSON_PREFIXES
from ..robot.capsules.obstacles import capsule_obstacle_distances, robot_obstacles
from .holds import held_pairs

#: A robot-robot penetration deeper than this [m] counts the frame (as self-collision).
PENETRATION_M = 0.005


@dataclass(frozen=True)
class PairMetrics:
    """The pair's scores (see the module docstring).

    Attributes:
        robot_a, robot_b: each robot's :func:`evaluate_motion` report.
        inter_close_pair_error: height fraction; inter_close_pairs: (frame, pair) samples.
        robot_penetration_mm: deepest robot-robot penetration [mm] (0: none);
        penetration_frames: frames deeper than 5 mm.
        hold_frames: held (frame, hand) samples; hold_error_max_mm, hold_error_mean_mm: the
            hand distance's error against the scaled source [mm] (NaN without holds);
        hold_within_30mm: fraction of held samples within 30 mm.
        robot_distance_m: (T,) [m] the robots' smallest capsule distance per output frame
            (+inf beyond the broad phase; the held hands excepted).
        hold_distance_m, hold_target_m: (N,) [m] the held hands' key-point distance and the
            scaled source distance of each held sample.
        deepest: the deepest robot-robot sample: output frame, robot a's capsule, robot b's
            capsule (None without penetration).
    """

    robot_a: dict
    robot_b: dict
    inter_close_pair_error: float
    inter_close_pairs: int
    robot_penetration_mm: float
    penetration_frames: int
    hold_frames: int
    hold_error_max_mm: float
    hold_error_mean_mm: float
    hold_within_30mm: float
    robot_distance_m: np.ndarray
    hold_distance_m: np.ndarray
    hold_target_m: np.ndarray
    deepest: tuple | None = None

    def summary(self) -> dict:
        """The pair's own figures (without the per-robot reports and per-frame arrays)."""
        return {k: v for k, v in self.__dict__.items()
                if not isinstance(v, (dict, np.ndarray)) and k != "deepest"} | {
                    "deepest": None if self.deepest is None else list(self.deepest)}


def _both(a: MarkerMotion, b: MarkerMotion, names: list[str]) -> MarkerMotion:
    return a.subset(names).concat_markers(b.subset(names), *PERSON_PREFIXES)


def inter_person_pairs(n: int) -> np.ndarray:
    """(n^2, 2) every pair (i of person a, j of person b) of a two-person motion of n markers
    each (a's first)."""
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return np.stack([i.ravel(), n + j.ravel()], axis=1)


def evaluate_pair(result, source_a=None, source_b=None,
                  reports: tuple[dict, dict] | None = None, release_s: float = 0.2
                  ) -> PairMetrics:
    """Score a :class:`~imesh.partners.pair.PairResult` (see the module docstring).

    Args:
        result: the pair's result.
        source_a, source_b: the raw clips for each robot's ``close_pair_error`` (None: null).
        reports: each robot's :func:`evaluate_motion` report already computed (the command
            line's verification), or None (computed here).
        release_s: the held hands' capsules touching within this of a hold [s] are a contact,
            not a penetration (:func:`~imesh.partners.holds.held_pairs`).
    """
    return evaluate_pair_motions(
        result.robot_a, result.a.motion, result.robot_b, result.b.motion, result.human_a,
        result.human_b, result.holds, result.world.scale, result.a.lead_frames[0],
        adapted=(result.a.adapted, result.b.adapted),
        seconds=(result.a.seconds, result.b.seconds), sources=(source_a, source_b),
        reports=reports, release_s=release_s)


def evaluate_pair_motions(robot_a, motion_a, robot_b, motion_b, human_a: MarkerMotion,
                          human_b: MarkerMotion, holds, scale: float, lead: int, *,
                          adapted=(None, None), seconds=(None, None), sources=(None, None),
                          reports: tuple[dict, dict] | None = None, release_s: float = 0.2
                          ) -> PairMetrics:
    """Score two robot motions of one pair (what :func:`evaluate_pair` and ``imesh evaluate
    --pair`` do).

    Args:
        robot_a, motion_a, robot_b, motion_b: the robots and their motions (same frames).
        human_a, human_b: the people's working markers (clip frames,
            :func:`imesh.pipeline.retarget.working_markers`).
        holds: the source's :class:`~imesh.partners.holds.Holds`.
        scale: the shared human-to-robot scale.
        lead: frames of lead-in before the clip's first frame in the motions.
        adapted, seconds, sources: per robot, for :func:`evaluate_motion`.
        reports, release_s: as :func:`evaluate_pair`.
    """
    if reports is None:
        rep_a, rep_b = (evaluate_motion(r, m, source=src, adapted=ad, seconds=sec)
                        for r, m, src, ad, sec in zip((robot_a, robot_b), (motion_a, motion_b),
                                                      sources, adapted, seconds, strict=True))
    else:
        rep_a, rep_b = reports
    T = human_a.n_frames
    clip = slice(lead, lead + T)
    names = [n for n in human_a.names
             if n in robot_a.markers.keypoints and n in robot_b.markers.keypoints]
    kp_a = keypoint_motion(robot_a, motion_a.q[clip], motion_a.fps, names=names)
    kp_b = keypoint_motion(robot_b, motion_b.q[clip], motion_b.fps, names=names)
    src = _both(human_a, human_b, names)
    out = _both(kp_a, kp_b, names)
    pairs = inter_person_pairs(len(names))
    d = np.linalg.norm(src.positions_m[:, pairs[:, 0]] - src.positions_m[:, pairs[:, 1]], axis=2)
    n_close = int((d < CLOSE_PAIR_FRACTION * src.height_m).sum())
    cpe = close_pair_error(src, out, pairs=pairs)
    # robot-robot penetration over every output frame (lead-in and lead-out too)
    # (robot b's capsules against robot a's, as in b's solve; the held hands excepted)
    obs = robot_obstacles(robot_a, motion_a.q)
    if len(holds):
        obs = dataclasses.replace(obs, ignored=held_pairs(
            robot_a, robot_b, holds, len(motion_a.q), lead,
            int(round(release_s * motion_a.fps))))
    own = robot_obstacles(robot_b, motion_b.q)  # robot b's capsules over its motion
    tt, cc, oo, dist, _, _ = capsule_obstacle_distances(own.segments_m, own.radius_m, obs, 0.0)
    deepest = None
    if len(dist) and dist.min() < 0:
        k = int(np.argmin(dist))
        deepest = (int(tt[k]), robot_a.capsule_model().capsules[oo[k]].name,
                   robot_b.capsule_model().capsules[cc[k]].name)
    low = np.full(len(motion_a.q), np.inf)
    np.minimum.at(low, tt, dist)
    depth = np.maximum(-low, 0.0)
    # hand holds
    err = dist_h = np.zeros(len(holds))
    target_h = scale * holds.source_distance_m
    hands = sorted(set(holds.marker_a) | set(holds.marker_b))
    if len(holds):
        ha = keypoint_motion(robot_a, motion_a.q[clip], motion_a.fps, names=hands)
        hb = keypoint_motion(robot_b, motion_b.q[clip], motion_b.fps, names=hands)
        xa = ha.positions_m[holds.frames, [ha.index(m) for m in holds.marker_a]]
        xb = hb.positions_m[holds.frames, [hb.index(m) for m in holds.marker_b]]
        dist_h = np.linalg.norm(xa - xb, axis=1)
        err = np.abs(dist_h - target_h)
    return PairMetrics(
        robot_a=rep_a, robot_b=rep_b, inter_close_pair_error=cpe, inter_close_pairs=n_close,
        robot_penetration_mm=float(1e3 * depth.max(initial=0.0)),
        penetration_frames=int((depth > PENETRATION_M).sum()), hold_frames=len(holds),
        hold_error_max_mm=float(1e3 * err.max()) if len(err) else float("nan"),
        hold_error_mean_mm=float(1e3 * err.mean()) if len(err) else float("nan"),
        hold_within_30mm=float(np.mean(err <= 0.030)) if len(err) else float("nan"),
        robot_distance_m=low, hold_distance_m=dist_h, hold_target_m=target_h, deepest=deepest)

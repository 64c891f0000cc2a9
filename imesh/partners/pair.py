"""``retarget_pair``: two people, two robots (docs/partners.md).

Stages (each robot keeps the single-person pipeline of :mod:`imesh.pipeline.retarget`):

1. both clips' working markers (same frames and rate, else :class:`PartnerError` before any
   work), one world for both (:mod:`.world`), each person arranged for its robot with its own
   contacts and support-foot targets (:func:`~imesh.pipeline.retarget.prepare`);
2. one spacetime morph of both people (:mod:`.mesh`);
3. robot a's initial fit and whole-body solve on its part of the morph, as alone;
4. robot b's, with robot a's capsules over a's solved motion as moving obstacles
   (:mod:`imesh.robot.capsules.obstacles`: a penalty in its initial fit, rows sharing the
   self-collision slack in its whole-body solve) and its holding hands aimed at a's
   (:mod:`.holds`).

Why in sequence and not one SQP over both robots: the whole-body QP of one robot is banded per
frame (49 unknowns a frame, half-bandwidth 230 on the G1 walk, DESIGN.md) and its cost grows
with ``n bw^2``; both robots in one QP double the unknowns per frame and the bandwidth, about 8
times the cost per factorization, and the partner's rows are a small part of either's. In
sequence the first robot moves as it would alone and the second one, which sees the first's
final motion, does the avoiding and the meeting of hands.

With ``PairConfig.together`` off, the same two retargets run alone (each person in its own
mesh, no obstacles, no holds) in the same world: the baseline of the close-pair comparison.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import ImeshError, OptionError
from ..metrics.markers import keypoint_motion
from ..pipeline.retarget import (
    PlanContext,
    RetargetConfig,
    RetargetResult,
    prepare,
    solve_prepared,
    working_markers,
)
from ..robot.capsules.obstacles import Obstacles, robot_obstacles
from .holds import HAND_MARKERS, Holds, detect_holds, held_pairs, hold_targets
from .mesh import morph_together
from .world import SharedWorld, shared_world

log = logging.getLogger(__name__)


class PartnerError(ImeshError):
    """Two clips that cannot be retargeted as partners: different frame counts or rates, or a
    setting the pair does not support."""


@dataclass(frozen=True)
class PairConfig:
    """Settings of a partner retarget.

    Attributes:
        retarget: the settings of each robot's pipeline (:class:`RetargetConfig`; the
            whole-body solve is required: the pair's rows live in it).
        together: one interaction mesh for both people, robot-robot avoidance and hand holds;
            False: each person retargeted alone in the same world (the baseline).
        hold_distance_m: hands closer than this in the source hold [m] (10 cm).
        hold_weight: weight of the second robot's held-hand targets (a foot's is 10).
        avoid: the second robot keeps out of the first's capsules (with ``together``).
        release_s: the held hands' capsules may touch from this long before a hold to this
            long after it [s] (:func:`~imesh.partners.holds.held_pairs`).
    """

    retarget: RetargetConfig = field(default_factory=RetargetConfig)
    together: bool = True
    hold_distance_m: float = 0.10
    hold_weight: float = 10.0
    avoid: bool = True
    release_s: float = 0.2

    def __post_init__(self) -> None:
        if self.retarget.balance != "wholebody":
            raise OptionError("balance", self.retarget.balance,
                              "wholebody (a pair's avoidance and holds are rows of the "
                              "whole-body solve)")
        if not (np.isfinite(self.hold_distance_m) and self.hold_distance_m > 0):
            raise OptionError("hold_distance_m", self.hold_distance_m, "a positive distance")
        if not (np.isfinite(self.hold_weight) and self.hold_weight >= 0):
            raise OptionError("hold_weight", self.hold_weight, "a number >= 0")


@dataclass(frozen=True, eq=False)
class PairResult:
    """Both robots' results and what joined them.

    Attributes:
        a, b: each robot's :class:`RetargetResult` (output frames aligned: same lead-in).
        robot_a, robot_b: the robots.
        human_a, human_b: the people's working markers (standard markers, low-passed) the
            evaluation compares against (source positions, clip frames).
        world: the shared scale and fixed point.
        holds: the source's hand holds (clip frames).
        together: the config's ``together``.
        seconds: wall time per stage [s].
    """

    a: RetargetResult
    b: RetargetResult
    robot_a: object
    robot_b: object
    human_a: MarkerMotion
    human_b: MarkerMotion
    world: SharedWorld
    holds: Holds
    together: bool
    seconds: dict

    def report(self) -> dict:
        return {"a": self.a.report(), "b": self.b.report(), "scale": self.world.scale,
                "own_scales": list(self.world.own_scales),
                "centre_m": self.world.centre_m.tolist(), "together": self.together,
                "holds": self.holds.summary(), "seconds": self.seconds}


def check_partners(a: MarkerMotion, b: MarkerMotion) -> None:
    """Refuse two clips that are not one recording: frame counts and rates must match.

    Raises:
        PartnerError: naming both files, their frames and rates.
    """
    if a.n_frames != b.n_frames or abs(a.fps - b.fps) > 1e-6 * a.fps:
        raise PartnerError(
            f"partners {a.source or 'a'} ({a.n_frames} frames at {a.fps:g} fps) and "
            f"{b.source or 'b'} ({b.n_frames} frames at {b.fps:g} fps): two people of one "
            "recording need the same frame count and rate (trim or resample one to the other)")


def retarget_pair(motion_a: MarkerMotion, motion_b: MarkerMotion, robot_a, robot_b, *,
                  config: PairConfig | None = None) -> PairResult:
    """Retarget two people recorded together to two robots (see the module docstring).

    Args:
        motion_a, motion_b: the two people, loaded in one world frame (same frames and rate).
        robot_a, robot_b: their robots (may be one model).
        config: PairConfig.

    Raises:
        PartnerError: the clips differ in frames or rate (before any work).
        SolverError: a whole-body solve failed.
    """
    config = config or PairConfig()
    rc = config.retarget
    check_partners(motion_a, motion_b)
    t0 = time.perf_counter()
    human_a, human_b = working_markers(motion_a, rc), working_markers(motion_b, rc)
    world = shared_world(human_a, human_b, robot_a, robot_b)
    log.info("partners: one world at scale %.4f (own %.4f, %.4f)", world.scale,
             *world.own_scales)
    prep_a = prepare(motion_a, robot_a, rc, human=human_a, scale=world.scale,
                     centre_m=world.centre_m)
    prep_b = prepare(motion_b, robot_b, rc, human=human_b, scale=world.scale,
                     centre_m=world.centre_m)
    holds = detect_holds(human_a, human_b, config.hold_distance_m)
    seconds = {"prepare": time.perf_counter() - t0}
    morph_a = morph_b = None
    if config.together:
        t1 = time.perf_counter()
        morph_a, morph_b, joint = morph_together(prep_a, prep_b, rc.morph)
        seconds["morph"] = time.perf_counter() - t1
        log.info("partners: joint morph of %d markers, bone residual %.2e m",
                 joint.positions_m.shape[1], joint.bone_residual_m)
    t1 = time.perf_counter()
    hook_a = None
    if config.together and len(holds) and config.hold_weight > 0:
        def hook_a(plan, ctx: PlanContext):  # robot a's holding hands on their markers
            return hold_targets(plan, ctx.names, ctx.targets.kp_markers,
                                holds.frames + ctx.lead_frames, holds.marker_a, None,
                                config.hold_weight)
    res_a = solve_prepared(prep_a, motion_a, robot_a, rc, morph=morph_a, plan_hook=hook_a)
    seconds["a"] = time.perf_counter() - t1
    hook = obstacles = None
    if config.together:
        hook = _partner_hook(robot_a, res_a, holds, config)
        if config.avoid:
            obstacles = _partner_obstacles(robot_a, robot_b, res_a, holds, config)
    t1 = time.perf_counter()
    res_b = solve_prepared(prep_b, motion_b, robot_b, rc, morph=morph_b, plan_hook=hook,
                           obstacles=obstacles)
    seconds["b"] = time.perf_counter() - t1
    seconds["total"] = time.perf_counter() - t0
    return PairResult(a=res_a, b=res_b, robot_a=robot_a, robot_b=robot_b, human_a=human_a,
                      human_b=human_b, world=world, holds=holds, together=config.together,
                      seconds=seconds)


def _partner_obstacles(robot_a, robot_b, res_a: RetargetResult, holds: Holds,
                       config: PairConfig) -> Obstacles:
    """Robot a's capsules over its solved motion (output frames), the held hands' pairs
    ignored around each hold."""
    q_a = res_a.motion.q
    obstacles = robot_obstacles(robot_a, q_a)
    if len(holds):
        obstacles = dataclasses.replace(obstacles, ignored=held_pairs(
            robot_a, robot_b, holds, len(q_a), res_a.lead_frames[0],
            int(round(config.release_s * res_a.motion.fps))))
    return obstacles


def _partner_hook(robot_a, res_a: RetargetResult, holds: Holds, config: PairConfig):
    """The plan edit of robot b: robot a's hands as its hold targets."""
    q_a = res_a.motion.q
    hands_a = keypoint_motion(robot_a, q_a, res_a.motion.fps, names=HAND_MARKERS)

    def hook(plan, ctx: PlanContext):
        if len(plan.q_init) != len(q_a):
            raise PartnerError(f"partner robots' motions differ in frames ({len(q_a)} and "
                               f"{len(plan.q_init)}): both need the same lead-in and lead-out")
        if len(holds) and config.hold_weight > 0:
            t = holds.frames + ctx.lead_frames
            shifts = (hands_a.positions_m[t, [hands_a.index(m) for m in holds.marker_a]]
                      - res_a.adapted.positions_m[t, res_a.adapted.indices(holds.marker_a)])
            plan = hold_targets(plan, ctx.names, ctx.targets.kp_markers, t, holds.marker_b,
                                shifts, config.hold_weight)
        return plan

    return hook

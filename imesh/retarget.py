"""The main pipeline: human motion -> robot joint trajectories.

    standard markers -> arrangement for the robot (sec. IV-A) -> contacts (sec. V-A)
      -> support-foot constraints (sec. V-B) -> spacetime morph (sec. III)
      -> joint fitting with motor limits (sec. IV-B; Kim 2005) -> RobotMotion

Every stage is a public function of its own module; this one only wires them.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .adapt import prepare_markers
from .arrange import Arrangement, arrange_for_robot
from .contacts import FOOT_MARKERS, SIDES, ContactConfig, Contacts, detect_contacts
from .morph.problem import MorphConfig, build_morph_problem
from .morph.solver import MorphResult, MorphStepReport, solve_morph
from .motion import MarkerMotion
from .support import SupportConfig, support_foot_targets

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class RetargetConfig:
    """Settings of every stage.

    Attributes:
        morph: MorphConfig of the spacetime morph.
        contacts: ContactConfig of the support detection.
        support: SupportConfig; None disables the support-foot constraints.
        fit: an :class:`imesh.fit.FitConfig` (None: defaults).
    """

    morph: MorphConfig = field(default_factory=MorphConfig)
    contacts: ContactConfig = field(default_factory=ContactConfig)
    support: SupportConfig | None = field(default_factory=SupportConfig)
    fit: object | None = None


@dataclass(frozen=True, eq=False)
class RetargetResult:
    """Everything the pipeline produced, stage by stage.

    Attributes:
        motion: the robot motion (an :class:`imesh.robot_motion.RobotMotion`).
        arrangement: the arranged, scaled human markers and robot targets.
        adapted: the morphed markers (same names as ``arrangement.motion``).
        contacts: support phases of the source.
        morph: the spacetime solver's result.
        fit: the fitting result (residuals, limit counts).
        seconds: wall time per stage [s].
    """

    motion: object
    arrangement: Arrangement
    adapted: MarkerMotion
    contacts: Contacts
    morph: MorphResult
    fit: object
    seconds: dict

    def report(self) -> dict:
        fit_report = self.fit.report() if hasattr(self.fit, "report") else {}
        return {
            "robot": self.arrangement.motion.meta.get("robot"),
            "frames": self.adapted.n_frames,
            "fps": self.adapted.fps,
            "markers": list(self.adapted.names),
            "human_scale": self.arrangement.scale,
            "bone_residual_m": self.morph.bone_residual_m,
            "position_residual_m": self.morph.position_residual_m,
            "morph_steps": self.morph.morph_steps,
            "contacts": self.contacts.summary(),
            "fit": fit_report,
            "seconds": self.seconds,
        }


def foot_geometry(arrangement: Arrangement) -> tuple[dict[str, float], dict[str, float]]:
    """Robot heights of the foot key points (nominal pose, soles at z = 0) and toe-ankle
    lengths per side."""
    pts = arrangement.meta["robot_points_m"]
    names = arrangement.motion.names
    heights = {m: float(pts[names.index(m), 2]) for side in SIDES for m in FOOT_MARKERS[side]}
    lengths = {side: float(np.linalg.norm(pts[names.index(FOOT_MARKERS[side][0])]
                                          - pts[names.index(FOOT_MARKERS[side][1])]))
               for side in SIDES}
    return heights, lengths


def retarget(motion: MarkerMotion, robot, *, config: RetargetConfig | None = None,
             progress: Callable[[MorphStepReport], None] | None = None) -> RetargetResult:
    """Adapt a human motion to ``robot`` (an :class:`imesh.robot.Robot`).

    Args:
        motion: any loaded human motion.
        robot: the target robot.
        config: RetargetConfig.
        progress: called after every morph step.

    Returns:
        RetargetResult; ``result.motion`` is the RobotMotion.
    """
    from .fit import FitConfig, fit_motion  # the fitting stage needs the robot stack

    config = config or RetargetConfig()
    seconds: dict[str, float] = {}
    t0 = time.perf_counter()
    human = prepare_markers(motion)
    arrangement = arrange_for_robot(human, robot)
    source = arrangement.motion
    contacts = detect_contacts(source, config.contacts)
    hard = soft = soft_w = None
    if config.support is not None:
        heights, lengths = foot_geometry(arrangement)
        hard, soft, soft_w = support_foot_targets(source, contacts, heights, lengths,
                                                  config.support)
    seconds["prepare"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    problem = build_morph_problem(source, pairs=arrangement.pairs,
                                  target_lengths_m=arrangement.target_lengths_m,
                                  hard_positions_m=hard, soft_positions_m=soft,
                                  soft_weights=soft_w, config=config.morph)
    morph = solve_morph(problem, progress=progress)
    adapted = source.with_positions(morph.positions_m, source=f"adapted:{source.source}")
    seconds["morph"] = time.perf_counter() - t1

    t2 = time.perf_counter()
    fit = fit_motion(robot, adapted, keypoints=arrangement.keypoints,
                     directions=arrangement.directions,
                     config=config.fit if config.fit is not None else FitConfig())
    seconds["fit"] = time.perf_counter() - t2
    seconds["total"] = time.perf_counter() - t0
    log.info("retargeted %s to %s: %d frames in %.2f s", motion.source, robot.name,
             adapted.n_frames, seconds["total"])
    return RetargetResult(motion=fit.motion, arrangement=arrangement, adapted=adapted,
                          contacts=contacts, morph=morph, fit=fit, seconds=seconds)

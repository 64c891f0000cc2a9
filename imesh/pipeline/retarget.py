"""The main pipeline: human motion -> robot joint trajectories.

    standard markers (resampled to the working rate) -> arrangement for the robot (sec. IV-A)
      -> contacts (sec. V-A) -> support-foot constraints (sec. V-B) -> spacetime morph (sec. III)
      -> initial fit with motor limits (sec. IV-B; Kim 2005)
      -> whole-body spacetime solve with a standing lead-in/out (imesh.solve; default)
         or the paper's Nishiwaki waist loop (sec. V-C/D; ``balance="nishiwaki"``)
      -> RobotMotion

Every stage is a public function of its own module; this one only wires them.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass, field

import numpy as np

from .. import __version__
from ..arms.config import ArmsConfig
from ..arms.solve import refine_arms
from ..balance import BalanceConfig, balance_loop, check_flight
from ..balance.loop import BalanceResult
from ..contacts.effectors import EffectorContacts, detect_effector_contacts, effector_targets
from ..contacts.phases import (
    FOOT_MARKERS,
    SIDES,
    ContactConfig,
    Contacts,
    detect_contacts,
    runs,
)
from ..contacts.support import SupportConfig, flat_support, support_blend, support_foot_targets
from ..contacts.surfaces import (
    drop_hanging,
    foot_surface_heights,
    lowered_feet,
    phase_heights,
    split_at_surface_changes,
)
from ..core.motion import MarkerMotion
from ..core.progress import ProgressCallback, notify
from ..core.provenance import make_provenance
from ..core.robot_motion import RobotMotion
from ..errors import OptionError
from ..fit import FitConfig, FitResult, fit_motion
from ..fit.limits import joint_limits
from ..fit.targets import CompiledTargets, compile_targets
from ..human.arrange import Arrangement, arrange_for_robot, carry_on_trunk
from ..human.filtering import lowpass
from ..morph.adapt import prepare_markers
from ..morph.planes import standard_planes
from ..morph.problem import MorphConfig, MorphWeights, build_morph_problem
from ..morph.solver import MorphResult, MorphStepReport, solve_morph, window_layout
from ..robot.capsules.obstacles import Obstacles
from ..robot.markers_config import Direction
from ..scene.surfaces import scene_planes, surface_heights
from ..solve import (
    WholeBodyConfig,
    WindowOptions,
    add_lead,
    lead_feet,
    plan_whole_body,
    smooth_initializer,
    solve_whole_body,
    windows,
)
from ..solve.props import pad_planes
from ..solve.sqp import WholeBodySolution

log = logging.getLogger(__name__)


BALANCE_MODES = ("wholebody", "nishiwaki", "none")


@dataclass(frozen=True)
class RetargetConfig:
    """Settings of every stage.

    Attributes:
        fps: the working and output frame rate [1/s]: the human motion is resampled to it
            first (None keeps the source rate). 30 fps is the rate of the common retargeted
            humanoid datasets; the whole-body solve's cost grows with the frame count.
        morph: MorphConfig of the spacetime morph. A robot must move smoothly: the default
            acceleration weight is 10 (adapt_motion's is 1). On the CMU walk the morph with
            weight 1 triples the markers' accelerations (centroid p50 2.4 vs 0.74 m/s^2 in the
            source; 1.1 with weight 100); but 100 distorts the first frames (wave, frame 0
            key-point RMS 93 mm vs 32 mm with 10).
        contacts: ContactConfig of the support detection.
        support: SupportConfig; None disables the support-foot constraints of the morph.
        fit: an :class:`imesh.fit.FitConfig` of the initial fit (None: defaults).
        arms: an :class:`imesh.arms.ArmsConfig`: the initial fit's arm joints re-solved with
            the SQP of Kim, Kim & Oh 2005 (:func:`imesh.arms.solve.refine_arms`) before the
            balance stage; None: the DLS fit's arms.
        balance: ``"wholebody"`` (default: the whole-body spacetime solve, :mod:`imesh.solve`),
            ``"nishiwaki"`` (the paper's loop: the Nishiwaki waist correction fed back into the
            morph, :func:`imesh.balance.balance_loop`) or ``"none"`` (the initial fit).
        wholebody: WholeBodyConfig of the whole-body solve.
        nishiwaki: BalanceConfig of the Nishiwaki loop (``balance="nishiwaki"``).
        lead_s: standing lead-in and lead-out of the whole-body solve [s] (0: none).
        lead_land_s: a foot in the air at the clip's first frame that lands within this
            time [s] stands through the lead-in into its landing (the end of a swing) instead
            of a step out of the lead-in (:func:`imesh.solve.add_lead`); alike at the end.
        lead_swing_s: the swing of a foot that steps out of the lead-in into the clip's first
            frame (or into the lead-out) [s]. The robot stands on the other foot through the
            swing with the markers held at the clip's first frame, which a walk's first frame
            does not balance on one foot: the CMU veer's toe-off held the trunk of JVRC-1
            270 mm in front of its markers. At 0.5 s the veers of G1, JVRC-1 and HRP-4C read
            58.5, 87.4 and 88.6 mm (marker RMS), at 0.15 s (4 frames at 30 fps) 46.0, 71.6
            and 77.4 (docs/wholebody.md).
        allow_flight: ``balance="nishiwaki"`` only: accept flight phases (both feet up):
            those frames get no support and no ZMP constraint, and the result lists them.
            False: refuse them with FlightPhaseError before any work. The whole-body solve
            plans flight as physics has it (ballistic CoM, :mod:`imesh.solve.forces`) and
            ignores this.
        pelvis_weight: priority of the pelvis triangle (pelvis, hip_l, hip_r) and the base's
            lateral direction: the paper fits the waist 6-DOF from these first; a high weight
            keeps the feet from swinging the base when other targets disagree.
        foot_weight: priority of the toe/ankle key points and the foot-roll directions in the
            fit, relative to the markers.toml weights.
        lowpass_hz: cut-off of the zero-phase low-pass applied to the human markers first
            (``imesh.human.filtering``); None keeps them as recorded.
        windows: WindowOptions of a long whole-body solve (window length, overlap, worker
            processes).
    """

    fps: float | None = 30.0
    morph: MorphConfig = field(
        default_factory=lambda: MorphConfig(weights=MorphWeights(accel=10.0)))
    contacts: ContactConfig = field(default_factory=ContactConfig)
    support: SupportConfig | None = field(default_factory=SupportConfig)
    fit: FitConfig | None = None
    arms: ArmsConfig | None = None
    balance: str = "wholebody"
    wholebody: WholeBodyConfig = field(default_factory=WholeBodyConfig)
    nishiwaki: BalanceConfig | None = None
    lead_s: float = 1.0
    lead_land_s: float = 0.15
    lead_swing_s: float = 0.15
    allow_flight: bool = False
    lowpass_hz: float | None = 8.0
    foot_weight: float = 10.0
    pelvis_weight: float = 3.0
    windows: WindowOptions = field(default_factory=WindowOptions)

    def __post_init__(self) -> None:
        if self.balance not in BALANCE_MODES:
            raise OptionError("balance", self.balance, BALANCE_MODES)
        if self.fps is not None and not (np.isfinite(self.fps) and self.fps > 0):
            raise OptionError("fps", self.fps, "a positive number or None")
        if not (np.isfinite(self.lead_s) and self.lead_s >= 0):
            raise OptionError("lead_s", self.lead_s, "a number of seconds >= 0")
        if not (np.isfinite(self.lead_land_s) and self.lead_land_s >= 0):
            raise OptionError("lead_land_s", self.lead_land_s, "a number of seconds >= 0")
        if not (np.isfinite(self.lead_swing_s) and self.lead_swing_s > 0):
            raise OptionError("lead_swing_s", self.lead_swing_s, "a number of seconds > 0")
        if self.balance == "wholebody" and self.support is None:
            raise OptionError("support", None, "a SupportConfig: the whole-body solve plans "
                              "footprints from the support phases")


@dataclass(frozen=True, eq=False)
class RetargetResult:
    """Everything the pipeline produced, stage by stage.

    Attributes:
        motion: the robot motion (an :class:`imesh.core.robot_motion.RobotMotion`), including the
            standing lead-in/out frames of the whole-body solve.
        arrangement: the arranged, scaled human markers and robot targets.
        adapted: the morphed markers, frame-aligned with ``motion`` (the lead-in/out frames
            hold the first/last frame): the targets ``marker_rms_mm`` is measured against.
        contacts: support phases of the source (footfalls, flight phases).
        support: the robot's planned support, frame-aligned with ``motion``.
        morph: the spacetime solver's result.
        fit: the initial fit (residuals, limit counts).
        wholebody: the whole-body solve (:class:`imesh.solve.WholeBodySolution`), or None.
        balance: the Nishiwaki loop's result (``balance="nishiwaki"``), or None.
        lead_frames: (lead-in, lead-out) frames added before and after the clip.
        unconstrained_frames: flight frames left without support or ZMP constraint and
            without a model of the flight, as [start, stop) ranges of ``motion``'s frames
            (none: the whole-body solve plans every flight frame, ``flight_frames``).
        flight_frames: the planned flight phases of the whole-body solve (no support, the CoM
            ballistic: :mod:`imesh.solve.forces`), as [start, stop) ranges of ``motion``'s
            frames.
        seconds: wall time per stage [s].
        arms: the report of the arms' SQP in the initial fit (``config.arms``), or None.
    """

    motion: RobotMotion
    arrangement: Arrangement
    adapted: MarkerMotion
    contacts: Contacts
    support: Contacts
    morph: MorphResult
    fit: FitResult
    wholebody: WholeBodySolution | None
    balance: BalanceResult | None
    lead_frames: tuple[int, int]
    unconstrained_frames: list
    seconds: dict
    arms: dict | None = None
    flight_frames: list = field(default_factory=list)

    def report(self) -> dict:
        fit_report = self.fit.report() if hasattr(self.fit, "report") else {}
        return {
            "robot": self.arrangement.robot,
            "frames": self.adapted.n_frames,
            "fps": self.adapted.fps,
            "lead_frames": list(self.lead_frames),
            "unconstrained_frames": self.unconstrained_frames,
            "flight_frames": self.flight_frames,
            "markers": list(self.adapted.names),
            "human_scale": self.arrangement.scale,
            "bone_residual_m": self.morph.bone_residual_m,
            "position_residual_m": self.morph.position_residual_m,
            "morph_steps": self.morph.morph_steps,
            "contacts": self.contacts.summary(),
            "fit": fit_report,
            "wholebody": self.wholebody.report() if self.wholebody is not None else None,
            "balance": self.balance.report() if self.balance is not None else None,
            "fit_sqp": self.arms,
            "seconds": self.seconds,
        }


def foot_geometry(arrangement: Arrangement) -> tuple[dict[str, float], dict[str, float]]:
    """Robot heights of the foot key points (nominal pose, soles at z = 0) and toe-ankle
    lengths per side."""
    pts = arrangement.robot_points_m
    names = arrangement.motion.names
    heights = {m: float(pts[names.index(m), 2]) for side in SIDES for m in FOOT_MARKERS[side]}
    lengths = {side: float(np.linalg.norm(pts[names.index(FOOT_MARKERS[side][0])]
                                          - pts[names.index(FOOT_MARKERS[side][1])]))
               for side in SIDES}
    return heights, lengths


def orientation_targets(adapted: MarkerMotion, robot, arrangement: Arrangement,
                        weight: float = 1.0, flat: np.ndarray | None = None,
                        pelvis_weight: float | None = None) -> tuple[MarkerMotion, tuple]:
    """Virtual markers and key directions that fix each foot's roll and the base's roll/yaw.

    The toe and ankle markers fix a foot's position, yaw and pitch but not its roll about the
    toe-ankle line; left free, the fit rolls soles by tens of degrees. For each foot a virtual
    marker ``foot_up_<side>`` is placed 0.1 m from the ankle along the zero-roll "up" vector of
    the foot: perpendicular to ankle->toe and to a lateral axis, which is the world-horizontal
    one (``f x z``: the sole flat on the ground) where the foot is in support (``flat`` = 1),
    the pelvis's lateral axis in swing (``f x z`` flips when the foot points down at toe-off),
    and a blend of the two on the support ramps. A key
    direction asks the robot's matching sole axis (the sole normal made perpendicular to the
    robot's own ankle->toe vector) to point there. With the toe and ankle at their support
    heights this makes the sole flat on the ground.

    Args:
        adapted: the morphed markers.
        robot, arrangement: the robot and the arrangement the markers come from.
        weight: weight of the foot-roll directions.
        flat: (T, 2) [left, right] support blend in [0, 1]
            (:func:`imesh.contacts.support.support_blend`); None: pelvis-based everywhere.
        pelvis_weight: weight of the base's lateral direction (None: ``weight``).

    Returns:
        (markers with the virtual markers appended, the extra Direction targets).
    """
    names = list(adapted.names)
    pos = adapted.positions_m
    pts = arrangement.robot_points_m
    extra_pos, extra_names, directions = [], [], []
    # the foot's zero-roll lateral axis: the pelvis's right-pointing axis (hip_l -> hip_r) made
    # perpendicular to the foot; f x z would flip when the foot points straight down (toe-off)
    pelvis_right = pos[:, names.index("hip_r")] - pos[:, names.index("hip_l")]
    for side in SIDES:
        toe_name, ankle_name = FOOT_MARKERS[side]
        toe, ankle = names.index(toe_name), names.index(ankle_name)
        f = pos[:, toe] - pos[:, ankle]
        f /= np.linalg.norm(f, axis=1, keepdims=True)
        lateral = pelvis_right - np.sum(pelvis_right * f, axis=1, keepdims=True) * f
        lateral /= np.maximum(np.linalg.norm(lateral, axis=1, keepdims=True), 1e-9)
        if flat is not None:
            k = SIDES.index(side)
            # right-pointing for a forward foot; left unnormalized (its length is the foot's
            # horizontal extent), so a foot pointing down on the ramps (toe-off) gets the
            # pelvis axis rather than an ill-defined f x z. Turned to the pelvis's side on the
            # ramps only (a foot pitched past its toe at toe-off points back); in full support
            # the sole lies flat and f x z is its own right-pointing axis, also where the foot
            # is turned more than 90 deg from the pelvis (a dancer's turned-out or pivoting
            # foot, whose sole-up target would otherwise point down)
            level = np.cross(f, [0.0, 0.0, 1.0])
            level *= np.where((np.sum(level * lateral, axis=1, keepdims=True) < 0)
                              & (flat[:, k, None] < 1.0), -1.0, 1.0)
            lateral = flat[:, k, None] * level + (1.0 - flat[:, k, None]) * lateral
            lateral /= np.maximum(np.linalg.norm(lateral, axis=1, keepdims=True), 1e-9)
        up = np.cross(lateral, f)
        extra_pos.append(pos[:, ankle] + 0.1 * up)
        extra_names.append(f"foot_up_{side[0]}")
        sole = robot.soles[side]
        rot = robot.frame_rotations(robot.q_nominal, [robot.frame_id(sole.frame)])[0]
        d = rot.T @ (pts[toe] - pts[ankle])
        d /= np.linalg.norm(d)
        axis = sole.normal - (sole.normal @ d) * d
        directions.append(Direction(frame=sole.frame, axis=axis / np.linalg.norm(axis),
                                    from_marker=ankle_name, to_marker=extra_names[-1],
                                    weight=weight))
    # The base: its lateral axis along hip_r -> hip_l (the free-flyer's roll and yaw from the
    # pelvis, as the paper fits the waist 6-DOF first).
    if "hip_l" in names and "hip_r" in names:
        waist = robot.frame_id(robot.waist_frame)
        rot = robot.frame_rotations(robot.q_nominal, [waist])[0]
        lat = rot.T @ (pts[names.index("hip_l")] - pts[names.index("hip_r")])
        directions.append(Direction(frame=robot.waist_frame, axis=lat / np.linalg.norm(lat),
                                    from_marker="hip_r", to_marker="hip_l",
                                    weight=weight if pelvis_weight is None else pelvis_weight))
    markers = MarkerMotion(positions_m=np.concatenate([pos, np.stack(extra_pos, axis=1)], axis=1),
                           fps=adapted.fps, names=tuple(names + extra_names),
                           valid=np.ones((adapted.n_frames, len(names) + 2), dtype=bool),
                           bones=adapted.bones, source=adapted.source, meta=adapted.meta)
    return markers, tuple(directions)


def lead_heights(surface_m: np.ndarray, markers_m: np.ndarray, names: MarkerMotion, scene,
                 n_lead: int, planes: list[np.ndarray]) -> np.ndarray:
    """(T + 2 n_lead, 2) [m] support surface height of each foot over the clip with its lead-in
    and lead-out: the clip's ``surface_m`` (T, 2), and in the lead frames the highest prop top
    under the foot's toe and ankle markers (``markers_m`` (T + 2 n_lead, M, 3), named as
    ``names``), whatever their height (:func:`imesh.solve.add_lead` puts a foot down at z = 0
    under where the clip has it; on a prop, its footprint goes on the top); ``planes``: the
    props' (:func:`imesh.scene.surfaces.scene_planes`)."""
    out = np.pad(surface_m, ((n_lead, n_lead), (0, 0)), mode="edge")
    lead = np.r_[0:n_lead, len(out) - n_lead:len(out)]
    out[lead] = tops_under_feet(markers_m[lead], names, scene, planes)
    return out


def tops_under_feet(markers_m: np.ndarray, names: MarkerMotion, scene,
                    planes: list[np.ndarray]) -> np.ndarray:
    """(F, 2) [m] [left, right] the highest prop top under each foot's toe and ankle markers
    (``markers_m`` (F, M, 3), named as ``names``), whatever their height (0: none, the
    floor): where a foot the lead puts down stands."""
    out = np.zeros((len(markers_m), 2))
    for k, side in enumerate(SIDES):
        pts = markers_m[:, [names.index(m) for m in FOOT_MARKERS[side]]].copy()
        pts[..., 2] = np.inf
        out[:, k] = surface_heights(scene, pts, np.inf, planes).max(axis=1)
    return out


@dataclass(frozen=True, eq=False)
class Prepared:
    """One person's clip made ready for the morph: arranged for its robot, its support
    detected and its support-foot targets set (the stages before the spacetime morph).

    Attributes:
        arrangement: the arranged, scaled human markers (``arrangement.motion``: (T, M, 3) [m])
            and the robot targets.
        contacts: the detected support phases of the arranged markers.
        surface: (T, 2) [m] height of each foot's support surface (with a scene), or None.
        flat: the support of the robot's flat soles (:func:`imesh.contacts.support.flat_support`).
        hard, soft: (T, M, 3) [m] hard and soft support-foot targets of the morph (NaN where
            free), or None without ``RetargetConfig.support``; soft_w: (T, M) their weights
            (the soft targets also hold hands and knees resting on a prop's top).
        effectors: the hands and knees on prop tops (with a scene), or None.
    """

    arrangement: Arrangement
    contacts: Contacts
    surface: np.ndarray | None
    flat: Contacts
    hard: np.ndarray | None
    soft: np.ndarray | None
    soft_w: np.ndarray | None
    effectors: EffectorContacts | None = None

    @property
    def source(self) -> MarkerMotion:
        """The arranged markers the morph starts from."""
        return self.arrangement.motion


def working_markers(motion: MarkerMotion, config: RetargetConfig) -> MarkerMotion:
    """The standard markers of ``motion`` at the working rate (``config.fps``), low-passed
    (``config.lowpass_hz``): what is arranged for the robot."""
    human = prepare_markers(motion)
    if config.fps is not None and abs(human.fps - config.fps) > 1e-9:
        human = human.resample(config.fps)
    if config.lowpass_hz is not None:
        human = lowpass(human, config.lowpass_hz)
    return human


def prepare(motion: MarkerMotion, robot, config: RetargetConfig, scene=None, *,
            human: MarkerMotion | None = None, scale: float | None = None,
            centre_m: np.ndarray | None = None) -> Prepared:
    """The stages before the morph: arrangement for ``robot`` (sec. IV-A), contacts (sec.
    V-A), support-foot targets (sec. V-B).

    Args:
        motion: the loaded human motion.
        robot, config, scene: as :func:`retarget`.
        human: ``motion``'s :func:`working_markers` when the caller has them (None: made here).
        scale, centre_m: the arrangement's scale and fixed point
            (:func:`imesh.human.arrange.arrange_for_robot`; None: the robot's own).

    Raises:
        FlightPhaseError: ``balance="nishiwaki"`` and flight phases without ``allow_flight``.
    """
    if human is None:
        human = working_markers(motion, config)
    arrangement = arrange_for_robot(human, robot, scale=scale, centre_m=centre_m)
    source = arrangement.motion
    surface = None  # (T, 2) height of each foot's support surface, with a scene
    effectors = None  # hands and knees on prop tops, with a scene
    if scene is not None and scene.props:
        effectors = detect_effector_contacts(source, scene)
        raw = foot_surface_heights(source, scene, config.contacts)
        lowered = lowered_feet(source, raw)
        contacts = split_at_surface_changes(detect_contacts(lowered, config.contacts), raw)
        contacts = drop_hanging(contacts, lowered,
                                3 * config.contacts.height_fraction * source.height_m)
        surface = phase_heights(contacts.support, raw)
        log.info("scene: %d of %d support frames on a prop's top", int(
            (contacts.support & (surface > 1e-3)).sum()), int(contacts.support.sum()))
    else:
        contacts = detect_contacts(source, config.contacts)
    if config.balance == "nishiwaki":  # fail before the morph, not after it (the whole-body
        # solve plans flight: ballistic, imesh.solve.forces)
        check_flight(motion.source or "motion", contacts.support, source.fps,
                     BalanceConfig(allow_flight=config.allow_flight))
    hard = soft = soft_w = None
    flat = contacts
    if config.support is not None:
        on_floor = source if surface is None else lowered_feet(source, surface)
        flat = flat_support(on_floor, contacts, config.support)
        heights, lengths = foot_geometry(arrangement)
        hard, soft, soft_w = support_foot_targets(on_floor, flat, heights, lengths,
                                                  config.support)
        if surface is not None:  # the targets of a foot on a prop's top: on that top
            for k, side in enumerate(SIDES):
                for m in FOOT_MARKERS[side]:
                    hard[:, source.index(m), 2] += surface[:, k]
    if effectors is not None and effectors.contact.any():  # hands and knees still on the tops
        held, held_w = effector_targets(source, effectors,
                                        (config.support or SupportConfig()).horizontal_weight)
        on = held_w > 0
        soft = np.where(on[..., None], held, np.full(held.shape, np.nan) if soft is None else soft)
        soft_w = np.where(on, held_w, 0.0 if soft_w is None else soft_w)
    return Prepared(arrangement=arrangement, contacts=contacts, surface=surface, flat=flat,
                    hard=hard, soft=soft, soft_w=soft_w, effectors=effectors)


@dataclass(frozen=True)
class PlanContext:
    """What a ``plan_hook`` of :func:`solve_prepared` may need about the plan it edits.

    Attributes:
        names: the marker names of the plan's target markers (the adapted markers and the
            virtual foot markers); ``targets.kp_markers`` index them.
        targets: the compiled key-point and direction targets of the solve.
        lead_frames: frames of standing lead-in before the clip's first frame.
    """

    names: tuple[str, ...]
    targets: CompiledTargets
    lead_frames: int


def retarget(motion: MarkerMotion, robot, *, config: RetargetConfig | None = None,
             progress: ProgressCallback | None = None, scene=None) -> RetargetResult:
    """Adapt a human motion to ``robot`` (an :class:`imesh.robot.Robot`).

    Args:
        motion: any loaded human motion.
        robot: the target robot.
        config: RetargetConfig.
        progress: called with an :class:`imesh.core.progress.StageProgress` as each stage moves
            (prepare, every morph step, fit, plan, every whole-body iteration); the command
            line draws its bar from these (:class:`imesh.core.progress.JobBar`).
        scene: the props in the robot's world (:func:`imesh.scene.morph_frame.scene_for_clip`),
            or None (the floor only). With props, a foot standing on a prop's top is a support
            there (:mod:`imesh.contacts.surfaces`), its morph targets and footprint are at the
            top's height, and the whole-body solve keeps every link out of the props
            (:mod:`imesh.solve.props`; docs/terrain.md).

    Returns:
        RetargetResult; ``result.motion`` is the RobotMotion, with its provenance (the clip
        file and its hash when ``motion`` was read from one, the lead-in/out frames, the robot
        configuration's hash, the imesh version).

    Raises:
        FlightPhaseError: ``balance="nishiwaki"``, the clip has flight phases and
            ``allow_flight`` is off (before any solve).
        SolverError: the whole-body solve failed.
    """
    config = config or RetargetConfig()
    t0 = time.perf_counter()
    prepared = prepare(motion, robot, config, scene)
    return solve_prepared(prepared, motion, robot, config, progress=progress, scene=scene,
                          seconds={"prepare": time.perf_counter() - t0}, t0=t0)


def solve_prepared(prepared: Prepared, motion: MarkerMotion, robot, config: RetargetConfig, *,
                   progress: ProgressCallback | None = None, scene=None,
                   seconds: dict | None = None, t0: float | None = None,
                   morph: MorphResult | None = None, plan_hook=None,
                   obstacles: Obstacles | None = None) -> RetargetResult:
    """The stages from the morph on (:func:`retarget` after :func:`prepare`).

    Args:
        prepared: the person's :class:`Prepared` stages.
        motion, robot, config, progress, scene: as :func:`retarget`.
        seconds: wall times of the stages so far [s]; t0: ``time.perf_counter()`` at the start.
        morph: the person's markers already morphed (their part of a mesh shared with a
            partner, :mod:`imesh.partners`); None: morphed here alone.
        plan_hook: ``plan_hook(plan, PlanContext) -> Plan`` edits the whole-body plan before
            the solve (a partner's hand holds); None: none.
        obstacles: capsules moving over the output frames (the lead-in and lead-out
            included; a partner robot's, :mod:`imesh.partners`) that the initial fit and the
            whole-body solve keep the robot's capsules from; None: none.
    """
    seconds = dict(seconds or {})
    t0 = time.perf_counter() if t0 is None else t0
    arrangement, source, contacts = prepared.arrangement, prepared.source, prepared.contacts
    surface, flat = prepared.surface, prepared.flat
    hard, soft, soft_w = prepared.hard, prepared.soft, prepared.soft_w
    effectors = prepared.effectors
    nishiwaki = config.nishiwaki or BalanceConfig(error_lowpass_hz=1.5,
                                                  allow_flight=config.allow_flight)
    shared = [morph]  # the partners' morph, used by the first morph_and_fit only
    n_work = source.n_frames
    notify(progress, "prepare", 1, 1, n_work)
    # the morph reports every step of every window (its re-linearizations too): counted
    n_morph = config.morph.steps * len(window_layout(n_work, config.morph.window_frames,
                                                     config.morph.window_lookahead))
    morph_calls = [0]

    def morph_step(report: MorphStepReport) -> None:
        morph_calls[0] += 1
        notify(progress, "morph", min(morph_calls[0], n_morph), n_morph, n_work,
               f"step {report.step}, window {report.window + 1}")

    fit_config = config.fit if config.fit is not None else FitConfig()
    n_lead = int(round(config.lead_s * source.fps)) if config.balance == "wholebody" else 0
    # the fit's frames are the clip's: the output's without the lead-in and lead-out
    fit_obstacles = (None if obstacles is None
                     else obstacles.frames(n_lead, n_lead + n_work))
    blend = (support_blend(flat, config.support.ramp.duration_s) if config.support is not None
             else None)
    # Priorities (W_e of eq. 7) as in the paper's order of fitting: the waist from the pelvis
    # triangle, the feet (they carry the robot), then the rest; so the fit does not swing the
    # base or slide a sole to meet an upper-body marker it cannot reach.
    gain = {m: config.foot_weight for side in SIDES for m in FOOT_MARKERS[side]}
    gain.update({m: config.pelvis_weight for m in ("pelvis", "hip_l", "hip_r")})
    keypoints = {n: (dataclasses.replace(k, weight=k.weight * gain[n]) if n in gain else k)
                 for n, k in arrangement.keypoints.items()}

    def morph_and_fit(soft_m=soft, soft_wm=soft_w, q_init=None):
        t1 = time.perf_counter()
        if shared[0] is not None:
            morph, shared[0] = shared[0], None
        else:
            problem = build_morph_problem(source, pairs=arrangement.pairs,
                                          target_lengths_m=arrangement.target_lengths_m,
                                          hard_positions_m=hard, soft_positions_m=soft_m,
                                          soft_weights=soft_wm, config=config.morph,
                                          planes=standard_planes(source.names))
            morph = solve_morph(problem, progress=morph_step if progress is not None else None)
        adapted = source.with_positions(carry_on_trunk(morph.positions_m, arrangement),
                                        source=f"adapted:{source.source}")
        t2 = time.perf_counter()
        fit_markers, extra_dirs = orientation_targets(adapted, robot, arrangement,
                                                      weight=config.foot_weight, flat=blend,
                                                      pelvis_weight=config.pelvis_weight)
        fit = fit_motion(robot, fit_markers, keypoints=keypoints,
                         directions=arrangement.directions + extra_dirs, config=fit_config,
                         q_init=q_init, obstacles=fit_obstacles)
        seconds["morph"] = seconds.get("morph", 0.0) + t2 - t1
        seconds["fit"] = seconds.get("fit", 0.0) + time.perf_counter() - t2
        notify(progress, "fit", 1, 1, n_work)
        return morph, adapted, fit_markers, fit, arrangement.directions + extra_dirs

    morph, adapted, fit_markers, fit, directions = morph_and_fit()
    q_out = fit.motion.q
    arms_report = None
    if config.arms is not None:  # Kim 2005 for the arms, as part of the initial fit

        t2 = time.perf_counter()
        refined, arms_report = refine_arms(robot, fit.motion, adapted, config.arms)
        q_out = refined.q
        seconds["fit"] += time.perf_counter() - t2
    balance = solution = None
    lead = (0, 0)
    unconstrained: list = []
    flight: list = []
    support_out = flat
    if config.balance == "nishiwaki":
        t3 = time.perf_counter()
        pelvis = source.index("pelvis")
        shape = source.positions_m.shape
        base_soft = soft if soft is not None else np.full(shape, np.nan)
        base_w = soft_w if soft_w is not None else np.zeros(shape[:2])
        stages = [(morph, adapted, fit)]

        def step(waist_xy: np.ndarray) -> np.ndarray:
            # The corrected waist is a soft target of large weight rather than the paper's hard
            # constraint: with both feet pinned, a correction the legs cannot reach would make
            # the hard constraints inconsistent and the morph fail.
            s_m, w_m = base_soft.copy(), base_w.copy()
            s_m[:, pelvis, :2] = waist_xy
            w_m[:, pelvis] = nishiwaki.waist_weight
            m_, a_, _, f_, _ = morph_and_fit(s_m, w_m, q_init=stages[-1][2].motion)
            stages.append((m_, a_, f_))
            return f_.motion.q

        balance = balance_loop(robot, q_out, source.fps, flat.support,
                               adapted.positions_m[:, pelvis, :2], step, nishiwaki)
        morph, adapted, fit = stages[balance.best]
        q_out = balance.q
        seconds["balance"] = time.perf_counter() - t3
    elif config.balance == "wholebody":
        t3 = time.perf_counter()
        q_init = smooth_initializer(robot, q_out, source.fps, config.wholebody.initial_lowpass_hz)
        targets = compile_targets(robot, fit_markers.names, keypoints, directions,
                                  source=fit_markers.source or "motion")
        faces = None if surface is None else scene_planes(scene)
        # a foot the lead puts down over a prop's top stands on it, with its markers
        ends = (None if faces is None else tops_under_feet(
            fit_markers.positions_m[[0, -1]], fit_markers, scene, faces))
        ext = add_lead(q_init, fit_markers.positions_m, flat.support, n_lead, n_lead,
                       step_frames=max(1, int(round(config.lead_swing_s * source.fps))),
                       land_frames=int(round(config.lead_land_s * source.fps)),
                       feet=lead_feet(robot, q_init, targets, ends))
        limits = joint_limits(robot, fit_config.limits)
        sliding = np.zeros_like(ext.support)
        sliding[n_lead:n_lead + n_work] = flat.moving
        inferred = np.zeros_like(ext.support)
        if flat.inferred is not None:
            inferred[n_lead:n_lead + n_work] = flat.inferred
        surface_z = planes = None
        if surface is not None and faces is not None:
            surface_z = lead_heights(surface, ext.markers, fit_markers, scene, n_lead, faces)
            planes = pad_planes(faces)
        plan, footprints = plan_whole_body(robot, ext.q, ext.markers, targets, ext.support,
                                           source.fps, limits, config.wholebody,
                                           rest_frames=3 if n_lead >= 3 else 0,
                                           sliding=sliding, support_heights=surface_z,
                                           props=planes,
                                           effectors=(None if effectors is None
                                                      else effectors.padded(n_lead, n_lead)),
                                           inferred=inferred)
        if obstacles is not None:
            plan = dataclasses.replace(plan, obstacles=obstacles)
        if plan_hook is not None:
            plan = plan_hook(plan, PlanContext(names=fit_markers.names, targets=targets,
                                               lead_frames=n_lead))
        seconds["plan"] = time.perf_counter() - t3
        n_out = len(ext.q)
        notify(progress, "plan", 1, 1, n_out)
        t4 = time.perf_counter()

        def sqp_step(done: int, total: int) -> None:
            notify(progress, "wholebody", done, total, n_out, f"SQP iteration {done}")

        if n_out > config.windows.frames:
            def window_step(done: int, total: int, text: str) -> None:
                notify(progress, "wholebody", done, total, n_out, text)

            solution = windows.solve_windowed(robot, plan, footprints, targets,
                                              config.wholebody, config.windows,
                                              progress=window_step)
        else:
            solution = solve_whole_body(robot, plan, footprints, targets, config.wholebody,
                                        progress=sqp_step)
        seconds["wholebody"] = time.perf_counter() - t4
        q_out = solution.q
        lead = (n_lead, n_lead)
        flight = runs(plan.flight)
        adapted = adapted.with_positions(
            ext.markers[:, :adapted.n_markers], source=adapted.source)
        for f in footprints:  # and the pivots the plan adds (planted runs turning in the fit)
            if f.sliding:
                sliding[f.start:f.stop, SIDES.index(f.side)] = True
        support_out = Contacts(support=plan.support, fps=source.fps,
                               sliding=sliding & plan.support)
    # The whole-body solve's support phases are the plan the motion holds (its soles are on
    # their footprints exactly there), so the file carries them for the evaluator and the DART
    # check; other modes leave the robot's support to be detected from its soles.
    motion_out = dataclasses.replace(fit.motion, q=q_out,
                                     provenance=make_provenance(motion, robot, lead, __version__),
                                     contact_modes=(support_out.modes if solution is not None
                                                    else None))
    seconds["total"] = time.perf_counter() - t0
    log.info("retargeted %s to %s: %d frames in %.2f s", motion.source, robot.name,
             motion_out.n_frames, seconds["total"])
    return RetargetResult(motion=motion_out, arrangement=arrangement, adapted=adapted,
                          contacts=contacts, support=support_out, morph=morph, fit=fit,
                          wholebody=solution, balance=balance, lead_frames=lead,
                          unconstrained_frames=unconstrained, seconds=seconds,
                          arms=arms_report, flight_frames=flight)

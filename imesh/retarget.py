"""The main pipeline: human motion -> robot joint trajectories.

    standard markers -> arrangement for the robot (sec. IV-A) -> contacts (sec. V-A)
      -> support-foot constraints (sec. V-B) -> spacetime morph (sec. III)
      -> joint fitting with motor limits (sec. IV-B; Kim 2005) -> RobotMotion

Every stage is a public function of its own module; this one only wires them.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .adapt import prepare_markers
from .arrange import Arrangement, arrange_for_robot
from .contacts import FOOT_MARKERS, SIDES, ContactConfig, Contacts, detect_contacts
from .filtering import lowpass
from .morph.problem import MorphConfig, build_morph_problem
from .morph.solver import MorphResult, MorphStepReport, solve_morph
from .motion import MarkerMotion
from .support import SupportConfig, flat_support, support_blend, support_foot_targets

log = logging.getLogger(__name__)


def _default_balance():
    from .balance import BalanceConfig

    return BalanceConfig()


def _default_plant():
    from .fit.legs import PlantConfig

    return PlantConfig()


@dataclass(frozen=True)
class RetargetConfig:
    """Settings of every stage.

    Attributes:
        morph: MorphConfig of the spacetime morph. A robot must move smoothly: the default
            acceleration weight is 10 (adapt_motion's is 1). On the CMU walk the morph with
            weight 1 triples the markers' accelerations (centroid p50 2.4 vs 0.74 m/s^2 in the
            source; 1.1 with weight 100) and the multibody ZMP error follows (700 mm; 180 mm
            with 100); but 100 distorts the first frames (wave, frame 0 key-point RMS 93 mm vs
            32 mm with 10).
        contacts: ContactConfig of the support detection.
        support: SupportConfig; None disables the support-foot constraints.
        fit: an :class:`imesh.fit.FitConfig` (None: defaults).
        plant: an :class:`imesh.fit.legs.PlantConfig`: after the fit, the base is smoothed,
            each support sole is planted flat on its footprint and the legs are solved for it
            (:func:`imesh.fit.legs.plant_feet`); None keeps the fitted motion. It needs the
            support-foot constraints.
        balance: an :class:`imesh.balance.BalanceConfig`; None skips the balance loop
            (sec. V-C/D). It needs the support-foot constraints. With ``plant`` (and
            ``balance.feedback == "joints"``) the waist correction moves the planted motion's
            base and the legs are solved again; otherwise it goes back into the morph.
        pelvis_weight: priority of the pelvis triangle (pelvis, hip_l, hip_r) and the base's
            lateral direction: the paper fits the waist 6-DOF from these first; a high weight
            keeps the feet from swinging the base when other targets disagree.
        foot_weight: priority of the toe/ankle key points and the foot-roll directions in the
            fit, relative to the markers.toml weights.
        lowpass_hz: cut-off of the zero-phase low-pass applied to the human markers first
            (``imesh.filtering``); None keeps them as recorded.
    """

    morph: MorphConfig = field(default_factory=lambda: MorphConfig(accel_weight=10.0))
    contacts: ContactConfig = field(default_factory=ContactConfig)
    support: SupportConfig | None = field(default_factory=SupportConfig)
    fit: object | None = None
    plant: object | None = field(default_factory=lambda: _default_plant())
    balance: object | None = field(default_factory=lambda: _default_balance())
    lowpass_hz: float | None = 8.0
    foot_weight: float = 10.0
    pelvis_weight: float = 3.0


@dataclass(frozen=True, eq=False)
class RetargetResult:
    """Everything the pipeline produced, stage by stage.

    Attributes:
        motion: the robot motion (an :class:`imesh.robot_motion.RobotMotion`).
        arrangement: the arranged, scaled human markers and robot targets.
        adapted: the morphed markers (same names as ``arrangement.motion``).
        contacts: support phases of the source (footfalls, flight phases).
        support: the robot's planned support: the flat part of each source support phase
            (:func:`imesh.support.flat_support`), held by the support-foot constraints; equal
            to ``contacts`` when the constraints are off.
        morph: the spacetime solver's result.
        fit: the fitting result (residuals, limit counts) of the markers; ``motion`` differs
            from ``fit.motion`` when the feet were planted or the motion balanced.
        planted: the planted-feet stage's result (:class:`imesh.fit.legs.Planted`; None when
            off).
        balance: the balance loop's result (:class:`imesh.balance.BalanceResult`; None when
            the balance stage is off). ``adapted``, ``morph`` and ``fit`` are its best iterate.
        seconds: wall time per stage [s].
    """

    motion: object
    arrangement: Arrangement
    adapted: MarkerMotion
    contacts: Contacts
    support: Contacts
    morph: MorphResult
    fit: object
    balance: object | None
    seconds: dict
    planted: object | None = None

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
            "balance": self.balance.report() if self.balance is not None else None,
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
        flat: (T, 2) [left, right] support blend in [0, 1] (:func:`imesh.support.support_blend`);
            None: pelvis-based everywhere.
        pelvis_weight: weight of the base's lateral direction (None: ``weight``).

    Returns:
        (markers with the virtual markers appended, the extra Direction targets).
    """
    from .robot.config import Direction

    names = list(adapted.names)
    pos = adapted.positions_m
    pts = arrangement.meta["robot_points_m"]
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
            # pelvis axis rather than an ill-defined f x z
            level = np.cross(f, [0.0, 0.0, 1.0])
            level *= np.where(np.sum(level * lateral, axis=1, keepdims=True) < 0, -1.0, 1.0)
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


def _support_height_p95(robot, q: np.ndarray, fps: float, support: np.ndarray) -> float:
    """[m] 95th percentile of |lowest sole corner z| over the support frames (0 if none)."""
    from .metrics.kinematics import sole_tracks

    h = sole_tracks(robot, q, fps).support_heights(support)
    return float(np.percentile(h, 95)) if h.size else 0.0


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
    if config.lowpass_hz is not None:
        human = lowpass(human, config.lowpass_hz)
    arrangement = arrange_for_robot(human, robot)
    source = arrangement.motion
    contacts = detect_contacts(source, config.contacts)
    if config.balance is not None:  # fail before the morph, not after it
        from .balance import check_flight

        check_flight(motion.source or "motion", contacts.support, source.fps, config.balance)
    hard = soft = soft_w = None
    flat = contacts
    if config.support is not None:
        flat = flat_support(source, contacts, config.support)
        heights, lengths = foot_geometry(arrangement)
        hard, soft, soft_w = support_foot_targets(source, flat, heights, lengths,
                                                  config.support)
    seconds["prepare"] = time.perf_counter() - t0

    fit_config = config.fit if config.fit is not None else FitConfig()
    blend = (support_blend(flat, config.support.ramp_s) if config.support is not None
             else None)
    # Priorities (W_e of eq. 7) as in the paper's order of fitting: the waist from the pelvis
    # triangle, the feet (they carry the robot), then the rest; so the whole-body fit does not
    # swing the base or slide a sole to meet an upper-body marker it cannot reach.
    gain = {m: config.foot_weight for side in SIDES for m in FOOT_MARKERS[side]}
    gain.update({m: config.pelvis_weight for m in ("pelvis", "hip_l", "hip_r")})
    keypoints = {n: (dataclasses.replace(k, weight=k.weight * gain[n]) if n in gain else k)
                 for n, k in arrangement.keypoints.items()}
    stages: list[tuple[MorphResult, MarkerMotion, object]] = []

    def morph_and_fit(hard_m, q_init=None, soft_m=soft, soft_wm=soft_w):
        t1 = time.perf_counter()
        problem = build_morph_problem(source, pairs=arrangement.pairs,
                                      target_lengths_m=arrangement.target_lengths_m,
                                      hard_positions_m=hard_m, soft_positions_m=soft_m,
                                      soft_weights=soft_wm, config=config.morph)
        morph = solve_morph(problem, progress=progress)
        adapted = source.with_positions(morph.positions_m, source=f"adapted:{source.source}")
        t2 = time.perf_counter()
        fit_markers, extra_dirs = orientation_targets(adapted, robot, arrangement,
                                                      weight=config.foot_weight, flat=blend,
                                                      pelvis_weight=config.pelvis_weight)
        fit = fit_motion(robot, fit_markers, keypoints=keypoints,
                         directions=arrangement.directions + extra_dirs, config=fit_config,
                         q_init=q_init)
        seconds["morph"] = seconds.get("morph", 0.0) + t2 - t1
        seconds["fit"] = seconds.get("fit", 0.0) + time.perf_counter() - t2
        stages.append((morph, adapted, fit))
        return fit

    fit = morph_and_fit(hard)
    q_out = fit.motion.q
    planted = balance = None
    limits = None
    chosen = 0  # the stage (morph, adapted, fit) the output comes from
    if config.plant is not None and config.support is not None:
        from .fit.dls import joint_limits
        from .fit.legs import plant_feet

        t3 = time.perf_counter()
        limits = joint_limits(robot, fit_config)
        planted = plant_feet(robot, q_out, source.fps, flat.support, limits, config.plant)
        # a quality gate: planting must not put the support soles further off the ground than
        # the fit had them (where the legs cannot reach the footprints even after letting go)
        before, after = (_support_height_p95(robot, q, source.fps, flat.support)
                         for q in (q_out, planted.q))
        if after <= before + 1e-3:
            q_out = planted.q
        else:
            log.warning("planted feet: support soles %.1f mm off the ground (95th percentile) "
                        "vs %.1f mm in the fit; keeping the fitted motion", 1e3 * after,
                        1e3 * before)
            planted = None
        seconds["plant"] = time.perf_counter() - t3
    if config.balance is not None:
        from .balance import balance_loop

        t3 = time.perf_counter()
        if planted is not None and config.balance.feedback == "joints":
            from .fit.legs import resolve_legs

            base = planted.q

            def step(waist_xy: np.ndarray) -> np.ndarray:
                # the corrected waist moves the base; the planted soles stay, the legs follow
                q = base.copy()
                q[:, :2] = waist_xy
                return resolve_legs(robot, q, planted.targets, source.fps, limits,
                                    config.plant).q

            balance = balance_loop(robot, q_out, source.fps, flat.support, base[:, :2], step,
                                   config.balance)
        else:
            pelvis = source.index("pelvis")
            shape = source.positions_m.shape
            base_soft = soft if soft is not None else np.full(shape, np.nan)
            base_w = soft_w if soft_w is not None else np.zeros(shape[:2])

            def step(waist_xy: np.ndarray) -> np.ndarray:
                # The corrected waist is a soft target of large weight rather than the
                # paper's hard constraint: with both feet pinned, a correction the legs cannot
                # reach would make the hard constraints inconsistent and the morph fail.
                s_m, w_m = base_soft.copy(), base_w.copy()
                s_m[:, pelvis, :2] = waist_xy
                w_m[:, pelvis] = config.balance.waist_weight
                return morph_and_fit(hard, q_init=stages[-1][2].motion, soft_m=s_m,
                                     soft_wm=w_m).motion.q

            balance = balance_loop(robot, q_out, source.fps, flat.support,
                                   stages[0][1].positions_m[:, pelvis, :2], step,
                                   config.balance)
            chosen = balance.best
        q_out = balance.q
        seconds["balance"] = time.perf_counter() - t3
    morph, adapted, fit = stages[chosen]
    motion_out = fit.motion if q_out is fit.motion.q else dataclasses.replace(fit.motion,
                                                                               q=q_out)
    seconds["total"] = time.perf_counter() - t0
    log.info("retargeted %s to %s: %d frames in %.2f s", motion.source, robot.name,
             adapted.n_frames, seconds["total"])
    return RetargetResult(motion=motion_out, arrangement=arrangement, adapted=adapted,
                          contacts=contacts, support=flat, morph=morph, fit=fit,
                          balance=balance, seconds=seconds, planted=planted)

"""Settings of joint fitting: the weights of the objective (Nakaoka & Komura 2012, eq. 7-8, plus
the smoothing and posture terms), the damped least-squares iteration budget, which of Kim, Kim &
Oh 2005's limits (eqs 9, 13, 14) apply, and the free-flyer's trust region and velocity box
(docs/fitting.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.limits import LimitOptions
from .errors import FitError


@dataclass(frozen=True)
class FitConfig:
    """Settings of :func:`fit_motion`.

    Attributes:
        damping: lambda of eq. 7 at the start of each frame (weighted-residual units per unit
            of dq; with unit weights metres per radian). Each step uses
            ``lambda^2 = f (damping^2 + |W e|^2)`` with a Levenberg-Marquardt factor f in
            [0.01, 1e8]; larger damping is more cautious near singular poses.
        iterations: maximum damped least-squares solves per frame (frames >= 1).
        first_frame_iterations: maximum solves for frame 0 (starts from the geometric guess).
        tolerance: a frame is converged when the next step would change no weighted residual
            (key point [m], direction [rad], smoothing row) by more than this; frame 0 uses a
            hundredth of it.
        position_weight: multiplies every key-point residual (times its own weight) [1/m].
        direction_weight: multiplies every direction residual (times its own weight) [1/rad]:
            with both at 1, a direction error of 1 rad costs like a 1 m key-point error, so a
            markers.toml direction weight of 0.3 makes 1 degree cost like 5 mm.
        smoothing: constant part mu_0 of the smoothing weight mu: every frame i >= 1 adds
            ``mu^2 |q_j - q_{i-1},j|^2`` (joints only) to its objective [weighted-residual units
            per rad]. It anchors joints the targets do not determine (null space, e.g. a wrist
            yaw about the hand axis) against drift.
        adaptive_smoothing: gain k [1/m] of the residual-proportional part:
            ``mu = mu_0 + k * rms_{i-1}`` with rms_{i-1} the key-point RMS of the previous frame
            [m]. Targets the robot cannot meet (2 cm RMS) make the objective flat along
            redundant joint combinations (waist vs hips, forearm twist); without this term the
            per-frame optimum wanders along them and the joints chatter against their
            acceleration limits. Exact targets (rms -> 0) get mu -> mu_0 and no lag. The lag it
            costs is about ``(mu / sigma)^2`` of a frame's motion along Jacobian directions of
            singular value sigma (docs/fitting.md has the measurements).
        posture: eta, weight of the joint deviation from the nominal pose,
            ``eta^2 |q_j - q_nominal,j|^2`` in every frame i >= 1 [weighted-residual units per
            rad]: pulls joints that no target determines back towards the nominal pose instead
            of letting them drift into their limits; negligible for observed joints.
        limits: which of Kim's limits apply (eqs 9, 13, 14), an override of ``robot.a_max``
            and the braking box (:class:`imesh.core.limits.LimitOptions`; default: all).
        lookahead: when velocity or acceleration limits apply, fit the frames with the position
            box only, then project the joint trajectory onto all the limits over the whole
            clip (:mod:`imesh.fit.feasible`): the result satisfies Kim's eqs 9, 13 and 14 in
            every frame and brakes ahead of fast motion. False: Kim's per-frame boxes inside
            the DLS (greedy: a joint that cannot follow its target saturates, overshoots and
            chases it; docs/fitting.md has the comparison).
        base_step_m, base_step_rad: trust region of the free-flyer in one damped step
            (linear [m], angular [rad]); many steps may still move it far (frame 0), but no
            single step can flip the base into another basin.
        base_speed_m_s, base_rate_rad_s: velocity box of the free-flyer (linear, angular), like
            Kim eq. 13 for the joints: without it, when rate-limited leg joints lag, the fit
            swings the unbounded base instead (seen: +-30 degrees of base yaw on a walk).
            The rate is a dancer's: a pirouette turns the pelvis at up to 15 rad/s (CMU 05_06,
            10.7 at the 95th percentile); at 3 rad/s the base fell behind the spin and the fit
            rolled it upside down (358 mm key-point RMS; 167 at 20). No walk, wave or wash
            of the shared clips comes near it (their fits are the same at 3 and 20).
        restart_rms_m: a frame whose key-point RMS after its warm-started solve is above this
            [m] is also solved from a start placed on its own markers (nominal joints, upright
            base on the pelvis and hips: :func:`imesh.fit.initial.frame_guesses`), and keeps
            the better basin. The warm start finds only the basin it starts in: on CMU 05_06
            (leaps and pirouettes) on G1 the fit lost the markers after a développé (frames
            26-54) and never found them again (140 mm RMS standing still at the end; 27 mm
            from a fresh start). The dance's fit RMS on G1 / JVRC-1: 239 / 390 mm without
            restarts, 87 / 71 at 50 mm, 91 / 74 at 80 mm, 96 / 86 at 120 mm; the walks, wave,
            wash and zombie walk restart no frame. inf: no restarts.
        restart_gain: the restart wins when its cost ``|W e|^2`` (key points and directions)
            is below this fraction of the warm start's.
        restart_iterations: largest number of solves from the fresh start.
        extrapolate: warm start frame i from the constant-velocity prediction of frames i-2 and
            i-1 (clipped into the box) instead of frame i-1; saves ~1 solve per frame.
        collision_weight: w of the self-collision penalty ``w (margin - d)`` of every checked
            capsule pair closer than ``collision_margin_m`` (:mod:`imesh.fit.collision`)
            [weighted-residual units per metre]: at 10, a millimetre of shortfall costs like 10
            mm of key-point error. 0: no penalty (the scaled person's arms fitted into the
            robot's torso and hands through each other, which the whole-body solve then has
            to undo).
        collision_margin_m: the signed capsule distance the penalty keeps [m] (the whole-body
            solve's ``CollisionOptions.margin_m``).
    """

    damping: float = 1e-2
    iterations: int = 8
    first_frame_iterations: int = 300
    tolerance: float = 1e-5
    position_weight: float = 1.0
    direction_weight: float = 1.0
    smoothing: float = 1e-3
    adaptive_smoothing: float = 5.0
    posture: float = 3e-4
    limits: LimitOptions = field(default_factory=LimitOptions)
    lookahead: bool = True
    extrapolate: bool = True
    base_step_m: float = 0.05
    base_step_rad: float = 0.1
    base_speed_m_s: float = 3.0
    base_rate_rad_s: float = 20.0
    restart_rms_m: float = 0.05
    restart_gain: float = 0.5
    restart_iterations: int = 100
    collision_weight: float = 10.0
    collision_margin_m: float = 0.005

    def __post_init__(self) -> None:
        positive = ("damping", "iterations", "first_frame_iterations", "tolerance",
                    "restart_gain", "restart_iterations")
        non_negative = ("position_weight", "direction_weight", "smoothing",
                        "adaptive_smoothing", "posture", "collision_weight", "collision_margin_m")
        for name in positive + non_negative:
            value = getattr(self, name)
            try:
                ok = bool(np.isfinite(value) and (value > 0 if name in positive else value >= 0))
            except TypeError:
                ok = False
            if not ok:
                kind = "positive" if name in positive else "non-negative"
                raise FitError(f"FitConfig.{name} = {value!r} is invalid: must be a finite "
                               f"{kind} number")
        try:
            ok = bool(self.restart_rms_m > 0)  # inf: no restarts
        except TypeError:
            ok = False
        if not ok:
            raise FitError(f"FitConfig.restart_rms_m = {self.restart_rms_m!r} is invalid: must be "
                           "a positive number [m] (inf: no restarts)")

"""Settings of the arm imitation (:class:`ArmsConfig`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.limits import LimitOptions
from ..robot.config import SIDES
from .errors import ArmsError

#: Per-frame solvers: ``"gn"`` box-constrained Gauss-Newton (the default, see docs/arms.md),
#: ``"slsqp"`` scipy's SQP (the paper's kind of solver; the baseline).
SOLVERS = ("gn", "slsqp")
#: Frames the human arm vectors are expressed in before they are put on the robot.
FRAMES = ("torso", "world")


@dataclass(frozen=True)
class ArmsConfig:
    """How the arms are imitated (Kim, Kim & Oh 2005).

    Attributes:
        sides: the arms to solve (``"left"``, ``"right"``); the others keep the reference.
        point_weights: (W_wrist, W_hand, W_thumb) of eq. 3, each for the three coordinates
            of its point [1/m^2 in the objective]. The thumb weight fades to 0 where its derived
            direction is undefined (see ``thumb_fade_deg``).
        upper_arm_weight: W_10 of eq. 2, the weight of the squared upper-arm orientation error
            ``||s_elbow||^2`` [m^2] of eq. 4.
        damping: ``damping^2 |dtheta|^2`` is added to eq. 2 [m/rad]: 1e-2 makes a 1 rad
            increment cost like a 1 cm hand-point error (a frame's increments are ~0.01 rad, so
            ~0.1 mm), which only matters for joint combinations no target sees (the elbow
            swivel with W_10 = 0, the hand roll where the thumb point fades out): there it
            keeps the joints where they were instead of letting Gauss-Newton wander along a
            flat valley. 0 gives the paper's objective exactly.
        thumb_fade_deg: the third hand point's weight fades in as the angle between upper arm
            and hand axis grows from 0 to this [deg] (smoothstep of the sine).
        solver: one of :data:`SOLVERS`.
        iterations: maximum solver iterations per frame (frames >= 1).
        first_frame_iterations: maximum iterations of frame 0 (starts from the reference pose).
        tolerance_rad: the Gauss-Newton iteration stops when no joint would move by more than
            this [rad].
        objective_tolerance: both solvers stop when an iteration lowers f by less than this
            [m^2] (SLSQP's ``ftol``; 1e-12 is a 0.5 um change of a 1 mm hand-point error).
        limits: which of the limits apply (eqs 9, 13, 14), an override of ``robot.a_max`` and
            the braking box (:class:`imesh.core.limits.LimitOptions`; default: all).
        extrapolate: warm start from the constant-velocity prediction (clipped into the box)
            instead of the previous frame (the paper's ``dtheta = 0``).
        lookahead: instead of bounding every frame's increment by its velocity and
            acceleration limits (eqs 13, 14: greedy, it cannot brake before a fast target
            motion), solve every frame with the position bounds only (eq. 9) and project the
            joint trajectory onto all limits over the whole clip at once
            (:func:`imesh.fit.feasible.project_joint_trajectory`, the main pipeline's look-ahead).
            Off by default: the paper's per-frame scheme; see docs/arms.md for when to use it.
        frame: ``"torso"``: human arm vectors are taken relative to the human torso (pelvis ->
            neck up, shoulder line across) and put on the robot's torso, so body sway does not
            move the robot arms; ``"world"``: taken as they are (markers already in the
            robot's world, e.g. adapted by the main pipeline).
        lowpass_hz: cut-off of the zero-phase low-pass of the human markers (None: off). 3 Hz,
            below the main pipeline's 8 Hz: the per-frame bounds cannot follow (and lose the
            arm on) motions far beyond the acceleration limits, such as the wave's 4.7 Hz hand
            flap (docs/arms.md, "The human's low-pass").
    """

    sides: tuple[str, ...] = SIDES
    point_weights: tuple[float, float, float] = (1.0, 1.0, 1.0)
    upper_arm_weight: float = 1.0
    damping: float = 1e-2
    thumb_fade_deg: float = 20.0
    solver: str = "gn"
    iterations: int = 50
    first_frame_iterations: int = 300
    tolerance_rad: float = 1e-7
    objective_tolerance: float = 1e-12
    limits: LimitOptions = field(default_factory=LimitOptions)
    extrapolate: bool = False
    lookahead: bool = False
    frame: str = "torso"
    lowpass_hz: float | None = 3.0

    def __post_init__(self) -> None:
        if self.solver not in SOLVERS:
            raise ArmsError(f"ArmsConfig.solver = {self.solver!r}; valid: {', '.join(SOLVERS)}")
        if self.frame not in FRAMES:
            raise ArmsError(f"ArmsConfig.frame = {self.frame!r}; valid: {', '.join(FRAMES)}")
        sides = tuple(self.sides)
        if not sides or any(s not in SIDES for s in sides) or len(set(sides)) != len(sides):
            raise ArmsError(f"ArmsConfig.sides = {self.sides!r}; valid: distinct values of "
                            f"{', '.join(SIDES)}")
        object.__setattr__(self, "sides", sides)
        w = np.asarray(self.point_weights, dtype=float)
        if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w < 0) or not w.any():
            raise ArmsError(f"ArmsConfig.point_weights = {self.point_weights!r}: three finite "
                            "non-negative numbers (wrist, hand, thumb), not all zero")
        for name in ("upper_arm_weight", "damping"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ArmsError(f"ArmsConfig.{name} = {value!r}: a finite number >= 0")
        for name in ("thumb_fade_deg", "tolerance_rad", "objective_tolerance"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ArmsError(f"ArmsConfig.{name} = {value!r}: a positive number")
        for name in ("iterations", "first_frame_iterations"):
            value = getattr(self, name)
            if not (isinstance(value, int) and value >= 1):
                raise ArmsError(f"ArmsConfig.{name} = {value!r}: an integer >= 1")
        if self.lowpass_hz is not None and not (np.isfinite(self.lowpass_hz)
                                                and self.lowpass_hz > 0):
            raise ArmsError(f"ArmsConfig.lowpass_hz = {self.lowpass_hz!r}: a positive frequency "
                            "[Hz] or None")

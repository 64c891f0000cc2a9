"""The damped least-squares step of one frame (Nakaoka & Komura 2012, eq. 7), iterated
Levenberg-Marquardt style to the frame's optimum inside its joint box.

Each step, over the free-flyer base (6) and all joints, ``dq`` in the tangent space:

    dq = argmin |W (J dq - e)|^2 + mu^2 |q_j + dq_j - r_j|^2 + lambda^2 |dq|^2
         subject to the increment box

with ``W e`` and ``W J`` the rows of eq. 8 (:mod:`imesh.fit.residual`). The ``mu`` rows (joints
only; r = mostly the previous frame, a little the nominal pose) are the smoothing and posture
terms of FitConfig; lambda is adapted per step (see :func:`solve_frame`), so the iteration
converges to the minimizer of ``|W e|^2 + mu^2 |q_j - r_j|^2`` in the box, whatever the damping.
Each step solves the bounded problem exactly (primal-dual active set on the normal equations,
:mod:`imesh.fit.boxqp`); the box of the joints is Kim et al.'s (:mod:`imesh.fit.limits`), the
base gets a trust region and a velocity box of its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..robot.capsules.obstacles import Obstacles
from .boxqp import solve_box_qp
from .collision import CollisionPenalty
from .config import FitConfig
from .kinematics import Kinematics
from .residual import FrameRows

_LM_MIN = 1e-2  # smallest Levenberg-Marquardt factor
_RESIDUAL_DAMPING = 1.0  # weight of |W e|^2 in lambda^2
_STALL = 1e-3  # stop when sqrt(E) improves by less than this times the tolerance
_FIRST_FRAME_TOL = 1e-2
_CHORD_STEP = 1e-3  # [rad or m] largest step after which the Jacobian is reused
_MAX_CHORDS = 2  # chord steps per Jacobian
_JOINT_SCALE = 1e-3  # [m/rad] a joint step of 10 mrad counts as a 10 um change
_NONE = np.zeros(0)  # no collision residual


@dataclass(frozen=True, eq=False)
class FitProblem:
    """What stays fixed over the frames of one fit.

    Attributes:
        robot: the ``imesh.robot.Robot``.
        kin: its kinematics for the fitted targets.
        config: the settings.
        base_step: (6,) trust region of the free-flyer in one step (linear [m], angular [rad]).
        base_reach: (6,) largest base displacement from the previous frame in one frame (base
            velocity bound times dt, in the base frame) [m, rad].
        q_posture: (n,) the nominal joints clipped into the position limits [rad], the
            reference of the posture term.
        collision: the self-collision penalty (:mod:`imesh.fit.collision`; with a partner's
            capsules as obstacles), or None.
    """

    robot: Any
    kin: Kinematics
    config: FitConfig
    base_step: np.ndarray
    base_reach: np.ndarray
    q_posture: np.ndarray
    collision: CollisionPenalty | None = None

    @classmethod
    def build(cls, robot: Any, kin: Kinematics, config: FitConfig, lower: np.ndarray,
              upper: np.ndarray, fps: float, obstacles: Obstacles | None = None
              ) -> FitProblem:
        """From the settings, the (n,) position limits [rad], the frame rate [Hz] and the
        obstacles over the fitted frames (or None)."""
        # Trust region of the free-flyer per LM step: joints are boxed by their limits, the base
        # is not, and one poorly damped step could turn it by 90 degrees into another basin
        # (seen on the CMU walk: the base yaw jumped 40 degrees in one frame and never came
        # back).
        base_step = np.array([config.base_step_m] * 3 + [config.base_step_rad] * 3)
        base_reach = np.array([config.base_speed_m_s] * 3 + [config.base_rate_rad_s] * 3) / fps
        q_posture = np.clip(np.asarray(robot.q_nominal, dtype=np.float64)[7:], lower, upper)
        collision = (CollisionPenalty.build(robot, config.collision_weight,
                                            config.collision_margin_m, obstacles)
                     if hasattr(robot, "capsule_model") else None)
        return cls(robot=robot, kin=kin, config=config, base_step=base_step,
                   base_reach=base_reach, q_posture=q_posture, collision=collision)

    def base_bounds(self, q: np.ndarray, q_prev: np.ndarray | None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """(6,) lower and upper bounds of the free-flyer part of a step from ``q`` (nq,): the
        trust region, intersected with the base velocity box around ``q_prev`` (nq,) unless
        None (a bound the base already passed becomes 0: no step further out)."""
        base_lo, base_hi = -self.base_step, self.base_step
        if q_prev is not None:
            # first-order: the base displacement so far plus this step stays in the box
            moved = self.robot.difference(q_prev, q)[:6]
            base_lo = np.maximum(base_lo, np.minimum(-self.base_reach - moved, 0.0))
            base_hi = np.minimum(base_hi, np.maximum(self.base_reach - moved, 0.0))
        return base_lo, base_hi


@dataclass(frozen=True, eq=False)
class FrameProblem:
    """What one frame adds to the :class:`FitProblem`.

    Attributes:
        lo, hi: (n,) absolute joint bounds of this frame [rad].
        rows: the frame's targets and row weights (eq. 8).
        q_ref: (n,) reference r of the mu term [rad].
        mu: smoothing weight [weighted-residual units per rad] (ignored on frame 0).
        max_it: largest number of box-QP solves.
        first: frame 0 (no smoothing term, a tighter tolerance).
        q_prev: (nq,) the previous frame's configuration when the free-flyer gets a velocity
            box around it like the joints (None: no box).
        index: the frame's index in the fit (the obstacles' frame), or None.
    """

    lo: np.ndarray
    hi: np.ndarray
    rows: FrameRows
    q_ref: np.ndarray
    mu: float
    max_it: int
    first: bool
    q_prev: np.ndarray | None
    index: int | None = None


def target_cost(problem: FitProblem, frame: FrameProblem, q: np.ndarray, points: np.ndarray,
                axes: np.ndarray) -> float:
    """``|W e|^2`` of the frame's targets at ``q`` (nq,) (its key points (K, 3) and direction
    axes (D, 3) given), with the self-collision penalty's residuals."""
    res = frame.rows.residual(points, axes)
    cost = float(res @ res)
    if problem.collision is not None:
        res_c = problem.collision.residual(q, frame.index)[0]
        cost += float(res_c @ res_c)
    return cost


def solve_frame(problem: FitProblem, frame: FrameProblem, q: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Levenberg-Marquardt iterations of the box-bounded DLS step (eq. 7) for one frame.

    Minimizes ``E(q) = |W e(q)|^2 + mu^2 |q_j - q_ref|^2`` (joints only; see FitConfig),
    plus the self-collision penalty's residuals in ``W e`` (:mod:`imesh.fit.collision`)
    by steps ``dq = argmin |W (J dq - e)|^2 + mu^2 |q_j + dq_j - q_ref|^2 + lambda^2 |dq|^2``
    inside the increment box. ``lambda^2 = f (damping^2 + |W e|^2)``: the residual term stands in
    for the second-order part of the Hessian that Gauss-Newton ignores (it grows with the
    residual, so inconsistent targets get damped steps while exact targets converge
    quadratically); the factor f starts at 1, grows tenfold when a step fails to lower E (the
    step is retried from the last accepted pose) and shrinks tenfold (to at least
    ``_LM_MIN``) after an accepted step. After a small step (< ``_CHORD_STEP``) that achieved at
    least half of its predicted decrease, the next step reuses the Jacobian (a chord step: one
    forward-kinematics call instead of a Jacobian; at most ``_MAX_CHORDS`` in a row). Frame 0
    (``frame.first``) has no previous frame: no smoothing term, and a 100 times tighter tolerance,
    since later frames inherit its weakly observed joints.

    Stops when the next step would change no weighted residual (key point, direction) by more
    than ``config.tolerance`` and move no joint by more than ``tolerance / _JOINT_SCALE``
    (steps along directions no target sees do not keep it iterating), when an accepted step
    lowered sqrt(E) by less than 1e-3 of the tolerance, or after ``frame.max_it`` solves.

    Args:
        problem: what is fixed over the frames (robot, kinematics, settings, base bounds).
        frame: this frame's box, targets, reference, weight mu and solve budget.
        q: (nq,) starting configuration, joints inside [frame.lo, frame.hi].

    Returns:
        (q, key points (K, 3), direction axes (D, 3), solves) at the last accepted pose.
    """
    robot, kin, config = problem.robot, problem.kin, problem.config
    lo, hi, q_ref, rows = frame.lo, frame.hi, frame.q_ref, frame.rows
    nv = robot.nv
    tol = config.tolerance * (_FIRST_FRAME_TOL if frame.first else 1.0)
    damp2 = config.damping ** 2
    mu2 = 0.0 if frame.first else frame.mu * frame.mu
    factor = 1.0
    pen = problem.collision
    points, axes = kin.points_and_axes(q)
    res = rows.residual(points, axes)
    res_c, state = pen.residual(q, frame.index) if pen is not None else (_NONE, None)
    dev = q[7:] - q_ref
    fit_cost = float(res @ res) + float(res_c @ res_c)
    cost = fit_cost + mu2 * float(dev @ dev)
    it = 0
    chords = 0
    a_rows = None
    c_rows = np.zeros((0, nv))
    active = None
    while it < frame.max_it and cost > 0.0:
        fresh = a_rows is None
        if a_rows is None:  # (fresh; spelled out so the type checker narrows a_rows)
            chords = 0
            jp, jw = kin.jacobians(q)
            a_rows = rows.jacobian(jp, jw, axes, nv)
            if pen is not None and state is not None:
                c_rows = pen.rows(q, state)
            h0 = a_rows.T @ a_rows + c_rows.T @ c_rows
            if mu2:
                h0[6:, 6:].flat[:: nv - 5] += mu2
            diag0 = h0.diagonal().copy()
        g = a_rows.T @ res + c_rows.T @ res_c
        if mu2:
            g[6:] -= mu2 * dev
        base_lo, base_hi = problem.base_bounds(q, frame.q_prev)
        step_lo = np.concatenate([base_lo, lo - q[7:]])
        step_hi = np.concatenate([base_hi, hi - q[7:]])
        while True:
            h = h0.copy()
            h.flat[:: nv + 1] = diag0 + factor * (damp2 + _RESIDUAL_DAMPING * fit_cost)
            dq, _, active = solve_box_qp(h, g, step_lo, step_hi, guess=active)
            it += 1
            step = float(np.max(np.abs(dq)))
            # converged when the step would move no weighted residual (key point [m], direction
            # [rad], smoothing) by more than tol: steps along unobservable joint combinations
            # (driven by rounding noise when lambda is small) do not count
            change = max(float(np.max(np.abs(a_rows @ dq))),
                         float(np.max(np.abs(c_rows @ dq), initial=0.0)),
                         _JOINT_SCALE * float(np.max(np.abs(dq[6:]))))
            if change < tol:
                return q, points, axes, it
            q_new = np.array(robot.integrate(q, dq), dtype=np.float64)
            q_new[7:] = np.clip(q_new[7:], lo, hi)
            p_new, a_new = kin.points_and_axes(q_new)
            r_new = rows.residual(p_new, a_new)
            rc_new, state_new = (pen.residual(q_new, frame.index) if pen is not None
                                 else (_NONE, None))
            dev_new = q_new[7:] - q_ref
            fit_new = float(r_new @ r_new) + float(rc_new @ rc_new)
            c_new = fit_new + mu2 * float(dev_new @ dev_new)
            if c_new <= cost:
                lin = res - a_rows @ dq
                lin_c = res_c - c_rows @ dq
                dev_lin = dev + dq[6:]
                predicted = (cost - float(lin @ lin) - float(lin_c @ lin_c)
                             - mu2 * float(dev_lin @ dev_lin))
                gain = np.sqrt(cost) - np.sqrt(c_new)
                # reuse the Jacobian only after a small step that did what the linear model
                # predicted: the chord step then converges nearly as fast as a fresh one
                # (and not while capsule pairs are penalized: their set may change)
                reuse = (step < _CHORD_STEP and chords < _MAX_CHORDS
                         and (cost - c_new) >= 0.5 * predicted
                         and not len(res_c) and not len(rc_new))
                q, points, axes, res, fit_cost = q_new, p_new, a_new, r_new, fit_new
                res_c, state = rc_new, state_new
                dev, cost = dev_new, c_new
                if gain < _STALL * tol:
                    return q, points, axes, it
                factor = max(_LM_MIN, 0.1 * factor)
                if reuse:
                    chords += 1
                else:
                    a_rows = None
                break
            if not fresh:  # a chord step failed: recompute the Jacobian at q first
                a_rows = None
                break
            factor *= 10.0
            if it >= frame.max_it or factor > 1e8:
                return q, points, axes, it
    return q, points, axes, it

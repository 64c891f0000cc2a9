"""Bounded per-frame solvers of the arm problem: scipy's SLSQP (the SQP of the paper, the
baseline) and a box-constrained Gauss-Newton method (the default).

Both minimize f of eq. 2 over the increments ``dtheta`` subject to the box ``lo <= dtheta <= hi``
of eqs 9, 13 and 14, from the same warm start.

- ``slsqp``: :func:`scipy.optimize.minimize` (method SLSQP) with the analytic gradient of eqs
  16-18 (:meth:`FrameObjective.value_and_gradient`); its quasi-Newton Hessian starts from the
  identity at every frame.
- ``gn``: f is a sum of squares ``|R|^2`` (:mod:`imesh.arms.problem`), so an SQP step with the
  Gauss-Newton Hessian ``J^T J`` is a box-bounded linear least-squares problem, solved exactly
  by the active-set method of :func:`imesh.fit.boxqp.solve_box_qp`; a Levenberg-Marquardt term
  keeps steps that do not decrease f from being taken. Near a solution with small residuals it
  converges almost quadratically; every iterate stays inside the box.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fit.boxqp import solve_box_qp
from .problem import FrameObjective

_LM_START = 1e-6  # initial Levenberg-Marquardt factor (relative to the largest diagonal of J^T J)
_LM_MIN = 1e-9
_LM_MAX = 1e8
_WIDEN = 1e-12  # [rad] SLSQP gets a box this wide where a joint is pinned (lo == hi)
#: SLSQP sees f in cm^2: its quasi-Newton start (the identity) and its line search then work at
#: the scale of the problem; in m^2 it stopped up to 17 times above the optimum on the wave.
SLSQP_SCALE = 1e4


@dataclass(frozen=True)
class SolveInfo:
    """What one frame's solve did.

    Attributes:
        iterations: solver iterations (Gauss-Newton steps tried / SLSQP major iterations).
        evaluations: kinematics evaluations (forward kinematics, with or without Jacobians).
        converged: the stopping test was met (not the iteration cap).
    """

    iterations: int
    evaluations: int
    converged: bool


def solve_gn(obj: FrameObjective, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray,
             iterations: int, tolerance: float, ftol: float) -> tuple[np.ndarray, SolveInfo]:
    """Box-constrained Gauss-Newton (Levenberg-Marquardt) on ``|R(dtheta)|^2``.

    Each iteration solves ``min |R + J d|^2 + lambda |d|^2`` subject to
    ``lo - x <= d <= hi - x`` exactly; the step is taken when it lowers f, else lambda grows
    tenfold. Stops when a step would move no joint by more than ``tolerance`` [rad] or lowered
    f by less than ``ftol`` [m^2].

    Returns:
        (dtheta inside [lo, hi], SolveInfo).
    """
    x = np.clip(x0, lo, hi)
    r, jac = obj.residuals_and_jacobian(x)
    cost = float(r @ r)
    factor = _LM_START
    active = None
    it = 0
    while it < iterations:
        h = jac.T @ jac
        g = -(jac.T @ r)
        scale = max(float(h.diagonal().max()), 1e-12)
        while True:
            hd = h.copy()
            hd.flat[:: h.shape[0] + 1] += factor * scale
            d, _, active = solve_box_qp(hd, g, lo - x, hi - x, guess=active)
            it += 1
            if float(np.max(np.abs(d), initial=0.0)) < tolerance:
                return x, SolveInfo(it, obj.evaluations, True)
            x_new = np.clip(x + d, lo, hi)
            r_new = obj.residuals(x_new)
            c_new = float(r_new @ r_new)
            if c_new <= cost:
                gain = cost - c_new
                x, cost = x_new, c_new
                if gain < ftol:
                    return x, SolveInfo(it, obj.evaluations, True)
                factor = max(_LM_MIN, 0.1 * factor)
                break
            factor *= 10.0
            if it >= iterations or factor > _LM_MAX:
                return x, SolveInfo(it, obj.evaluations, False)
        r, jac = obj.residuals_and_jacobian(x)
    return x, SolveInfo(it, obj.evaluations, False)


def solve_slsqp(obj: FrameObjective, lo: np.ndarray, hi: np.ndarray, x0: np.ndarray,
                iterations: int, tolerance: float, ftol: float) -> tuple[np.ndarray, SolveInfo]:
    """scipy SLSQP with the analytic gradient (eqs 16-18) and the bounds of eqs 9, 13, 14;
    ``ftol`` [m^2] is its stopping tolerance on f (``tolerance`` is not used). f and its
    gradient are passed in cm^2 (:data:`SLSQP_SCALE`).

    Returns:
        (dtheta inside [lo, hi], SolveInfo).
    """
    from scipy.optimize import Bounds, minimize  # 0.07 s of imports, for this solver only

    def scaled(x: np.ndarray) -> tuple[float, np.ndarray]:
        f, g = obj.value_and_gradient(x)
        return SLSQP_SCALE * f, SLSQP_SCALE * g

    hi_w = np.maximum(hi, lo + _WIDEN)
    res = minimize(scaled, np.clip(x0, lo, hi_w), jac=True, method="SLSQP",
                   bounds=Bounds(lo, hi_w),
                   options={"maxiter": iterations, "ftol": SLSQP_SCALE * ftol})
    x = np.clip(np.asarray(res.x, dtype=np.float64), lo, hi)
    return x, SolveInfo(int(res.nit), obj.evaluations, bool(res.success))


SOLVER_FUNCTIONS = {"gn": solve_gn, "slsqp": solve_slsqp}

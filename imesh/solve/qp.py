"""One sparse convex QP and the solvers that take it.

    minimize    1/2 x^T P x + c^T x
    subject to  A x = b,   l <= G x <= u,   x_l <= x <= x_u

The whole-body solve builds one of these per SQP iteration (:mod:`imesh.solve.problem`). The
solver was chosen by measurement on the real problem (``benchmarks/wholebody.py``,
docs/wholebody.md): PIQP's sparse interior-point method is the default; Clarabel and OSQP are
kept for comparison.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..core.lazy import optional
from ..errors import OptionError, QpInfeasibleError, SolverError

log = logging.getLogger(__name__)

SOLVERS = ("piqp", "clarabel", "osqp")


@dataclass(frozen=True, eq=False)
class QpProblem:
    """A sparse QP (see the module docstring); infinite bounds allowed."""

    P: sp.csc_matrix
    c: np.ndarray
    A: sp.csc_matrix
    b: np.ndarray
    G: sp.csc_matrix
    l: np.ndarray  # noqa: E741 - the usual name of the lower bound
    u: np.ndarray
    x_l: np.ndarray
    x_u: np.ndarray

    @property
    def n(self) -> int:
        return len(self.c)

    def residuals(self, x: np.ndarray) -> dict[str, float]:
        """Largest violation of the equalities, the inequalities and the bounds at ``x``."""
        gx = self.G @ x
        return {
            "equality": float(np.abs(self.A @ x - self.b).max(initial=0.0)),
            "inequality": float(np.maximum(self.l - gx, gx - self.u).max(initial=0.0)),
            "bounds": float(np.maximum(self.x_l - x, x - self.x_u).max(initial=0.0)),
        }


@dataclass(frozen=True, eq=False)
class QpSolution:
    """Result of one QP solve.

    Attributes:
        x: (n,) float solution.
        status: the solver's status text.
        iterations: solver iterations.
        seconds: wall time of setup and solve [s].
        residuals: largest equality / inequality / bound violation at ``x``.
        kkt_residual: infinity norm of the stationarity residual
            ``P x + c + A^T y + G^T z + z_x`` with the solver's multipliers (NaN if not given).
        attempt: which of PIQP's runs converged (:data:`PIQP_ATTEMPTS`: 0 scaled, 1
            unscaled, 2 scaled again with the plain LDL^T); 0 for the other solvers.
    """

    x: np.ndarray
    status: str
    iterations: int
    seconds: float
    residuals: dict
    kkt_residual: float
    attempt: int = 0


#: PIQP's iteration limit for a first attempt. The whole-body QPs take 23-47 interior-point
#: iterations; one that is still unconverged here is solved again without Ruiz scaling
#: (:data:`PIQP_RETRY_MAX_ITER`).
PIQP_MAX_ITER = 80
#: Iteration limit of the retry without preconditioning. On the HRP-4C wash's fourth QP the
#: scaled problem stalled with a dual residual of 0.06-0.13 through 250 iterations (56 s)
#: where the unscaled one converges in 31 (docs/collision.md); the unscaled runs that
#: converged took 21-31 iterations, one of the 60 s dance's that did not ran 250 (55 s).
PIQP_RETRY_MAX_ITER = 100
#: Iteration limit of the last attempt (:data:`PIQP_LAST_PRECONDITIONER_ITER`): it converged
#: in 75-161 iterations where the first two had not.
PIQP_LAST_MAX_ITER = 250
#: Ruiz equilibration passes of a first attempt (PIQP's default is 10). With 10 the walk's and
#: wave's QPs took about 900 interior-point iterations together, 800 with 3 (then with PIQP's
#: default fine-tune limit; with :data:`PIQP_REG_FINETUNE_LOWER_LIMIT` 483 against 467 on
#: their 18 QPs, docs/speed.md).
PIQP_PRECONDITIONER_ITER = 3
#: PIQP's KKT back end of a first attempt. ``sparse_ldlt_eq_cond`` eliminates the equality
#: rows' multipliers (730 of the 870 equalities define the CoM and momentum auxiliaries) into
#: the primal block before the LDL^T: on every QP of the G1 walk and wave the same
#: interior-point iterations and objectives in 0.95 and 0.99 of the cpu time of
#: ``sparse_ldlt`` (docs/speed.md).
PIQP_KKT_SOLVER = "sparse_ldlt_eq_cond"
#: KKT back end of the retry without preconditioning: unscaled, ``sparse_ldlt_eq_cond`` stalled
#: (250 iterations) on a QP ``sparse_ldlt`` solves in 21 (tests/test_wholebody.py).
PIQP_RETRY_KKT_SOLVER = "sparse_ldlt"
#: Ruiz passes of the last attempt, scaled again with the plain LDL^T, when the unscaled retry
#: fails too. The first QP of the 60 s dance's second chain (25,550 unknowns) stalls scaled with
#: ``sparse_ldlt_eq_cond`` (dual residual 0.53 after 80 iterations, still unconverged after
#: 250), is declared dual infeasible unscaled (6 iterations), and converges with 5 passes and
#: ``sparse_ldlt`` in 75 (25 cpu s, the objective of Clarabel's solution to 8 digits, which
#: took 108 cpu s; docs/clips-flight.md).
PIQP_LAST_PRECONDITIONER_ITER = 5
#: Smallest proximal regularization (rho, delta) of PIQP's "fine-tune" mode, which it enters
#: after several iterations without a primal or dual update; PIQP's default is 1e-13, below its
#: ordinary lower limit (``reg_lower_limit``, 1e-10). On the whole-body QPs (cost gradient up to
#: 1e4, rows up to 900) a KKT system regularized by 1e-13 is factorized too inexactly to make
#: progress: the G1 wave's first two QPs stalled there (regularization 3e-13, steps of 1e-3 to
#: 1e-1, the dual residual at 0.1-0.3 through 250 iterations) and converge in 31 and 26 with
#: the fine-tune limit at the ordinary one, to the same objective as the unscaled run's
#: (docs/speed.md). Where 1e-13 was better: iCub's first QP (generated from its URDF) keeps
#: its duality gap open at 1e-10 and goes on to the unscaled retry (358 -> 378 iterations).
PIQP_REG_FINETUNE_LOWER_LIMIT = 1e-10


def accepted_residual(tol: float) -> float:
    """Largest constraint violation of a QP solution :func:`solve_qp` accepts at solver
    tolerance ``tol``."""
    return 1e3 * tol + 1e-6


@dataclass(frozen=True)
class _Attempt:
    """One PIQP run's settings: Ruiz passes, iteration limit, KKT back end, duality-gap test."""

    preconditioner_iter: int
    max_iter: int
    kkt_solver: str
    gap_check: bool


#: PIQP's runs, tried in turn until one converges: scaled, unscaled, scaled again with the
#: plain LDL^T (:func:`solve_qp`'s ``first_attempt`` skips the first ones).
PIQP_ATTEMPTS = ("scaled", "unscaled", "scaled again")


def _piqp_attempts(gap_check: bool) -> list[_Attempt]:
    """The runs of :data:`PIQP_ATTEMPTS`."""
    first = _Attempt(PIQP_PRECONDITIONER_ITER, PIQP_MAX_ITER, PIQP_KKT_SOLVER, gap_check)
    # unscaled, the duality gap can stay open where the residuals have met the tolerance
    # (iCub's QPs: 250 iterations without it closing, 27 to the residuals)
    retry = _Attempt(0, PIQP_RETRY_MAX_ITER, PIQP_RETRY_KKT_SOLVER, False)
    last = _Attempt(PIQP_LAST_PRECONDITIONER_ITER, PIQP_LAST_MAX_ITER, PIQP_RETRY_KKT_SOLVER,
                    gap_check)
    return [first, retry, last]


def _solve_piqp(p: QpProblem, tol: float, gap_check: bool = True, first_attempt: int = 0):
    piqp = optional("piqp", "pip install piqp", "the whole-body QP (solver piqp)")

    def run(a: _Attempt):
        solver = piqp.SparseSolver()
        solver.settings.eps_abs = tol
        solver.settings.eps_rel = 0.0
        solver.settings.verbose = False
        solver.settings.check_duality_gap = a.gap_check
        solver.settings.eps_duality_gap_abs = tol  # PIQP's default (1e-8) is not ``tol``'s
        solver.settings.max_iter = a.max_iter
        solver.settings.kkt_solver = getattr(piqp.KKTSolver, a.kkt_solver)
        solver.settings.preconditioner_iter = a.preconditioner_iter
        solver.settings.reg_finetune_lower_limit = PIQP_REG_FINETUNE_LOWER_LIMIT
        big = 1e30  # PIQP takes infinite bounds as +-inf; keep them finite for the KKT check
        solver.setup(p.P, p.c, p.A, p.b, p.G, np.maximum(p.l, -big), np.minimum(p.u, big),
                     p.x_l, p.x_u)
        return solver.solve(), solver.result

    iterations, infeasible = 0, 0
    attempts = _piqp_attempts(gap_check)
    for attempt in range(first_attempt, len(attempts)):
        a = attempts[attempt]
        status, r = run(a)
        iterations += int(r.info.iter)
        if status == piqp.PIQP_SOLVED:
            break
        # a run stopped on another status whose point meets the constraints to the accepted
        # residual is kept, as any solver's is (the JVRC-1 leap's first QP: "primal
        # infeasible" at 17 iterations with every row met within 1e-2)
        x = np.asarray(r.x)
        if status != piqp.PIQP_MAX_ITER_REACHED and np.all(np.isfinite(x)) \
                and max(p.residuals(x).values()) <= accepted_residual(tol):
            break
        # two runs with different scalings finding the same certificate of primal
        # infeasibility: no solver will find a point (Clarabel took 69 cpu s to say so on a
        # window of the 60 s dance, whose trust region was 12 mm short of a velocity row)
        infeasible += status == piqp.PIQP_PRIMAL_INFEASIBLE
        if infeasible == 2:
            break
        log.info("PIQP (%d Ruiz passes, %s): %s after %d iterations (dual residual %.3g); "
                 "trying the next settings", a.preconditioner_iter, a.kkt_solver, status,
                 int(r.info.iter), r.info.dual_res)
    x = np.asarray(r.x)
    # PIQP's multipliers: y (equalities), z_l/z_u (G rows), z_bl/z_bu (bounds)
    stat = p.P @ x + p.c + p.A.T @ np.asarray(r.y) \
        + p.G.T @ (np.asarray(r.z_u) - np.asarray(r.z_l)) \
        + (np.asarray(r.z_bu) - np.asarray(r.z_bl))
    return (x, str(status), iterations, float(np.abs(stat).max(initial=0.0)), attempt,
            infeasible == 2)


def _solve_clarabel(p: QpProblem, tol: float, gap_check: bool = True, first_attempt: int = 0):
    clarabel = optional("clarabel", "pip install clarabel", "the whole-body QP (solver clarabel)")
    finite_lo, finite_hi = np.isfinite(p.l), np.isfinite(p.u)
    bl, bu = np.isfinite(p.x_l), np.isfinite(p.x_u)
    eye = sp.identity(p.n, format="csc")
    # Clarabel: A x + s = b, s in cones: zero cone for equalities, nonnegative for the rest
    blocks = [p.A, -p.G[finite_lo], p.G[finite_hi], -eye[bl], eye[bu]]
    rhs = [p.b, -p.l[finite_lo], p.u[finite_hi], -p.x_l[bl], p.x_u[bu]]
    A = sp.vstack(blocks, format="csc")
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_feas = tol
    settings.tol_gap_rel = tol
    cones = [clarabel.ZeroConeT(p.A.shape[0]),
             clarabel.NonnegativeConeT(A.shape[0] - p.A.shape[0])]
    solver = clarabel.DefaultSolver(sp.triu(p.P, format="csc"), p.c, A, np.concatenate(rhs),
                                    cones, settings)
    sol = solver.solve()
    return (np.asarray(sol.x), str(sol.status), int(sol.iterations), float("nan"), 0,
            str(sol.status) == "PrimalInfeasible")


def _solve_osqp(p: QpProblem, tol: float, gap_check: bool = True, first_attempt: int = 0):
    osqp = optional("osqp", "pip install osqp", "the whole-body QP (solver osqp)")
    eye = sp.identity(p.n, format="csc")
    A = sp.vstack([p.A, p.G, eye], format="csc")
    lo = np.concatenate([p.b, p.l, p.x_l])
    hi = np.concatenate([p.b, p.u, p.x_u])
    solver = osqp.OSQP()
    solver.setup(sp.triu(p.P, format="csc"), p.c, A, lo, hi, eps_abs=tol, eps_rel=0.0,
                 max_iter=20000, polishing=True, verbose=False)
    r = solver.solve()
    return (np.asarray(r.x), str(r.info.status), int(r.info.iter), float("nan"), 0,
            str(r.info.status) == "primal infeasible")


def solve_qp(problem: QpProblem, solver: str = "piqp", tol: float = 1e-7,
             gap_check: bool = True, first_attempt: int = 0) -> QpSolution:
    """Solve a QP with one of :data:`SOLVERS`.

    ``gap_check=False`` lets PIQP stop on its primal and dual residuals alone: on the QPs of a
    window of a long clip (:mod:`imesh.solve.windows`) its duality-gap test did not close in
    250 iterations where the residuals met ``tol`` after 23, at the same objective to 7
    digits (docs/speed.md). PIQP's runs in turn (:data:`PIQP_ATTEMPTS`): scaled, unscaled
    (no preconditioning, :data:`PIQP_RETRY_KKT_SOLVER`), scaled again with
    :data:`PIQP_LAST_PRECONDITIONER_ITER` passes and the plain LDL^T; it stops at the first
    that converges, or once two of them certify primal infeasibility. ``first_attempt``
    starts at that run: the SQP asks for the run a QP of its solve needed.

    Raises:
        OptionError: unknown solver or first attempt.
        QpInfeasibleError: the solver certified that no point meets the constraints (PIQP: two
            runs with different scalings).
        SolverError: the solver failed or returned a non-finite point (the message carries the
            status and the residuals).
    """
    run = {"piqp": _solve_piqp, "clarabel": _solve_clarabel, "osqp": _solve_osqp}.get(solver)
    if run is None:
        raise OptionError("QP solver", solver, SOLVERS)
    if first_attempt not in range(len(PIQP_ATTEMPTS)):
        raise OptionError("first_attempt", first_attempt,
                          [f"{i} ({name})" for i, name in enumerate(PIQP_ATTEMPTS)])
    t0 = time.perf_counter()
    x, status, iterations, kkt, attempt, infeasible = run(problem, tol, gap_check,
                                                          first_attempt)
    seconds = time.perf_counter() - t0
    if infeasible:
        raise QpInfeasibleError(f"QP solver {solver}: {status} after {iterations} iterations "
                                f"({seconds:.1f} s)")
    if not np.all(np.isfinite(x)):
        raise SolverError(f"QP solver {solver} returned a non-finite point (status {status})")
    res = problem.residuals(x)
    if max(res.values()) > accepted_residual(tol):
        raise SolverError(f"QP solver {solver} stopped with status {status}: constraint "
                          f"residuals {res}", residual=max(res.values()))
    return QpSolution(x=x, status=status, iterations=iterations, seconds=seconds,
                      residuals=res, kkt_residual=kkt, attempt=attempt)

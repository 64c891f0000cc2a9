"""QP solvers on the real whole-body problem: the first SQP step of a retarget, every solver.

    python benchmarks/qp_solvers.py [--clip cmu_02_01_walk.bvh] [--robot g1] [--fps 30]
                                    [--tol 1e-7] [--repeat 3]
    python benchmarks/qp_solvers.py --kkt [--clip ...] [--robot ...] [--repeat 3]

Builds the first QP of the whole-body solve of the clip (``imesh.retarget`` up to the first
``solve_qp`` call) and solves it with PIQP (its two sparse KKT back ends), Clarabel, OSQP and
ProxSuite (the last two from ``pip install -e .[bench]``), each directly (no qpsolvers layer),
and our own banded interior-point solver (``_banded_ipm.py``: the KKT system in a band, LAPACK's
banded LU).
Prints wall time (best of ``--repeat``), iterations, the largest constraint violation and the
objective; the solver the solve uses by default (``WholeBodyConfig.sqp.solver``) is chosen from
this table (docs/wholebody.md).

``--kkt``: every QP of the whole-body solve (captured from ``solve_qp`` during a retarget with
default settings) solved again as the solve solves it (``imesh.solve.qp.solve_qp``, its
tolerance and PIQP settings) with each of PIQP's sparse KKT back ends
(``imesh.solve.qp.PIQP_KKT_SOLVER``): cpu seconds of all of them (best of ``--repeat``
rounds, the back ends taken in turn within a round), interior-point iterations, the largest
distance of a solution to the ``sparse_ldlt`` one and of its objective (docs/speed.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

import numpy as np
import scipy.sparse as sp
from _data import data_root, load


class _Captured(Exception):
    pass


def captured_qps(clip: str, robot_name: str, fps: float = 30.0, first_only: bool = False
                 ) -> list:
    """The QpProblems the whole-body SQP of ``clip`` on ``robot_name`` solves (``imesh.retarget``
    with default settings at ``fps``), each solved as usual; ``first_only``: the first one,
    the retarget stopped there."""
    import imesh.solve.sqp as sqp
    from imesh.io import load_motion
    from imesh.pipeline.retarget import RetargetConfig, retarget

    box = []
    real = sqp.solve_qp

    def capture(qp, *args, **kwargs):  # the signature of imesh.solve.qp.solve_qp
        box.append(qp)
        if first_only:
            raise _Captured
        return real(qp, *args, **kwargs)

    sqp.solve_qp = capture
    try:
        retarget(load_motion(data_root() / "mocap" / clip), load(robot_name),
                 config=dataclasses.replace(RetargetConfig(), fps=fps))
    except _Captured:
        pass
    finally:
        sqp.solve_qp = real
    return box


KKT_SOLVERS = ("sparse_ldlt", "sparse_ldlt_eq_cond", "sparse_ldlt_ineq_cond", "sparse_ldlt_cond")


def kkt_table(clip: str, robot_name: str, repeat: int) -> None:
    """Print the ``--kkt`` table (see the module docstring)."""
    import imesh.solve.qp as qpmod
    from imesh.solve import SqpOptions

    qps = captured_qps(clip, robot_name)
    tol = SqpOptions().qp_tolerance
    print(f"{clip} on {robot_name}: {len(qps)} QPs of {qps[0].n} variables, "
          f"{qps[0].A.shape[0]} equalities, {qps[0].G.shape[0]} inequality rows, tolerance {tol:g}")
    best = {k: np.inf for k in KKT_SOLVERS}
    sols = {}
    default = qpmod.PIQP_KKT_SOLVER
    try:
        for _ in range(repeat):
            for kkt in KKT_SOLVERS:
                qpmod.PIQP_KKT_SOLVER = kkt
                t0 = time.process_time()
                sols[kkt] = [qpmod.solve_qp(qp, "piqp", tol) for qp in qps]
                best[kkt] = min(best[kkt], time.process_time() - t0)
    finally:
        qpmod.PIQP_KKT_SOLVER = default
    ref = sols["sparse_ldlt"]
    print(f"{'KKT back end':<24} {'cpu s':>7} {'/ ldlt':>7} {'PIQP iterations':>16} "
          f"{'max |dx|':>9} {'max |dobj|':>10}")
    for kkt in KKT_SOLVERS:
        dx = max(float(np.abs(a.x - b.x).max()) for a, b in zip(sols[kkt], ref, strict=True))
        dobj = max(abs(_objective(q, a.x) - _objective(q, b.x))
                   for q, a, b in zip(qps, sols[kkt], ref, strict=True))
        its = sum(s.iterations for s in sols[kkt])
        print(f"{kkt:<24} {best[kkt]:7.2f} {best[kkt] / best['sparse_ldlt']:7.3f} {its:16d} "
              f"{dx:9.1e} {dobj:10.1e}")


def _objective(qp, x: np.ndarray) -> float:
    return float(0.5 * x @ (qp.P @ x) + qp.c @ x)


def _piqp(qp, tol, kkt):
    import piqp

    s = piqp.SparseSolver()
    s.settings.eps_abs, s.settings.eps_rel = tol, 0.0
    s.settings.kkt_solver = getattr(piqp.KKTSolver, kkt)
    s.setup(qp.P, qp.c, qp.A, qp.b, qp.G, np.maximum(qp.l, -1e30), np.minimum(qp.u, 1e30),
            qp.x_l, qp.x_u)
    status = s.solve()
    return np.asarray(s.result.x), str(status).split(".")[-1], int(s.result.info.iter)


def _proxsuite(qp, tol):
    import proxsuite

    eye = sp.identity(qp.n, format="csc")
    C = sp.vstack([qp.G, eye], format="csc")
    lo = np.maximum(np.concatenate([qp.l, qp.x_l]), -1e20)
    hi = np.minimum(np.concatenate([qp.u, qp.x_u]), 1e20)
    s = proxsuite.proxqp.sparse.QP(qp.n, qp.A.shape[0], C.shape[0])
    s.settings.eps_abs, s.settings.eps_rel = tol, 0.0
    s.settings.max_iter = 10000
    s.init(sp.triu(qp.P, format="csc"), qp.c, qp.A, qp.b, C, lo, hi)
    s.solve()
    return np.asarray(s.results.x), str(s.results.info.status).split(".")[-1], \
        int(s.results.info.iter)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default="cmu_02_01_walk.bvh")
    ap.add_argument("--robot", default="g1")
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--tol", type=float, default=1e-7)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--solvers", nargs="+", help="only these rows (names as printed)")
    ap.add_argument("--kkt", action="store_true",
                    help="every QP of the solve with each of PIQP's sparse KKT back ends")
    args = ap.parse_args(argv)
    if args.kkt:
        kkt_table(args.clip, args.robot, args.repeat)
        return 0

    from imesh.solve.qp import solve_qp

    qp = captured_qps(args.clip, args.robot, args.fps, first_only=True)[0]
    print(f"{args.clip} on {args.robot} at {args.fps:g} fps: {qp.n} variables, "
          f"{qp.A.shape[0]} equalities, {qp.G.shape[0]} inequality rows, nnz P {qp.P.nnz}")
    runs = {
        "piqp sparse_ldlt": lambda: _piqp(qp, args.tol, "sparse_ldlt"),
        "piqp sparse_ldlt_eq_cond": lambda: _piqp(qp, args.tol, "sparse_ldlt_eq_cond"),
        "piqp sparse_multistage": lambda: _piqp(qp, args.tol, "sparse_multistage"),
    }
    for name in ("clarabel", "osqp"):
        def run(name=name):
            sol = solve_qp(qp, name, args.tol)
            return sol.x, sol.status, sol.iterations
        runs[name] = run
    runs["proxsuite sparse"] = lambda: _proxsuite(qp, args.tol)

    def own():
        from _banded_ipm import solve_banded_qp

        x, status, it, bw = solve_banded_qp(qp, args.tol)
        return x, f"{status} (band {bw})", it
    runs["own banded IPM"] = own
    print(f"{'solver':<24} {'seconds':>8} {'status':>22} {'iter':>6} {'violation':>10} "
          f"{'objective':>14}")
    for name, run in runs.items():
        if args.solvers and name not in args.solvers:
            continue
        best = np.inf
        try:
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                x, status, it = run()
                best = min(best, time.perf_counter() - t0)
        except Exception as exc:  # a row per solver, whatever fails
            print(f"{name:<24} failed: {str(exc)[:80]}")
            continue
        viol = max(qp.residuals(x).values())
        obj = 0.5 * x @ (qp.P @ x) + qp.c @ x
        print(f"{name:<24} {best:8.3f} {status:>22} {it:6d} {viol:10.1e} {obj:14.6f}")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

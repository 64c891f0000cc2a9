"""Dense QP solvers on the whole-body controller's real QPs (why imesh uses DAQP).

    python benchmarks/wbc_qp.py [--robot g1] [--motion OUT.npz] [--steps 600]

Captures the QPs of the first ``--steps`` control steps of the DART check (the nominal pose,
or ``--motion``), then solves each with DAQP, quadprog and ProxSuite's dense solver (those
installed: ``pip install quadprog proxsuite``) and prints the median and worst time per QP,
the largest equality residual and the largest difference to DAQP's solution.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from _data import load


def _daqp(H, c, E, e, G, lo, up):
    from imesh.physics.qp import dense_qp

    return dense_qp(H, c, E, e, G, lo, up)


def _quadprog(H, c, E, e, G, lo, up):
    import quadprog

    fu, fl = np.isfinite(up), np.isfinite(lo)
    C = np.vstack([E, -G[fu], G[fl]]).T
    b = np.concatenate([e, -up[fu], lo[fl]])
    return quadprog.solve_qp(H, -c, C, b, len(e))[0]


def _proxsuite(H, c, E, e, G, lo, up):
    import proxsuite

    qp = proxsuite.proxqp.dense.QP(len(c), len(e), len(lo))
    qp.settings.eps_abs = 1e-9
    qp.init(H, c, E, e, G, np.maximum(lo, -1e20), np.minimum(up, 1e20))
    qp.solve()
    return qp.results.x


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="g1")
    ap.add_argument("--motion")
    ap.add_argument("--steps", type=int, default=600)
    args = ap.parse_args(argv)

    from imesh.core.robot_motion import RobotMotion
    from imesh.evaluate import load_motion_file
    from imesh.physics import PhysicsConfig, TimingConfig
    from imesh.physics.controllers import WbcTracker
    from imesh.physics.reference import build_reference
    from imesh.physics.world import DartRobot

    robot = load(args.robot)
    if args.motion:
        motion = load_motion_file(args.motion, robot)
    else:
        motion = RobotMotion(q=np.repeat(robot.q_nominal[None], 61, axis=0), fps=30.0,
                             robot=robot.name, joint_names=robot.joint_names)
    config = PhysicsConfig(timing=TimingConfig(settle_s=0.0))
    ref = build_reference(robot, motion.q, motion.fps)
    sim = DartRobot(robot, config)
    tracker = WbcTracker(sim, ref, config)
    captured = []
    solve = tracker.controller._solve

    def capture(*qp):
        captured.append(qp)
        return solve(*qp)

    tracker.controller._solve = capture
    sim.set_state(ref.q[0])
    skel = sim.skeleton
    for k in range(args.steps):
        tracker(k, k, True, skel.getPositions(), skel.getVelocities())
        sim.world.step()
    sizes = {(len(qp[1]), len(qp[3]), len(qp[5])) for qp in captured}
    print(f"{len(captured)} QPs of {args.robot}, (unknowns, equalities, inequalities): "
          f"{sorted(sizes)}")
    print(f"{'solver':<10} {'median us':>9} {'max us':>8} {'eq resid':>9} {'vs daqp':>9}")
    reference = [_daqp(*qp) for qp in captured]
    for name, fn in (("daqp", _daqp), ("quadprog", _quadprog), ("proxsuite", _proxsuite)):
        try:
            fn(*captured[0])
        except ImportError:
            print(f"{name:<10} not installed")
            continue
        times, resid, diff = [], 0.0, 0.0
        for qp, x_ref in zip(captured, reference, strict=True):
            t0 = time.perf_counter()
            x = fn(*qp)
            times.append(time.perf_counter() - t0)
            resid = max(resid, float(np.abs(qp[2] @ x - qp[3]).max()))
            if x_ref is not None:
                diff = max(diff, float(np.abs(x - x_ref).max()))
        print(f"{name:<10} {1e6 * np.median(times):>9.0f} {1e6 * np.max(times):>8.0f} "
              f"{resid:>9.1e} {diff:>9.1e}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

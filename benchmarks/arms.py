"""Arm imitation of Kim, Kim & Oh 2005 (imesh.arms) on the CMU wave: bounds, errors, speed,
solvers, ablations and the DART PID check, per robot.

    python benchmarks/arms.py                      # everything, jvrc1 g1 hrp4c
    python benchmarks/arms.py --robots jvrc1 --no-physics
    python benchmarks/arms.py --refine             # also the main pipeline's --fit sqp rows

Tables:

1. the wave with the default settings: per arm rho, frames outside the position / velocity /
   acceleration limits (backward differences of the output, against the robot's limits),
   hand-point RMS [mm], upper-arm orientation RMS [deg], ms per frame per arm, and the DART PID
   (fixed base) tracking RMS of the arm joints;
2. solvers: the same per-frame problems (the boxes of the default run, from dtheta = 0) solved
   by the box-constrained Gauss-Newton method and by scipy SLSQP: time, iterations, objective
   ratio; and whole runs with each;
3. ablation W10 = 0 / 0.1 / 1 (default) / 10;
4. ablation of the velocity bounds: off / on (acceleration bounds off in both, so the velocity
   bounds' own cost shows), then all bounds (per frame, and with the look-ahead projection), on
   the wave and on the wave played 2.5x faster
   ("x2.5": the same frames at 2.5 times the frame rate), where the human is faster than the
   motors ("max v/vmax" of the row without velocity bounds);
5. the human low-pass: 8 Hz (the main pipeline's) vs 3 Hz (the arm mode's default), each with
   Kim's per-frame bounds and with the look-ahead projection (``ArmsConfig(lookahead=True)``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from _data import data_root, load

ROBOTS = ("jvrc1", "g1", "hrp4c")
CLIP = "cmu_141_16_wave_hello.bvh"
SPEEDUP = 2.5


def _rule(head: str) -> None:
    print(head)
    print("-" * len(head))


def _outside(a) -> str:
    c = a.violations.counts()
    return f"{c['position']}/{c['velocity']}/{c['acceleration']}"


def wave_table(robots, clip, physics: bool) -> dict:
    """Table 1; returns the default results per robot (reused by the other tables)."""
    from imesh.arms import ArmsConfig, imitate_arms

    results = {}
    print(f"\n## 1. {CLIP} with the default settings (GN solver, W10 = 1, all bounds, 3 Hz)")
    _rule(f"{'robot':6s} {'arm':5s} {'dof':>3s} {'rho':>5s} {'outside p/v/a':>13s} "
          f"{'hand RMS mm':>11s} {'max mm':>7s} {'upper deg':>9s} {'ms/frame':>8s} "
          f"{'iters':>5s} {'at v/a bound':>12s} {'PID RMS rad':>11s} {'PID max':>7s} "
          f"{'stable':>6s}")
    for name in robots:
        robot = load(name)
        res = imitate_arms(robot, clip, config=ArmsConfig())
        results[name] = res
        tracking = None
        if physics:
            from imesh.physics.arms import track_arms

            tracking = {side: track_arms(robot, res.motion, a.arm.joints)
                        for side, a in res.arms.items()}
        for side, a in res.arms.items():
            s = a.summary()
            pid = (f"{tracking[side].arm_rms_rad:11.4f} {tracking[side].arm_max_rad:7.3f} "
                   f"{'yes' if not tracking[side].diverged else 'NO':>6s}") if tracking else ""
            print(f"{name:6s} {side:5s} {a.arm.n:3d} {s['rho']:5.2f} {_outside(a):>13s} "
                  f"{s['hand_rms_mm']:11.1f} {s['hand_max_mm']:7.1f} "
                  f"{s['upper_arm_rms_deg']:9.2f} {s['ms_per_frame']:8.3f} "
                  f"{s['mean_iterations']:5.2f} "
                  f"{s['frames_at_velocity_bound']:>5d}/{s['frames_at_acceleration_bound']:<6d} "
                  + pid)
    return results


def solver_table(robots, clip, results) -> None:
    """Table 2: same problems for both solvers, then whole runs."""
    from imesh.arms import ArmsConfig, FrameObjective, imitate_arms
    from imesh.arms.solvers import solve_gn, solve_slsqp

    cfg = ArmsConfig()
    print("\n## 2. solvers on the same per-frame problems (all frames >= 1 of table 1, both "
          "arms, from dtheta = 0)")
    _rule(f"{'robot':6s} {'solver':6s} {'ms/frame/arm':>12s} {'iters':>6s} {'FK evals':>8s} "
          f"{'f/f_gn median':>13s} {'f/f_gn max':>10s} {'f/f_gn min':>10s} {'converged':>9s}")
    for name in robots:
        res = results[name]
        stats = {"gn": ([], [], [], [], []), "slsqp": ([], [], [], [], [])}
        for a in res.arms.values():
            cols = 7 + a.arm.joint_index
            for t in range(1, res.motion.n_frames):
                q_prev = res.motion.q[t - 1]
                base = q_prev[cols]
                lo, hi = a.box_lo[t] - base, a.box_hi[t] - base
                for solver, fn in (("gn", solve_gn), ("slsqp", solve_slsqp)):
                    obj = FrameObjective(a.arm, q_prev, a.targets.hand_m[t],
                                         a.targets.weights[t], a.targets.upper_arm_dir[t],
                                         cfg.upper_arm_weight, cfg.damping)
                    t0 = time.perf_counter()
                    x, info = fn(obj, lo, hi, np.zeros(a.arm.n), cfg.iterations,
                                 cfg.tolerance_rad, cfg.objective_tolerance)
                    dt = time.perf_counter() - t0
                    st = stats[solver]
                    st[0].append(dt)
                    st[1].append(info.iterations)
                    st[2].append(info.evaluations)
                    st[3].append(obj.value(x))
                    st[4].append(info.converged)
        f_gn = np.array(stats["gn"][3])
        for solver, st in stats.items():
            ratio = np.array(st[3]) / np.maximum(f_gn, 1e-300)
            print(f"{name:6s} {solver:6s} {1e3 * np.mean(st[0]):12.3f} {np.mean(st[1]):6.2f} "
                  f"{np.mean(st[2]):8.2f} {np.median(ratio):13.9f} {ratio.max():10.6f} "
                  f"{ratio.min():10.6f} {np.mean(st[4]):9.3f}")
    print("\n   whole runs (each solver's own trajectory)")
    _rule(f"{'robot':6s} {'solver':6s} {'ms/frame/arm':>12s} {'hand RMS mm L/R':>15s} "
          f"{'upper deg L/R':>13s} {'outside p/v/a':>13s}")
    for name in robots:
        robot = load(name)
        for solver in ("gn", "slsqp"):
            res = (results[name] if solver == "gn"
                   else imitate_arms(robot, clip, config=ArmsConfig(solver=solver)))
            a = res.arms
            outside = res.report()["frames_outside"]
            print(f"{name:6s} {solver:6s} {res.report()['ms_per_frame_per_arm']:12.3f} "
                  f"{a['left'].hand_rms_mm:7.1f}/{a['right'].hand_rms_mm:<7.1f} "
                  f"{a['left'].upper_arm_rms_deg:6.2f}/{a['right'].upper_arm_rms_deg:<6.2f} "
                  f"{outside['position']:>7d}/{outside['velocity']}/{outside['acceleration']}")


def w10_table(robots, clip) -> None:
    """Table 3: the upper-arm term of eq. 2 off and on."""
    from imesh.arms import ArmsConfig, imitate_arms

    print("\n## 3. ablation: W10 (weight of the upper-arm orientation error, eq. 2)")
    _rule(f"{'robot':6s} {'W10':>5s} {'upper deg L':>11s} {'upper deg R':>11s} "
          f"{'hand mm L':>9s} {'hand mm R':>9s} {'outside p/v/a':>13s}")
    for name in robots:
        robot = load(name)
        for w10 in (0.0, 0.1, 1.0, 10.0):
            res = imitate_arms(robot, clip, config=ArmsConfig(upper_arm_weight=w10))
            a = res.arms
            o = res.report()["frames_outside"]
            print(f"{name:6s} {w10:5.1f} {a['left'].upper_arm_rms_deg:11.2f} "
                  f"{a['right'].upper_arm_rms_deg:11.2f} {a['left'].hand_rms_mm:9.1f} "
                  f"{a['right'].hand_rms_mm:9.1f} "
                  f"{o['position']:>7d}/{o['velocity']}/{o['acceleration']}")


def velocity_table(robots, clip) -> None:
    """Table 4: velocity bounds off / on, where the human is faster than the motors."""
    from imesh.arms import ArmsConfig, imitate_arms
    from imesh.core.limits import LimitOptions

    fast = clip.replace(fps=clip.fps * SPEEDUP, source=f"{clip.source} x{SPEEDUP}")
    print("\n## 4. ablation: velocity bounds (eq. 13) off / on; right (waving) arm; 'max v/vmax'"
          " of the 'pos' row = how much faster than its motors the unbounded arm moves")
    _rule(f"{'robot':6s} {'clip':5s} {'bounds':12s} {'hand RMS mm':>11s} {'upper deg':>9s} "
          f"{'max v/vmax':>10s} {'outside p/v/a':>13s} {'cost mm':>7s}")
    settings = (("pos", dict(limits=LimitOptions(enforce_velocity=False,
                                                 enforce_acceleration=False))),
                ("pos+vel", dict(limits=LimitOptions(enforce_acceleration=False))),
                ("pos+vel+acc", {}),
                ("all,lookahd", dict(lookahead=True)))
    for name in robots:
        robot = load(name)
        for label, motion in (("x1", clip), (f"x{SPEEDUP:g}", fast)):
            free = None
            for bounds, kw in settings:
                res = imitate_arms(robot, motion, config=ArmsConfig(sides=("right",), **kw))
                a = res.arms["right"]
                if free is None:
                    free = a
                cost = a.hand_rms_mm - free.hand_rms_mm
                print(f"{name:6s} {label:5s} {bounds:12s} {a.hand_rms_mm:11.1f} "
                      f"{a.upper_arm_rms_deg:9.2f} {a.violations.worst_velocity_ratio:10.2f} "
                      f"{_outside(a):>13s} {cost:7.1f}")


def lowpass_table(robots, clip) -> None:
    """Table 5: the greedy per-frame tracker against a target it cannot follow."""
    from imesh.arms import ArmsConfig, imitate_arms

    print("\n## 5. human low-pass: 8 Hz keeps the wave's 4.7 Hz hand flap (hundreds of rad/s^2 "
          "at the wrist), 3 Hz (default) removes it; right arm, all bounds")
    _rule(f"{'robot':6s} {'low-pass':>8s} {'scheme':10s} {'hand RMS mm':>11s} "
          f"{'vs 8 Hz targets':>15s} {'upper deg':>9s} {'outside p/v/a':>13s}")
    for name in robots:
        robot = load(name)
        ref = None
        for hz in (8.0, 3.0):
            for scheme in ("per-frame", "look-ahead"):
                config = ArmsConfig(sides=("right",), lowpass_hz=hz,
                                    lookahead=scheme == "look-ahead")
                a = imitate_arms(robot, clip, config=config).arms["right"]
                ref = a if ref is None else ref
                err = np.linalg.norm(a.robot_points_m[:, :3] - ref.targets.hand_m, axis=2)
                vs8 = 1e3 * np.sqrt(np.mean(err[a.hand_mask & ref.hand_mask] ** 2))
                print(f"{name:6s} {hz:8.0f} {scheme:10s} {a.hand_rms_mm:11.1f} {vs8:15.1f} "
                      f"{a.upper_arm_rms_deg:9.2f} {_outside(a):>13s}")


def refine_table(robots, clip) -> None:
    """The main pipeline (DLS) and its arms re-solved by the SQP (--fit sqp)."""
    from imesh.arms import refine_arms
    from imesh.pipeline.retarget import retarget

    print("\n## 6. --fit sqp: the main pipeline's arms (DLS) re-solved; errors against the same "
          "shoulder-anchored targets")
    _rule(f"{'robot':6s} {'arm':5s} {'DLS hand mm':>11s} {'SQP hand mm':>11s} "
          f"{'DLS upper deg':>13s} {'SQP upper deg':>13s} {'SQP outside p/v/a':>17s} "
          f"{'ms/frame':>8s}")
    for name in robots:
        robot = load(name)
        result = retarget(clip, robot)
        _, rep = refine_arms(robot, result.motion, result.adapted)
        for side, a in rep["arms"].items():
            b = rep["before"][side]
            o = a["frames_outside"]
            print(f"{name:6s} {side:5s} {b['hand_rms_mm']:11.1f} {a['hand_rms_mm']:11.1f} "
                  f"{b['upper_arm_rms_deg']:13.2f} {a['upper_arm_rms_deg']:13.2f} "
                  f"{o['position']:>11d}/{o['velocity']}/{o['acceleration']} "
                  f"{a['ms_per_frame']:8.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS))
    parser.add_argument("--no-physics", action="store_true", help="skip the DART PID check")
    parser.add_argument("--refine", action="store_true",
                        help="also the main pipeline with --fit sqp (table 6)")
    args = parser.parse_args()

    import logging

    import imesh

    logging.basicConfig(level=logging.ERROR)
    clip = imesh.load_motion(Path(data_root()) / "mocap" / CLIP)
    print(f"# {CLIP}: {clip.n_frames} frames at {clip.fps:.0f} fps; robots {args.robots}")
    results = wave_table(args.robots, clip, physics=not args.no_physics)
    solver_table(args.robots, clip, results)
    w10_table(args.robots, clip)
    velocity_table(args.robots, clip)
    lowpass_table(args.robots, clip)
    if args.refine:
        refine_table(args.robots, clip)


if __name__ == "__main__":
    main()

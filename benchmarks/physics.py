"""The DART check on the written outputs of the whole-body solve: one row per run and
controller (issue 29's table).

    python benchmarks/physics.py [--motions DIR] [--robots jvrc1 g1 hrp4c] [--clips ...]
                                 [--controllers wbc kinematic spd]

``--motions`` is the folder ``benchmarks/wholebody.py --out`` wrote (``<clip>_<robot>.npz``);
a missing motion is retargeted with default settings and written there first. Every motion is
read back from its file and checked by ``imesh.physics.simulate_motion`` (what
``imesh evaluate OUT.npz --physics --controller C`` runs). Columns: fell, survived [s] of the
duration, key-point tracking RMS / max [mm], joint tracking RMS [rad], base drift at the end
[mm], largest sole slip within a support phase [mm], largest torque ratio, fraction of steps
saturated (clamped), friction ratio, smallest centre-of-pressure margin to the sole edge [mm],
real-time factor.

``--perturb N`` checks each run N more times with the reference's joint angles moved by
independent N(0, ``--perturb-rad``) noise (default 1e-6 rad, far below anything a plan or a
file format decides) and prints, per run, the range of the largest key-point error and of the
slip over the nominal and the perturbed checks: a closed-loop simulation with contacts is
sensitive to its input, and a figure near a bound is only met if it is met across this range.

    python benchmarks/physics.py --motions DIR --controllers wbc --perturb 5
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path

import numpy as np
from _data import data_root, load

CLIPS = ("cmu_02_01_walk.bvh", "cmu_16_11_walk_veer_left.bvh", "cmu_141_16_wave_hello.bvh",
         "cmu_02_10_wash_self_cc3rig.bvh")


def _motion_file(out: Path, clip: str, robot) -> Path:
    path = out / f"{Path(clip).stem}_{robot.name}.npz"
    if not path.is_file():
        from imesh.io import load_motion
        from imesh.io.robot_motion import save_robot_motion
        from imesh.pipeline.retarget import retarget

        res = retarget(load_motion(data_root() / "mocap" / clip), robot)
        save_robot_motion(path, res.motion)
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--motions", default="out/wholebody")
    ap.add_argument("--robots", nargs="+", default=["jvrc1", "g1", "hrp4c"])
    ap.add_argument("--clips", nargs="+", default=list(CLIPS))
    ap.add_argument("--controllers", nargs="+", default=["wbc", "kinematic", "spd"])
    ap.add_argument("--perturb", type=int, default=0, metavar="N",
                    help="also check each run N times with perturbed joint angles")
    ap.add_argument("--perturb-rad", type=float, default=1e-6,
                    help="standard deviation of the perturbation [rad]")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    from imesh.evaluate import load_motion_file
    from imesh.physics import ControlConfig, PhysicsConfig, simulate_motion

    out = Path(args.motions)
    out.mkdir(parents=True, exist_ok=True)
    head = (f"{'clip':<30} {'robot':<6} {'ctrl':<9} {'fell':>5} {'surv s':>11} {'kp rms':>6} "
            f"{'kp max':>6} {'j rad':>6} {'drift':>6} {'slip':>6} {'trq':>5} {'sat':>5} "
            f"{'fric':>5} {'cop mm':>6} {'rt':>5}")
    print(head)
    print("-" * len(head))
    spread = []  # (clip, robot, controller, results of the nominal and perturbed checks)
    for clip in args.clips:
        for name in args.robots:
            robot = load(name)
            motion = load_motion_file(_motion_file(out, clip, robot), robot)
            for ctrl in args.controllers:
                config = PhysicsConfig(control=ControlConfig(controller=ctrl))
                r = simulate_motion(robot, motion, config=config)
                print(f"{clip:<30} {name:<6} {ctrl:<9} {str(r.fell):>5} "
                      f"{r.survived_s:>5.2f}/{r.duration_s:<5.2f} {r.keypoint_rms_mm:>6.1f} "
                      f"{r.keypoint_max_mm:>6.1f} {r.tracking_rms_rad:>6.3f} "
                      f"{1e3 * r.base_drift_m:>6.0f} {r.slip_mm:>6.1f} "
                      f"{r.torque_ratio_max:>5.2f} {r.saturation_fraction:>5.2f} "
                      f"{r.friction_ratio:>5.2f} {r.cop_margin_mm:>6.1f} "
                      f"{r.real_time_factor:>5.2f}")
                sys.stdout.flush()
                if args.perturb:
                    runs = [r] + [simulate_motion(robot, _perturbed(motion, seed, args.perturb_rad),
                                                  config=config)
                                  for seed in range(1, args.perturb + 1)]
                    spread.append((clip, name, ctrl, runs))
    if spread:
        print(f"\nthe same checks with the joint angles perturbed (N(0, {args.perturb_rad:g}) rad, "
              f"{args.perturb} seeds): range over the nominal and perturbed runs")
        head = (f"{'clip':<30} {'robot':<6} {'ctrl':<9} {'falls':>5} {'kp max mm':>13} "
                f"{'slip mm':>11} {'kp rms mm':>11}")
        print(head)
        print("-" * len(head))
        for clip, name, ctrl, runs in spread:
            kp = [x.keypoint_max_mm for x in runs]
            slip = [x.slip_mm for x in runs]
            rms = [x.keypoint_rms_mm for x in runs]
            print(f"{clip:<30} {name:<6} {ctrl:<9} {sum(x.fell for x in runs):>2}/{len(runs):<2} "
                  f"{min(kp):>6.1f}-{max(kp):<6.1f} {min(slip):>5.1f}-{max(slip):<5.1f} "
                  f"{min(rms):>5.1f}-{max(rms):<5.1f}")
    return 0


def _perturbed(motion, seed: int, sigma_rad: float):
    """The motion with its joint angles moved by N(0, sigma) noise (seeded)."""
    q = motion.q.copy()
    q[:, 7:] += np.random.default_rng(seed).normal(scale=sigma_rad, size=q[:, 7:].shape)
    return dataclasses.replace(motion, q=q)


if __name__ == "__main__":
    sys.exit(main())

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
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

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
    for clip in args.clips:
        for name in args.robots:
            robot = load(name)
            motion = load_motion_file(_motion_file(out, clip, robot), robot)
            for ctrl in args.controllers:
                r = simulate_motion(robot, motion,
                                    config=PhysicsConfig(control=ControlConfig(controller=ctrl)))
                print(f"{clip:<30} {name:<6} {ctrl:<9} {str(r.fell):>5} "
                      f"{r.survived_s:>5.2f}/{r.duration_s:<5.2f} {r.keypoint_rms_mm:>6.1f} "
                      f"{r.keypoint_max_mm:>6.1f} {r.tracking_rms_rad:>6.3f} "
                      f"{1e3 * r.base_drift_m:>6.0f} {r.slip_mm:>6.1f} "
                      f"{r.torque_ratio_max:>5.2f} {r.saturation_fraction:>5.2f} "
                      f"{r.friction_ratio:>5.2f} {r.cop_margin_mm:>6.1f} "
                      f"{r.real_time_factor:>5.2f}")
                sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Whole-body solve on real clips: the issue's acceptance table, scored by the evaluator.

    python benchmarks/wholebody.py [--robots jvrc1 g1 hrp4c] [--clips ...] [--physics]
                                   [--out DIR] [--solver piqp] [--plots DIR]
                                   [--zmp-margin 0.4] [--zmp-weight 10] [--by-marker]

For every clip x robot: ``imesh.retarget`` with default settings, the motion and the adapted
markers written to ``--out``, then the written file read back and scored by
``imesh.evaluate.evaluate_motion`` (what ``imesh evaluate OUT.npz --adapted MARKERS.npz
[--physics]`` prints). Prints one row per run: marker RMS, close-pair error (``cpe``: against
the source clip, on the clip's frames without the lead-in/out), sole deviation/tilt, skid, ground
penetration, limit violations, ZMP inside/error, DART, the reference's torque and friction
ratios and its single-support soles' yaw friction share (``yaw``: the friction ratio's
``yaw_ratio``), and the time of each stage.
``--zmp-margin`` and ``--zmp-weight`` plan with another ``ZmpOptions.margin`` or ``.weight``
than the default; ``--by-marker`` adds
a line per run with the key points' RMS at the trunk (chest, neck, head, shoulders) and the
worst three others.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from _data import cells, data_root, load, score_written

CLIPS = ("cmu_02_01_walk.bvh", "cmu_16_11_walk_veer_left.bvh", "cmu_141_16_wave_hello.bvh",
         "cmu_02_10_wash_self_cc3rig.bvh")


TRUNK = ("chest", "neck", "head", "shoulder_l", "shoulder_r")


def by_marker_line(robot, written, adapted) -> str:
    """The trunk key points' RMS [mm] against the adapted markers, then the worst three others."""
    from imesh.metrics.markers import keypoint_motion, marker_rms_by_name_mm

    kp = keypoint_motion(robot, written.q, written.fps)
    by = marker_rms_by_name_mm(kp.subset([n for n in kp.names if n in adapted.names]), adapted)
    others = [k for k in by if k not in TRUNK][:3]
    return ", ".join(f"{k} {by[k]:.0f}" for k in (*[t for t in TRUNK if t in by], *others))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["jvrc1", "g1", "hrp4c"])
    ap.add_argument("--clips", nargs="+", default=list(CLIPS))
    ap.add_argument("--physics", action="store_true", help="also run the DART check")
    ap.add_argument("--out", default="out/wholebody", help="folder of the written motions")
    ap.add_argument("--solver", default="piqp", help="QP solver of the whole-body solve")
    ap.add_argument("--plots", help="write the balance figure of each run here (PNG)")
    ap.add_argument("--zmp-margin", type=float, default=None,
                    help="ZmpOptions.margin of the plan (default: the library's)")
    ap.add_argument("--zmp-weight", type=float, default=None,
                    help="ZmpOptions.weight of the plan (default: the library's)")
    ap.add_argument("--torque-margin", type=float, default=None,
                    help="LimitMargins.torque of the plan (default: the library's)")
    ap.add_argument("--by-marker", action="store_true",
                    help="print the trunk key points' RMS [mm] under each run")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    import dataclasses

    from imesh.io import load_motion
    from imesh.pipeline.retarget import RetargetConfig, retarget

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    base = RetargetConfig()
    wholebody = dataclasses.replace(
        base.wholebody, sqp=dataclasses.replace(base.wholebody.sqp, solver=args.solver))
    if args.zmp_margin is not None:
        wholebody = dataclasses.replace(wholebody, zmp=dataclasses.replace(
            wholebody.zmp, margin=args.zmp_margin))
    if args.zmp_weight is not None:
        wholebody = dataclasses.replace(wholebody, zmp=dataclasses.replace(
            wholebody.zmp, weight=args.zmp_weight))
    if args.torque_margin is not None:
        wholebody = dataclasses.replace(wholebody, margins=dataclasses.replace(
            wholebody.margins, torque=args.torque_margin))
    config = dataclasses.replace(base, wholebody=wholebody)
    head = (f"{'clip':<30} {'robot':<6} {'frames':>6} {'rms mm':>7} {'cpe':>6} {'sole mm':>7} "
            f"{'tilt':>5} {'skid':>5} {'pen mm':>6} {'lim':>4} {'zmp in':>6} {'zmp mm':>6} "
            f"{'fell':>5} {'surv s':>6} {'trq':>5} {'trq rf':>6} {'fric':>5} {'yaw':>5} {'it':>3} "
            f"{'solve s':>7} {'total s':>7}")
    print(head)
    print("-" * len(head))
    for clip in args.clips:
        motion = load_motion(data_root() / "mocap" / clip)
        for name in args.robots:
            robot = load(name)
            stem = f"{Path(clip).stem}_{name}"
            t0 = time.perf_counter()
            try:
                res = retarget(motion, robot, config=config)
            except Exception as exc:  # a row per run, whatever fails
                print(f"{clip:<30} {name:<6} failed: {exc}")
                continue
            total = time.perf_counter() - t0
            written, m = score_written(robot, res, motion, out, stem, args.physics)
            wb = res.wholebody.report() if res.wholebody is not None else {}
            if args.plots:
                from imesh.viz.adapt import plot_wholebody

                plot_wholebody(robot, written, Path(args.plots) / f"{stem}.png",
                               title=f"{clip} on {name} (written output)")

            quality = cells(m, ("marker_rms_mm", "7.1f"), ("close_pair_error", "6.4f"),
                            ("sole_deviation_mm", "7.2f"), ("sole_tilt_deg", "5.2f"),
                            ("foot_skid_mm_per_frame", "5.2f"), ("ground_penetration_mm", "6.1f"),
                            ("limit_violation_frames", "4d"), ("zmp_inside_fraction", "6.3f"),
                            ("zmp_error_mm", "6.1f"))
            dynamics = cells(m, ("physics_survived_s", "6.2f"), ("torque_ratio_max", "5.2f"),
                             ("torque_ratio_ref", "6.2f"), ("friction_ratio_max", "5.2f"),
                             ("yaw_ratio", "5.2f"))
            print(f"{clip:<30} {name:<6} {written.n_frames:>6} {quality} "
                  f"{str(m.get('physics_fell', 'n/a')):>5} {dynamics} "
                  f"{wb.get('iterations', 0):>3} {res.seconds.get('wholebody', 0.0):>7.2f} "
                  f"{total:>7.2f}")
            if args.by_marker:
                print(f"    key points [mm]: {by_marker_line(robot, written, res.adapted)}")
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""``imesh evaluate``: argument parsing and the command (the library is imesh.evaluate)."""

from __future__ import annotations

import argparse

from .args import add_robot_arguments


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``evaluate`` command to an argparse subparsers object."""
    p = subparsers.add_parser(
        "evaluate", help="score a robot motion: every quality metric (and the DART check)",
        description="Compute the quality metrics of a robot motion (.npz/.csv: joint names, "
        "base position [m], base quaternion; see docs/checking.md), print a table and "
        "optionally write them as JSON (keys = the metric names).")
    p.add_argument("motion", help="robot motion (.npz or .csv)")
    add_robot_arguments(p)
    p.add_argument("--source", help="the human clip the motion was retargeted from")
    p.add_argument("--adapted", help="the adapted markers the robot fitted (.npz from "
                   "'imesh retarget --markers')")
    p.add_argument("--resample", action="store_true",
                   help="compare --source/--adapted markers of another frame rate or frame count "
                   "(resampled to the motion's fps, first common frames); by default such a "
                   "mismatch is refused")
    p.add_argument("--fps", type=float, help="frame rate of motion files that store none")
    p.add_argument("--physics", action="store_true", help="run the DART dynamics check")
    p.add_argument("--controller", choices=("spd", "pid"), default="spd",
                   help="DART tracking controller (default spd)")
    p.add_argument("--fixed-base", action="store_true",
                   help="weld the base at its first pose in DART (arm-only tracking)")
    p.add_argument("--plot", help="write the DART run's figure here (.png)")
    p.add_argument("--json", dest="report", help="write the metrics (JSON) here")
    p.add_argument("--report", dest="report_html",
                   help="write an HTML report (metrics table with the gates, figures, 3D view)")
    return p


def run(args) -> int:
    """Run ``imesh evaluate`` with parsed arguments; returns the exit status."""
    from ..evaluate.motion_files import load_motion_file
    from ..evaluate.scoreboard import evaluate_motion
    from ..evaluate.table import format_table
    from ..io.atomic import write_json
    from ..robot import load_robot

    robot = load_robot(args.robot, urdf=args.urdf)
    motion = load_motion_file(args.motion, robot, fps=args.fps)
    config = None
    if args.physics:
        from ..physics import PhysicsConfig

        config = PhysicsConfig(controller=args.controller, fixed_base=args.fixed_base)
    report = evaluate_motion(robot, motion, source=args.source, physics=args.physics,
                             adapted=args.adapted, physics_config=config,
                             plot=args.plot if args.physics else None,
                             resample=args.resample)
    print(f"{args.motion}: {motion.n_frames} frames of {robot.name} at {motion.fps:g} fps")
    print(format_table(report))
    if args.report:
        write_json(args.report, report)
    if args.report_html:
        from ..viz.report import write_report

        write_report(args.report_html, robot, args.motion, metrics=report, source=args.source,
                     fps=args.fps)
        print(f"report: {args.report_html}")
    return 0

"""``imesh export MOTION -o FILE``: a robot motion converted to another format
(:mod:`imesh.io.formats`, docs/exports.md)."""

from __future__ import annotations

from pathlib import Path

from ..io.formats import read_export, robot_for_motion_file, write_export


def run(args) -> int:
    """Read the motion (any format imesh writes), write it in the asked format (by default by
    the output's suffix), print one line; returns the exit status."""
    motion = read_export(args.motion, args.robot, fps=args.source_fps)
    fmt = args.format
    if fmt is None and Path(args.output).suffix.lower() == ".csv":
        fmt = "csv"
    robot = None
    if fmt == "mujoco" and args.mjcf is None:  # the robot's URDF, compiled by MuJoCo
        robot = robot_for_motion_file(args.motion, args.robot, args.urdf)
    write_export(motion, args.output, fmt, fps=args.fps, mjcf=args.mjcf, robot=robot)
    print(f"exported {args.motion} -> {args.output} ({fmt or 'npz'}, "
          f"{args.fps or motion.fps:g} fps)")
    return 0

"""``imesh evaluate MOTION``: the quality metrics of a robot motion as a table, JSON and an HTML
report (the library is :mod:`imesh.evaluate`)."""

from __future__ import annotations

import dataclasses

from ..evaluate.motion_files import load_motion_file
from ..evaluate.props import evaluate_scene, format_scene_table, scene_for_motion
from ..evaluate.scoreboard import evaluate_motion
from ..evaluate.table import format_table
from ..io.atomic import write_json
from ..io.clip import read_clip
from ..io.formats import robot_for_motion_file
from ..physics import ControlConfig, PhysicsConfig
from ..viz.report import write_report


def run(args) -> int:
    """Run ``imesh evaluate`` with parsed arguments; returns the exit status."""
    if getattr(args, "pair", None):  # both robots of imesh retarget --partner
        from .partners import evaluate_pair_files

        return evaluate_pair_files(args)
    robot = robot_for_motion_file(args.motion, args.robot, args.urdf)  # default: the file's
    motion = load_motion_file(args.motion, robot, fps=args.fps)
    if args.detect_support:  # judged as another tool's output is
        motion = dataclasses.replace(motion, contact_modes=None)
    config = None
    if args.physics:
        config = PhysicsConfig(fixed_base=args.fixed_base,
                               control=ControlConfig(controller=args.controller))
    source = args.source
    if source is not None and getattr(args, "body_model", None):
        # an AMASS clip (a GMR user's source, or a body-model folder that moved): read here
        # with the provenance's other reading options; frames and fps are still compared
        clip = motion.provenance.source if motion.provenance is not None else None
        source = read_clip(source, {**(dict(clip.load) if clip is not None else {}),
                                    "body_model": args.body_model})
    scene = scene_for_motion(robot, motion, args.motion, getattr(args, "scene", None) or (),
                             scale=getattr(args, "scene_scale", None), source=source)
    report = evaluate_motion(robot, motion, source=source, physics=args.physics,
                             adapted=args.adapted, physics_config=config,
                             plot=args.plot if args.physics else None,
                             resample=args.resample, scene=scene)
    print(f"{args.motion}: {motion.n_frames} frames of {robot.name} at {motion.fps:g} fps")
    print(format_table(report))
    metrics = report  # the motion's table (the scene's figures are a table of their own)
    if scene is not None:
        scene_report = evaluate_scene(robot, motion, scene, source=source)
        print(f"scene: {len(scene.props)} props ({', '.join(scene.names)}) at scale "
              f"{scene.scale:.4f} (docs/terrain.md)")
        print(format_scene_table(scene_report))
        report = {**report, "scene": scene_report}
    if args.report:
        write_json(args.report, report)
    if args.report_html:
        write_report(args.report_html, robot, args.motion, metrics=metrics, source=source,
                     fps=args.fps, props=scene)
        print(f"report: {args.report_html}")
    return 0

"""``imesh retarget CLIP -o MOTION``: the whole pipeline (:func:`imesh.pipeline.retarget.retarget`),
verified by the evaluator before the motion is written; ``--mode arms`` is :mod:`imesh.cli.arms`."""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path

from ..arms.solve import REFINE_CONFIG
from ..contacts.support import SupportConfig
from ..core.progress import retarget_bar
from ..evaluate.props import evaluate_scene, format_scene_table
from ..evaluate.table import format_table
from ..evaluate.verify import verify_motion
from ..io.atomic import atomic_path, write_json
from ..io.formats import write_export
from ..io.npz import save_marker_motion
from ..io.robot_motion import save_robot_motion
from ..physics import ControlConfig, PhysicsConfig
from ..pipeline.retarget import RetargetConfig, retarget
from ..robot import load_robot
from ..scene import save_scene, scene_path_for
from ..scene.morph_frame import scene_for_clip
from ..viz.balance import plot_balance
from ..viz.report import write_report
from .arms import run_arms
from .loading import load_clip
from .partners import check_partner_options, run_pair

log = logging.getLogger(__name__)


def run(args) -> int:
    """Retarget, verify and write (motion, markers, reports, plots), print the summary and the
    metrics table; returns the exit status (VerificationError: 3, unless ``--force``)."""
    check_partner_options(args)
    if getattr(args, "partner", None):  # two people, two robots (imesh.partners)
        return run_pair(args, _retarget_config(args, args.steps, args.window_frames,
                                               support=not args.no_support,
                                               balance=args.balance))
    if args.mode == "arms":  # Kim 2005 arm imitation (imesh/arms)
        if getattr(args, "scene", None):
            log.warning("--scene is ignored by --mode arms (the base stays at the nominal pose)")
        robot = load_robot(args.robot, urdf=args.urdf)
        motion = load_clip(args)
        status = run_arms(args, robot, motion)
        if args.report_html:
            write_report(args.report_html, robot, args.output, source=motion, balanced=False,
                         facts={"source clip": args.clip, "mode": "arms (Kim 2005)"})
        return status
    if getattr(args, "allow_flight", False) and args.balance != "nishiwaki":
        log.warning("--allow-flight is deprecated and does nothing with --balance %s: flight "
                    "phases are planned by default (ballistic CoM, bounded landings; "
                    "docs/clips-flight.md); it applies to --balance nishiwaki only",
                    args.balance)
    config = _retarget_config(args, args.steps, args.window_frames, support=not args.no_support,
                              balance=args.balance)
    motion = load_clip(args)
    bar = retarget_bar(args.quiet, f"{Path(args.clip).name} -> {args.robot}", motion, config)
    try:
        bar.stage("load", detail=f"robot {args.robot}")
        robot = load_robot(args.robot, urdf=args.urdf)
        bar.stage("prepare")  # the robot is loaded: the bar moves before the clip's filtering
        scene = None
        if getattr(args, "scene", None):  # read (and refused) before the solve
            scene = scene_for_clip(args.scene, motion, robot, scale=args.scene_scale,
                                   fps=config.fps, lowpass_hz=config.lowpass_hz)
        result = retarget(motion, robot, config=config, progress=bar, scene=scene)
        if scene is not None and args.scene_scale is None and \
                abs(scene.scale - result.arrangement.scale) > 1e-9:
            log.warning("scene scaled by %.6f, the human by %.6f: the props may not match",
                        scene.scale, result.arrangement.scale)
        report = result.report()
        if args.plots and result.balance is not None:
            report["balance_plots"] = plot_balance(result.balance, args.plots, robot.name)
        robot_motion = result.motion
        # verify before writing: the summary and the gates are the evaluator's report of the
        # motion as it will be written (the file holds exactly these float64 configurations)
        bar.stage("verify", robot_motion.n_frames)
        metrics, failed = verify_motion(robot, robot_motion, adapted=result.adapted,
                                        seconds=result.seconds, name=args.clip,
                                        balanced=args.balance != "none", force=args.force,
                                        source=motion,
                                        physics=PhysicsConfig(control=ControlConfig(
                                            controller=args.controller))
                                        if args.physics else None, scene=scene)
        report["metrics"] = metrics
        report["verification"] = {"passed": not failed,
                                  "failed": {k: {"value": v[0], "gate": v[1]}
                                             for k, v in failed.items()}}
        bar.stage("write", robot_motion.n_frames)
        if args.format in (None, "npz"):
            save_robot_motion(args.output, robot_motion, markers=result.adapted)
        else:
            write_export(robot_motion, args.output, args.format, mjcf=args.mjcf, robot=robot)
        if args.markers:
            save_marker_motion(args.markers, result.adapted)
        if scene is not None:
            save_scene(scene_path_for(args.output), scene, atomic=atomic_path)
            report["scene"] = evaluate_scene(robot, robot_motion, scene, source=motion)
        if args.report:
            write_json(args.report, report)
        if args.report_html:
            write_report(args.report_html, robot, args.output, source=motion,
                         balanced=args.balance != "none", props=scene,
                         facts={"source clip": args.clip,
                                "retarget time": f"{report['seconds']['total']:.1f} s"})
        bar.finish()
    finally:
        bar.close()
    print(f"retargeted {report['frames']} frames to {robot.name} in "
          f"{report['seconds']['total']:.2f} s -> {args.output}")
    if report["unconstrained_frames"]:
        print(f"flight frames without support or ZMP constraint: "
              f"{report['unconstrained_frames']}")
    if report["flight_frames"]:
        print(f"flight frames (planned ballistic, no support): {report['flight_frames']}")
    print(format_table(metrics))
    if scene is not None and "scene" in report:
        print(f"scene: {len(scene.props)} props at scale {scene.scale:.4f} -> "
              f"{scene_path_for(args.output)}")
        print(format_scene_table(report["scene"]))
    return 0


def _retarget_config(args, steps: int, window_frames: int = 2000, support: bool = True,
                     balance: str = "wholebody") -> RetargetConfig:
    """The pipeline's configuration from the parsed options (defaults of RetargetConfig for
    options a caller's namespace lacks)."""
    base = RetargetConfig()
    return RetargetConfig(morph=dataclasses.replace(base.morph, steps=steps,
                                                    window_frames=window_frames),
                          support=SupportConfig() if support else None, balance=balance,
                          fps=getattr(args, "fps", None) or base.fps,
                          allow_flight=getattr(args, "allow_flight", False),
                          lead_s=0.0 if getattr(args, "no_lead", False) else base.lead_s,
                          windows=dataclasses.replace(
                              base.windows,
                              workers=getattr(args, "solve_workers", base.windows.workers)),
                          arms=_arms_config(args))


def _arms_config(args):
    """``--fit sqp``: the initial fit's arms by Kim's SQP (imesh/arms), else None."""
    if getattr(args, "fit", "dls") != "sqp":
        return None
    return dataclasses.replace(REFINE_CONFIG, solver=args.solver)

"""``imesh demo``: the main job on the built-in clip (a 2.9 s CMU walk shipped in
``imesh/data/demo``, :func:`imesh.api.demo_clip`): retarget to JVRC-1 with the whole-body
solve, verify, and write the motion, the HTML report and the viewer page."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from ..api import demo_clip
from ..core.progress import retarget_bar
from ..errors import VerificationError
from ..evaluate.motion_files import load_motion_file
from ..evaluate.scoreboard import evaluate_motion
from ..evaluate.table import format_table
from ..evaluate.verify import failed_gates
from ..io import load_motion
from ..io.atomic import write_json
from ..io.robot_motion import save_robot_motion
from ..pipeline.retarget import RetargetConfig, retarget
from ..robot import load_robot
from ..viz.html import write_viewer
from ..viz.report import write_report
from ..viz.scene import build_scene


def run(args) -> int:
    """Retarget the demo clip (or ``--clip``), verify, write the motion, the metrics JSON, the
    report and the viewer page into ``-o``, print where; returns the exit status
    (VerificationError: 3, after writing)."""
    t_start = time.perf_counter()
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    clip = Path(args.clip) if args.clip else demo_clip()
    base = RetargetConfig()
    config = dataclasses.replace(base, morph=dataclasses.replace(base.morph, steps=args.steps))
    motion = load_motion(clip)
    bar = retarget_bar(args.quiet, "demo", motion, config, extra=("viewer", "report"))
    try:
        bar.stage("load", detail=f"robot {args.robot}")
        robot = load_robot(args.robot, urdf=args.urdf)
        result = retarget(motion, robot, config=config, progress=bar)

        bar.stage("verify", result.motion.n_frames)
        run_metrics = evaluate_motion(robot, result.motion, source=motion,
                                      adapted=result.adapted, seconds=result.seconds)
        failed = failed_gates(run_metrics)

        bar.stage("write", result.motion.n_frames)
        motion_path, json_path = out / "motion.npz", out / "report.json"
        save_robot_motion(motion_path, result.motion, markers=result.adapted)
        report = result.report()
        report["metrics"] = run_metrics
        report["verification"] = {"passed": not failed,
                                  "failed": {k: {"value": v[0], "gate": v[1]}
                                             for k, v in failed.items()}}
        write_json(json_path, report)

        bar.stage("viewer", result.motion.n_frames)
        written = load_motion_file(motion_path, robot)  # the page shows the file as written
        scene = build_scene(robot, written, source=clip,
                            title=f"{clip.name} -> {robot.name}")
        viewer_path = write_viewer(out / "viewer.html", scene)

        bar.stage("report", result.motion.n_frames)
        seconds = result.seconds
        facts = {"source clip": f"{clip} ({motion.n_frames} frames at {motion.fps:g} fps)",
                 "retarget time": f"{seconds['total']:.1f} s (" + ", ".join(
                     f"{k} {v:.1f} s" for k, v in seconds.items() if k != "total") + ")",
                 "data": "CMU Graphics Lab Motion Capture Database (mocap.cs.cmu.edu), "
                         "funded by NSF EIA-0196217" if not args.clip else str(clip)}
        report_path = write_report(out / "report.html", robot, motion_path, source=clip,
                                   facts=facts, scene=scene)
        bar.finish()
    finally:
        bar.close()
    elapsed = time.perf_counter() - t_start
    print(f"demo: retargeted {clip.name} ({motion.n_frames / motion.fps:.1f} s) to "
          f"{robot.name}: {result.motion.n_frames} frames in {seconds['total']:.1f} s "
          f"(demo {elapsed:.1f} s)")
    print(format_table(run_metrics))
    print(f"verification: {'passed every gate' if not failed else 'FAILED ' + ', '.join(failed)}")
    print(f"  robot motion  {motion_path}")
    print(f"  report        {report_path}   (open in a browser)")
    print(f"  viewer page   {viewer_path}   (open in a browser; no server needed)")
    print(f"  metrics JSON  {json_path}")
    print(f"live viewer:    imesh view {motion_path} --robot {robot.name} --source {clip}")
    if failed:
        raise VerificationError(f"demo motion of {clip} for {robot.name} (written with its "
                                "report)", failed)
    return 0


"""``imesh demo``: the main job on the built-in clip (a 2.9 s CMU walk shipped in
``imesh/data/demo``, :func:`imesh.api.demo_clip`): retarget to JVRC-1 with the whole-body
solve, verify, write the motion, check the written motion in DART (the default controller;
``--no-physics`` skips it), and write the metrics JSON, the HTML report and the viewer page
with the simulated robot beside the reference.

A fall in the DART check is reported (printed, in report.json, the report and the page), never
an error: the demo's exit status is that of the verification gates of ``imesh retarget``."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

from ..api import demo_clip
from ..core.progress import retarget_bar
from ..errors import ImeshError, VerificationError
from ..evaluate.motion_files import load_motion_file
from ..evaluate.scoreboard import evaluate_motion, physics_entries
from ..evaluate.table import format_table, physics_line
from ..evaluate.verify import failed_gates
from ..io import load_motion
from ..io.atomic import write_json
from ..io.robot_motion import save_robot_motion
from ..metrics.collision import check_self_collisions
from ..physics import PhysicsConfig, simulate_motion
from ..pipeline.retarget import RetargetConfig, retarget
from ..robot import load_robot
from ..viz.html import write_viewer
from ..viz.report import write_report
from ..viz.scene import build_scene


def run(args) -> int:
    """Retarget the demo clip (or ``--clip``), verify, write the motion, run the DART check on
    it (unless ``--no-physics``), write the metrics JSON, the report and the viewer page into
    ``-o``, print where; returns the exit status (VerificationError: 3, after writing; a fall
    in the DART check is reported, not an error)."""
    t_start = time.perf_counter()
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    clip = Path(args.clip) if args.clip else demo_clip()
    base = RetargetConfig()
    config = dataclasses.replace(base, morph=dataclasses.replace(base.morph, steps=args.steps))
    motion = load_motion(clip)
    check = not args.no_physics
    bar = retarget_bar(args.quiet, "demo", motion, config,
                       extra=(("physics",) if check else ()) + ("viewer", "report"))
    physics, physics_s, not_run = None, 0.0, ""
    try:
        bar.stage("load", detail=f"robot {args.robot}")
        robot = load_robot(args.robot, urdf=args.urdf)
        result = retarget(motion, robot, config=config, progress=bar)

        bar.stage("verify", result.motion.n_frames)
        # one self-collision check for the table, the viewer and the report (the file holds
        # these joint positions as they are)
        collisions = check_self_collisions(robot, result.motion.q)
        run_metrics = evaluate_motion(robot, result.motion, source=motion,
                                      adapted=result.adapted, seconds=result.seconds,
                                      collisions=collisions)
        failed = failed_gates(run_metrics)

        bar.stage("write", result.motion.n_frames)
        motion_path, json_path = out / "motion.npz", out / "report.json"
        save_robot_motion(motion_path, result.motion, markers=result.adapted)
        written = load_motion_file(motion_path, robot)  # checked and shown as written

        if check:  # the figures `imesh evaluate motion.npz --physics` prints
            bar.stage("physics", result.motion.n_frames)
            t0 = time.perf_counter()
            try:
                physics = simulate_motion(robot, written, config=PhysicsConfig())
            except ImeshError as exc:  # e.g. dartpy missing: the retarget is still the demo's
                not_run = f"physics check: not run ({exc})"
            else:
                run_metrics.update(physics_entries(physics))
            physics_s = time.perf_counter() - t0
        report = result.report()
        report["metrics"] = run_metrics
        report["verification"] = {"passed": not failed,
                                  "failed": {k: {"value": v[0], "gate": v[1]}
                                             for k, v in failed.items()}}
        report["physics_check"] = {  # its figures are the physics_* metrics
            "ran": physics is not None,
            "verdict": physics_line(run_metrics) if physics is not None else not_run or None,
            "seconds": round(physics_s, 2) if physics is not None else None,
            "gated": False, "note": "a fall is reported, not a failed gate, in the demo "
                                    "(imesh retarget --physics gates on it)"}
        write_json(json_path, report)

        bar.stage("viewer", result.motion.n_frames)
        scene = build_scene(robot, written, source=clip, physics=physics,
                            collisions=collisions, title=f"{clip.name} -> {robot.name}")
        viewer_path = write_viewer(out / "viewer.html", scene)

        bar.stage("report", result.motion.n_frames)
        seconds = result.seconds
        facts = {"source clip": f"{clip} ({motion.n_frames} frames at {motion.fps:g} fps)",
                 "retarget time": f"{seconds['total']:.1f} s (" + ", ".join(
                     f"{k} {v:.1f} s" for k, v in seconds.items() if k != "total") + ")",
                 "data": "CMU Graphics Lab Motion Capture Database (mocap.cs.cmu.edu), "
                         "funded by NSF EIA-0196217" if not args.clip else str(clip)}
        if physics is not None:
            facts["physics check time"] = f"{physics_s:.1f} s"
        report_path = write_report(out / "report.html", robot, motion_path, source=clip,
                                   facts=facts, scene=scene, physics=physics,
                                   collisions=collisions)
        bar.finish()
    finally:
        bar.close()
    elapsed = time.perf_counter() - t_start
    print(f"demo: retargeted {clip.name} ({motion.n_frames / motion.fps:.1f} s) to "
          f"{robot.name}: {result.motion.n_frames} frames in {seconds['total']:.1f} s "
          f"(demo {elapsed:.1f} s" + (f", of which the physics check {physics_s:.1f} s)"
                                       if physics is not None else ")"))
    print(format_table(run_metrics))
    print(f"verification: {'passed every gate' if not failed else 'FAILED ' + ', '.join(failed)}")
    print(physics_line(run_metrics) if physics is not None else not_run or
          "physics check: skipped (--no-physics); imesh evaluate --physics runs it")
    print(f"  robot motion  {motion_path}")
    print(f"  report        {report_path}   (open in a browser)")
    print(f"  viewer page   {viewer_path}   (open in a browser; no server needed)")
    print(f"  metrics JSON  {json_path}")
    print(f"live viewer:    imesh view {motion_path} --robot {robot.name} --source {clip}"
          + (" --physics" if physics is not None else ""))
    if failed:
        raise VerificationError(f"demo motion of {clip} for {robot.name} (written with its "
                                "report)", failed)
    return 0


"""``imesh view`` and ``imesh demo``: argument parsing and the commands (the library is
:mod:`imesh.viz`).

``imesh demo`` runs the main job on the built-in clip (a 2.9 s CMU walk shipped in
``imesh/data/demo``): retarget to JVRC-1 with the whole-body solve, verify, and write the motion,
the HTML report and the viewer page.
"""

from __future__ import annotations

import logging
import time
from importlib import resources
from pathlib import Path

from .args import add_robot_arguments

log = logging.getLogger("imesh")

#: The built-in clip of ``imesh demo`` (CMU 02_01 walk; terms in CMU_TERMS.txt beside it).
DEMO_CLIP = "cmu_02_01_walk.bvh"


def demo_clip() -> Path:
    """Path of the built-in demo clip (package data)."""
    return Path(str(resources.files("imesh").joinpath("data", "demo", DEMO_CLIP)))


def add_parsers(sub) -> None:
    """Add the ``view`` and ``demo`` commands to an argparse subparsers object."""
    p = sub.add_parser(
        "view", help="look at a robot motion: 3D viewer in the browser, one self-contained "
        "page (--html) or a video (--video)",
        description="Show a robot motion (.npz/.csv from 'imesh retarget') in 3D: the robot's "
        "meshes, the adapted markers and the human source, the interaction mesh, soles, support "
        "polygon, desired and actual ZMP, self-collisions and limit violations, with a "
        "timeline. Without --html/--video the page is served on 127.0.0.1 until Ctrl-C.")
    p.add_argument("motion", help="robot motion (.npz or .csv)")
    add_robot_arguments(p)
    p.add_argument("--source", help="the human clip, drawn beside the robot")
    p.add_argument("--fps", type=float, help="frame rate of motion files that store none")
    p.add_argument("--html", help="write the viewer as one self-contained page (.html): no "
                   "server, no network")
    p.add_argument("--video", help="render the whole motion to a video (.mp4), headless: robot "
                   "with the markers and the human beside it (needs chromium)")
    p.add_argument("--video-fps", type=float, help="video frame rate (default: the motion's)")
    p.add_argument("--port", type=int, default=8765, help="server port (default 8765; 0: any)")
    p.add_argument("--no-browser", action="store_true", help="serve without opening a browser")

    p = sub.add_parser("demo", help="retarget the built-in CMU walk to JVRC-1 and write the "
                       "motion, an HTML report and a 3D viewer page")
    p.add_argument("-o", "--output", default="imesh-demo", help="output folder (default "
                   "imesh-demo)")
    p.add_argument("--clip", help=f"another clip instead of the built-in {DEMO_CLIP}")
    add_robot_arguments(p)
    p.add_argument("--steps", type=int, default=10, help="morph steps (default 10)")


# ----------------------------------------------------------------------------------------------
# progress


# ----------------------------------------------------------------------------------------------
# commands


def run_view(args) -> int:
    """``imesh view``."""
    from ..evaluate.motion_files import load_motion_file
    from ..robot import load_robot
    from ..viz.scene import build_scene

    robot = load_robot(args.robot, urdf=args.urdf)
    motion = load_motion_file(args.motion, robot, fps=args.fps)
    scene = build_scene(robot, motion, source=args.source,
                        title=f"{Path(args.motion).name} ({robot.name})")
    if args.html or args.video:
        if args.html:
            from ..viz.html import write_viewer

            write_viewer(args.html, scene)
            print(f"viewer page: {args.html} (open it in a browser; no server needed)")
        if args.video:
            from ..viz.video import write_video

            n = write_video(args.video, scene, fps=args.video_fps,
                            progress=None if args.quiet else "video")
            print(f"video: {args.video} ({n} frames at {args.video_fps or motion.fps:g} fps)")
        return 0
    from ..viz.server import ViewerServer

    server = ViewerServer(scene, port=args.port)
    print(f"viewer: {server.url}  (Ctrl-C to stop)", flush=True)
    if not args.no_browser:
        import webbrowser

        webbrowser.open(server.url)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
    return 0


def run_demo(args) -> int:
    """``imesh demo``: the real main job on the built-in clip (module docstring)."""
    import dataclasses

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
        run_metrics = evaluate_motion(robot, result.motion, adapted=result.adapted,
                                      seconds=result.seconds)
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


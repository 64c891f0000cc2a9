"""``imesh view MOTION``: a robot motion in 3D, served to the browser, as one self-contained page
(``--html``) or as a video (``--video``); with ``--physics`` the DART check runs first and the
simulated robot is drawn beside the reference. The library is :mod:`imesh.viz`."""

from __future__ import annotations

import time
import webbrowser
from pathlib import Path

from ..evaluate.motion_files import load_motion_file
from ..evaluate.scoreboard import physics_entries
from ..evaluate.table import physics_line
from ..io.formats import robot_for_motion_file
from ..physics import ControlConfig, PhysicsConfig, simulate_motion
from ..viz.html import write_viewer
from ..viz.scene import build_scene
from ..viz.server import ViewerServer
from ..viz.video import write_video


def run(args) -> int:
    """Write the page or the video, or serve the viewer until Ctrl-C; returns the exit
    status."""
    robot = robot_for_motion_file(args.motion, args.robot, args.urdf)  # default: the file's
    motion = load_motion_file(args.motion, robot, fps=args.fps)
    physics = None
    if args.physics:
        physics = simulate_motion(robot, motion, config=PhysicsConfig(
            control=ControlConfig(controller=args.controller)))
        print(physics_line(physics_entries(physics)))
    scene = build_scene(robot, motion, source=args.source, physics=physics,
                        title=f"{Path(args.motion).name} ({robot.name})")
    if args.html or args.video:
        if args.html:
            write_viewer(args.html, scene)
            print(f"viewer page: {args.html} (open it in a browser; no server needed)")
        if args.video:
            n = write_video(args.video, scene, fps=args.video_fps,
                            progress=None if args.quiet else "video")
            print(f"video: {args.video} ({n} frames at {args.video_fps or motion.fps:g} fps)")
        return 0
    server = ViewerServer(scene, port=args.port)
    print(f"viewer: {server.url}  (Ctrl-C to stop)", flush=True)
    if not args.no_browser:
        webbrowser.open(server.url)
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
    return 0

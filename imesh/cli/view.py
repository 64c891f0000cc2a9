"""``imesh view MOTION``: a robot motion in 3D, served to the browser, as one self-contained page
(``--html``) or as a video (``--video``); with ``--physics`` the DART check runs first and the
simulated robot is drawn beside the reference. ``imesh view OUT.pair.json`` shows the two robots
of a pair (``imesh retarget --partner``) in their one world. The props of the motion's scene
(``OUT.scene.npz`` beside it, or ``--scene``) are drawn as static meshes. The library is
:mod:`imesh.viz`."""

from __future__ import annotations

import logging
import time
import webbrowser
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..errors import ImeshError
from ..evaluate.motion_files import load_motion_file
from ..evaluate.props import scene_for_motion
from ..evaluate.scoreboard import physics_entries
from ..evaluate.table import physics_line
from ..io.clip import read_clip
from ..io.formats import robot_for_motion_file
from ..partners import detect_holds
from ..partners.evaluate import evaluate_pair_motions
from ..partners.pair import PartnerError
from ..physics import ControlConfig, PhysicsConfig, simulate_motion
from ..robot import load_robot
from ..scene import SCENE_SUFFIX, find_scene, scene_from_files
from ..viz.html import write_viewer
from ..viz.report import write_pair_report
from ..viz.scene import PairView, SceneRobot, build_robots_scene, build_scene
from ..viz.server import ViewerServer
from ..viz.video import write_video
from .parsers import NAMED_CLIP
from .partners import PairFiles, read_pair_manifest

log = logging.getLogger(__name__)

#: The pair's two robots, in the manifest's order.
KEYS = ("a", "b")


def is_pair_manifest(path: str | Path) -> bool:
    """``OUT.pair.json`` (or any ``.json``): a pair's manifest, not a motion file."""
    return str(path).lower().endswith(".json")


def run(args) -> int:
    """Write the page or the video, or serve the viewer until Ctrl-C; returns the exit
    status."""
    if is_pair_manifest(args.motion):
        given = [opt for opt, v in (("--robot", args.robot), ("--urdf", args.urdf),
                                    ("--fps", args.fps)) if v]
        if given:
            raise PartnerError(f"{', '.join(given)} with the pair manifest {args.motion}: it "
                               "names both robots and their files")
        if args.source not in (None, NAMED_CLIP):
            raise PartnerError(f"--source {args.source} with the pair manifest {args.motion}: "
                               "give --source alone, the manifest names both clips")
        scene = pair_scene(args.motion, source=args.source is not None,
                           controller=args.controller if args.physics else None,
                           scene_files=args.scene)
    else:
        scene = _motion_scene(args)
    if args.html or args.video:
        if args.html:
            write_viewer(args.html, scene)
            print(f"viewer page: {args.html} (open it in a browser; no server needed)")
        if args.video:
            n = write_video(args.video, scene, fps=args.video_fps,
                            progress=None if args.quiet else "video")
            print(f"video: {args.video} ({n} frames at {args.video_fps or scene['fps']:g} fps)")
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


def _physics(robot, motion, controller: str | None, props=None):
    """The DART check of a motion with its props (printed), or None without ``controller``."""
    if controller is None:
        return None
    physics = simulate_motion(robot, motion, config=PhysicsConfig(
        control=ControlConfig(controller=controller)), scene=props)
    print(physics_line(physics_entries(physics)))
    return physics


def named_clip(motion, motion_path: str | Path):
    """The clip a motion file's provenance names, read with the options the retarget read it
    with (``--source`` without a file).

    Raises:
        ImeshError: the file names no clip, or the clip is no longer there.
    """
    clip = motion.provenance.source if motion.provenance is not None else None
    if clip is None:
        raise ImeshError(f"--source without a clip: {motion_path} names no source clip; valid: "
                         "--source CLIP")
    if not Path(clip.path).is_file():
        raise ImeshError(f"--source without a clip: {motion_path} was made from {clip.path}, "
                         "which is not there any more; valid: --source CLIP")
    return read_clip(clip.path, clip.load)


def _motion_scene(args) -> dict:
    """The scene of one motion file (``imesh view MOTION``)."""
    robot = robot_for_motion_file(args.motion, args.robot, args.urdf)  # default: the file's
    motion = load_motion_file(args.motion, robot, fps=args.fps)
    path = Path(args.motion)
    manifest = path.with_name(path.stem.removesuffix(".partner") + ".pair.json")
    if manifest.is_file():
        print(f"{args.motion} is one robot of a pair: imesh view {manifest} shows both")
    source = named_clip(motion, path) if args.source == NAMED_CLIP else args.source
    props = scene_for_motion(robot, motion, path, args.scene or (), source=source)
    physics = _physics(robot, motion, args.controller if args.physics else None, props)
    return build_scene(robot, motion, source=source, physics=physics, props=props,
                       title=f"{path.name} ({robot.name})")


def pair_scene(manifest: str | Path | PairFiles, *, source: bool = False,
               controller: str | None = None,
               scene_files: Sequence[str] = (), metrics: Sequence[Mapping] | None = None,
               pair_metrics: Mapping | None = None) -> dict:
    """The viewer scene of a pair from the files ``imesh retarget --partner`` wrote: both
    robots in their one world, each with its adapted markers (its person, morphed), overlays,
    self-collisions and limits, and the pair's figures with the robots' distance and the hand
    holds per frame (from the clips the manifest names, read again as the retarget read them;
    without them, the manifest's figures only).

    Args:
        manifest: ``OUT.pair.json``, or its contents already read (:class:`PairFiles`).
        source: draw both people (the clips, arranged in the pair's world at its shared scale).
        controller: run the DART check of each robot with this controller; None: not run.
        scene_files: props: ``.scene.npz`` files in the robots' world; default: the one beside
            robot a's motion, if any.
        metrics: each robot's evaluator report (default: the manifest's).
        pair_metrics: the pair's figures (default: the manifest's).

    Raises:
        PartnerError: not a pair manifest, or props given as meshes (a pair's props must be in
            its world: a ``.scene.npz``).
        ImeshError: a file it names is unreadable; ``source`` and a clip is missing.
    """
    files = manifest if isinstance(manifest, PairFiles) else read_pair_manifest(manifest)
    robots = [load_robot(files.robots[k]) for k in KEYS]
    motions = [load_motion_file(files.motions[k], r) for k, r in zip(KEYS, robots, strict=True)]
    metrics = metrics or [files.manifest.get("metrics", {}).get(k, {}) for k in KEYS]
    try:
        humans = files.humans()
    except ImeshError as exc:
        if source:
            raise
        log.warning("%s: the clips are not read (%s): the pair's distance per frame is not "
                    "shown", files.manifest_path, exc)
        humans = None
    view = _pair_view(files, robots, motions, humans, metrics,
                      pair_metrics or files.manifest.get("pair_metrics", {}))
    props = _pair_props(files, scene_files)
    entries = [SceneRobot(r, m, label=f"{k} {r.name}",
                          source=humans[i] if source and humans else None,
                          source_scale=files.scale, source_centre_m=np.asarray(files.centre_m),
                          physics=_physics(r, m, controller, props))
               for i, (k, r, m) in enumerate(zip(KEYS, robots, motions, strict=True))]
    return build_robots_scene(entries, props=props, pair=view,
                              title=f"{files.manifest_path.name}: " + ", ".join(
                                  f"{Path(files.clips[k]).name} -> {files.robots[k]}"
                                  for k in KEYS))


def _pair_view(files: PairFiles, robots, motions, humans, metrics, pair_metrics) -> PairView:
    """The pair's figures, and with the people's markers the robots' distance and the held
    frames per output frame (:func:`imesh.partners.evaluate.evaluate_pair_motions`)."""
    if humans is None:
        return PairView(dict(pair_metrics))
    holds = detect_holds(*humans)
    scored = evaluate_pair_motions(robots[0], motions[0], robots[1], motions[1], humans[0],
                                   humans[1], holds, files.scale, files.lead,
                                   reports=(metrics[0], metrics[1]))
    held = np.zeros(motions[0].n_frames, dtype=bool)
    held[np.clip(files.lead + np.asarray(holds.frames, dtype=int), 0, len(held) - 1)] = True
    return PairView(dict(pair_metrics), distance_m=scored.robot_distance_m, held=held)


def _pair_props(files: PairFiles, scene_files: Sequence[str]):
    """The props of a pair: the ``.scene.npz`` given, or the one beside robot a's motion."""
    if not scene_files:
        return find_scene(files.motions["a"])
    meshes = [f for f in scene_files if not str(f).endswith(SCENE_SUFFIX)]
    if meshes:
        raise PartnerError(f"--scene {', '.join(map(str, meshes))} with a pair: its props must "
                           f"be in the pair's world; valid: a {SCENE_SUFFIX} file")
    return scene_from_files(scene_files)


def write_pair_report_files(path: str | Path, manifest_path: str | Path, *,
                            metrics: Sequence[Mapping] | None = None,
                            pair_metrics: Mapping | None = None) -> Path:
    """Write the HTML report of a pair from its written files
    (:func:`imesh.viz.report.write_pair_report`): the pair's figures, both robots' tables and
    figures, and the viewer with both robots and both people (when the clips are there).

    Args:
        path: the ``.html`` file.
        manifest: ``OUT.pair.json``, or its contents already read (:class:`PairFiles`).
        metrics, pair_metrics: as :func:`pair_scene` (default: the manifest's).
    """
    files = read_pair_manifest(manifest_path)
    metrics = metrics or [files.manifest["metrics"][k] for k in KEYS]
    pair_metrics = pair_metrics or files.manifest["pair_metrics"]
    clips = all(Path(files.clips[k]).is_file() for k in KEYS)
    scene = pair_scene(files, source=clips, metrics=metrics, pair_metrics=pair_metrics)
    robots = [load_robot(files.robots[k]) for k in KEYS]
    return write_pair_report(path, robots, [files.motions[k] for k in KEYS], metrics=metrics,
                             pair_metrics=pair_metrics, scene=scene, keys=KEYS,
                             manifest=str(files.manifest_path),
                             facts={f"clip {k}": files.clips[k] for k in KEYS})

"""The ``imesh`` command line: inspect, rig, adapt, retarget and demo.

``main(argv)`` returns the exit status, so it can be tested in-process. Any ImeshError is printed
as one line (``imesh: error: ...``) with exit status 2; no traceback. Every output path is checked
before the command starts (:data:`OUTPUTS`), and the outputs of one command are kept together or
not at all (:func:`imesh.io.atomic.output_transaction`). Exit statuses: docs/errors.md.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import ImeshError
from .args import add_robot_arguments

if TYPE_CHECKING:  # pragma: no cover - typing only (the commands import lazily)
    from ..core.motion import MarkerMotion

log = logging.getLogger("imesh")


def _scale(text: str) -> tuple[str, float]:
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected GROUP=FACTOR, got {text!r}")
    group, value = text.split("=", 1)
    try:
        return group.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"factor of {group!r} must be a number, got {value!r}"
                                         ) from None


def _add_load_options(p: argparse.ArgumentParser, resample: bool = True) -> None:
    p.add_argument("--units",
                   help="override the detected unit (m, dm, cm, mm, in, cmu, or metres per unit)")
    p.add_argument("--up-axis", help="override the detected up axis (+X -X +Y -Y +Z -Z)")
    if resample:
        p.add_argument("--fps", type=float, help="resample to this frame rate")
    p.add_argument("--source-fps", type=float,
                   help="frame rate of formats that store none (AMC; default 120)")
    p.add_argument("--asf", help="skeleton (.asf) of an .amc clip (default: the .asf beside it "
                   "whose name starts the .amc name)")
    p.add_argument("--rig", help="rig table mapping the file to the standard markers: a .toml "
                   "(see `imesh rig`) or a built-in name; default: recognized from the skeleton")


def _add_morph_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scale", type=_scale, action="append", default=[], metavar="GROUP=FACTOR",
                   help="scale a bone group: arms, forearms, legs, spine, all (repeatable)")
    p.add_argument("--steps", type=int, default=10, help="morph steps (default 10)")
    p.add_argument("--accel-weight", type=float, default=1.0,
                   help="acceleration energy weight w_A, normalized to 30 fps (default 1)")
    p.add_argument("--window-frames", type=int, default=2000,
                   help="solve longer clips in windows of this many frames (default 2000)")


def _add_format_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=("npz", "csv", "mujoco"),
                   help="output format (imesh.io.formats): npz (imesh's), csv (one headerless row "
                        "per frame: base xyz, quaternion xyzw, joints), mujoco (qpos .npz, "
                        "quaternion wxyz, MJCF joint order); default: imesh's by the suffix")
    p.add_argument("--mjcf", help="MuJoCo model (.xml) for --format mujoco (default: the "
                   "robot's model in mujoco-menagerie; g1)")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="imesh",
        description="Adapt human motion capture to humanoid robots with the interaction mesh.")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="log decisions (-v) and solver steps (-vv)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    from .. import __version__

    parser.add_argument("--version", action="version", version=f"imesh {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("inspect", help="summarize a motion file and its rig mapping")
    p.add_argument("clip")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    _add_load_options(p)

    p = sub.add_parser("rig", help="recognize the human rig of a skeleton and write it as a rig "
                       "table (TOML) to edit and pass back with --rig")
    p.add_argument("clip")
    p.add_argument("-o", "--output", required=True, help="rig table to write (.toml)")
    p.add_argument("--name", help="rig name in the table (default: the output file's stem)")
    _add_load_options(p, resample=False)

    p = sub.add_parser("adapt", help="adapt human markers to new body proportions")
    p.add_argument("clip")
    p.add_argument("--people", help="a second performer in the same world frame (same mesh)")
    p.add_argument("-o", "--output", required=True, help="adapted markers (.npz or .csv)")
    p.add_argument("--json", dest="report", help="write the report (JSON) here")
    _add_load_options(p)
    _add_morph_options(p)

    p = sub.add_parser("retarget", help="adapt a motion file to a robot")
    p.add_argument("clip")
    add_robot_arguments(p)
    p.add_argument("-o", "--output", required=True,
                   help="robot motion (.npz or .csv: base position, base quaternion xyzw, joints)")
    p.add_argument("--json", dest="report", help="write the report (JSON) here")
    p.add_argument("--no-support", action="store_true",
                   help="no support-foot constraints in the morph")
    p.add_argument("--markers", help="also write the adapted markers (.npz or .csv)")
    _add_format_options(p)
    p.add_argument("--report", dest="report_html",
                   help="write an HTML report of the written motion (metrics, figures, 3D view)")
    p.add_argument("--balance", choices=("wholebody", "nishiwaki", "none"), default="wholebody",
                   help="wholebody: the whole-body spacetime solve (default; docs/wholebody.md); "
                        "nishiwaki: the paper's waist-correction loop; none: the initial fit")
    p.add_argument("--allow-flight", action="store_true",
                   help="accept flight phases (both feet up): those frames are left without "
                        "support and ZMP constraints and listed in the report")
    p.add_argument("--force", action="store_true",
                   help="write the motion even when it fails verification (exit 3 otherwise; "
                        "the report marks the failed gates)")
    p.add_argument("--no-lead", action="store_true",
                   help="no standing lead-in/out (1 s of settled double support each)")
    _add_load_options(p)
    p.add_argument("--steps", type=int, default=10, help="morph steps (default 10)")
    p.add_argument("--window-frames", type=int, default=2000,
                   help="solve longer clips in windows of this many frames (default 2000)")
    p.add_argument("--solve-workers", type=int, choices=(1, 2), default=1,
                   help="processes of a whole-body solve in several windows: 2 solves two "
                        "halves at once and joins them (pays only with a free core; default 1)")
    from .arms import add_options as add_arms_options

    add_arms_options(p)  # --mode {full,arms}, --fit {dls,sqp}, --solver, --plots

    p = sub.add_parser("robots", help="list the robots imesh knows; `imesh robots init "
                       "ROBOT.urdf -o DIR` generates a configuration from a URDF")
    p.add_argument("name", nargs="?", help="a robot (with --collisions), or init")
    p.add_argument("path", nargs="?", help="with init: the humanoid's URDF")
    p.add_argument("-o", "--output", help="with init: the folder to write (default: the URDF's "
                   "stem)")
    p.add_argument("--robot-name", help="with init: the robot's name (default: the URDF's)")
    p.add_argument("--collisions", action="store_true",
                   help="print the robot's self-collision capsules and the ignored pairs")
    p.add_argument("--write", action="store_true",
                   help="with --collisions: write robots/NAME/collision_pairs.toml from the rule")
    p.add_argument("--urdf", help="model file for robots whose model the user provides (hrp4c)")

    p = sub.add_parser("export", help="convert a robot motion to another format (CSV in the "
                       "retargeted-LAFAN1 layout, MuJoCo qpos, imesh .npz); docs/exports.md")
    p.add_argument("motion", help="robot motion (.npz or .csv, imesh's or an export)")
    p.add_argument("-o", "--output", required=True, help="file to write (.npz or .csv)")
    p.add_argument("--robot", help="the robot of a headerless CSV (its joint order)")
    p.add_argument("--fps", type=float, help="resample to this frame rate (slerp for the base)")
    p.add_argument("--source-fps", type=float,
                   help="frame rate of a headerless CSV given as input (default 30)")
    _add_format_options(p)

    from .batch import add_parser as add_batch_parser

    add_batch_parser(sub)

    from .evaluate import add_parser as add_evaluate_parser
    from .reduction import add_parser as add_reduce_parser

    add_evaluate_parser(sub)
    add_reduce_parser(sub)

    from .view import add_parsers as add_view_parsers

    add_view_parsers(sub)  # view, demo
    return parser


#: Frames the adapt/retarget pipeline needs: its zero-phase low-pass (order 4, run forwards and
#: backwards) pads 3 x 5 coefficients, and contacts, velocities and the acceleration energy need
#: neighbouring frames.
PIPELINE_MIN_FRAMES = 16


def _load(args, *, apply_rig: bool = True) -> MarkerMotion:
    from ..core.motion import require_frames
    from ..io import load_motion

    motion = load_motion(args.clip, units=_units(args.units), up_axis=args.up_axis,
                         fps=args.source_fps, asf=getattr(args, "asf", None))
    if getattr(args, "fps", None):
        motion = motion.resample(args.fps)
    if apply_rig and getattr(args, "rig", None):
        from ..human.markerset import to_standard

        motion = to_standard(motion, rig=args.rig)
    if args.command in ("adapt", "retarget"):
        require_frames(motion, PIPELINE_MIN_FRAMES, f"imesh {args.command} (its low-pass filter, "
                       "contact and acceleration terms)")
    return motion


def _units(text: str | None) -> str | float | None:
    """A unit name, or metres per file unit given as a number."""
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        return text


def _rig_mapping(motion, rig: str | None) -> dict:
    """What maps the motion to the standard markers (``imesh inspect``): a table given with
    --rig, the recognized skeleton, or a marker-set table found by name; ``error`` otherwise."""
    from ..errors import MarkerMappingError
    from ..human.markerset import detect_rig, load_rig

    def combos(markers: dict) -> dict:
        return {m: [[n, w] for n, w in c] for m, c in markers.items()}

    try:
        if rig:
            table = load_rig(rig)
            return {"table": table.name, "source": table.path, "markers": combos(table.markers)}
        if len(motion.bones):
            from ..human.rig import recognize_motion

            body, scale = recognize_motion(motion)
            return {"table": "recognized", "confidence": body.overall_confidence,
                    "confidence_by_part": dict(body.confidence),
                    "standing_height_m": body.height * scale,
                    "markers": combos(body.markers(scale)), "notes": list(body.notes),
                    "lines": body.describe(scale)}
        table = detect_rig(motion)
        return {"table": table.name, "source": table.path, "markers": combos(table.markers)}
    except MarkerMappingError as exc:
        return {"table": None, "error": str(exc)}


def _progress(args, total: int, desc: str):
    """A tqdm bar updated by the morph's per-step callback (None when quiet)."""
    if args.quiet:
        return None, None
    from tqdm import tqdm

    bar = tqdm(total=total, desc=desc, unit="step", leave=False, file=sys.stderr)

    def update(report) -> None:
        bar.set_postfix(bone_res=f"{report.bone_residual_m:.1e}")
        bar.update(1)

    return bar, update


def _morph_config(args):
    from ..morph.problem import MorphConfig

    return MorphConfig(steps=args.steps, accel_weight=args.accel_weight,
                       window_frames=args.window_frames)


def _run_adapt(args, motion, people=None):
    from ..morph.adapt import adapt_motion

    config = _morph_config(args)
    bar, update = _progress(args, config.steps, "morph")
    try:
        result = adapt_motion(motion, scales=dict(args.scale), people=people, config=config,
                              progress=update)
    finally:
        if bar is not None:
            bar.close()
    return result


def cmd_inspect(args) -> int:
    motion = _load(args, apply_rig=False)
    summary = motion.summary()
    rig = _rig_mapping(motion, args.rig)
    if args.json:
        summary["rig"] = {k: v for k, v in rig.items() if k != "lines"}
        print(json.dumps(summary))
        return 0
    for key, value in summary.items():
        if key == "markers":
            value = f"{len(value)}: " + ", ".join(value)
        print(f"{key:>17}: {value}")
    if rig.get("error"):
        print(f"{'rig':>17}: not recognized: {rig['error']}")
        return 0
    if "lines" in rig:
        print(f"{'rig':>17}: recognized from the skeleton (confidence "
              f"{rig['confidence']:.2f}), standing height {rig['standing_height_m']:.3f} m")
        lines = rig["lines"]
    else:
        print(f"{'rig':>17}: table {rig['table']} ({rig['source']})")
        lines = [f"{m:>10} = " + " + ".join(f"{w:g} {n}" if len(c) > 1 else n for n, w in c)
                 for m, c in rig["markers"].items()]
    for line in lines:
        print(f"{'':>19}{line}")
    return 0


def cmd_rig(args) -> int:
    from ..human.markerset import detect_rig, rig_toml
    from ..io.atomic import atomic_path

    motion = _load(args, apply_rig=False)
    name = args.name or Path(args.output).stem
    head = [f"Rig table for {Path(args.clip).name}, written by `imesh rig` (units "
            f"{motion.meta.get('units', 'm')}, up axis {motion.meta.get('up_axis', '+Z')}).",
            "Each standard marker = a joint, a list (equal-weight mean) or name = weight pairs",
            "(summing to 1). Edit it and pass it back with --rig FILE."]
    if len(motion.bones):
        from ..human.rig import recognize_motion

        body, scale = recognize_motion(motion)
        table = body.table(scale, name=name)
        head.append(f"Recognized from the skeleton, confidence {body.overall_confidence:.2f} ("
                    + ", ".join(f"{k} {v:.2f}" for k, v in body.confidence.items()) + ").")
        head += [f"Note: {note}" for note in body.notes]
        lines = body.describe(scale)
    else:  # a marker set: its table found by the marker names, as a starting point
        found = detect_rig(motion)
        table = type(found)(name=name, description=found.description, detect=found.detect,
                            markers=found.markers, path=args.output)
        head.append(f"Marker set: copied from the built-in table {found.name!r}.")
        lines = []
    with atomic_path(args.output) as tmp:
        tmp.write_text(rig_toml(table, [*head, ""]))
    for line in lines:
        print(line)
    print(f"wrote rig table {name!r} -> {args.output}")
    return 0


def cmd_adapt(args) -> int:
    from ..io import load_motion
    from ..io.atomic import write_json
    from ..io.npz import save_marker_motion

    motion = _load(args)
    people = None
    if args.people:
        people = load_motion(args.people, units=_units(args.units), up_axis=args.up_axis,
                             fps=args.source_fps)
        if args.fps:
            people = people.resample(args.fps)
        if args.rig:
            from ..human.markerset import to_standard

            people = to_standard(people, rig=args.rig)
    result = _run_adapt(args, motion, people)
    report = result.report()
    save_marker_motion(args.output, result.adapted)
    if args.report:
        write_json(args.report, report)
    print(f"adapted {report['frames']} frames x {report['markers']} markers in "
          f"{report['seconds']:.2f} s: bone residual {report['bone_residual_m']:.2e} m, "
          f"close-pair error {report['close_pair_error']:.4f} "
          f"(naive scaling {report['naive_close_pair_error']:.4f}) -> {args.output}")
    return 0


def _arms_config(args):
    """``--fit sqp``: the initial fit's arms by Kim's SQP (imesh/arms), else None."""
    if getattr(args, "fit", "dls") != "sqp":
        return None
    import dataclasses

    from ..arms.solve import REFINE_CONFIG

    return dataclasses.replace(REFINE_CONFIG, solver=args.solver)


def _retarget_config(args, steps: int, window_frames: int = 2000, support: bool = True,
                     balance: str = "wholebody"):
    import dataclasses

    from ..contacts.support import SupportConfig
    from ..pipeline.retarget import RetargetConfig

    base = RetargetConfig()
    return RetargetConfig(morph=dataclasses.replace(base.morph, steps=steps,
                                                    window_frames=window_frames),
                          support=SupportConfig() if support else None, balance=balance,
                          fps=getattr(args, "fps", None) or base.fps,
                          allow_flight=getattr(args, "allow_flight", False),
                          lead_s=0.0 if getattr(args, "no_lead", False) else base.lead_s,
                          workers=getattr(args, "solve_workers", base.workers),
                          arms=_arms_config(args))


def cmd_retarget(args) -> int:
    from ..io.atomic import write_json
    from ..io.npz import save_marker_motion
    from ..io.robot_motion import save_robot_motion
    from ..robot import load_robot

    if args.mode == "arms":  # Kim 2005 arm imitation (imesh/arms)
        from .arms import run_arms

        robot = load_robot(args.robot, urdf=args.urdf)
        motion = _load(args)
        status = run_arms(args, robot, motion)
        if args.report_html:
            from ..viz.report import write_report

            write_report(args.report_html, robot, args.output, source=motion, balanced=False,
                         facts={"source clip": args.clip, "mode": "arms (Kim 2005)"})
        return status
    motion = _load(args)
    config = _retarget_config(args, args.steps, args.window_frames, support=not args.no_support,
                              balance=args.balance)
    from ..core.progress import retarget_bar

    bar = retarget_bar(args.quiet, f"{Path(args.clip).name} -> {args.robot}", motion, config)
    try:
        bar.stage("load", detail=f"robot {args.robot}")
        robot = load_robot(args.robot, urdf=args.urdf)
        from ..pipeline.retarget import retarget

        result = retarget(motion, robot, config=config, progress=bar)
        report = result.report()
        if args.plots and result.balance is not None:
            from ..viz.balance import plot_balance

            report["balance_plots"] = plot_balance(result.balance, args.plots, robot.name)
        robot_motion = result.motion
        # verify before writing: the summary and the gates are the evaluator's report of the
        # motion as it will be written (the file holds exactly these float64 configurations)
        from ..errors import VerificationError
        from ..evaluate.scoreboard import evaluate_motion, format_table
        from ..evaluate.verify import failed_gates

        bar.stage("verify", robot_motion.n_frames)
        metrics = evaluate_motion(robot, robot_motion, adapted=result.adapted,
                                  seconds=result.seconds)
        report["metrics"] = metrics
        failed = failed_gates(metrics, balanced=args.balance != "none")
        report["verification"] = {"passed": not failed,
                                  "failed": {k: {"value": v[0], "gate": v[1]}
                                             for k, v in failed.items()}}
        if failed and not args.force:
            raise VerificationError(f"retargeted motion of {args.clip} for {robot.name}", failed)
        bar.stage("write", robot_motion.n_frames)
        if args.format in (None, "npz"):
            save_robot_motion(args.output, robot_motion, markers=result.adapted)
        else:
            from ..io.formats import write_export

            write_export(robot_motion, args.output, args.format, mjcf=args.mjcf)
        if args.markers:
            save_marker_motion(args.markers, result.adapted)
        if args.report:
            write_json(args.report, report)
        if args.report_html:
            from ..viz.report import write_report

            write_report(args.report_html, robot, args.output, source=motion,
                         balanced=args.balance != "none",
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
    print(format_table(metrics))
    return 0


def cmd_robots(args) -> int:
    from ..robot import list_robots

    if args.name == "init":
        from .robots import cmd_robots_init

        return cmd_robots_init(args.path, args.output, args.robot_name)
    if args.collisions or args.name:
        from ..robot import load_robot
        from ..robot.capsules.robot import describe_collisions

        if not args.name:
            raise ImeshError("imesh robots --collisions needs a robot name")
        print(describe_collisions(load_robot(args.name, urdf=args.urdf), write=args.write))
        return 0

    rows = list_robots()
    print(f"{'robot':<8} {'DOF':>4}  {'licence':<14} source")
    for r in rows:
        dof = r.get("dof", "?")
        print(f"{r['name']:<8} {dof!s:>4}  {r.get('licence', ''):<14} {r.get('source', '')}")
    print("any other humanoid: imesh robots init ROBOT.urdf -o DIR (docs/byo-robot.md)")
    return 0


def cmd_export(args) -> int:
    from ..io.formats import read_export, write_export

    motion = read_export(args.motion, args.robot, fps=args.source_fps)
    fmt = args.format
    if fmt is None and Path(args.output).suffix.lower() == ".csv":
        fmt = "csv"
    write_export(motion, args.output, fmt, fps=args.fps, mjcf=args.mjcf)
    print(f"exported {args.motion} -> {args.output} ({fmt or 'npz'}, "
          f"{args.fps or motion.fps:g} fps)")
    return 0


def cmd_batch(args) -> int:
    from .batch import run

    return run(args)


def cmd_demo(args) -> int:
    from .view import run_demo

    return run_demo(args)


def cmd_view(args) -> int:
    from .view import run_view

    return run_view(args)


def cmd_evaluate(args) -> int:
    from .evaluate import run

    return run(args)


def cmd_reduce(args) -> int:
    from .reduction import run

    return run(args)


COMMANDS = {"inspect": cmd_inspect, "rig": cmd_rig, "adapt": cmd_adapt, "retarget": cmd_retarget,
            "robots": cmd_robots, "demo": cmd_demo, "evaluate": cmd_evaluate,
            "reduce": cmd_reduce, "view": cmd_view, "export": cmd_export,
            "batch": cmd_batch}


_MOTION = (".npz", ".csv")
_JSON = (".json",)
_HTML = (".html", ".htm")
_FOLDER = None
#: The output options of each command, checked before it starts: (attribute of the parsed
#: arguments, option, valid extensions or _FOLDER for an output folder). A new output option
#: must be listed here.
OUTPUTS: dict[str, tuple[tuple[str, str, tuple[str, ...] | None], ...]] = {
    "adapt": (("output", "-o", _MOTION), ("report", "--json", _JSON)),
    "retarget": (("output", "-o", _MOTION), ("report", "--json", _JSON),
                 ("markers", "--markers", _MOTION), ("plots", "--plots", _FOLDER),
                 ("report_html", "--report", _HTML)),
    "evaluate": (("report", "--json", _JSON), ("plot", "--plot", (".png", ".pdf", ".svg")),
                 ("report_html", "--report", _HTML)),
    "view": (("html", "--html", _HTML), ("video", "--video", (".mp4",))),
    "reduce": (("output", "-o", (".npz",)), ("report", "--json", _JSON),
               ("plots", "--plots", _FOLDER)),
    "demo": (("output", "-o", _FOLDER),),
    "rig": (("output", "-o", (".toml",)),),
    "export": (("output", "-o", _MOTION),),
    "batch": (("output", "-o", _FOLDER),),
}

#: Exit statuses: 0 success, 2 bad input or usage, 3 reserved for an output that was written but
#: failed its verification; 130 interrupted; 141 (128 + SIGPIPE) when the reader of the standard
#: output went away (``imesh ... | head``).
EXIT_OK, EXIT_USAGE, EXIT_VERIFY, EXIT_INTERRUPTED, EXIT_PIPE = 0, 2, 3, 130, 141


def check_command_outputs(args) -> None:
    """Check every output path of the parsed command (extension, folder exists and is
    writable) before any work; raises :class:`~imesh.errors.OutputPathError`."""
    from ..io.atomic import Output, check_outputs

    check_outputs(Output(getattr(args, attr), option, exts or (), folder=exts is None)
                  for attr, option, exts in OUTPUTS.get(args.command, ())
                  if getattr(args, attr, None))


def _stdout_gone() -> int:
    """The reader of stdout closed it: no traceback, no message (as ``cat`` and ``git``)."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's final flush must not fail again
    except (OSError, ValueError):  # stdout is not a real file (in-process tests)
        pass
    return EXIT_PIPE


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 2 on any ImeshError, see
    :data:`EXIT_OK` ...)."""
    from ..io.atomic import output_transaction

    parser = build_parser()
    args = parser.parse_args(argv)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    logging.getLogger("imesh").setLevel(level)
    try:
        with output_transaction():
            check_command_outputs(args)
            return COMMANDS[args.command](args)
    except ImeshError as exc:
        one_line = " ".join(str(exc).split())  # names read from a file may hold newlines
        print(f"imesh: error: {one_line}", file=sys.stderr)
        return getattr(exc, "exit_status", EXIT_USAGE)  # VerificationError: EXIT_VERIFY
    except BrokenPipeError:
        return _stdout_gone()
    except KeyboardInterrupt:
        print("imesh: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def entry_point() -> None:
    try:
        status = main()
        sys.stdout.flush()
    except BrokenPipeError:
        status = _stdout_gone()
    sys.exit(status)


if __name__ == "__main__":
    entry_point()

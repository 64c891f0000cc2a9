"""The argument parsers of every ``imesh`` command: one ``add_<command>(subparsers)`` per command
and the option groups several commands share.

This module stays light (argparse only): :func:`imesh.cli.app.build_parser` builds the whole
parser, for ``imesh --help`` too, before any command module (and its heavy imports) is loaded.
"""

from __future__ import annotations

import argparse

#: The per-frame solvers of the arm problem, :data:`imesh.arms.config.SOLVERS` (that module
#: imports numpy and the robot model: a third of a second of ``imesh --help``);
#: tests/test_cli.py checks that both agree.
ARM_SOLVERS = ("gn", "slsqp")

#: What ``imesh view|evaluate`` do without ``--robot``/``--urdf`` (the help says it).
FILE_ROBOT = "the robot the motion file names"
#: ``imesh view MOTION --source`` without a clip: the clip(s) the motion file or pair names.
NAMED_CLIP = "the clip the motion names"

#: The built-in clip of ``imesh demo`` (:func:`imesh.api.demo_clip`), named in its help.
DEMO_CLIP = "cmu_02_01_walk.bvh"


# ----------------------------------------------------------------------------------------------
# option types and groups


def _scale(text: str) -> tuple[str, float]:
    """``GROUP=FACTOR`` of ``--scale`` as (group, factor)."""
    if "=" not in text:
        raise argparse.ArgumentTypeError(f"expected GROUP=FACTOR, got {text!r}")
    group, value = text.split("=", 1)
    try:
        return group.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"factor of {group!r} must be a number, got {value!r}"
                                         ) from None


def _rank(text: str) -> int | None:
    """``--rank`` of ``imesh reduce``: 1..5, or None for 'full'."""
    if text.lower() in ("full", "none"):
        return None
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"rank must be 1..5 or 'full', got {text!r}") from None
    if not 1 <= value <= 5:
        raise argparse.ArgumentTypeError(f"rank must be 1..5 or 'full', got {value}")
    return value


def add_robot_arguments(p: argparse.ArgumentParser, default: str = "jvrc1") -> None:
    """``--robot`` (a folder of robots/ or a robot.toml) and ``--urdf`` (the model file of
    robots whose model the user provides; alone, a configuration generated from it);
    ``default`` says in the help what happens without them."""
    p.add_argument("--robot", default=None,
                   help=f"robot: a folder of robots/ (jvrc1, g1, hrp4c) or a robot.toml "
                        f"(default {default}; with --urdf alone, generated from the URDF)")
    p.add_argument("--urdf", help="model file for robots whose model the user provides "
                   "(hrp4c); alone: any humanoid URDF, configured automatically "
                   "(imesh robots init)")


def _robot_command(sub, name: str, subject: str, subject_help: str | None = None, *,
                   metavar: str | None = None, robot_default: str = "jvrc1",
                   **kwargs) -> argparse.ArgumentParser:
    """A command on one file or folder (``subject``) for a robot (``--robot``, ``--urdf``)."""
    p = sub.add_parser(name, **kwargs)
    p.add_argument(subject, metavar=metavar, help=subject_help)
    add_robot_arguments(p, robot_default)
    return p


def _add_load_options(p: argparse.ArgumentParser, resample: bool = True) -> None:
    """How to read a human clip: units, up axis, frame rates, ASF skeleton, rig table."""
    p.add_argument("--units",
                   help="override the detected unit (m, dm, cm, mm, in, cmu, or metres per unit)")
    p.add_argument("--up-axis", help="override the detected up axis (+X -X +Y -Y +Z -Z)")
    if resample:
        p.add_argument("--fps", type=float, help="resample to this frame rate")
    p.add_argument("--source-fps", type=float,
                   help="the clip's capture rate: for formats that store none (AMC: default 120; "
                   "joint-position .npy: required), or replacing the file's (default: the "
                   "file's, halved where the performer's balance says it is twice the capture "
                   "rate: docs/clips.md)")
    p.add_argument("--asf", help="skeleton (.asf) of an .amc clip (default: the .asf beside it "
                   "whose name starts the .amc name)")
    p.add_argument("--rig", help="rig table mapping the file to the standard markers: a .toml "
                   "(see `imesh rig`) or a built-in name; default: recognized from the skeleton")
    p.add_argument("--body-model", metavar="DIR",
                   help="folder of the SMPL-X / SMPL-H body-model files an AMASS .npz needs "
                   "(DIR/smplx/SMPLX_NEUTRAL.npz ...; docs/amass.md)")
    p.add_argument("--joints", metavar="FILE",
                   help="joint names of a joint-position .npy/.npz, one per line (default: "
                   "names stored in the .npz, or a joint_names.txt beside the file; "
                   "docs/terrain.md)")


def _add_morph_options(p: argparse.ArgumentParser) -> None:
    """The spacetime morph of ``imesh adapt``: bone scales, steps, weights, windows."""
    p.add_argument("--scale", type=_scale, action="append", default=[], metavar="GROUP=FACTOR",
                   help="scale a bone group: arms, forearms, legs, spine, all (repeatable)")
    p.add_argument("--steps", type=int, default=10, help="morph steps (default 10)")
    p.add_argument("--accel-weight", type=float, default=1.0,
                   help="acceleration energy weight w_A, normalized to 30 fps (default 1)")
    p.add_argument("--window-frames", type=int, default=2000,
                   help="solve longer clips in windows of this many frames (default 2000)")


def _add_format_options(p: argparse.ArgumentParser) -> None:
    """``--format`` and ``--mjcf`` of the robot-motion writers."""
    p.add_argument("--format", choices=("npz", "csv", "mujoco", "gmr"),
                   help="output format (imesh.io.formats): npz (imesh's), csv (one headerless row "
                        "per frame: base xyz, quaternion xyzw, joints), mujoco (qpos .npz, "
                        "quaternion wxyz, MJCF joint order), gmr (GMR's .pkl: fps, root_pos, "
                        "root_rot xyzw, dof_pos in GMR's joint order; G1); default: imesh's by "
                        "the suffix")
    p.add_argument("--mjcf", help="MuJoCo model for --format mujoco: an MJCF (.xml) whose joints "
                   "are the robot's, or 'menagerie' (mujoco-menagerie's model: g1); default: "
                   "compiled by MuJoCo from the robot's URDF, offline")


def _add_arms_options(p: argparse.ArgumentParser) -> None:
    """``--mode``, ``--fit``, ``--solver`` and ``--plots`` of ``imesh retarget`` (the arm
    imitation of Kim 2005: :mod:`imesh.cli.arms`)."""
    p.add_argument("--mode", choices=("full", "arms"), default="full",
                   help="full: the whole pipeline (default); arms: only the arms imitate the "
                   "clip (Kim 2005), base, legs and torso stay at the nominal pose")
    p.add_argument("--fit", choices=("dls", "sqp"), default="dls",
                   help="full mode's fitting: dls (default) or dls with the arm joints re-solved "
                   "by Kim's SQP")
    p.add_argument("--solver", choices=ARM_SOLVERS, default="gn",
                   help="per-frame solver of the arm problem: gn (box-constrained "
                   "Gauss-Newton, default) or slsqp (scipy)")
    p.add_argument("--plots", help="write figures (PNG) into this folder: arms mode Kim's "
                   "Fig. 3 and Fig. 4 for every arm, full mode the balance plots")


# ----------------------------------------------------------------------------------------------
# the commands


def add_inspect(sub) -> argparse.ArgumentParser:
    """``imesh inspect CLIP``."""
    p = sub.add_parser("inspect", help="summarize a motion file and its rig mapping")
    p.add_argument("clip")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    _add_load_options(p)
    return p


def add_rig(sub) -> argparse.ArgumentParser:
    """``imesh rig CLIP -o TABLE.toml``."""
    p = sub.add_parser("rig", help="recognize the human rig of a skeleton and write it as a rig "
                       "table (TOML) to edit and pass back with --rig")
    p.add_argument("clip")
    p.add_argument("-o", "--output", required=True, help="rig table to write (.toml)")
    p.add_argument("--name", help="rig name in the table (default: the output file's stem)")
    _add_load_options(p, resample=False)
    return p


def add_adapt(sub) -> argparse.ArgumentParser:
    """``imesh adapt CLIP -o MARKERS``."""
    p = sub.add_parser("adapt", help="adapt human markers to new body proportions")
    p.add_argument("clip")
    p.add_argument("--people", help="a second performer in the same world frame (same mesh)")
    p.add_argument("-o", "--output", required=True, help="adapted markers (.npz or .csv)")
    p.add_argument("--json", dest="report", help="write the report (JSON) here")
    _add_load_options(p)
    _add_morph_options(p)
    return p


def add_retarget(sub) -> argparse.ArgumentParser:
    """``imesh retarget CLIP -o MOTION``."""
    p = _robot_command(sub, "retarget", "clip", help="adapt a motion file to a robot")
    p.add_argument("-o", "--output", required=True,
                   help="robot motion (.npz or .csv: base position, base quaternion xyzw, joints)")
    p.add_argument("--json", dest="report", help="write the report (JSON) here")
    p.add_argument("--no-support", action="store_true",
                   help="no support-foot constraints in the morph")
    p.add_argument("--markers", help="also write the adapted markers (.npz or .csv)")
    p.add_argument("--partner", metavar="CLIP",
                   help="a second person recorded with CLIP in one world (same frames and "
                        "rate): both in one interaction mesh, two robots; writes OUTPUT, "
                        "OUTPUT.partner and OUTPUT.pair.json (docs/partners.md)")
    p.add_argument("--partner-robot", metavar="ROBOT",
                   help="robot of --partner (a folder of robots/ or a robot.toml; default "
                        "--robot)")
    p.add_argument("--alone", action="store_true",
                   help="with --partner: retarget each person alone in the same world (no "
                        "shared mesh, avoidance or holds): the baseline")
    p.add_argument("--frames", metavar="START:STOP",
                   help="with --partner: only these clip frames (at the file's rate)")
    _add_format_options(p)
    p.add_argument("--report", dest="report_html",
                   help="write an HTML report of the written motion (metrics, figures, 3D view)")
    p.add_argument("--balance", choices=("wholebody", "nishiwaki", "none"), default="wholebody",
                   help="wholebody: the whole-body spacetime solve (default; docs/wholebody.md); "
                        "nishiwaki: the paper's waist-correction loop; none: the initial fit")
    p.add_argument("--allow-flight", action="store_true",
                   help="deprecated: flight phases are planned by default (ballistic); only "
                        "--balance nishiwaki, which has no flight model, needs it to accept "
                        "them (those frames are left without support and ZMP constraints)")
    p.add_argument("--force", action="store_true",
                   help="write the motion even when it fails verification (exit 3 otherwise; "
                        "the report marks the failed gates)")
    p.add_argument("--no-lead", action="store_true",
                   help="no standing lead-in/out (1 s of settled double support each)")
    p.add_argument("--physics", action="store_true",
                   help="also run the DART check before writing and gate on it: a fall is a "
                        "failed gate (exit 3, nothing written without --force)")
    p.add_argument("--controller", choices=("wbc", "kinematic", "spd", "pid"), default="wbc",
                   help="controller of the DART check (--physics; default wbc, docs/checking.md)")
    _add_load_options(p)
    p.add_argument("--steps", type=int, default=10, help="morph steps (default 10)")
    p.add_argument("--window-frames", type=int, default=2000,
                   help="solve longer clips in windows of this many frames (default 2000)")
    p.add_argument("--scene", action="append", default=[], metavar="FILE",
                   help="static props (OBJ/STL/PLY meshes, or a URDF of fixed links) in the "
                   "clip's frame and units (repeatable): scaled with the human, written beside "
                   "the output as OUT.scene.npz and measured (penetration, contacts kept, skid); "
                   "not yet part of the solve (docs/terrain.md)")
    p.add_argument("--scene-scale", type=float, metavar="S",
                   help="scale the props by S about the retarget's fixed point instead of the "
                   "human-to-robot scale (the robot's legs over the human's)")
    p.add_argument("--solve-workers", type=int, choices=(1, 2), default=1,
                   help="processes of a whole-body solve in several windows: 2 solves two "
                        "halves at once and joins them (pays only with a free core; default 1)")
    _add_arms_options(p)
    return p


def add_robots(sub) -> argparse.ArgumentParser:
    """``imesh robots [NAME --collisions | init URDF -o DIR]``."""
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
    return p


def add_export(sub) -> argparse.ArgumentParser:
    """``imesh export MOTION -o FILE``."""
    p = sub.add_parser("export", help="convert a robot motion to another format (CSV in the "
                       "retargeted-LAFAN1 layout, MuJoCo qpos, imesh .npz); docs/exports.md")
    p.add_argument("motion", help="robot motion (.npz or .csv, imesh's or an export)")
    p.add_argument("-o", "--output", required=True, help="file to write (.npz or .csv)")
    p.add_argument("--robot", help="the robot of a headerless CSV (its joint order); default: "
                   "the robot the motion file names")
    p.add_argument("--urdf", help="model file of a robot whose model the user provides "
                   "(hrp4c), for --format mujoco")
    p.add_argument("--fps", type=float, help="resample to this frame rate (slerp for the base)")
    p.add_argument("--source-fps", type=float,
                   help="frame rate of a headerless CSV given as input (default 30)")
    _add_format_options(p)
    return p


def add_batch(sub) -> argparse.ArgumentParser:
    """``imesh batch IN_DIR_OR_GLOB -o OUT_DIR`` (:mod:`imesh.pipeline.batch`, docs/batch.md)."""
    p = _robot_command(
        sub, "batch", "inputs", "folder of clips or glob pattern", metavar="IN_DIR_OR_GLOB",
        help="retarget a folder or glob of clips on Ray (resumable); docs/batch.md",
        description="Retarget every clip of a folder (or a glob pattern) to a robot, on a local "
        "Ray runtime or a cluster. Outputs whose input and settings are unchanged are skipped. "
        "Exit status 0 when every clip is done, 4 when some failed (see OUT_DIR/batch.jsonl).")
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("--workers", type=int, default=2, help="clips at a time (default 2)")
    p.add_argument("--address", help="join this Ray cluster (e.g. 'auto' after `ray start "
                   "--head`); default: a local Ray runtime")
    p.add_argument("--backend", choices=("ray", "processes"), default="ray",
                   help="ray (default) or local processes (no Ray needed)")
    p.add_argument("--format", choices=("npz", "csv", "mujoco", "gmr"), default="npz",
                   help="output format (docs/exports.md; default npz)")
    p.add_argument("--mjcf", help="MuJoCo model for --format mujoco")
    p.add_argument("--fps", type=float, help="output frame rate (default 30)")
    p.add_argument("--balance", choices=("wholebody", "nishiwaki", "none"), default="wholebody")
    p.add_argument("--force", action="store_true",
                   help="write motions that fail verification (otherwise such a clip fails)")
    p.add_argument("--retry-failed", action="store_true",
                   help="run clips again that failed before with the same input and settings "
                        "(default: reported as failed again, not recomputed)")
    return p


def add_evaluate(sub) -> argparse.ArgumentParser:
    """``imesh evaluate MOTION`` (the library is :mod:`imesh.evaluate`)."""
    p = _robot_command(
        sub, "evaluate", "motion", "robot motion (.npz or .csv)", robot_default=FILE_ROBOT,
        help="score a robot motion: every quality metric (and the DART check)",
        description="Compute the quality metrics of a robot motion (.npz/.csv: joint names, "
        "base position [m], base quaternion; see docs/checking.md), print a table and "
        "optionally write them as JSON (keys = the metric names).")
    p.add_argument("--source", help="the human clip the motion was retargeted from")
    p.add_argument("--pair", metavar="PAIR.json",
                   help="the motion is robot a of imesh retarget --partner: score both robots "
                        "and the pair (inter-person close-pair error, robot-robot penetration, "
                        "held hands) from the manifest it wrote (docs/partners.md)")
    p.add_argument("--body-model", metavar="DIR",
                   help="the body-model folder of an AMASS --source (default: the one the "
                   "motion's provenance records; docs/amass.md)")
    p.add_argument("--adapted", help="the adapted markers the robot fitted (.npz from "
                   "'imesh retarget --markers')")
    p.add_argument("--resample", action="store_true",
                   help="compare --source/--adapted markers of another frame rate or frame count "
                   "(resampled to the motion's fps, first common frames); by default such a "
                   "mismatch is refused")
    p.add_argument("--fps", type=float, help="frame rate of motion files that store none")
    p.add_argument("--detect-support", action="store_true",
                   help="judge the soles by the support detected from them, as another tool's "
                   "output is judged, instead of the plan's contact modes an imesh .npz carries "
                   "(for side-by-side comparisons)")
    p.add_argument("--scene", action="append", default=[], metavar="FILE",
                   help="the props to measure the motion against: a .scene.npz written by "
                   "'imesh retarget --scene', or meshes/URDF in the clip's frame, scaled like "
                   "the retarget (needs the source clip); default: MOTION's .scene.npz beside "
                   "it (docs/terrain.md)")
    p.add_argument("--scene-scale", type=float, metavar="S",
                   help="scale mesh/URDF --scene props by S instead of the human-to-robot scale")
    p.add_argument("--physics", action="store_true", help="run the DART dynamics check")
    p.add_argument("--controller", choices=("wbc", "kinematic", "spd", "pid"), default="wbc",
                   help="controller of the DART check: wbc (whole-body QP with balance "
                        "feedback, default), kinematic (joints follow exactly, base free: the "
                        "paper's check), spd/pid (open-loop joint tracking)")
    p.add_argument("--fixed-base", action="store_true",
                   help="weld the base at its first pose in DART (arm-only tracking)")
    p.add_argument("--plot", help="write the DART run's figure here (.png)")
    p.add_argument("--json", dest="report", help="write the metrics (JSON) here")
    p.add_argument("--report", dest="report_html",
                   help="write an HTML report (metrics table with the gates, figures, 3D view)")
    return p


def add_reduce(sub) -> argparse.ArgumentParser:
    """``imesh reduce CLIP -o CYCLE.npz``: dynamically consistent cyclic motion by motion
    reduction (:mod:`imesh.reduction`)."""
    p = sub.add_parser(
        "reduce", help="dynamically consistent cyclic motion by PCA motion reduction "
                       "(Okada & Miyazaki)",
        description="Turn a human walking clip into a cyclic robot motion that satisfies the "
                    "robot's equations of motion, closed-loop foot contact, joint-angle and "
                    "torque limits and positive ground forces, optimized in a PCA subspace.")
    p.add_argument("clip", help="a walking clip (BVH, ASF/AMC, C3D, TRC)")
    p.add_argument("--robot", default="planar_biped",
                   help="planar_biped (the project's 7-link planar biped, default), jvrc1 or g1 "
                        "(their sagittal hip/knee/ankle pitch joints), or a planar biped URDF")
    p.add_argument("-o", "--output", required=True, help="robot motion of one cycle (.npz)")
    p.add_argument("--json", dest="report", help="write the report (JSON) here")
    p.add_argument("--rank", type=_rank, default=3,
                   help="reduced dimension r of the five non-foot angles, or 'full' (default 3)")
    p.add_argument("--method", default="gauss-newton", choices=("gauss-newton", "gradient"),
                   help="stage (I) step: Levenberg-Marquardt on the same residuals (default) or "
                        "the paper's steepest descent (Jacobi-scaled)")
    p.add_argument("--max-iterations", type=int, default=200,
                   help="stage (I)+(II) iterations at most (default 200)")
    p.add_argument("--samples", type=int, help="samples per cycle (default: the clip's frames "
                                               "per cycle)")
    p.add_argument("--harmonics", type=int, default=15,
                   help="harmonics of the optimized trajectories (default 15)")
    p.add_argument("--cutoff", type=float, default=40.0,
                   help="cut-off of the differentiating filters [Hz] (default 40)")
    p.add_argument("--dart", action="store_true",
                   help="run the result in DART (planar biped only) and add it to the report")
    p.add_argument("--dart-cycles", type=int, default=3, help="cycles in DART (default 3)")
    p.add_argument("--plots", help="write the figures (joint angles/torques, y_m, ground "
                                   "forces, convergence, stick figures) into this folder")
    p.add_argument("--units", help="override the detected unit (m, cm, mm, in, cmu)")
    p.add_argument("--up-axis", help="override the detected up axis (+X -X +Y -Y +Z -Z)")
    p.add_argument("--source-fps", type=float,
                   help="the clip's capture rate: for formats that store none (AMC: default 120; "
                   "joint-position .npy: required), or replacing the file's (default: the "
                   "file's, halved where the performer's balance says it is twice the capture "
                   "rate: docs/clips.md)")
    return p


def add_view(sub) -> argparse.ArgumentParser:
    """``imesh view MOTION`` or ``imesh view OUT.pair.json`` (the library is :mod:`imesh.viz`)."""
    p = _robot_command(
        sub, "view", "motion", "robot motion (.npz or .csv), or a pair's OUT.pair.json (imesh "
        "retarget --partner): both robots in one scene", robot_default=FILE_ROBOT,
        help="look at a robot motion or a pair: 3D viewer in the browser, one self-contained "
        "page (--html) or a video (--video)",
        description="Show a robot motion (.npz/.csv from 'imesh retarget') in 3D: the robot's "
        "meshes, the adapted markers and the human source, the interaction mesh, soles, support "
        "polygon, desired and actual ZMP, self-collisions and limit violations, with a "
        "timeline; the props of its scene (OUT.scene.npz beside it, or --scene). Given a "
        "pair's OUT.pair.json, both robots in their one world, each with its own overlays, "
        "and the pair's figures. Without --html/--video the page is served on 127.0.0.1 until "
        "Ctrl-C.")
    p.add_argument("--source", nargs="?", const=NAMED_CLIP, metavar="CLIP",
                   help="the human clip, drawn beside the robot; without CLIP (after MOTION): "
                   "the clip the motion file names, or both clips of a pair's manifest")
    p.add_argument("--scene", action="append", default=[], metavar="FILE",
                   help="the props to draw: a .scene.npz written by 'imesh retarget --scene', "
                   "or meshes/URDF in the clip's frame, scaled like the retarget (needs the "
                   "source clip); default: MOTION's .scene.npz beside it (repeatable)")
    p.add_argument("--fps", type=float, help="frame rate of motion files that store none")
    p.add_argument("--html", help="write the viewer as one self-contained page (.html): no "
                   "server, no network")
    p.add_argument("--video", help="render the whole motion to a video (.mp4), headless: robot "
                   "with the markers and the human beside it (needs chromium)")
    p.add_argument("--video-fps", type=float, help="video frame rate (default: the motion's)")
    p.add_argument("--physics", action="store_true",
                   help="run the DART check first and draw the simulated robot beside the "
                        "reference, with its fall time (docs/checking.md); each robot of a pair")
    p.add_argument("--controller", choices=("wbc", "kinematic", "spd", "pid"), default="wbc",
                   help="controller of the DART check (--physics; default wbc)")
    p.add_argument("--port", type=int, default=8765, help="server port (default 8765; 0: any)")
    p.add_argument("--no-browser", action="store_true", help="serve without opening a browser")
    return p


def add_demo(sub) -> argparse.ArgumentParser:
    """``imesh demo [-o DIR]``."""
    p = sub.add_parser("demo", help="retarget the built-in CMU walk to JVRC-1, check it in "
                       "DART and write the motion, an HTML report and a 3D viewer page")
    p.add_argument("-o", "--output", default="imesh-demo", help="output folder (default "
                   "imesh-demo)")
    p.add_argument("--clip", help=f"another clip instead of the built-in {DEMO_CLIP}")
    add_robot_arguments(p)
    p.add_argument("--steps", type=int, default=10, help="morph steps (default 10)")
    p.add_argument("--no-physics", action="store_true",
                   help="skip the DART check (a fall is reported, never an error)")
    return p


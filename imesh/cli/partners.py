"""``imesh retarget A --partner B -o OUT``: two people, two robots (:mod:`imesh.partners`).

Writes robot a's motion to OUT, robot b's beside it as ``OUT.partner.<suffix>`` (each with its
adapted markers, as ``imesh retarget`` writes one), and ``OUT.pair.json``: both files, both
robots, the shared scale, the source's hand holds and the pair's metrics (``--report R.html``:
the pair's HTML report too). Both motions are verified before anything is written (exit 3
unless ``--force``).
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path

from ..core.motion import MarkerMotion
from ..evaluate.motion_files import load_motion_file
from ..evaluate.table import format_table
from ..evaluate.verify import verify_motion
from ..io.atomic import write_json
from ..io.clip import read_pair
from ..io.robot_motion import save_robot_motion
from ..partners import PairConfig, detect_holds, evaluate_pair, retarget_pair
from ..partners.evaluate import evaluate_pair_motions
from ..partners.pair import PartnerError
from ..pipeline.retarget import RetargetConfig, working_markers
from ..robot import load_robot
from .loading import load_pair

log = logging.getLogger(__name__)


def partner_path(output: str | Path) -> Path:
    """``OUT.partner.npz`` beside ``OUT.npz``: robot b's motion."""
    p = Path(output)
    return p.with_name(f"{p.stem}.partner{p.suffix}")


def pair_path(output: str | Path) -> Path:
    """``OUT.pair.json`` beside ``OUT.npz``: the pair's manifest and metrics."""
    p = Path(output)
    return p.with_name(f"{p.stem}.pair.json")


def parse_frames(text: str | None) -> tuple[int, int] | None:
    """``START:STOP`` clip frames (at the file's rate) -> (start, stop); None -> None."""
    if text is None:
        return None
    try:
        start, stop = (int(x) for x in text.split(":"))
    except ValueError:
        raise PartnerError(f"--frames {text!r}: expected START:STOP (clip frames at the file's "
                           "rate, e.g. 400:760)") from None
    if not 0 <= start < stop:
        raise PartnerError(f"--frames {text!r}: need 0 <= START < STOP")
    return start, stop


def check_partner_options(args) -> None:
    """``--frames``, ``--alone`` and ``--partner-robot`` mean nothing without ``--partner``.

    Raises:
        PartnerError: naming the options given.
    """
    given = [opt for opt, v in (("--frames", getattr(args, "frames", None)),
                                ("--alone", getattr(args, "alone", False)),
                                ("--partner-robot", getattr(args, "partner_robot", None))) if v]
    if given and not getattr(args, "partner", None):
        raise PartnerError(f"{', '.join(given)} without --partner: these options are for a "
                           "pair (imesh retarget A.bvh --partner B.bvh ...)")


def run_pair(args, config) -> int:
    """Retarget the pair, verify both motions, write (see the module docstring)."""
    if args.format not in (None, "npz"):
        raise PartnerError(f"--format {args.format} with --partner: a pair is written as "
                           "imesh .npz files (export each one with imesh export)")
    if args.balance != "wholebody":
        raise PartnerError(f"--balance {args.balance} with --partner: the pair's avoidance and "
                           "hand holds are rows of the whole-body solve (--balance wholebody)")
    unsupported = [opt for opt, given in (("--physics", args.physics),
                                          ("--scene", getattr(args, "scene", None)),
                                          ("--markers", args.markers),
                                          ("--mode arms", args.mode == "arms"))
                   if given]
    if unsupported:
        raise PartnerError(f"{', '.join(unsupported)} with --partner: not supported for a pair "
                           "yet (each robot's file carries its adapted markers; imesh evaluate "
                           "--pair and imesh view OUT.pair.json take the pair; docs/partners.md)")
    frames = parse_frames(getattr(args, "frames", None))
    motion_a, motion_b = load_pair(args, args.partner)  # both people on one floor
    if frames is not None:
        for m, path in ((motion_a, args.clip), (motion_b, args.partner)):
            if frames[1] > m.n_frames:
                raise PartnerError(f"{path}: --frames {frames[0]}:{frames[1]} beyond its "
                                   f"{m.n_frames} frames")
        motion_a, motion_b = motion_a.frames(*frames), motion_b.frames(*frames)
    robot_a = load_robot(args.robot, urdf=args.urdf)
    robot_b = load_robot(args.partner_robot or args.robot,
                         urdf=args.urdf if args.partner_robot is None else None)
    result = retarget_pair(motion_a, motion_b, robot_a, robot_b,
                           config=PairConfig(retarget=config, together=not args.alone))
    reports, failed = [], {}
    for key, robot, res, motion, name in (("a", robot_a, result.a, motion_a, args.clip),
                                          ("b", robot_b, result.b, motion_b, args.partner)):
        metrics, bad = verify_motion(robot, res.motion, adapted=res.adapted,
                                     seconds=res.seconds, name=name, force=args.force,
                                     source=motion)
        reports.append(metrics)
        failed.update({f"{key}:{k}": v for k, v in bad.items()})
    pair = evaluate_pair(result, reports=(reports[0], reports[1]))
    out_b = partner_path(args.output)
    save_robot_motion(args.output, result.a.motion, markers=result.a.adapted)
    save_robot_motion(out_b, result.b.motion, markers=result.b.adapted)
    report = {"files": {"a": str(args.output), "b": str(out_b)},
              "robots": {"a": robot_a.name, "b": robot_b.name},
              "clips": {"a": str(args.clip), "b": str(args.partner)},
              "frames": list(frames) if frames is not None else None,
              "pair": result.report(), "pair_metrics": pair.summary(),
              "metrics": {"a": reports[0], "b": reports[1]},
              "verification": {"passed": not failed,
                               "failed": {k: {"value": v[0], "gate": v[1]}
                                          for k, v in failed.items()}}}
    write_json(pair_path(args.output), report)
    if args.report:
        write_json(args.report, report)
    if args.report_html:  # from the files as written, as the report of one robot
        from .view import write_pair_report_files

        write_pair_report_files(args.report_html, pair_path(args.output),
                                metrics=(reports[0], reports[1]), pair_metrics=pair.summary())
        print(f"report: {args.report_html}")
    print(f"retargeted the pair: {Path(args.clip).name} -> {robot_a.name} ({args.output}), "
          f"{Path(args.partner).name} -> {robot_b.name} ({out_b}) in "
          f"{result.seconds['total']:.1f} s")
    for key, metrics in (("a", reports[0]), ("b", reports[1])):
        print(f"robot {key}:")
        print(format_table(metrics))
    print("pair:")
    for k, v in pair.summary().items():
        print(f"  {k:24s} {v:.4g}" if isinstance(v, float) else f"  {k:24s} {v}")
    return 0


@dataclass(frozen=True)
class PairFiles:
    """A pair's files as its manifest ``OUT.pair.json`` names them (:func:`run_pair`).

    Attributes:
        manifest_path: the manifest.
        manifest: its contents.
        motions: {"a": path, "b": path} the robots' motion files (as written, or beside the
            manifest when the folder moved).
        robots: {"a": name, "b": name} the robots.
        clips: {"a": path, "b": path} the people's clips.
        frames: (start, stop) clip frames retargeted (``--frames``), or None: all.
        fps: the motions' frame rate [1/s] (the working rate).
        scale: the human-to-robot scale the two people share.
        centre_m: (3,) [m] the fixed point of that scale.
        lead: frames of standing lead-in before the clip's first frame in the motions.
    """

    manifest_path: Path
    manifest: dict
    motions: dict[str, Path]
    robots: dict[str, str]
    clips: dict[str, str]
    frames: tuple[int, int] | None
    fps: float
    scale: float
    centre_m: tuple[float, float, float]
    lead: int

    def humans(self) -> tuple[MarkerMotion, MarkerMotion]:
        """The people's working markers as the retarget made them: both clips read on one floor,
        the same frames, the working rate and low-pass of the retarget's defaults.

        Raises:
            MotionFileError: a clip is missing or unreadable.
        """
        config = RetargetConfig(fps=self.fps)
        humans = []
        for motion in read_pair(self.clips["a"], self.clips["b"]):  # on one floor
            if self.frames is not None:
                motion = motion.frames(*self.frames)
            humans.append(working_markers(motion, config))
        return humans[0], humans[1]


def read_pair_manifest(path: str | Path) -> PairFiles:
    """Read ``OUT.pair.json`` (written by ``imesh retarget --partner``).

    Raises:
        PartnerError: not such a manifest (naming the file and what a manifest holds).
    """
    manifest_path = Path(path)
    try:
        manifest = json.loads(manifest_path.read_text())
        files, robots, clips = manifest["files"], manifest["robots"], manifest["clips"]
        pair = manifest["pair"]
        fps, scale, lead = float(pair["a"]["fps"]), float(pair["scale"]), pair["a"]["lead_frames"]
        cx, cy, cz = (float(c) for c in pair["centre_m"])
        frames = manifest.get("frames")
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise PartnerError(f"{manifest_path}: not a pair manifest of imesh retarget --partner "
                           f"({exc!r}); valid: the OUT.pair.json it writes beside OUT.npz"
                           ) from None

    def beside(f: str) -> Path:  # as written, or beside the manifest
        p = Path(f)
        return p if p.is_file() else manifest_path.parent / p.name

    return PairFiles(manifest_path, manifest, {k: beside(files[k]) for k in ("a", "b")},
                     dict(robots), dict(clips), tuple(frames) if frames is not None else None,
                     fps, scale, (cx, cy, cz), int(lead[0]))


def evaluate_pair_files(args) -> int:
    """``imesh evaluate OUT.npz --pair OUT.pair.json``: both robots' metrics and the pair's
    (:func:`imesh.partners.evaluate.evaluate_pair_motions`), from the files ``imesh retarget
    --partner`` wrote; the people's markers are read again from the clips the manifest names
    (same frames, the working rate and low-pass of the retarget's defaults). ``--report
    R.html`` writes the pair's HTML report (:func:`imesh.cli.view.write_pair_report_files`)."""
    files = read_pair_manifest(args.pair)
    if Path(args.motion).resolve() != files.motions["a"].resolve():
        raise PartnerError(f"{args.motion}: the pair manifest {files.manifest_path} is of "
                           f"{files.manifest['files']['a']} (robot a's motion)")
    robots = files.robots
    robot_a, robot_b = load_robot(robots["a"]), load_robot(robots["b"])
    motion_a = load_motion_file(files.motions["a"], robot_a)
    motion_b = load_motion_file(files.motions["b"], robot_b)
    human_a, human_b = files.humans()
    holds = detect_holds(human_a, human_b)
    metrics = evaluate_pair_motions(robot_a, motion_a, robot_b, motion_b, human_a, human_b,
                                    holds, files.scale, files.lead)
    for key, report in (("a", metrics.robot_a), ("b", metrics.robot_b)):
        print(f"robot {key} ({robots[key]}):")
        print(format_table(report))
    print("pair:")
    for k, v in metrics.summary().items():
        print(f"  {k:24s} {v:.4g}" if isinstance(v, float) else f"  {k:24s} {v}")
    if args.report:
        write_json(args.report, {"pair_metrics": metrics.summary(),
                                 "metrics": {"a": metrics.robot_a, "b": metrics.robot_b}})
    if getattr(args, "report_html", None):
        from .view import write_pair_report_files

        write_pair_report_files(args.report_html, files.manifest_path,
                                metrics=(metrics.robot_a, metrics.robot_b),
                                pair_metrics=metrics.summary())
        print(f"report: {args.report_html}")
    return 0

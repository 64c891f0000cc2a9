"""Command-line glue of the arm imitation for ``imesh retarget``: ``--mode arms`` (arms only,
base and legs at the nominal pose) and ``--fit sqp`` (the main pipeline with its arm joints
re-solved by :func:`imesh.arms.refine_arms`)."""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from ..arms.config import SOLVERS

log = logging.getLogger(__name__)


def add_options(p: argparse.ArgumentParser) -> None:
    """Add ``--mode``, ``--fit``, ``--solver`` and ``--plots`` to the retarget sub-command."""
    p.add_argument("--mode", choices=("full", "arms"), default="full",
                   help="full: the whole pipeline (default); arms: only the arms imitate the "
                   "clip (Kim 2005), base, legs and torso stay at the nominal pose")
    p.add_argument("--fit", choices=("dls", "sqp"), default="dls",
                   help="full mode's fitting: dls (default) or dls with the arm joints re-solved "
                   "by Kim's SQP")
    p.add_argument("--solver", choices=SOLVERS, default="gn",
                   help="per-frame solver of the arm problem: gn (box-constrained "
                   "Gauss-Newton, default) or slsqp (scipy)")
    p.add_argument("--plots", help="write figures (PNG) into this folder: arms mode Kim's "
                   "Fig. 3 and Fig. 4 for every arm, full mode the balance plots")


def run_arms(args, robot, motion) -> int:
    """``imesh retarget CLIP --mode arms``: solve, save the motion (and markers, report, plots),
    print one line; returns the exit status."""
    from ..arms.config import ArmsConfig
    from ..arms.solve import human_arm_markers, solve_arms
    from ..io.atomic import write_json
    from ..io.npz import save_marker_motion
    from ..io.robot_motion import save_robot_motion

    config = ArmsConfig(solver=args.solver)
    human = human_arm_markers(motion, config.lowpass_hz)
    result = solve_arms(robot, human, robot.q_nominal, config=config)
    report = result.report()
    save_robot_motion(args.output, result.motion)
    if getattr(args, "markers", None):
        save_marker_motion(args.markers, human)
    if args.plots:
        from ..viz.arms import write_plots

        files = write_plots(result, args.plots, prefix=f"{robot.name}_")
        report["plots"] = [str(f) for f in files]
    if args.report:
        write_json(args.report, report)
    arms = ", ".join(f"{side} {a['hand_rms_mm']:.1f} mm / {a['upper_arm_rms_deg']:.1f} deg"
                     for side, a in report["arms"].items())
    out = report["frames_outside"]
    print(f"imitated the arms of {Path(str(motion.source)).name or 'the clip'} "
          f"({report['frames']} frames) with {robot.name}: hand-point RMS / upper-arm error "
          f"{arms}; frames outside position/velocity/acceleration bounds {out['position']}/"
          f"{out['velocity']}/{out['acceleration']}; {report['ms_per_frame_per_arm']:.2f} "
          f"ms/frame/arm ({args.solver}) -> {args.output}")
    return 0



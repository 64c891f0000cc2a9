"""``imesh retarget CLIP --mode arms``: the arm imitation of Kim 2005 (arms only, base and legs at
the nominal pose; :func:`imesh.arms.solve_arms`). Its options (``--mode``, ``--fit``,
``--solver``, ``--plots``) are in :func:`imesh.cli.parsers.add_retarget`; ``--fit sqp`` (the
main pipeline with its arm joints re-solved) is :func:`imesh.cli.retarget._arms_config`."""

from __future__ import annotations

from pathlib import Path

from ..arms.config import ArmsConfig
from ..arms.solve import human_arm_markers, solve_arms
from ..io.atomic import write_json
from ..io.npz import save_marker_motion
from ..io.robot_motion import save_robot_motion
from ..viz.arms import write_plots


def run_arms(args, robot, motion) -> int:
    """Solve, save the motion (and markers, report, plots), print one line; returns the exit
    status."""
    config = ArmsConfig(solver=args.solver)
    human = human_arm_markers(motion, config.lowpass_hz)
    result = solve_arms(robot, human, robot.q_nominal, config=config)
    report = result.report()
    save_robot_motion(args.output, result.motion)
    if getattr(args, "markers", None):
        save_marker_motion(args.markers, human)
    if args.plots:
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

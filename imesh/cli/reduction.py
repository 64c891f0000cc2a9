"""``imesh reduce``: dynamically consistent cyclic robot motion by motion reduction.

Wired into :mod:`imesh.cli` by ``add_parser(subparsers)`` and ``run(args) -> int``.
"""

from __future__ import annotations

import argparse
import logging
import sys

from ..errors import OptionError

log = logging.getLogger(__name__)


def _rank(text: str) -> int | None:
    if text.lower() in ("full", "none"):
        return None
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"rank must be 1..5 or 'full', got {text!r}") from None
    if not 1 <= value <= 5:
        raise argparse.ArgumentTypeError(f"rank must be 1..5 or 'full', got {value}")
    return value


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add the ``reduce`` sub-command to an argparse sub-parser collection."""
    p = subparsers.add_parser(
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
                   help="frame rate of formats that store none (AMC; default 120)")
    p.set_defaults(func=run)
    return p


def run(args) -> int:
    """Run ``imesh reduce``; returns the exit status (ImeshError propagates to the caller)."""
    from ..io import load_motion
    from ..io.atomic import write_json
    from ..io.reduction import save_reduction
    from ..reduction.optimize import ReductionConfig
    from ..reduction.pipeline import CycleConfig, reduce_motion

    if not str(args.output).endswith(".npz"):
        raise OptionError("output file", args.output, "a .npz file")
    if args.max_iterations < 1:
        raise OptionError("--max-iterations", args.max_iterations, "an integer >= 1")
    motion = load_motion(args.clip, units=args.units, up_axis=args.up_axis, fps=args.source_fps)
    config = ReductionConfig(rank=args.rank, method=args.method,
                             max_iterations=args.max_iterations, harmonics=args.harmonics,
                             cutoff_hz=args.cutoff)
    bar = None
    update = None
    if not getattr(args, "quiet", False):
        from tqdm import tqdm

        bar = tqdm(total=args.max_iterations, desc=f"reduce for {args.robot}", unit="it",
                   leave=False, file=sys.stderr)

        def update(rec) -> None:
            bar.set_postfix(J_m=f"{rec.J_m:.3g}", y_mm=f"{rec.closure_max_mm:.2f}")
            bar.update(1)
    try:
        result = reduce_motion(motion, args.robot, config, CycleConfig(samples=args.samples),
                               progress=update)
    finally:
        if bar is not None:
            bar.close()
    report = result.report()
    save_reduction(args.output, result)
    dart_text = ""
    if args.dart:
        from ..physics.reduction import DartConfig, simulate_planar

        dart = simulate_planar(result, DartConfig(cycles=args.dart_cycles))
        report["dart"] = dart.summary()
        outcome = f"FELL after {dart.survived_s:.2f} s" if dart.fell else "walked"
        dart_text = (f"; DART {args.dart_cycles} cycles: {outcome}, "
                     f"tracking RMS {dart.tracking_rms_rad:.3f} rad")
        if args.plots:
            from pathlib import Path

            from ..viz.reduction import plot_dart

            Path(args.plots).mkdir(parents=True, exist_ok=True)
            plot_dart(dart, result, Path(args.plots) / "dart_tracking.png")
    if args.plots:
        from ..viz.reduction import plot_all

        plot_all(result, args.plots)
    if args.report:
        write_json(args.report, report)
    print(f"reduced {result.source} for {result.robot} (r = {args.rank or 'full'}): J_m "
          f"{report['J_m_initial']:.3g} -> {report['J_m_final']:.3g} "
          f"({report['J_m_reduction']:.0f}x), |y_m| <= {report['closure_error_mm']:.3f} mm, "
          f"min ground force {report['min_vertical_grf_N']:.1f} N, limit violations "
          f"{report['angle_violations']} angle / {report['torque_violations']} torque, "
          f"{report['iterations']} iterations in {report['seconds']:.1f} s{dart_text} -> "
          f"{args.output}")
    return 0

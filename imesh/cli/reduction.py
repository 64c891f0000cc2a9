"""``imesh reduce CLIP -o CYCLE.npz``: dynamically consistent cyclic robot motion by motion
reduction (Okada & Miyazaki; :mod:`imesh.reduction`)."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

from tqdm import tqdm

from ..errors import OptionError
from ..io import load_motion
from ..io.atomic import write_json
from ..io.reduction import save_reduction
from ..physics.reduction import DartConfig, simulate_planar
from ..reduction.config import ReductionConfig, SolverConfig, SubspaceConfig
from ..reduction.pipeline import CycleConfig, reduce_motion
from ..viz.reduction import plot_all, plot_dart

log = logging.getLogger(__name__)


def run(args) -> int:
    """Run ``imesh reduce``; returns the exit status (ImeshError propagates to the caller)."""
    if not str(args.output).endswith(".npz"):
        raise OptionError("output file", args.output, "a .npz file")
    if args.max_iterations < 1:
        raise OptionError("--max-iterations", args.max_iterations, "an integer >= 1")
    motion = load_motion(args.clip, units=args.units, up_axis=args.up_axis, fps=args.source_fps)
    config = ReductionConfig(
        subspace=SubspaceConfig(rank=args.rank, harmonics=args.harmonics, cutoff_hz=args.cutoff),
        solver=SolverConfig(method=args.method, max_iterations=args.max_iterations))
    bar = None
    update = None
    if not getattr(args, "quiet", False):
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
        dart = simulate_planar(result, DartConfig(cycles=args.dart_cycles))
        report["dart"] = dart.summary()
        outcome = f"FELL after {dart.survived_s:.2f} s" if dart.fell else "walked"
        dart_text = (f"; DART {args.dart_cycles} cycles: {outcome}, "
                     f"tracking RMS {dart.tracking_rms_rad:.3f} rad")
        if args.plots:
            Path(args.plots).mkdir(parents=True, exist_ok=True)
            plot_dart(dart, result, Path(args.plots) / "dart_tracking.png")
    if args.plots:
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

"""``imesh adapt CLIP -o MARKERS``: the human markers adapted to new body proportions by the
spacetime morph (:func:`imesh.morph.adapt.adapt_motion`)."""

from __future__ import annotations

import sys

from tqdm import tqdm

from ..io.atomic import write_json
from ..io.npz import save_marker_motion
from ..morph.adapt import AdaptResult, adapt_motion
from ..morph.problem import MorphConfig, MorphWeights
from .loading import load_clip, load_pair


def run(args) -> int:
    """Adapt the clip (and ``--people``, a second performer in the same mesh), write the
    markers and the report, print one line; returns the exit status."""
    people = None
    if not args.people:
        motion = load_clip(args)
    else:  # both performers on one floor
        motion, people = load_pair(args, args.people)
    result = _adapt(args, motion, people)
    report = result.report()
    save_marker_motion(args.output, result.adapted)
    if args.report:
        write_json(args.report, report)
    print(f"adapted {report['frames']} frames x {report['markers']} markers in "
          f"{report['seconds']:.2f} s: bone residual {report['bone_residual_m']:.2e} m, "
          f"close-pair error {report['close_pair_error']:.4f} "
          f"(naive scaling {report['naive_close_pair_error']:.4f}) -> {args.output}")
    return 0


def _adapt(args, motion, people=None) -> AdaptResult:
    """The morph with the parsed options, a progress bar per morph step unless ``-q``."""
    config = MorphConfig(steps=args.steps, weights=MorphWeights(accel=args.accel_weight),
                         window_frames=args.window_frames)
    bar, update = None, None
    if not args.quiet:
        bar = tqdm(total=config.steps, desc="morph", unit="step", leave=False, file=sys.stderr)

        def update(report) -> None:
            bar.set_postfix(bone_res=f"{report.bone_residual_m:.1e}")
            bar.update(1)
    try:
        return adapt_motion(motion, scales=dict(args.scale), people=people, config=config,
                            progress=update)
    finally:
        if bar is not None:
            bar.close()

"""Spacetime morph speed and memory: frames x markers table with the fitted time exponent.

Each configuration runs in a fresh subprocess (peak memory = its max RSS). The motion is the
built-in synthetic walker (21 standard markers, real skeleton structure). Marker counts: 21 (one
performer), 40 (two performers of different heights side by side in one mesh, each without the
spine marker, as the robot-arranged marker models have it) and 42 (two full performers). The
morph scales the arms by 1.3 with the default MorphConfig (10 steps + re-linearization +
projection).

    python benchmarks/spacetime.py        # full table: 300..8000 frames, 21 and 42 markers
    python benchmarks/spacetime.py --frames 300 1000 --markers 21
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np


def _performer(steps: int, frames: int, height: float, shift_y: float, spine: bool):
    from imesh.human.markerset import STANDARD_MARKERS
    from imesh.io.synthetic import synthetic_walk_clap
    from imesh.morph.adapt import prepare_markers

    m = synthetic_walk_clap(steps=steps, fps=60.0, height_m=height)
    m = m.with_positions(m.positions_m + [0.0, shift_y, 0.0]).frames(0, frames)
    if not spine:  # drop the spine marker, re-attaching the chest to the pelvis
        m = prepare_markers(m)
        keep = [n for n in STANDARD_MARKERS if n != "spine"]
        sub = m.subset(keep)
        bones = np.concatenate([sub.bones, [[keep.index("pelvis"), keep.index("chest")]]])
        m = sub.replace(bones=bones, meta={**m.meta, "rig": ""})
    return m


def run_one(frames: int, markers: int, threads: int | None = None) -> dict:
    from imesh.morph.adapt import adapt_motion
    from imesh.morph.problem import MorphConfig

    steps = max(4, int(frames / 60 / 0.55) + 2)
    spine = markers != 40
    a = _performer(steps, frames, 1.45, 0.0, spine)
    people = _performer(steps, frames, 1.62, 0.9, spine) if markers > 21 else None
    t0 = time.perf_counter()
    result = adapt_motion(a, scales={"arms": 1.3}, people=people,
                          config=MorphConfig(threads=threads))
    total = time.perf_counter() - t0
    morph = result.morph
    steps_per_window = len(morph.steps) / morph.windows
    return {
        "frames": frames, "markers": result.source.n_markers, "windows": morph.windows,
        "steps": steps_per_window, "total_s": total, "mesh_s": morph.timings["mesh"],
        "solve_s": morph.timings["solve"],
        "step_s": morph.timings["solve"] / steps_per_window,
        "ms_per_frame_step": 1e3 * morph.timings["solve"] / steps_per_window / frames,
        "bone_residual_m": morph.bone_residual_m,
        "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, nargs="+", default=[300, 1000, 3000, 8000])
    parser.add_argument("--markers", type=int, nargs="+", default=[21, 40, 42],
                        help="21 (one performer), 40 (two without spine) or 42 (two)")
    parser.add_argument("--threads", type=int, default=1,
                        help="BLAS threads for the band factorization (default 1)")
    parser.add_argument("--one", nargs=2, type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_one(*args.one, threads=args.threads)))
        return
    rows = []
    header = (f"{'frames':>6} {'markers':>7} {'win':>3} {'steps':>5} {'s/step':>8} "
              f"{'ms/frame/step':>13} {'mesh s':>7} {'total s':>8} {'peak MB':>8} "
              f"{'bone res m':>10}")
    print(header)
    print("-" * len(header))
    for m in args.markers:
        for f in args.frames:
            out = subprocess.run([sys.executable, __file__, "--one", str(f), str(m),
                                  "--threads", str(args.threads)],
                                 capture_output=True, text=True, check=True)
            r = json.loads(out.stdout.strip().splitlines()[-1])
            rows.append(r)
            print(f"{r['frames']:>6} {r['markers']:>7} {r['windows']:>3} {r['steps']:>5.0f} "
                  f"{r['step_s']:>8.3f} {r['ms_per_frame_step']:>13.3f} {r['mesh_s']:>7.2f} "
                  f"{r['total_s']:>8.2f} {r['peak_mb']:>8.0f} {r['bone_residual_m']:>10.1e}",
                  flush=True)
    print()
    for m in sorted({r["markers"] for r in rows}):
        sel = [r for r in rows if r["markers"] == m]
        if len(sel) >= 2:
            f = np.log([r["frames"] for r in sel])
            slope_step = np.polyfit(f, np.log([r["step_s"] for r in sel]), 1)[0]
            slope_total = np.polyfit(f, np.log([r["total_s"] for r in sel]), 1)[0]
            print(f"{m} markers: time exponent in frames: per morph step {slope_step:.2f}, "
                  f"whole morph {slope_total:.2f}")


if __name__ == "__main__":
    main()

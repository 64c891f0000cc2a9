"""Balance loop per clip and robot: iterations, ZMP metrics before/after, feet, seconds/frame.

For each clip x robot the full pipeline (``imesh.pipeline.retarget.retarget``) runs twice: without
the balance loop and with it (the default). Printed per run: the multibody ZMP inside the planned
support polygon (fraction of support frames), the RMS ZMP error against the desired ZMP [mm],
the support-foot slip (mean, mm per frame at 30 fps) and height (95th percentile of the lowest
sole corner |z| in support, mm), limit violations, and seconds per frame of the whole pipeline.

    python benchmarks/balance.py
    python benchmarks/balance.py --robots jvrc1 --clips cmu_02_10_wash_self_cc3rig.bvh
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _data import data_root, load

CLIPS = ("cmu_02_01_walk.bvh", "cmu_16_11_walk_veer_left.bvh", "cmu_141_16_wave_hello.bvh",
         "cmu_02_10_wash_self_cc3rig.bvh")
ROBOTS = ("jvrc1", "g1", "hrp4c")


def row(robot, clip: str, result, seconds: float, balanced: bool) -> dict:
    from imesh.balance import zmp_state
    from imesh.metrics.limits import limit_violations
    from imesh.metrics.skid import foot_skid
    from imesh.metrics.soles import sole_tracks

    motion = result.motion
    support = result.support.support
    state = zmp_state(robot, motion.q, motion.fps, support)
    soles = sole_tracks(robot, motion.q, motion.fps)
    skid = foot_skid(soles, support)
    heights = soles.support_heights(support)
    limits = limit_violations(robot, motion.q, motion.fps)
    bal = result.balance
    return {
        "robot": robot.name, "clip": clip, "balanced": balanced,
        "iterations": (len(bal.iterations) - 1) if bal is not None else 0,
        "best": bal.iterations[bal.best].iteration if bal is not None else 0,
        "inside": state.inside_fraction, "zmp_mm": state.error_mm,
        "slip": skid.mean_mm_per_frame,
        "foot_p95_mm": float(1e3 * np.percentile(heights, 95)) if heights.size else np.nan,
        "limit_frames": int((limits.position | limits.velocity).sum()),
        "s_per_frame": seconds / motion.n_frames,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS))
    parser.add_argument("--clips", nargs="+", default=list(CLIPS))
    args = parser.parse_args()

    import imesh
    from imesh.pipeline.retarget import RetargetConfig, retarget

    head = (f"{'robot':6s} {'clip':30s} {'balance':>7s} {'iters':>5s} {'best':>4s} "
            f"{'ZMP in %':>8s} {'ZMP err mm':>10s} {'slip mm/f':>9s} {'foot p95 mm':>11s} "
            f"{'limit viol':>10s} {'ms/frame':>8s}")
    print(head)
    print("-" * len(head))
    for clip in args.clips:
        motion = imesh.load_motion(data_root() / "mocap" / clip)
        for name in args.robots:
            robot = load(name)
            for balanced in (False, True):
                config = RetargetConfig(balance="nishiwaki" if balanced else "none")
                t0 = time.perf_counter()
                try:
                    result = retarget(motion, robot, config=config)
                except imesh.ImeshError as exc:
                    print(f"{name:6s} {clip[:30]:30s} failed: {exc}")
                    continue
                r = row(robot, clip, result, time.perf_counter() - t0, balanced)
                print(f"{name:6s} {clip[:30]:30s} {'yes' if balanced else 'no':>7s} "
                      f"{r['iterations']:5d} {r['best']:4d} {100 * r['inside']:8.1f} "
                      f"{r['zmp_mm']:10.1f} {r['slip']:9.2f} {r['foot_p95_mm']:11.1f} "
                      f"{r['limit_frames']:10d} {1e3 * r['s_per_frame']:8.2f}", flush=True)


if __name__ == "__main__":
    main()

"""Joint fitting speed and accuracy per robot: seconds per frame, key-point RMS, frames at limits.

Two kinds of rows, printed by the same table (:func:`fit_table`):

- FK round trip: a smooth random within-limit joint trajectory with a walking, turning base;
  key points and direction markers by forward kinematics; fitted back with the default
  FitConfig (the exact answer is known, so RMS measures the solver).
- real clips: the pipeline up to the initial fit (``imesh.pipeline.retarget.retarget`` with
  ``balance="none"``: arrangement, contacts, morph, fit) on clips of ``IMESH_DATA/mocap``; the
  fitting stage's numbers are reported, then for the output motion: key-point RMS against the
  adapted markers, the largest |v|/v_max and |a|/a_max, the sole height in the planned support
  frames and the slip. The whole-body solve that follows by default: benchmarks/wholebody.py.

    python benchmarks/fitting.py                           # FK rows, 600 frames, 3 robots
    python benchmarks/fitting.py --frames 2000 --robots jvrc1
    python benchmarks/fitting.py --clips cmu_02_01_walk.bvh cmu_141_16_wave_hello.bvh
    python benchmarks/fitting.py --frames 0 --clips cmu_02_01_walk.bvh --acceleration-limit 0
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from _data import data_root, load

ROOT = Path(__file__).resolve().parents[1]
ROBOTS = ("jvrc1", "g1", "hrp4c")


def row_from_fit(result, source: str, robot) -> dict:
    """One table row from a FitResult."""
    s = result.summary()
    q = result.motion.joint_positions
    v = np.abs(np.diff(q, axis=0)) * result.motion.fps
    return {
        "robot": robot.name, "source": source, "frames": s["frames"],
        "fps": result.motion.fps, "s_per_frame": s["seconds_per_frame"],
        "solves_per_frame": float(result.iterations[1:].mean()) if len(q) > 1 else 0.0,
        "marker_rms_mm": s["marker_rms_mm"], "keypoint_max_mm": s["keypoint_max_mm"],
        "direction_rms_deg": s["direction_rms_deg"],
        "frames_at_position": s["frames_at_position_bound"],
        "frames_at_velocity": s["frames_at_velocity_bound"],
        "frames_at_acceleration": s["frames_at_acceleration_bound"],
        "conflicts": s["conflict_frames"],
        "max_v_ratio": float((v / robot.v_max).max()) if len(q) > 1 else 0.0,
    }


def fk_rows(robots=ROBOTS, frames: int = 600, fps: float = 30.0, seed: int = 1) -> list[dict]:
    """FK round-trip rows: exact targets from a known smooth motion (see tests/test_fit.py)."""
    sys.path.insert(0, str(ROOT / "tests"))
    from test_fit import fk_markers, smooth_trajectory

    from imesh.fit import fit_motion, robot_targets

    rows = []
    for name in robots:
        robot = load(name)
        keypoints, directions = robot_targets(robot)
        qs = smooth_trajectory(robot, frames, fps, seed=seed)
        markers, dirs = fk_markers(robot, qs, fps, keypoints, directions)
        result = fit_motion(robot, markers, keypoints=keypoints, directions=dirs)
        rows.append(row_from_fit(result, "fk round trip", robot))
    return rows


def clip_rows(clips, robots=ROBOTS, fit_config=None) -> list[dict]:
    """Real-clip rows through the whole pipeline (imesh.retarget); fitting-stage numbers.

    Args:
        clips: file names in IMESH_DATA/mocap.
        robots: robot names.
        fit_config: an imesh.fit.FitConfig for the fitting stage (None: defaults).
    """
    import imesh
    from imesh.pipeline.retarget import RetargetConfig, retarget

    config = RetargetConfig(fit=fit_config, balance="none")  # the fitting stage alone

    rows = []
    for clip in clips:
        motion = imesh.load_motion(data_root() / "mocap" / clip)
        for name in robots:
            robot = load(name)
            t0 = time.perf_counter()
            try:
                result = retarget(motion, robot, config=config)
            except imesh.ImeshError as exc:  # an earlier stage failed: report, go on
                print(f"# {clip} on {name}: pipeline failed before fitting: {exc}")
                continue
            row = row_from_fit(result.fit, clip, robot)
            row["pipeline_s"] = time.perf_counter() - t0
            row.update(support_feet(robot, result))
            rows.append(row)
    return rows


def support_feet(robot, result) -> dict:
    """The output motion: key-point RMS [mm] against the adapted markers, largest |v|/v_max and
    |a|/a_max of the joints, sole height in the planned support frames (|lowest sole corner
    z| [mm]: median, p95, max over both feet) and the horizontal sole-centre slip [mm per frame
    at 30 fps]."""
    from imesh.contacts.phases import SIDES
    from imesh.fit import FitConfig
    from imesh.fit.limits import joint_limits
    from imesh.metrics.markers import keypoint_motion, marker_rms_mm
    from imesh.metrics.soles import sole_tracks

    motion = result.motion
    kp = keypoint_motion(robot, motion.q, motion.fps)
    out_rms = marker_rms_mm(kp, result.adapted)
    limits = joint_limits(robot, (result.fit.config or FitConfig()).limits)
    vmax, amax = limits.v_max, limits.a_max
    joints = motion.q[:, 7:]
    v_ratio = float((np.abs(np.diff(joints, axis=0)) * motion.fps / vmax).max())
    a_ratio = float((np.abs(np.diff(joints, n=2, axis=0)) * motion.fps**2 / amax).max())

    soles = sole_tracks(robot, result.motion.q, result.motion.fps)
    sup = result.support.support
    slips = []
    for k, side in enumerate(SIDES):
        step = np.linalg.norm(np.diff(soles.centers[side][:, :2], axis=0), axis=1)
        slips.append(step[sup[1:, k] & sup[:-1, k]] * result.motion.fps / 30.0)
    h = 1e3 * soles.support_heights(sup)
    sl = 1e3 * np.concatenate(slips)
    extra = {"out_rms_mm": out_rms, "out_v_ratio": v_ratio, "out_a_ratio": a_ratio}
    if not h.size:
        return {"foot_mm": (np.nan,) * 3, "slip_mm": (np.nan,) * 2, **extra}
    return {"foot_mm": (float(np.median(h)), float(np.percentile(h, 95)), float(h.max())),
            "slip_mm": (float(np.median(sl)), float(np.percentile(sl, 95))), **extra}


def fit_table(rows: list[dict]) -> None:
    """Print one line per row: robot, source, frames, ms/frame, key-point RMS/max [mm],
    direction RMS [deg], frames at position/velocity/acceleration bounds, box conflicts."""
    head = (f"{'robot':7s} {'source':32s} {'frames':>6s} {'fps':>5s} {'ms/frame':>8s} "
            f"{'solves':>6s} {'RMS mm':>7s} {'max mm':>7s} {'dir deg':>7s} "
            f"{'at pos/vel/acc':>15s} {'confl':>5s} {'max v/vmax':>10s} "
            f"| {'out RMS':>7s} {'v/vmax':>6s} {'a/amax':>6s} "
            f"{'foot z mm med/p95/max':>21s} {'slip med/p95':>12s}")
    print(head)
    print("-" * len(head))
    for r in rows:
        limits = (f"{r['frames_at_position']}/{r['frames_at_velocity']}/"
                  f"{r['frames_at_acceleration']}")
        print(f"{r['robot']:7s} {r['source'][:32]:32s} {r['frames']:6d} {r['fps']:5.0f} "
              f"{1e3 * r['s_per_frame']:8.3f} {r['solves_per_frame']:6.2f} "
              f"{r['marker_rms_mm']:7.3f} {r['keypoint_max_mm']:7.3f} "
              f"{r['direction_rms_deg']:7.3f} {limits:>15s} {r['conflicts']:5d} "
              f"{r['max_v_ratio']:10.2f} "
              + (" | {:7.1f} {:6.3f} {:6.3f} {:5.1f} /{:5.1f} /{:5.1f}    {:5.2f}/{:5.2f}".format(
                  r["out_rms_mm"], r["out_v_ratio"], r["out_a_ratio"], *r["foot_mm"],
                  *r["slip_mm"]) if "foot_mm" in r else ""))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robots", nargs="+", default=list(ROBOTS))
    parser.add_argument("--frames", type=int, default=600)
    parser.add_argument("--fps", type=float, default=30.0)
    parser.add_argument("--clips", nargs="*", default=[],
                        help="clips of IMESH_DATA/mocap to run through imesh.retarget")
    parser.add_argument("--acceleration-limit", type=float, default=None,
                        help="override every joint's a_max [rad/s^2] (0: no acceleration box)")
    args = parser.parse_args()
    from imesh.core.limits import LimitOptions
    from imesh.fit import FitConfig

    if args.acceleration_limit is None:
        config = FitConfig()
    elif args.acceleration_limit > 0:
        config = FitConfig(limits=LimitOptions(acceleration_limit=args.acceleration_limit))
    else:
        config = FitConfig(limits=LimitOptions(enforce_acceleration=False))
    rows = fk_rows(args.robots, args.frames, args.fps) if args.frames > 0 else []
    if args.clips:
        rows += clip_rows(args.clips, args.robots, config)
    fit_table(rows)


if __name__ == "__main__":
    main()

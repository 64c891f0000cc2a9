"""Self-collision avoidance on real clips: issue 16's acceptance table, scored by the evaluator.

    python benchmarks/collision.py [--robots jvrc1 g1 hrp4c] [--clips ...] [--out DIR]
                                   [--modes off on] [--no-mesh]

For every clip x robot and mode (``off``:
``WholeBodyConfig(collision=CollisionOptions(enabled=False))``, ``on``: the default),
``imesh.retarget`` with default settings otherwise; the motion and the adapted
markers are written to ``--out``, read back and scored by ``imesh.evaluate.evaluate_motion``
(``self_collision_frames`` on the capsules, ``marker_rms_mm``, ``close_pair_error`` of the
robot's key points against the adapted markers) and by
:func:`imesh.metrics.collision.check_self_collisions` (the URDF's own geometry with coal, same
pairs: its collision elements; HRP-4C's visual meshes, docs/collision.md). Columns:
``cap``/``mesh`` frames with a penetration > 5 mm and the deepest [mm], marker RMS [mm],
close-pair error, SQP iterations, whole-body solve time [s].
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
from pathlib import Path

from _data import cells, data_root, load, write_and_read

CLIPS = ("cmu_02_01_walk.bvh", "cmu_16_11_walk_veer_left.bvh", "cmu_141_16_wave_hello.bvh",
         "cmu_02_10_wash_self_cc3rig.bvh", "cmu_60_10_salsa_partnerA_sl_scaled.bvh")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["jvrc1", "g1", "hrp4c"])
    ap.add_argument("--clips", nargs="+", default=list(CLIPS))
    ap.add_argument("--modes", nargs="+", default=["off", "on"], choices=["off", "on"])
    ap.add_argument("--out", default="out/collision", help="folder of the written motions")
    ap.add_argument("--no-mesh", action="store_true", help="skip the URDF-geometry check")
    ap.add_argument("--allow-flight", action="store_true",
                    help="RetargetConfig(allow_flight=True): clips with both feet off the ground "
                         "(the salsa's jumps)")
    ap.add_argument("--rescore", action="store_true",
                    help="only score the motions already written in --out for the whole-body "
                         "guarantees (soles, limits, ZMP, ground)")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    if args.rescore:
        return rescore(Path(args.out))

    from imesh.evaluate.scoreboard import evaluate_motion, metric_values
    from imesh.io import load_motion
    from imesh.io.npz import load_marker_motion
    from imesh.metrics.collision import check_self_collisions
    from imesh.pipeline.retarget import RetargetConfig, retarget
    from imesh.solve import CollisionOptions

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    base = RetargetConfig(allow_flight=args.allow_flight)
    head = (f"{'clip':<38} {'robot':<6} {'mode':<4} {'frames':>6} {'cap>5':>5} {'cap mm':>6} "
            f"{'mesh>5':>6} {'mesh mm':>7} {'rms mm':>7} {'close':>6} {'it':>3} {'solve s':>7}")
    print(head)
    print("-" * len(head))
    for clip in args.clips:
        motion = load_motion(data_root() / "mocap" / clip)
        for name in args.robots:
            robot = load(name)
            for mode in args.modes:
                config = dataclasses.replace(base, wholebody=dataclasses.replace(
                    base.wholebody, collision=CollisionOptions(enabled=mode == "on")))
                stem = f"{Path(clip).stem}_{name}_{mode}"
                try:
                    res = retarget(motion, robot, config=config)
                except Exception as exc:  # a row per run, whatever fails
                    print(f"{clip:<38} {name:<6} {mode:<4} failed: {exc}")
                    continue
                written, markers = write_and_read(out, stem, res, robot)
                adapted = load_marker_motion(markers)
                rep = evaluate_motion(robot, written, source=adapted, adapted=adapted)
                m = metric_values(rep)
                cap_mm = rep["self_collision_frames"].get("deepest_mm", float("nan"))
                if args.no_mesh:
                    mesh_n, mesh_mm = "n/a", "n/a"
                else:
                    mesh = check_self_collisions(robot, written.q).mesh
                    mesh_n = str(mesh.n_frames)
                    mesh_mm = f"{1e3 * float(mesh.max_depth_m.max(initial=0.0)):.1f}"
                wb = res.wholebody.report() if res.wholebody is not None else {}
                close = m.get("close_pair_error")
                print(f"{clip:<38} {name:<6} {mode:<4} {written.n_frames:>6} "
                      f"{m['self_collision_frames']:>5d} {cap_mm:>6.1f} {mesh_n:>6} "
                      f"{mesh_mm:>7} {m['marker_rms_mm']:>7.1f} "
                      f"{close if close is None else format(close, '.4f'):>6} "
                      f"{wb.get('iterations', 0):>3} {res.seconds.get('wholebody', 0.0):>7.2f}")
                sys.stdout.flush()
    return 0


def rescore(out: Path) -> int:
    """The whole-body guarantees of every motion written in ``out`` (no DART)."""
    from imesh.evaluate.scoreboard import evaluate_motion, metric_values
    from imesh.io.npz import load_marker_motion
    from imesh.io.robot_motion import load_robot_motion

    robots: dict = {}
    print(f"{'run':<46} {'sole mm':>7} {'tilt':>5} {'lim':>4} {'zmp in':>6} {'zmp mm':>6} "
          f"{'pen mm':>6}")
    for path in sorted(out.glob("*_o[nf]*.npz")):
        if path.stem.endswith("_markers"):
            continue
        name = path.stem.split("_")[-2]
        robot = robots.setdefault(name, load(name))
        v = metric_values(evaluate_motion(
            robot, load_robot_motion(path, robot),
            adapted=load_marker_motion(path.with_name(path.stem + "_markers.npz"))))
        print(f"{path.stem:<46} " + cells(
            v, ("sole_deviation_mm", "7.2f"), ("sole_tilt_deg", "5.2f"),
            ("limit_violation_frames", "4d"), ("zmp_inside_fraction", "6.3f"),
            ("zmp_error_mm", "6.1f"), ("ground_penetration_mm", "6.1f")))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Configurations generated from the URDF alone (``imesh robots init``) against hand-written ones.

    python benchmarks/generate.py [--clips walk wave veer wash walk0705]
                                  [--robots jvrc1 g1 hrp4c romeo icub talos]
                                  [--physics] [--out DIR]

For the shipped robots (JVRC-1, G1, HRP-4C) each clip is retargeted twice, with the hand-written
configuration (``hand``) and with the one generated from the robot's URDF (``gen``); Romeo,
iCub and Talos (example-robot-data) have only the generated one. Every motion and its adapted
markers are written to ``--out``, read back and scored by ``imesh.evaluate.evaluate_motion``, as
``imesh evaluate`` does. Columns: marker RMS [mm] and its difference to the hand-written run,
close-pair error (against the source clip), sole deviation, skid, limit-violation frames, ZMP
inside fraction and mean error [mm], self-collision frames deeper than 5 mm on the capsules
(``cap``) and on the URDF's collision geometry with coal (``mesh``), DART fall (``--physics``),
and the retarget time [s].
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

from _data import cells, data_root, load, score_written

#: The shared CMU clips without flight phases (issue 33 asks every one of them on every robot):
#: the walk, wave, veer and wash, and the ASF/AMC walk 07_05 (read with its cmu_07.asf).
CLIPS = {"walk": "cmu_02_01_walk.bvh", "wave": "cmu_141_16_wave_hello.bvh",
         "veer": "cmu_16_11_walk_veer_left.bvh", "wash": "cmu_02_10_wash_self_cc3rig.bvh",
         "walk0705": "cmu_07_05.amc"}
#: Robots without a hand-written configuration: example-robot-data files.
GENERATED_ONLY = {"romeo": "romeo_description/urdf/romeo.urdf",
                  "icub": "icub_description/robots/icub.urdf",
                  "talos": "talos_data/robots/talos_reduced.urdf"}


def erd_file(suffix: str) -> Path:
    from importlib import metadata

    for f in metadata.files("example-robot-data") or []:
        if str(f).replace("\\", "/").endswith(suffix):
            return Path(f.locate())
    raise SystemExit(f"example-robot-data has no {suffix}: pip install imesh-retarget[g1]")


def generated(name: str, out: Path):
    """The robot loaded from a configuration generated from its URDF (written under out/)."""
    from imesh.robot import load_robot, resolve_urdf
    from imesh.robot.generate import generate_robot_config
    from imesh.robot.generate_files import write_generated

    if name in GENERATED_ONLY:
        urdf = erd_file(GENERATED_ONLY[name])
    else:
        hand = load(name)
        urdf, _ = resolve_urdf(hand.config, data_root().parent / "robots" / "hrp4c" /
                               "HRP4Cmain_reduced.urdf" if name == "hrp4c" else None)
    folder = out / f"config_{name}"
    write_generated(generate_robot_config(urdf, name=name), folder)
    return load_robot(folder / "robot.toml", urdf=urdf)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", nargs="+", default=["walk", "wave"], choices=list(CLIPS))
    ap.add_argument("--robots", nargs="+",
                    default=["jvrc1", "g1", "hrp4c", "romeo", "icub", "talos"])
    ap.add_argument("--physics", action="store_true", help="also run the DART check")
    ap.add_argument("--out", default="out/generate", help="folder of configurations and motions")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    from imesh.io import load_motion
    from imesh.metrics.collision import check_self_collisions
    from imesh.pipeline.retarget import retarget

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    head = (f"{'clip':<5} {'robot':<6} {'config':<5} {'rms mm':>7} {'d rms':>6} {'cpe':>6} "
            f"{'sole mm':>7} {'skid':>5} {'lim':>4} {'zmp in':>6} {'zmp mm':>6} {'cap':>4} "
            f"{'mesh':>4} {'fell':>5} {'total s':>7}")
    print(head)
    print("-" * len(head))
    robots = {}
    for name in args.robots:
        kinds = [("gen", generated(name, out))]
        if name not in GENERATED_ONLY:
            kinds.insert(0, ("hand", load(name)))
        robots[name] = kinds
    for key in args.clips:
        motion = load_motion(data_root() / "mocap" / CLIPS[key])
        for name, kinds in robots.items():
            hand_rms = None
            for kind, robot in kinds:
                t0 = time.perf_counter()
                try:
                    res = retarget(motion, robot)
                except Exception as exc:  # a row per run, whatever fails
                    print(f"{key:<5} {name:<6} {kind:<5} failed: {exc}")
                    continue
                total = time.perf_counter() - t0
                written, m = score_written(robot, res, motion, out, f"{key}_{name}_{kind}",
                                           args.physics)
                mesh = check_self_collisions(robot, written.q).mesh.n_frames
                rms = m["marker_rms_mm"]
                if kind == "hand":
                    hand_rms = rms
                d = "-" if kind == "hand" or hand_rms is None else f"{rms - hand_rms:+.1f}"
                metrics = cells(m, ("close_pair_error", "6.4f"), ("sole_deviation_mm", "7.2f"),
                                ("foot_skid_mm_per_frame", "5.2f"),
                                ("limit_violation_frames", "4d"), ("zmp_inside_fraction", "6.3f"),
                                ("zmp_error_mm", "6.1f"), ("self_collision_frames", "4d"))
                print(f"{key:<5} {name:<6} {kind:<5} {rms:>7.1f} {d:>6} {metrics} "
                      f"{mesh:>4} {str(m.get('physics_fell', 'n/a')):>5} {total:>7.1f}")
                sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

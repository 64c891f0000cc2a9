"""Every clip gets through (issue 31): runs, hops, leaps, pivots and slides, one row per clip and
robot, measured on the written output.

    python benchmarks/every_clip.py [--robots g1 jvrc1] [--clips ...] [--out DIR] [--physics]

For every clip x robot: ``imesh.retarget`` with default settings (no ``--allow-flight``), the
motion written, read back and scored by ``imesh.evaluate.evaluate_motion`` (what ``imesh
evaluate OUT.npz --adapted MARKERS.npz`` prints), the gates of ``imesh retarget`` applied
(``ok``: it would be written), and on the written motion (:mod:`imesh.metrics.flight`):

- ``fl``: frames in flight (no sole within 10 mm of the ground); ``acc err``: the largest
  ``|c'' - g|`` of the CoM in the flight frames the evaluator's differences can judge [m/s^2];
- ``land v`` / ``land F``: the largest landing speed [m/s] and normal force [body weights];
- ``skid``: foot skid [mm per 1/30 s] over the support frames that are not planned slides;
  ``slide``: the same measure over the slides (how fast the planned slides go);
- what the detector found in the clip: flight phases, slide and pivot frames;
- with ``--physics``, the DART check of the written motion (``imesh evaluate OUT.npz
  --physics``: the closed-loop controller, the planned slides on a floor of
  ``GroundConfig.slide_friction``) on a line below the row: how long it stood, and why it fell.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
from _data import GATED_COLUMNS, cell, cells, data_root, gates_failed, load, score_written

CLIPS = ("cmu_05_06_dance_pirouettes_jete.bvh", "cmu_60_10_salsa_partnerA_sl_scaled.bvh",
         "makehuman_game_zombie_walk1.bvh", "cmu_02_01_walk.bvh", "cmu_16_11_walk_veer_left.bvh",
         "cmu_141_16_wave_hello.bvh")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["g1", "jvrc1"])
    ap.add_argument("--clips", nargs="+", default=list(CLIPS))
    ap.add_argument("--out", default="out/every_clip", help="folder of the written motions")
    ap.add_argument("--physics", action="store_true",
                    help="also run the DART check on every written motion")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    from imesh.io import load_motion
    from imesh.metrics.flight import flight_report
    from imesh.metrics.soles import sole_tracks
    from imesh.pipeline.retarget import retarget

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    head = (f"{'clip':<38} {'robot':<6} {'ok':>3} {'frames':>6} {'rms mm':>7} {'lim':>4} "
            f"{'coll':>4} {'pen mm':>6} {'zmp in':>6} {'fl':>3} {'acc err':>7} {'land v':>6} "
            f"{'land F':>6} {'skid':>5} {'slide':>6} {'flights':>7} {'sl/pv':>7} {'total s':>7}")
    print(head)
    print("-" * len(head))
    for clip in args.clips:
        motion = load_motion(data_root() / "mocap" / clip)
        for name in args.robots:
            robot = load(name)
            stem = f"{Path(clip).stem}_{name}"
            t0 = time.perf_counter()
            try:
                res = retarget(motion, robot)
            except Exception as exc:  # a row per run, whatever fails
                print(f"{clip:<38} {name:<6} failed: {type(exc).__name__}: {exc}")
                sys.stdout.flush()
                continue
            total = time.perf_counter() - t0
            written, m = score_written(robot, res, motion, out, stem, physics=args.physics)
            gates = gates_failed(m)
            soles = sole_tracks(robot, written.q, written.fps)
            fr = flight_report(robot, written.q, written.fps, soles)
            moving = res.contacts.moving
            piv = (res.contacts.pivoting if res.contacts.pivoting is not None
                   else np.zeros_like(moving)) & moving
            quality = cells(m, *GATED_COLUMNS)
            print(f"{clip:<38} {name:<6} {'yes' if not gates else 'no':>3} "
                  f"{written.n_frames:>6} {quality} {fr.flight_frames:>3} "
                  f"{fr.com_accel_error:>7.2f} {max(fr.landing_speed, default=0.0):>6.2f} "
                  f"{max(fr.landing_normal, default=0.0):>6.2f} "
                  f"{cell(m, 'foot_skid_mm_per_frame', '5.2f'):>5} "
                  f"{cell(m, 'slide_mm_per_frame', '6.2f'):>6} "
                  f"{len(res.contacts.flight_phases()):>7} "
                  f"{int((moving & ~piv).sum()):>3}/{int(piv.sum()):<3} {total:>7.1f}")
            if gates:
                print(f"    gates failed: {gates}")
            if args.physics:
                fell = m.get("physics_fell")
                print(f"    DART: {'fell' if fell else 'stood'} {m['physics_survived_s']:.2f} s"
                      + (f" ({m['physics_fall_reason']})" if fell else ""))
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

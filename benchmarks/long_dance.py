"""A 60 s dance on this machine (issue 31, acceptance 4): wall and CPU time of one default
retarget, and the written motion's quality.

    python benchmarks/long_dance.py [--robot g1] [--workers 1 2] [--out DIR]

The shared data holds no 60 s dance. The benchmark makes one from CMU 60_10 (salsa partner A,
20 s at its capture rate, 60 fps, :func:`imesh.io.load_motion` reads it so): the clip played
forward, backward and forward again, 3589 frames. Its positions are continuous at the two
turns (the dancer reverses there: every velocity flips sign at once) and every frame is the
real dance. One row per ``--workers`` value (the whole-body solve's windows in one process, or
in two chains in two processes: ``WindowOptions.workers``), measured on the written file as
``imesh evaluate`` scores it; CPU seconds are this process's and its workers' (user + system).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import resource
import sys
import time
from pathlib import Path

import numpy as np
from _data import GATED_COLUMNS, cells, data_root, gates_failed, load, score_written

CLIP = "cmu_60_10_salsa_partnerA_sl_scaled.bvh"


def palindrome(motion, turns: int = 2):
    """The clip played forward, then backward, forward ... (``turns`` reversals); the turn
    frames are not repeated."""
    pos = motion.positions_m
    parts = [pos]
    for k in range(turns):
        parts.append((pos[::-1] if k % 2 == 0 else pos)[1:])
    return motion.with_positions(np.concatenate(parts), source=f"{motion.source} (x{turns + 1})")


def cpu_seconds() -> float:
    """User + system CPU of this process and its reaped children [s]."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="g1")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2], choices=(1, 2))
    ap.add_argument("--out", default="out/long_dance", help="folder of the written motions")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    from imesh.io import load_motion
    from imesh.pipeline.retarget import RetargetConfig, retarget

    clip = load_motion(data_root() / "mocap" / CLIP)
    dance = palindrome(clip)
    robot = load(args.robot)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(f"{CLIP} forward, backward, forward: {dance.n_frames} frames at {dance.fps:g} fps "
          f"({dance.duration_s:.1f} s), robot {robot.name}")
    head = (f"{'workers':>7} {'frames':>6} {'wall s':>7} {'wall min':>8} {'cpu s':>7} "
            f"{'ok':>3} {'rms mm':>7} {'lim':>4} {'coll':>4} {'pen mm':>6} {'zmp in':>6} "
            f"{'skid':>5}")
    print(head)
    print("-" * len(head))
    for workers in args.workers:
        config = RetargetConfig()
        config = dataclasses.replace(
            config, windows=dataclasses.replace(config.windows, workers=workers))
        c0, t0 = cpu_seconds(), time.perf_counter()
        res = retarget(dance, robot, config=config)
        wall, cpu = time.perf_counter() - t0, cpu_seconds() - c0
        written, m = score_written(robot, res, dance, out, f"long_dance_{robot.name}_{workers}")
        gates = gates_failed(m)
        quality = cells(m, *GATED_COLUMNS, ("foot_skid_mm_per_frame", "5.2f"))
        print(f"{workers:>7} {written.n_frames:>6} {wall:>7.1f} {wall / 60:>8.1f} {cpu:>7.1f} "
              f"{'yes' if not gates else 'no':>3} {quality}")
        if gates:
            print(f"    gates failed: {gates}")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The acceptance table of issue 35: the CMU salsa couple on two robots (docs/partners.md).

    PYTHONPATH=. IMESH_DATA=../shared/data python benchmarks/partners.py [--frames 460:640]
        [--pairs g1:g1 g1:jvrc1] [--json OUT.json]

For every robot pair, the couple is retargeted together (one interaction mesh, robot b
avoiding robot a and meeting its hands where the people hold hands), together without the
avoidance (``no-avoid``: mesh and holds), and each person alone (own mesh, no avoidance, no
holds; same world, same settings): the baseline of the inter-person close-pair error. One
row per robot and mode with the single-robot gates (marker RMS over all output frames, and
"clip mm" over the window's own frames without the lead-in and lead-out, which hold the
window's first and last poses still) and the pair's figures. ``--frames`` takes clip frames;
the clips are read at their capture rate, 60 fps (their headers say 120:
:mod:`imesh.human.timing`), so the default window 460:640 is 3 s, holds the couple's hand
hold (clip frames 504-611) and not partner A's hop (304-318); ``--frames all`` runs the
whole clip. ``--plot DIR`` writes one figure per robot pair (the
held hands' distance and the robots' smallest distance per frame, per mode; docs/partners/).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import time
from pathlib import Path

from _data import data_root

from imesh.io.clip import read_pair
from imesh.partners import PairConfig, evaluate_pair, retarget_pair
from imesh.robot import load_robot

MOCAP = data_root() / "mocap"
CLIP_A = MOCAP / "cmu_60_10_salsa_partnerA_sl_scaled.bvh"
CLIP_B = MOCAP / "cmu_61_10_salsa_partnerB_sl_scaled.bvh"

#: mode -> the pair's settings
MODES = {"together": PairConfig(), "no-avoid": PairConfig(avoid=False),
         "alone": PairConfig(together=False)}

HEADER = (f"{'robots':12s} {'mode':8s} {'robot':6s} {'frames':>6s} {'rms mm':>7s} {'clip mm':>7s} "
          f"{'lim':>4s} "
          f"{'coll':>4s} {'sole mm':>8s} {'skid':>6s} {'zmp in':>6s} | {'pen mm':>7s} "
          f"{'pen fr':>6s} {'hold max':>8s} {'hold<=30':>8s} {'inter cpe':>9s} {'s':>6s}")


def value(report: dict, key: str) -> float:
    v = report[key]["value"]
    return float("nan") if v is None else float(v)


def rows(pair: str, mode: str, result, metrics) -> list[dict]:
    out = []
    for key, rep, res in (("a", metrics.robot_a, result.a), ("b", metrics.robot_b, result.b)):
        out.append({"robots": pair, "mode": mode, "robot": f"{key}:{res.arrangement.robot}",
                    "frames": res.motion.n_frames,
                    "marker_rms_mm": value(rep, "marker_rms_mm"),
                    # the window's own frames: the lead-in and lead-out hold a mid-dance pose
                    "clip_frames_mm": float(rep["marker_rms_mm"].get("clip_frames_mm",
                                                                     float("nan"))),
                    "limit_violation_frames": value(rep, "limit_violation_frames"),
                    "self_collision_frames": value(rep, "self_collision_frames"),
                    "sole_deviation_mm": value(rep, "sole_deviation_mm"),
                    "foot_skid_mm_per_frame": value(rep, "foot_skid_mm_per_frame"),
                    "zmp_inside_fraction": value(rep, "zmp_inside_fraction"),
                    **metrics.summary(), "seconds": result.seconds["total"]})
    return out


def line(r: dict) -> str:
    return (f"{r['robots']:12s} {r['mode']:8s} {r['robot'][:6]:6s} {r['frames']:6d} "
            f"{r['marker_rms_mm']:7.1f} {r['clip_frames_mm']:7.1f} "
            f"{r['limit_violation_frames']:4.0f} "
            f"{r['self_collision_frames']:4.0f} {r['sole_deviation_mm']:8.2f} "
            f"{r['foot_skid_mm_per_frame']:6.2f} {r['zmp_inside_fraction']:6.3f} | "
            f"{r['robot_penetration_mm']:7.1f} {r['penetration_frames']:6d} "
            f"{r['hold_error_max_mm']:8.1f} {r['hold_within_30mm']:8.2f} "
            f"{r['inter_close_pair_error']:9.4f} {r['seconds']:6.0f}")


def plot(path, pair: str, runs: dict, lead: int, fps: float) -> None:
    """The held hands' distance and the robots' smallest distance per frame, per mode."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    first = next(iter(runs.values()))
    t_hold = (first[0].holds.frames + lead) / fps
    ax1.plot(t_hold, 1e3 * first[1].hold_target_m, "k.", label="source, scaled")
    for mode, (_, m) in runs.items():
        ax1.plot(t_hold, 1e3 * m.hold_distance_m, "o", ms=4, label=f"robots, {mode}")
        d = np.where(np.isfinite(m.robot_distance_m), m.robot_distance_m, np.nan)
        ax2.plot(np.arange(len(d)) / fps, 1e3 * d, label=mode)
    ax2.axhline(-5, color="r", lw=0.8, ls="--", label="-5 mm (penetration gate)")
    ax1.set_ylabel("held hands' distance [mm]")
    ax2.set_ylabel("robots' smallest capsule\ndistance [mm]")
    ax2.set_xlabel("output time [s] (lead-in included)")
    ax1.set_title(f"CMU salsa couple on {pair}")
    ax1.legend(fontsize=8)
    ax2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", default="460:640", help="START:STOP clip frames, or 'all'")
    ap.add_argument("--pairs", nargs="+", default=["g1:g1", "g1:jvrc1"])
    ap.add_argument("--modes", nargs="+", default=list(MODES), choices=list(MODES))
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--plot", help="write one figure per robot pair into this folder")
    ap.add_argument("--clip-fps", type=float,
                    help="the clips' real frame rate (the CMU listing says 60 for subjects "
                         "60/61; the header 120): the motion is played at this rate")
    args = ap.parse_args()
    logging.basicConfig(level=logging.WARNING)
    a, b = read_pair(CLIP_A, CLIP_B)
    if args.clip_fps:
        a, b = (dataclasses.replace(m, fps=args.clip_fps) for m in (a, b))
    if args.frames != "all":
        start, stop = (int(x) for x in args.frames.split(":"))
        a, b = a.frames(start, stop), b.frames(start, stop)
    print(f"CMU 60_10 / 61_10 salsa, clip frames {args.frames} at {a.fps:.0f} fps "
          f"({a.n_frames} frames), working rate 30 fps")
    print(HEADER)
    print("-" * len(HEADER))
    table = []
    for pair in args.pairs:
        name_a, name_b = pair.split(":")
        robot_a, robot_b = load_robot(name_a), load_robot(name_b)
        runs = {}
        for mode in args.modes:
            t0 = time.perf_counter()
            result = retarget_pair(a, b, robot_a, robot_b, config=MODES[mode])
            metrics = evaluate_pair(result, source_a=a, source_b=b)
            runs[mode] = (result, metrics)
            for r in rows(pair, mode, result, metrics):
                r["wall_s"] = time.perf_counter() - t0
                table.append(r)
                print(line(r), flush=True)
        if args.plot:
            Path(args.plot).mkdir(parents=True, exist_ok=True)
            res = next(iter(runs.values()))[0]
            plot(Path(args.plot) / f"salsa_{name_a}_{name_b}.png", pair, runs,
                 res.a.lead_frames[0], res.a.motion.fps)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(table, f, indent=1)


if __name__ == "__main__":
    main()

"""Terrain and props (issue 34): the shared climbing sequences, what imesh reads of them, what the
person does with the boxes, and what a retarget does to the boxes today.

    python benchmarks/terrain.py [--robots g1] [--window 200 800] [--out DIR] [--no-robot]
                                 [--floor-only] [--seqs seq_0 seq_1] [--rescore] [--physics]

Three tables, on ``IMESH_DATA/interaction/holosoma_climb`` (MANIFEST.md there):

1. **Read.** Each ``.npy`` read by :mod:`imesh.io.joints` at 120 fps (the MANIFEST's reading; the
   files state no rate), the names found beside it: frames, duration, units, up axis and floor
   as detected, the head joint's height standing, the human-to-robot scale of the retarget
   (:func:`imesh.scene.morph_frame.morph_transform`, the robot's legs over the human's) and the
   box tops at the human's and the robot's scale.
2. **Human contacts.** Frames (120 fps, whole sequence) in which a toe, hand or knee marker is in
   contact with each box (:func:`imesh.metrics.props.human_contacts`, thresholds
   ``HUMAN_CONTACT_M``: 6 cm toes and hands, 10 cm knees, signed distance of the joint centre).
3. **Robot.** A window of each sequence (``--window``, source frames at 120 fps; default
   200-800, 150 frames at the retarget's 30 fps, plus its 1 s standing lead-in and lead-out)
   retargeted with default settings; the motion and its scene written to ``--out`` and read
   back, then measured: prop penetration (deepest, frames deeper than 10 mm), the human's prop
   contacts kept within 20 mm, skid on any surface, the evaluator's ground penetration,
   self-collision frames and limit violations, and the fraction of frames whose
   gravito-inertial wrench is inside the contact wrench cone of the robot's own contacts
   (``cwc_inside_fraction``, :mod:`imesh.metrics.cwc`). The props are in the solve (supports on
   their tops, hands and knees held on them, no link inside them, the contact wrench cone:
   docs/terrain.md); ``--floor-only`` retargets without them (the solve knows only the floor
   z = 0, as before issue 34's part 3).
4. **DART** (``--physics``): each written motion tracked by the whole-body controller with its
   props in the world (boxes, their tops the soles' surfaces, the hands and knees the
   reference rests on them point contacts: docs/checking.md), and the same motion on the floor
   alone: the time it stood, its key points against the reference's, the force on the hands.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
from _data import data_root, load

SEQS = (("seq_0", "mocap_climb_seq_0", "mocap_climb_seq_0_joint_positions_f900-3700.npy"),
        ("seq_1", "mocap_climb_seq_1", "mocap_climb_seq_1_joint_positions_f0-2422.npy"))
#: The rate the MANIFEST infers (holosoma keeps every 4th frame and saves at 30 fps).
SOURCE_FPS = 120.0
EFFECTORS = ("toe_l", "toe_r", "hand_l", "hand_r", "knee_l", "knee_r")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", nargs="+", default=["g1"])
    ap.add_argument("--window", nargs=2, type=int, default=[200, 800], metavar=("START", "STOP"),
                    help="source frames (120 fps) of the robot window (default 200 800)")
    ap.add_argument("--out", default="out/terrain", help="folder of the written motions")
    ap.add_argument("--no-robot", action="store_true", help="tables 1 and 2 only")
    ap.add_argument("--floor-only", action="store_true",
                    help="retarget without the props in the solve (the scene only measured)")
    ap.add_argument("--seqs", nargs="+", default=[s[0] for s in SEQS],
                    help="sequences of table 3 (default: both)")
    ap.add_argument("--physics", action="store_true",
                    help="the DART check of each written motion with its props in the world "
                         "(a fourth table)")
    ap.add_argument("--rescore", action="store_true",
                    help="table 3 from the motions and scenes already written in --out")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)

    from imesh.evaluate.props import human_scene_contacts
    from imesh.human.standard import to_standard
    from imesh.io import load_motion
    from imesh.scene import human_scene, load_scene, robot_scene
    from imesh.scene.morph_frame import morph_transform

    base = data_root() / "interaction" / "holosoma_climb"
    if not base.is_dir():
        print(f"{base} not found: set IMESH_DATA to the shared data folder", file=sys.stderr)
        return 2
    robots = {name: load(name) for name in args.robots}
    clips, scenes = {}, {}

    print("1. read (120 fps given; units, up axis, floor detected)")
    head = (f"{'seq':<6} {'frames':>6} {'s @120':>6} {'units':>5} {'up':>3} {'floor m':>7} "
            f"{'head95':>6} {'robot':<6} {'scale':>6} {'box tops human m':<18} {'robot m':<18}")
    print(head)
    for seq, folder, name in SEQS:
        motion = load_motion(base / folder / name, fps=SOURCE_FPS)
        clips[seq] = motion
        human = human_scene(load_scene(sorted((base / folder / "box_models").glob("*.obj"))),
                            motion.meta)
        std = to_standard(motion)
        # standing height: the head joint above the lowest joint, 95th percentile over the
        # frames (the person also crouches, kneels and sits; MANIFEST: 1.56-1.59 m standing)
        z = motion.positions_m[..., 2]
        standing = float(np.percentile(std.positions_m[:, std.index("head"), 2] - z.min(axis=1),
                                       95))
        for rname, robot in robots.items():
            s, c = morph_transform(motion, robot)
            scenes[seq, rname] = robot_scene(human, s, c)
            print(f"{seq:<6} {motion.n_frames:>6} {motion.n_frames / motion.fps:>6.1f} "
                  f"{motion.meta['units']:>5} {motion.meta['up_axis'][1]:>3} "
                  f"{motion.meta['floor_offset_m']:>7.3f} {standing:>6.2f} {rname:<6} {s:>6.4f} "
                  f"{' / '.join(f'{t:.3f}' for t in human.tops_m()):<18} "
                  f"{' / '.join(f'{t:.3f}' for t in scenes[seq, rname].tops_m()):<18}")

    print("\n2. human contacts per box (frames at 120 fps; toes/hands within 6 cm, knees 10 cm)")
    print(f"{'seq':<6} {'box':<5} {'top m':>5} " + " ".join(f"{e:>6}" for e in EFFECTORS))
    for seq, folder, _ in SEQS:
        scene = human_scene(load_scene(sorted((base / folder / "box_models").glob("*.obj"))),
                            clips[seq].meta)
        contacts = human_scene_contacts(to_standard(clips[seq]), scene)
        n = contacts.contact.sum(axis=0)  # (E, P)
        for k, prop in enumerate(scene.props):
            cells = [int(n[contacts.effectors.index(e), k]) if e in contacts.effectors else 0
                     for e in EFFECTORS]
            print(f"{seq:<6} {prop.name:<5} {prop.top_m:>5.2f} "
                  + " ".join(f"{v:>6}" for v in cells))
    if args.no_robot:
        return 0
    return robot_table(args, base, robots, clips)


def robot_table(args, base: Path, robots: dict, clips: dict) -> int:
    from imesh.evaluate.props import evaluate_scene
    from imesh.evaluate.scoreboard import evaluate_motion, metric_values
    from imesh.io.atomic import atomic_path
    from imesh.io.robot_motion import load_robot_motion, save_robot_motion
    from imesh.pipeline.retarget import retarget
    from imesh.scene import find_scene, save_scene, scene_path_for
    from imesh.scene.morph_frame import scene_for_clip

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    a, b = args.window
    checks = []  # (seq, robot, motion, scene) for the DART table
    print(f"\n3. robot: source frames {a}-{b - 1} retargeted with default settings (30 fps, "
          "1 s lead-in/out); " + ("the solve knows the floor only" if args.floor_only
                                  else "the props in the solve"))
    print(f"{'seq':<6} {'robot':<6} {'frames':>6} {'solve s':>7} {'pen mm per box':<15} "
          f"{'>10mm':>5} {'deepest link (box)':<32} {'kept':>5} {'of':>4} {'skid':>5} "
          f"{'max':>5} {'slide':>5} {'ground':>6} {'self':>4} {'limit':>5} {'cwc':>5}")
    for seq, folder, _ in SEQS:
        if seq not in args.seqs:
            continue
        window = clips[seq].frames(a, b)
        for rname, robot in robots.items():
            tag = "_floor" if args.floor_only else ""
            path = out / f"{seq}_{a}_{b}_{rname}{tag}.npz"
            seconds = float("nan")
            if not args.rescore:
                scene = scene_for_clip(sorted((base / folder / "box_models").glob("*.obj")),
                                       window, robot)
                t0 = time.perf_counter()
                result = retarget(window, robot, scene=None if args.floor_only else scene)
                seconds = time.perf_counter() - t0
                save_robot_motion(path, result.motion)
                save_scene(scene_path_for(path), scene, atomic=atomic_path)
            motion = load_robot_motion(path, robot)
            written = find_scene(path)
            assert written is not None
            props = evaluate_scene(robot, motion, written, source=window)
            values = metric_values(evaluate_motion(robot, motion, source=window))
            pen = props["prop_penetration_mm"]
            worst = max(pen["props"].items(), key=lambda kv: kv[1]["deepest_mm"])
            kept = props["prop_contacts_kept"]
            skid = props["surface_skid_mm_per_frame"]

            def f(v, fmt):
                return "n/a" if v is None else format(v, fmt)

            per_box = "/".join(f"{v['deepest_mm']:.0f}" for v in pen["props"].values())
            print(f"{seq:<6} {rname:<6} {motion.n_frames:>6} {seconds:>7.1f} "
                  f"{per_box:<15} {props['prop_penetration_frames']['value']:>5} "
                  f"{(worst[1]['worst_link'] or '-') + ' (' + worst[0] + ')':<32} "
                  f"{f(kept['value'], '.2f'):>5} {kept.get('samples', 0):>4} "
                  f"{f(skid['value'], '.2f'):>5} {f(skid.get('max_mm'), '.1f'):>5} "
                  f"{f(skid.get('slide_mm_per_frame'), '.1f'):>5} "
                  f"{f(values['ground_penetration_mm'], '.1f'):>6} "
                  f"{values['self_collision_frames']:>4} {values['limit_violation_frames']:>5} "
                  f"{props['cwc_inside_fraction']['value']:>5.3f}")
            checks.append((seq, rname, robot, motion, written))
    print("pen: deepest point of the robot's collision proxies inside each box [mm] (the "
          "distance to the box's nearest face: at most the box's half-thickness, 187 mm for "
          "box1 at the G1's scale); >10mm: frames with a box penetrated deeper than 10 mm; "
          "kept: the human's box contacts (toe/hand/knee samples on the clip's frames) whose "
          "robot link is within 20 mm of the box surface; skid, max: mean and largest "
          "slide of a sole supporting on any surface (the motion's planned support; its planned "
          "slides apart, their mean motion in slide) [mm per 1/30 s]; ground: the "
          "evaluator's ground penetration [mm]; cwc: fraction of frames whose "
          "gravito-inertial wrench is inside the contact wrench cone of the robot's own contacts")
    if args.physics:
        physics_table(checks)
    return 0


def physics_table(checks) -> None:
    """4. The DART check of each written motion, with its props in the world and without."""
    from imesh.physics import simulate_motion

    print("\n4. DART check (whole-body controller, 1 kHz) of the written motions: the props "
          "in the world, and the same motion on the floor alone")
    print(f"{'seq':<6} {'robot':<6} {'world':<6} {'stood s':>7} {'of':>5} {'kp rms':>6} "
          f"{'kp max':>6} {'hands N':>7} {'slip':>5}  fall")
    for seq, rname, robot, motion, scene in checks:
        for world, sc in (("props", scene), ("floor", None)):
            r = simulate_motion(robot, motion, scene=sc)
            hands = float(np.nanmax(r.link_contact_force_n)) if np.isfinite(
                r.link_contact_force_n).any() else 0.0
            print(f"{seq:<6} {rname:<6} {world:<6} {r.survived_s:>7.2f} "
                  f"{(motion.n_frames - 1) / motion.fps:>5.2f} {r.keypoint_rms_mm:>6.1f} "
                  f"{r.keypoint_max_mm:>6.1f} {hands:>7.0f} {r.slip_mm:>5.1f}  "
                  f"{r.fall_reason or '-'}")
    print("stood s: simulated time before a fall (of: the motion's duration); kp: the robot's "
          "key points against the reference's over the frames it stood [mm]; hands N: "
          "largest vertical force on links other than the soles (hands, knees), averaged "
          "per frame; slip: sole slip within a support phase [mm]")


if __name__ == "__main__":
    sys.exit(main())

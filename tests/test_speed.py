"""Speed work: one progress bar over every stage, with frame totals, silenced by --quiet."""

from __future__ import annotations

import io
import json
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import load_test_robot

from imesh import load_motion
from imesh.core.progress import JobBar, StageProgress, retarget_bar
from imesh.pipeline.retarget import RetargetConfig, retarget
from imesh.solve import SqpOptions, WholeBodyConfig, WindowOptions


def test_job_bar_moves_forward_through_the_stages_and_ends_full(monkeypatch):
    """Each stage fills its share of the bar in order; a stage reported again (the Nishiwaki
    loop re-runs the morph) never moves it back; finish() fills it."""
    stream = io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    bar = JobBar(False, "job", 100, ["load", "morph", "wholebody", "write"])
    positions = []
    bar.stage("load")
    positions.append(bar.position)
    for k in range(1, 11):
        bar(StageProgress("morph", k, 10, 80))
        positions.append(bar.position)
    for k in range(1, 21):
        bar(StageProgress("wholebody", k, 20, 100, f"SQP iteration {k}"))
        positions.append(bar.position)
    bar(StageProgress("morph", 1, 10, 80))
    positions.append(bar.position)
    bar.stage("write")
    positions.append(bar.position)
    bar.finish()
    assert positions == sorted(positions)
    # the whole-body solve is 0.1 s a frame against 1.5 ms for the morph: most of the bar
    assert bar.share["wholebody"] > 0.7
    assert positions[11 + 19] == pytest.approx(100 * (bar.start["wholebody"]
                                                      + bar.share["wholebody"]))
    assert bar.position == 100
    text = stream.getvalue()
    # tqdm draws at most every 0.1 s: the last state is drawn, with the elapsed<ETA field
    assert text.rstrip().endswith("job: write (100 frames): 100%|##########| 100/100 frames "
                                  "[00:00<00:00]")


def test_quiet_bar_draws_nothing(monkeypatch):
    stream = io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    bar = JobBar(True, "job", 50, ["load", "wholebody"])
    bar.stage("load")
    bar(StageProgress("wholebody", 3, 20, 50))
    bar.finish()
    assert stream.getvalue() == ""


def test_retarget_reports_every_stage_in_order(mocap):
    """The library reports prepare, every morph step, fit, plan and every SQP iteration to the
    callback, in this order, with the frame counts of each stage (the bar's totals)."""
    robot = load_test_robot("g1")
    motion = load_motion(mocap("cmu_02_01_walk.bvh"))
    config = RetargetConfig(wholebody=WholeBodyConfig(sqp=SqpOptions(iterations=2)))
    events: list[StageProgress] = []
    res = retarget(motion, robot, config=config, progress=events.append)
    stages = [e.stage for e in events]
    order = ["prepare", "morph", "fit", "plan", "wholebody"]
    assert sorted(set(stages), key=order.index) == order
    assert [order.index(s) for s in stages] == sorted(order.index(s) for s in stages)
    assert stages.count("morph") >= config.morph.steps
    assert [e.done for e in events if e.stage == "wholebody"] == [1, 2]
    n_work = res.adapted.n_frames - sum(res.lead_frames)
    assert {e.frames for e in events if e.stage in ("prepare", "morph", "fit")} == {n_work}
    assert {e.frames for e in events if e.stage in ("plan", "wholebody")} == {
        res.motion.n_frames}
    # the CLI's bar counts the same output frames
    assert retarget_bar(True, "walk", motion, config).frames == res.motion.n_frames


@pytest.mark.parametrize("clip", ["cmu_02_01_walk.bvh", "reactidle_003_acted_idle_long.bvh",
                                  "cmu_60_10_salsa_partnerA_sl_scaled.bvh"])
def test_streamed_bvh_reader_equals_the_full_parser(mocap, clip, monkeypatch):
    """The bounded-memory reader (frames parsed and put through forward kinematics 8192 at a
    time) gives bit-identical positions and the same metadata as the whole-file parser."""
    import numpy as np

    import imesh.io.bvh as bvh

    monkeypatch.setattr(bvh, "STREAM_FRAMES", 100)  # several blocks on a short clip
    assert bvh._read_streamed(str(mocap(clip)), mocap(clip)) is not None
    streamed = bvh.read_bvh(mocap(clip))
    monkeypatch.setattr(bvh, "_read_streamed", lambda p, path: None)
    full = bvh.read_bvh(mocap(clip))
    assert np.array_equal(streamed.positions, full.positions)
    assert (streamed.names, streamed.fps, streamed.rig) == (full.names, full.fps, full.rig)
    assert streamed.meta == full.meta


def _concatenated(source, n_frames: int, path):
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from speed import concatenated_bvh

    return concatenated_bvh(source, n_frames, path)


def test_inspect_of_a_30_minute_clip_stays_within_500_mb(mocap, tmp_path):
    """216,000 frames at 120 Hz (the walk forwards and backwards, 200 MB of text): `imesh
    inspect` read it whole in 4.2 GB before the streamed reader; the bound is 500 MB."""
    import subprocess

    clip = _concatenated(mocap("cmu_02_01_walk.bvh"), 216000, tmp_path / "long.bvh")
    probe = ("import resource, subprocess, sys; "
             "r = subprocess.run([sys.executable, '-m', 'imesh', 'inspect', '--json', "
             "sys.argv[1]], capture_output=True, text=True); "
             "print(r.returncode, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); "
             "print(r.stdout)")
    out = subprocess.run([sys.executable, "-c", probe, str(clip)], capture_output=True,
                         text=True, check=True, cwd=Path(__file__).resolve().parents[1])
    status, peak_kb = (int(x) for x in out.stdout.split("\n")[0].split())
    summary = json.loads(out.stdout.split("\n", 1)[1])
    assert status == 0 and summary["frames"] == 216000
    assert summary["rig"]["table"] == "recognized"
    assert peak_kb / 1024 <= 500, f"peak {peak_kb / 1024:.0f} MB"


@pytest.mark.parametrize(("n_frames", "window", "overlap"), [
    (146, 80, 16), (901, 900, 60), (1060, 900, 60), (2060, 900, 60), (4060, 900, 60),
    (1790, 900, 60), (54058, 900, 60), (1700, 450, 60), (3000, 450, 60)])
def test_windows_have_one_length_but_the_last_and_cover_the_clip(n_frames, window, overlap):
    """Every window is ``window`` frames long but the last (equal windows whose length followed
    the clip's made the cost grow as frames^1.05); none is shorter than half a window; each
    starts on the 4 frames before what the previous one keeps; together they keep every frame
    once; a solve of at most one window is that one window."""
    from imesh.solve.windows import FIXED_FRAMES, window_layout

    layout = window_layout(n_frames, window, overlap)
    lengths = [stop - start for start, stop, _ in layout]
    assert max(lengths) <= window and min(lengths) >= window / 2
    if len(layout) > 2:
        assert set(lengths[:-2]) == {window}
    assert layout[0][0] == 0 and layout[-1][1] == layout[-1][2] == n_frames
    for (_, stop, keep), (start, _, _) in zip(layout[:-1], layout[1:], strict=True):
        assert keep == stop - overlap and start == keep - FIXED_FRAMES
    kept = np.concatenate([np.arange(start + (FIXED_FRAMES if k else 0), keep)
                           for k, (start, _, keep) in enumerate(layout)])
    assert np.array_equal(kept, np.arange(n_frames))
    for short in (window - 1, window):
        assert window_layout(short, window, overlap) == [(0, short, short)]


def test_solve_workers_flag_reaches_the_retarget_config():
    from imesh.cli.app import build_parser
    from imesh.cli.retarget import _retarget_config

    for argv, workers in ((["retarget", "c.bvh", "-o", "o.npz"], 1),
                          (["retarget", "c.bvh", "-o", "o.npz", "--solve-workers", "2"], 2)):
        args = build_parser().parse_args(argv)
        assert _retarget_config(args, args.steps, args.window_frames).windows.workers == workers
    with pytest.raises(SystemExit):  # argparse names the valid choices
        build_parser().parse_args(["retarget", "c.bvh", "-o", "o.npz", "--solve-workers", "3"])


def test_workers_option_names_what_is_valid():
    from imesh.errors import OptionError

    for bad in (0, 3, 1.0, True, "2", None):
        with pytest.raises(OptionError, match="workers"):
            WindowOptions(workers=bad)
    assert WindowOptions(workers=2).workers == 2 and RetargetConfig().windows.workers == 1


def _border_checks(robot, written, borders) -> None:
    """The ZMP inside the support polygon and the joint accelerations within their limits in
    the 12 frames around each border of the written motion."""
    from imesh.metrics.soles import sole_tracks
    from imesh.metrics.support import detect_support
    from imesh.metrics.zmp import zmp_report, zmp_trajectory

    q, fps = written.q, written.fps
    soles = sole_tracks(robot, q, fps)
    support = detect_support(soles).support
    zmp = zmp_report(zmp_trajectory(robot, q, fps), soles, support)
    acc = np.abs(np.diff(q[:, 7:], 2, axis=0)) * fps ** 2 / robot.a_max
    for border in borders:
        near = np.arange(border - 6, border + 6)
        assert zmp.inside[near][zmp.support_frames[near]].all()
        assert acc[near - 1].max() <= 1.0


def _written_figures(robot, res, tmp_path):
    from imesh.evaluate.motion_files import load_motion_file
    from imesh.evaluate.scoreboard import evaluate_motion, metric_values
    from imesh.io.npz import save_marker_motion
    from imesh.io.robot_motion import save_robot_motion

    path, markers = tmp_path / "walk.npz", tmp_path / "walk_markers.npz"
    save_robot_motion(path, res.motion)
    save_marker_motion(markers, res.adapted)
    written = load_motion_file(path, robot)
    return written, metric_values(evaluate_motion(robot, written, adapted=str(markers)))


def _assert_quality(m) -> None:
    assert m["limit_violation_frames"] == 0
    assert m["self_collision_frames"] == 0
    assert m["zmp_inside_fraction"] == 1.0
    assert m["sole_deviation_mm"] <= 1.0 and m["foot_skid_mm_per_frame"] <= 0.1
    # with the ZMP in the inner 30 % of the soles and the soles flat through the double
    # supports: markers 38.0 mm in windows, 37.9 in one (47.9 and 47.8 before the morph's bend
    # planes); the ZMP error is measured from the desired ZMP, the centre of a double support
    # with the feet 0.49 m apart where the lead-in accelerates the CoM, and the lower weight
    # there lets it go (90.0 mm, 89.8 in one; 82.7 before the bend planes, 62 with the full
    # weight in all of double support)
    assert m["marker_rms_mm"] <= 45.0 and m["zmp_error_mm"] <= 95.0


def test_windows_hold_soles_limits_and_zmp_across_their_borders(mocap, tmp_path):
    """The G1 walk (146 frames with the lead-in/out) solved in windows of 80, 53 and 53
    frames, one after the other: the evaluator, on the written file, finds the soles on their
    footprints, no limit violation, no self-collision and the ZMP inside the support polygon
    at every frame, the frames around each border included; the result stays that of one
    window (one window: 46.6 mm marker RMS, 41.6 mm ZMP error; these windows: 46.2, 41.5,
    measured)."""
    from imesh.solve.windows import window_layout

    robot = load_test_robot("g1")
    motion = load_motion(mocap("cmu_02_01_walk.bvh"))
    config = RetargetConfig(windows=WindowOptions(frames=80, overlap_frames=16, workers=1))
    res = retarget(motion, robot, config=config)
    layout = window_layout(res.motion.n_frames, 80, 16)
    assert len(layout) == 3 and res.wholebody.seconds["windows"] == 3
    written, m = _written_figures(robot, res, tmp_path)
    _assert_quality(m)
    _border_checks(robot, written, [keep for _, _, keep in layout[:-1]])


def test_the_join_starts_on_a_crossfade_within_the_acceleration_it_needs():
    """Two chains that end 0.88 rad apart at a joint (as the 60 s dance's did at the waist)
    and with the base's quaternion of opposite signs (the same rotation): the crossfade starts
    at the first, ends at the second, keeps unit quaternions, and its second differences stay
    within the smoothstep's 6 D / n^2 (a step between them is D itself)."""
    from imesh.solve.windows import crossfade

    robot = load_test_robot("g1")
    n = 60
    joint = 7 + list(robot.joint_names).index("left_shoulder_pitch_joint")
    a = np.repeat(np.asarray(robot.q_nominal, dtype=float)[None], n, axis=0)
    a[:, 3:7] = [0.0, 0.0, 0.0, 1.0]  # identity (x, y, z, w)
    b = a.copy()
    b[:, 6] = -1.0  # the same rotation, the other sign
    b[:, joint] -= 0.88
    b[:, 0] += 0.1
    q = crossfade(robot, a, b)
    assert np.allclose(np.linalg.norm(q[:, 3:7], axis=1), 1.0)
    assert np.allclose(q[:, 3:7], [0.0, 0.0, 0.0, 1.0])  # never through the other sign
    d = q[:, joint] - a[:, joint]
    assert abs(d[0]) < 0.01 * 0.88 and abs(d[-1] + 0.88) < 0.01 * 0.88
    assert np.abs(np.diff(d, 2)).max() <= 6 * 0.88 / n ** 2
    assert np.all(np.diff(d) <= 0.0) and np.all(np.diff(q[:, 0]) >= 0.0)


def test_two_chains_and_their_join_window_hold_both_ends_and_every_border(
        mocap, tmp_path, monkeypatch):
    """``workers=2`` on the walk in windows of 90 frames: the first half in this process, the
    second in a spawned one from the initializer, then a join window across the middle. The
    join's first and last 4 frames stay at the chains' solutions (the written motion's, to
    1e-9); soles, limits, self-collisions and the ZMP hold across both of its borders; the
    quality is that of one window (46.6 mm marker RMS, 41.6 mm ZMP error, measured)."""
    import imesh.solve.windows as windows

    robot = load_test_robot("g1")
    motion = load_motion(mocap("cmu_02_01_walk.bvh"))
    solves = []
    real = windows.solve_whole_body

    def recorded(robot, plan, *args, **kwargs):  # the real solve, its plan and result kept
        sol = real(robot, plan, *args, **kwargs)
        solves.append((plan, sol))
        return sol

    monkeypatch.setattr(windows, "solve_whole_body", recorded)
    config = RetargetConfig(windows=WindowOptions(frames=90, overlap_frames=16, workers=2))
    res = retarget(motion, robot, config=config)
    T = res.motion.n_frames
    stop1, start2, j0, j1 = windows.join_layout(T, 90, 16)
    # the chains overlap by 16 frames about the middle: the join starts on their crossfade
    assert (stop1, start2, j1 - j0) == (T // 2 + 8, T // 2 - 8, 40)
    assert res.wholebody.seconds["workers"] == 2 and res.wholebody.seconds["windows"] == 3
    # this process solved chain 1 (one window) and the join; chain 2 ran in the other one
    (plan1, _), (join_plan, join) = solves
    assert len(plan1.q_init) == stop1 and plan1.rest_ends == (True, False)
    assert (join_plan.fixed_frames, join_plan.fixed_end_frames) == (4, 4)
    assert join_plan.rest_ends == (False, False)
    q = res.motion.q
    assert np.abs(join.q[:4] - q[j0:j0 + 4]).max() <= 1e-9
    assert np.abs(join.q[-4:] - q[j1 - 4:j1]).max() <= 1e-9
    assert np.abs(q[j0 + 4:j1 - 4] - join.q[4:-4]).max() <= 1e-9  # the join's own frames
    written, m = _written_figures(robot, res, tmp_path)
    _assert_quality(m)
    _border_checks(robot, written, [j0 + 4, j1 - 4])


def test_evaluator_in_blocks_of_frames_gives_the_same_report(mocap, monkeypatch):
    """The capsule distances and the inverse dynamics run over blocks of frames (9 GB on a
    30-minute clip at once): the report is the same to the last digit. (The wash's first 10 s:
    300 frames at 30 fps, six blocks of 50, fitted without the fit's self-collision penalty so
    that there are collisions to score: a hand in a hip or knee link in 176 of them.)"""
    from imesh.evaluate import scoreboard as ev  # the module that reads the block size
    from imesh.fit import FitConfig

    robot = load_test_robot("g1")
    res = retarget(load_motion(mocap("cmu_02_10_wash_self_cc3rig.bvh")).frames(0, 600), robot,
                   config=RetargetConfig(balance="none", fit=FitConfig(collision_weight=0.0)))
    monkeypatch.setattr(ev, "EVAL_BLOCK_FRAMES", 10 ** 9)
    whole = ev.evaluate_motion(robot, res.motion, adapted=res.adapted)
    from imesh.metrics import collision

    calls = []  # frames per block of capsule distances (capsule and mesh pairs): 50 at a time
    body = collision._body_distances
    monkeypatch.setattr(collision, "_body_distances",
                        lambda model, cap, keys: calls.append(len(cap)) or body(model, cap, keys))
    monkeypatch.setattr(ev, "EVAL_BLOCK_FRAMES", 50)
    blocked = ev.evaluate_motion(robot, res.motion, adapted=res.adapted)
    assert max(calls) == 50 and sum(calls) == 2 * res.motion.n_frames > 8 * 50
    assert whole["self_collision_frames"]["value"] > 0  # the wash: hands on the body
    for report in (whole, blocked):
        report.pop("seconds_per_frame")  # the evaluator's own timing
    assert json.dumps(whole, sort_keys=True, default=str) == json.dumps(
        blocked, sort_keys=True, default=str)


def test_keypoint_laplacians_in_blocks_equal_all_at_once(mocap, monkeypatch):
    """The whole-body plan's interaction meshes are built 2048 frames at a time (1 GB at once
    on a 30-minute clip); each frame's mesh is its own, so blocks change nothing."""
    import numpy as np

    import imesh.solve.sqp as sqp

    points = load_motion(mocap("cmu_02_01_walk.bvh")).positions_m[:, :15]
    whole = sqp.keypoint_laplacians(points)
    monkeypatch.setattr(sqp, "LAPLACIAN_BLOCK_FRAMES", 50)
    assert np.array_equal(sqp.keypoint_laplacians(points), whole)
    assert np.count_nonzero(whole) > 15 * len(points)

"""Speed of the whole process: where the time goes, frames per second, memory, start-up.

    python benchmarks/speed.py [--tables profile whole startup robots gmr inspect scaling]
                               [--robot g1] [--clips cmu_02_01_walk.bvh cmu_141_16_wave_hello.bvh]
                               [--inspect-frames 216000] [--scaling-frames 500 1000 2000]
                               [--runs 5] [--gmr-runs 3] [--out DIR]

Tables (each printed as it is measured; docs/speed.md quotes them):

* ``profile``: ``imesh retarget CLIP --robot ROBOT`` (default settings, no ``--physics``) run
  under cProfile with the process's cpu clock (``time.process_time``: on a shared machine
  the wall clock counts the other jobs' time too); the cpu time split by stage from the
  cumulative times of the
  stage functions: read the clip, load the robot, prepare (resample, low-pass, arrangement,
  contacts), morph, fit, plan, capsule fit, the whole-body SQP split into assemble
  (``build_qp``), QP (``solve_qp``) and linearize + line search (the rest of
  ``solve_whole_body``), verify (the evaluator), write; "other" is imports and the CLI.
  Each clip in a process of its own (:data:`PROFILE`, imports included).
  Then the functions of largest own time.
* ``whole``: the same command as a separate process (``python -m imesh``), timed from
  outside with ``/usr/bin/time -v``: wall seconds, source frames per second (the clip's frames
  at its own rate over the wall time, as per-frame IK tools count) and peak memory.
* ``startup``: ``imesh --help`` wall time, and the time from the start of ``imesh retarget
  CLIP --robot ROBOT`` to its progress bar's first line ("first bar") and to its first advance
  (the robot loaded and the clip prepared: "first advance"), the process stopped there; medians of
  ``--runs`` runs with a warm cache (one run before them fills it).
* ``robots``: ``load_robot`` of G1, JVRC-1 and HRP-4C (the URDF beside the shared data) and
  their first ``capsule_model()``, each in a process of its own, with an empty cache folder
  (``IMESH_CACHE_DIR`` a new temporary folder: the URDF's meshes read, proxies and capsules
  fitted) and with a warm one; medians of ``--runs`` runs (cold: of 2).
* ``gmr``: GMR (the per-frame IK tool, ``../shared/tools/gmr``, README.md there) and ``imesh -q
  retarget CLIP --robot g1`` on the same clips as whole processes, in pairs (GMR, imesh, GMR,
  imesh... after one warm-up pair), ``--gmr-runs`` pairs per clip: medians of the cpu seconds
  (user + system), of the wall seconds, peak memory (MiB), source frames per cpu second and the
  ratio imesh / GMR of the cpu seconds. When GMR is not set up (its venv or source missing) the
  table says why and times imesh alone. ``--baseline DIR`` (another imesh source tree, e.g.
  ``git archive`` of an older commit unpacked) adds it to each round as "before", with the
  ratio of imesh's cpu seconds to its.
* ``inspect``: ``imesh inspect`` on a long clip built in a temporary folder by concatenating a
  shared BVH forwards and backwards (positions stay continuous) to ``--inspect-frames`` frames:
  wall seconds and peak memory.
* ``scaling``: ``imesh retarget`` on such concatenated clips of ``--scaling-frames`` frames
  (source frames at 120 Hz; "solved" counts the working frames at 30 fps with the lead-in
  and lead-out, "windows" the whole-body windows, "workers" its processes): the pipeline's
  own time (the report's ``seconds.total``, without start-up and robot load), the cpu
  seconds of the whole process tree (user + system; under other jobs' load they move far
  less than wall seconds), the 5-minute load average at the row's end, peak memory
  (the resident memory of the process and its children summed, sampled every 0.2 s with
  psutil: a worker's memory counts too), and the exponent of a least-squares fit
  ``time ~ frames^k`` of both times. ``--workers 1`` or ``2`` is passed on as ``imesh
  retarget --solve-workers`` (``RetargetConfig.windows.workers``; default 1).

Single runs: on a shared machine quote ``farm-bench`` medians for any claim (docs/speed.md).
"""

from __future__ import annotations

import argparse
import json
import os
import pstats
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _data import ROOT, data_root

CLIPS = ("cmu_02_01_walk.bvh", "cmu_141_16_wave_hello.bvh")

#: Stage -> the functions (module path suffix, name) whose cumulative times make it up.
STAGES = {
    "read clip": [("imesh/io/__init__.py", "load_motion")],
    "load robot": [("imesh/robot/model.py", "load_robot")],
    "prepare": [("imesh/morph/adapt.py", "prepare_markers"),
                ("imesh/human/filtering.py", "lowpass"),
                ("imesh/human/arrange.py", "arrange_for_robot"),
                ("imesh/contacts/phases.py", "detect_contacts"),
                ("imesh/contacts/support.py", "flat_support"),
                ("imesh/contacts/support.py", "support_foot_targets")],
    "morph": [("imesh/morph/problem.py", "build_morph_problem"),
              ("imesh/morph/solver.py", "solve_morph")],
    "fit": [("imesh/pipeline/retarget.py", "orientation_targets"),
            ("imesh/fit/motion.py", "fit_motion")],
    "plan": [("imesh/solve/initial.py", "smooth_initializer"), ("imesh/solve/lead.py", "add_lead"),
             ("imesh/fit/targets.py", "compile_targets"),
             ("imesh/solve/sqp.py", "plan_whole_body")],
    "capsule fit": [("imesh/robot/model.py", "capsule_model")],
    "SQP assemble": [("imesh/solve/problem.py", "build_qp")],
    "SQP QP": [("imesh/solve/qp.py", "solve_qp")],
    "SQP linearize + line search": [],  # solve_whole_body minus the three above
    "verify (evaluator)": [("imesh/evaluate/scoreboard.py", "evaluate_motion")],
    "write": [("imesh/io/robot_motion.py", "save_robot_motion"),
              ("imesh/io/atomic.py", "write_json")],
}


#: ``python -c PROFILE OUT.prof ARGS...``: ``imesh ARGS`` under cProfile on the process's cpu
#: clock.
PROFILE = """import cProfile, sys, time
prof = cProfile.Profile(time.process_time)
prof.enable()
from imesh.cli.app import main
try:
    code = main(sys.argv[2:])
finally:
    prof.disable()
    prof.dump_stats(sys.argv[1])
sys.exit(code)
"""


def _cumulative(stats: pstats.Stats, path: str, name: str) -> float:
    return sum(v[3] for (f, _, n), v in stats.stats.items()
               if n == name and f.replace(os.sep, "/").endswith(path))


def profile_stages(clip: Path, robot: str, out: Path, root: Path | None = None
                   ) -> tuple[dict[str, float], pstats.Stats]:
    """Run ``imesh retarget`` as its own process under cProfile on the cpu clock
    (:data:`PROFILE`: imports included, nothing cached from another run); cpu seconds per
    stage (``STAGES``)."""
    prof = out / f"{clip.stem}.prof"
    argv = [sys.executable, "-c", PROFILE, str(prof), "-q",
            "retarget", str(clip), "--robot", robot, "-o", str(out / "profile.npz"),
            "--json", str(out / "profile.json"), "--force"]
    # in the tree's own folder: ``python -c`` and ``-m`` put the working folder first on sys.path
    proc = subprocess.run(argv, capture_output=True, text=True, env=_env(root),
                          cwd=str(root or ROOT))
    if proc.returncode != 0:
        raise SystemExit(f"imesh retarget {clip.name} exited {proc.returncode}:\n"
                         f"{proc.stderr[-2000:]}")
    stats = pstats.Stats(str(prof))
    total = stats.total_tt
    row = {stage: sum(_cumulative(stats, p, n) for p, n in fns) for stage, fns in STAGES.items()}
    sqp = _cumulative(stats, "imesh/solve/sqp.py", "solve_whole_body")
    row["SQP linearize + line search"] = max(
        0.0, sqp - row["SQP assemble"] - row["SQP QP"] - row["capsule fit"])
    row["other (imports, CLI)"] = total - sum(row.values())
    row["total"] = total
    return row, stats


def table_profile(clips: list[Path], robot: str, out: Path, root: Path | None = None) -> None:
    rows, stats = {}, {}
    for clip in clips:
        rows[clip], stats[clip] = profile_stages(clip, robot, out, root)
    head = f"{'stage':<30}" + "".join(f"{c.stem[:22]:>24}" for c in clips)
    print(f"\n## profile: imesh retarget --robot {robot} (cProfile, cpu seconds, one process per "
          f"clip; imesh from {root or ROOT})\n")
    print(head)
    print("-" * len(head))
    for stage in rows[clips[0]]:
        cells = []
        for c in clips:
            s, tot = rows[c][stage], rows[c]["total"]
            cells.append(f"{s:>10.2f} s {100 * s / tot:>5.1f} %    ")
        print(f"{stage:<30}" + "".join(f"{x:>24}" for x in cells))
    for clip in clips:
        print(f"\nlargest own time, {clip.name}:")
        entries = sorted(stats[clip].stats.items(), key=lambda kv: -kv[1][2])[:12]
        for (f, line, name), (_, ncalls, tt, ct, _) in entries:
            where = f"{Path(f).parent.name}/{Path(f).name}:{line}" if line else f
            print(f"  {tt:8.2f} s own {ct:8.2f} s cum {ncalls:>8} calls  {name} ({where})")


def _timed(argv: list[str], env: dict | None = None, cwd: Path | None = None
           ) -> tuple[float, float, str]:
    """Run a command under ``/usr/bin/time -v`` (in ``cwd``): (wall s, peak MB, its stdout)."""
    cmd = ["/usr/bin/time", "-v", *argv]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=env,
                          cwd=None if cwd is None else str(cwd))
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited {proc.returncode}:\n{proc.stderr[-2000:]}")
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", proc.stderr)
    parts = [float(x) for x in wall.group(1).split(":")]
    seconds = sum(p * 60 ** k for k, p in enumerate(reversed(parts)))
    peak = float(re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr).group(1))
    return seconds, peak / 1024.0, proc.stdout


def _env(root: Path | None = None) -> dict:
    """The environment of a timed process: imesh from ``root`` (default this tree)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(root or ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def _imesh(*args: str) -> list[str]:
    return [sys.executable, "-m", "imesh", *args]


def _source_frames(clip: Path) -> int:
    from imesh.io import load_motion

    return load_motion(clip).n_frames


def table_whole(clips: list[Path], robot: str, out: Path) -> None:
    print(f"\n## whole process: imesh -q retarget CLIP --robot {robot} (default settings)\n")
    head = f"{'clip':<30} {'frames':>7} {'wall s':>8} {'frames/s':>9} {'peak MB':>8} {'solve s':>8}"
    print(head)
    print("-" * len(head))
    for clip in clips:
        report = out / f"{clip.stem}.json"
        wall, peak, _ = _timed(_imesh("-q", "retarget", str(clip), "--robot", robot, "-o",
                                      str(out / f"{clip.stem}.npz"), "--json", str(report)),
                               _env())
        n = _source_frames(clip)
        solve = json.loads(report.read_text())["seconds"]["total"]
        print(f"{clip.name:<30} {n:>7} {wall:>8.2f} {n / wall:>9.1f} {peak:>8.0f} {solve:>8.2f}")


def first_progress(clip: Path, robot: str, out: Path
                   ) -> tuple[float, float, float, float]:
    """Seconds from the start of ``imesh retarget CLIP --robot ROBOT`` to its progress bar's
    first line and to the bar's first advance (the robot loaded and the clip prepared; the
    process is stopped there), and the process's cpu seconds (user + system) at both (what a
    machine without other jobs would take)."""
    import select

    import psutil

    argv = _imesh("retarget", str(clip), "--robot", robot, "-o", str(out / "first.npz"),
                  "--force")
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    assert proc.stderr is not None
    fd = proc.stderr.fileno()
    first = loaded = None
    cpu = cpu_first = float("nan")
    text = b""
    try:
        while loaded is None and time.perf_counter() - t0 < 600:
            ready, _, _ = select.select([fd], [], [], 0.05)
            if not ready:
                if proc.poll() is not None:
                    break
                continue
            chunk = os.read(fd, 65536)
            if not chunk:
                break
            now = time.perf_counter() - t0
            text += chunk
            if first is None and b"%|" in text:
                first = now
                use = psutil.Process(proc.pid).cpu_times()
                cpu_first = use.user + use.system
            # the bar's description names the stage: anything after "load" is an advance
            lines = text.replace(b"\r", b"\n").split(b"\n")
            if any(b"%|" in ln and b": load" not in ln and b" 0/" not in ln for ln in lines):
                loaded = now
                use = psutil.Process(proc.pid).cpu_times()
                cpu = use.user + use.system
    finally:
        proc.kill()
        proc.wait()
    if first is None or loaded is None:
        raise SystemExit(f"no progress bar from {' '.join(argv)}:\n{text.decode()[-2000:]}")
    return first, loaded, cpu_first, cpu


def _median(xs: list[float]) -> float:
    import statistics

    return float(statistics.median(xs))


def table_startup(clip: Path, robot: str, out: Path, runs: int = 5) -> None:
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run(_imesh("--help"), capture_output=True, env=_env(), check=True)
        times.append(time.perf_counter() - t0)
    times.sort()
    print(f"\n## start-up: imesh --help: median {_median(times):.3f} s (min {times[0]:.3f}, max "
          f"{times[-1]:.3f}; {runs} runs)")
    first_progress(clip, robot, out)  # fills the cache
    firsts, loads, cpu_firsts, cpus = zip(
        *(first_progress(clip, robot, out) for _ in range(runs)), strict=True)
    print(f"imesh retarget {clip.name} --robot {robot}, warm cache, {runs} runs: first bar "
          f"median {_median(list(firsts)):.3f} s (min {min(firsts):.3f}, max "
          f"{max(firsts):.3f}), first advance median {_median(list(loads)):.3f} s (min "
          f"{min(loads):.3f}, max {max(loads):.3f}); cpu seconds at the first bar median "
          f"{_median(list(cpu_firsts)):.3f} s, at the first advance {_median(list(cpus)):.3f}"
          f" s; load average "
          f"{os.getloadavg()[0]:.2f}")


#: A child process loading a robot: prints the wall and cpu seconds of the import, load_robot
#: and capsule_model.
_LOAD_ROBOT = """
import json, sys, time
w, c = [time.perf_counter()], [time.process_time()]
from imesh.robot import load_robot
w.append(time.perf_counter()); c.append(time.process_time())
robot = load_robot(sys.argv[1], urdf=sys.argv[2] or None)
w.append(time.perf_counter()); c.append(time.process_time())
robot.capsule_model()
w.append(time.perf_counter()); c.append(time.process_time())
print(json.dumps({"import": w[1] - w[0], "load": w[2] - w[1], "capsules": w[3] - w[2],
                  "load_cpu": c[2] - c[1], "capsules_cpu": c[3] - c[2]}))
"""


def table_robots(runs: int = 5) -> None:
    hrp4c = data_root().parent / "robots" / "hrp4c" / "HRP4Cmain_reduced.urdf"
    print("\n## robots: load_robot and the first capsule_model(), one process per run "
          f"(medians; warm: {runs} runs, cold: 2)\n")
    head = (f"{'robot':<8} {'cache':<6} {'import s':>9} {'load_robot s':>13} {'cpu s':>6} "
            f"{'capsule_model s':>16} {'cpu s':>6} {'process s':>10} {'peak MB':>8}")
    print(head)
    print("-" * len(head))
    for name, urdf in (("g1", ""), ("jvrc1", ""), ("hrp4c", str(hrp4c))):
        argv = [sys.executable, "-c", _LOAD_ROBOT, name, urdf]
        _timed(argv, _env())  # fills the cache
        for cache, n in (("warm", runs), ("cold", 2)):
            rows = []
            for _ in range(n):
                env = _env()
                with tempfile.TemporaryDirectory(prefix="imesh-cache-") as empty:
                    if cache == "cold":
                        env["IMESH_CACHE_DIR"] = empty
                    wall, peak, stdout = _timed(argv, env)
                rows.append((json.loads(stdout.strip().splitlines()[-1]), wall, peak))
            med = {k: _median([r[0][k] for r in rows]) for k in rows[0][0]}
            print(f"{name:<8} {cache:<6} {med['import']:>9.2f} {med['load']:>13.2f} "
                  f"{med['load_cpu']:>6.2f} {med['capsules']:>16.2f} {med['capsules_cpu']:>6.2f} "
                  f"{_median([r[1] for r in rows]):>10.2f} "
                  f"{_median([r[2] for r in rows]):>8.0f}", flush=True)


def _cpu_timed(argv: list[str], env: dict | None = None, cwd: Path | None = None
               ) -> tuple[float, float, float]:
    """Run a command to its end: (wall s, cpu s (user + system, of it and its children), peak
    MiB of its largest process (``/usr/bin/time``'s maximum resident set size))."""
    import resource

    def cpu() -> float:
        use = resource.getrusage(resource.RUSAGE_CHILDREN)
        return use.ru_utime + use.ru_stime

    cpu0 = cpu()
    wall, peak, _ = _timed(argv, env, cwd)
    return wall, cpu() - cpu0, peak


def gmr_setup(gmr_dir: Path) -> tuple[list[str] | None, str]:
    """GMR's command (``[python, run_gmr.py]``) and "", or None and why it cannot run."""
    venv = Path(os.environ.get("GMR_VENV", Path.home() / ".cache" / "gmr-venv"))
    src = Path(os.environ.get("GMR_SRC", Path.home() / ".cache" / "gmr-src"))
    script = gmr_dir / "run_gmr.py"
    if not script.is_file():
        return None, f"{script} not found"
    if not (venv / "bin" / "python").is_file():
        return None, (f"no GMR venv in {venv}: bash {gmr_dir / 'setup.sh'} <git mirror of "
                      "github:YanjieZe/GMR> (README.md there)")
    if not (src / "general_motion_retargeting").is_dir():
        return None, f"no GMR source in {src}: bash {gmr_dir / 'setup.sh'} <git mirror>"
    return [str(venv / "bin" / "python"), str(script)], ""


def table_gmr(clips: list[Path], out: Path, runs: int = 3, gmr_dir: Path | None = None,
              baseline: Path | None = None) -> None:
    gmr_dir = gmr_dir or data_root().parent / "tools" / "gmr"
    gmr, why = gmr_setup(gmr_dir)
    load0 = os.getloadavg()[1]
    print(f"\n## GMR beside imesh: G1, whole processes in pairs, {runs} pairs per clip after "
          "one warm-up pair (medians)\n")
    if gmr is None:
        print(f"GMR unavailable: {why}; imesh timed alone\n")
    if baseline is not None:
        print(f"before: imesh from {baseline}\n")
    head = (f"{'clip':<28} {'frames':>6} {'tool':<6} {'cpu s':>7} {'wall s':>7} "
            f"{'peak MiB':>8} {'f/cpu s':>8} {'imesh/GMR cpu':>14} {'imesh/before':>13}")
    print(head)
    print("-" * len(head))
    for clip in clips:
        n = _source_frames(clip)
        tools = {"imesh": _imesh("-q", "retarget", str(clip), "--robot", "g1", "-o",
                                 str(out / f"gmr-imesh-{clip.stem}.npz"), "--force")}
        roots = {"imesh": None}
        if baseline is not None:
            tools["before"] = _imesh("-q", "retarget", str(clip), "--robot", "g1", "-o",
                                     str(out / f"gmr-before-{clip.stem}.npz"), "--force")
            roots["before"] = baseline
        if gmr is not None:
            tools = {"GMR": [*gmr, str(clip), str(out / f"gmr-{clip.stem}.npz")], **tools}
        rows: dict[str, list[tuple[float, float, float]]] = {t: [] for t in tools}
        for k in range(runs + 1):
            for tool, argv in tools.items():
                # in the tree's folder: ``python -m`` puts the working folder first on sys.path
                row = _cpu_timed(argv, _env(roots.get(tool)), roots.get(tool) or ROOT)
                if k:  # the first round warms the caches up
                    rows[tool].append(row)
        med = {t: [_median([r[i] for r in rows[t]]) for i in range(3)] for t in tools}
        for tool in tools:
            wall, cpu, peak = med[tool]
            ratio = (f"{cpu / med['GMR'][1]:>14.2f}" if tool != "GMR" and "GMR" in med
                     else f"{'':>14}")
            before = (f"{cpu / med['before'][1]:>13.3f}" if tool == "imesh" and "before" in med
                      else f"{'':>13}")
            print(f"{clip.name[:28]:<28} {n:>6} {tool:<6} {cpu:>7.2f} {wall:>7.2f} "
                  f"{peak:>8.0f} {n / cpu:>8.1f} {ratio} {before}", flush=True)
    print(f"load average (5 min) {load0:.2f} before, {os.getloadavg()[1]:.2f} after")


def concatenated_bvh(source: Path, n_frames: int, path: Path) -> Path:
    """Write a BVH of ``n_frames`` frames: ``source``'s frames forwards, then backwards, and so
    on (the positions stay continuous; a walk turns into a walk backwards)."""
    text = source.read_text()
    head, _, rest = text.partition("MOTION")
    lines = [ln for ln in rest.splitlines() if ln.strip()]
    frame_time, frames = lines[1], lines[2:]
    cycle = frames + frames[::-1]
    with open(path, "w") as f:
        f.write(f"{head}MOTION\nFrames: {n_frames}\n{frame_time}\n")
        done = 0
        while done < n_frames:
            chunk = cycle[:n_frames - done]
            f.write("\n".join(chunk) + "\n")
            done += len(chunk)
    return path


def table_inspect(source: Path, n_frames: int, tmp: Path) -> None:
    clip = concatenated_bvh(source, n_frames, tmp / f"long_{n_frames}.bvh")
    wall, peak, _ = _timed(_imesh("inspect", str(clip)), _env())
    size = clip.stat().st_size / 2 ** 20
    clip.unlink()
    print(f"\n## inspect on a long clip ({source.name} concatenated to {n_frames} frames, "
          f"{size:.0f} MB)\n")
    print(f"wall {wall:.2f} s, peak {peak:.0f} MB")


def _timed_tree(argv: list[str], env: dict | None = None) -> tuple[float, float, float]:
    """Run a command: (wall s, cpu s (user + system of it and every process it waited for),
    peak MB of its resident memory summed over the process and its children, sampled every
    0.2 s)."""
    import resource

    import psutil

    def cpu() -> float:
        use = resource.getrusage(resource.RUSAGE_CHILDREN)
        return use.ru_utime + use.ru_stime

    cpu0 = cpu()
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    root, peak = psutil.Process(proc.pid), 0
    while proc.poll() is None:
        try:
            tree = [root, *root.children(recursive=True)]
            peak = max(peak, sum(p.memory_info().rss for p in tree))
        except psutil.Error:  # a process ended between the listing and the reading
            pass
        time.sleep(0.2)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited {proc.returncode}:\n"
                         f"{proc.stderr.read().decode()[-2000:]}")
    return wall, cpu() - cpu0, peak / 2 ** 20


def table_scaling(source: Path, sizes: list[int], robot: str, tmp: Path,
                  workers: int | None = None) -> None:
    import numpy as np

    print(f"\n## scaling: imesh retarget --robot {robot} on {source.name} concatenated"
          f"{'' if workers is None else f', workers={workers}'}\n")
    head = (f"{'frames':>7} {'solved':>7} {'windows':>7} {'workers':>7} {'pipeline s':>11} "
            f"{'ms/frame':>9} {'wall s':>8} {'cpu s':>8} {'load':>5} {'peak MB':>8}")
    print(head)
    print("-" * len(head))
    xs, ys, cs = [], [], []
    for n in sizes:
        clip = concatenated_bvh(source, n, tmp / f"scale_{n}.bvh")
        report = tmp / f"scale_{n}.json"
        args = ["-q", "retarget", str(clip), "--robot", robot, "-o",
                str(tmp / f"scale_{n}.npz"), "--json", str(report), "--force"]
        if workers is not None:
            args += ["--solve-workers", str(workers)]
        wall, cpu, peak = _timed_tree(_imesh(*args), _env())
        load = os.getloadavg()[1]  # over the last 5 minutes: the machine beside this row
        rep = json.loads(report.read_text())
        total = rep["seconds"]["total"]
        seconds = rep["wholebody"]["seconds"]
        windows = int(seconds.get("windows", 1))
        used = int(seconds.get("workers", 1))
        solved = rep["frames"]
        xs.append(n)
        ys.append(total)
        cs.append(cpu)
        print(f"{n:>7} {solved:>7} {windows:>7} {used:>7} {total:>11.2f} "
              f"{1e3 * total / n:>9.2f} {wall:>8.2f} {cpu:>8.2f} {load:>5.2f} {peak:>8.0f}",
              flush=True)
    if len(xs) >= 2:
        k = np.polyfit(np.log(xs), np.log(ys), 1)[0]
        k_cpu = np.polyfit(np.log(xs), np.log(cs), 1)[0]
        # cpu seconds hardly move with the load of other jobs, wall seconds do
        print(f"fitted exponent (time ~ frames^k): pipeline k = {k:.3f}, cpu k = {k_cpu:.3f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", nargs="+", default=["profile", "whole", "startup", "inspect"],
                    choices=("profile", "whole", "startup", "robots", "gmr", "inspect",
                             "scaling"))
    ap.add_argument("--robot", default="g1")
    ap.add_argument("--clips", nargs="+", default=list(CLIPS))
    ap.add_argument("--inspect-frames", type=int, default=216000)
    ap.add_argument("--scaling-frames", type=int, nargs="+", default=[500, 1000, 2000])
    ap.add_argument("--workers", type=int, choices=(1, 2), default=None,
                    help="imesh retarget --solve-workers of the scaling table (default 1)")
    ap.add_argument("--runs", type=int, default=5,
                    help="runs of the startup and robots tables (medians)")
    ap.add_argument("--gmr-runs", type=int, default=3, help="pairs per clip of the gmr table")
    ap.add_argument("--gmr-dir", type=Path, default=None,
                    help="GMR's harness (default: ../shared/tools/gmr beside the data)")
    ap.add_argument("--baseline", type=Path, default=None,
                    help="gmr table: also time imesh from this source tree (\"before\")")
    ap.add_argument("--root", type=Path, default=None,
                    help="profile table: profile imesh from this source tree (default this one)")
    ap.add_argument("--out", help="folder of the written motions (default: a temporary one)")
    args = ap.parse_args(argv)
    clips = [data_root() / "mocap" / c for c in args.clips]
    with tempfile.TemporaryDirectory(prefix="imesh-speed-") as tmp_name:
        tmp = Path(tmp_name)
        out = Path(args.out) if args.out else tmp
        out.mkdir(parents=True, exist_ok=True)
        load = os.getloadavg()
        print(f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, {os.cpu_count()} cores, "
              f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
        for table in args.tables:
            if table == "profile":
                table_profile(clips, args.robot, out, args.root)
            elif table == "whole":
                table_whole(clips, args.robot, out)
            elif table == "startup":
                table_startup(clips[0], args.robot, out, args.runs)
            elif table == "robots":
                table_robots(args.runs)
            elif table == "gmr":
                table_gmr(clips, out, args.gmr_runs, args.gmr_dir, args.baseline)
            elif table == "inspect":
                table_inspect(clips[0], args.inspect_frames, tmp)
            elif table == "scaling":
                table_scaling(clips[0], args.scaling_frames, args.robot, tmp, args.workers)
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())

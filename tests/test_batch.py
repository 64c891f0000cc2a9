"""``imesh batch`` on Ray: two real clips and a corrupt one; exit "partial", the error named in
the log, verified outputs, a second run that recomputes nothing, an interrupted run that leaves
no partial file and a restart that completes it."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import mocap_path

from imesh.cli import main
from imesh.pipeline.batch import EXIT_PARTIAL, LOG_NAME, BatchSettings, is_done

ROOT = Path(__file__).resolve().parents[1]
pytest.importorskip("ray")


def _first_frames(src: Path, dst: Path, n: int) -> None:
    """The BVH ``src`` up to its frame ``n`` (the hierarchy and the values as they are)."""
    lines = src.read_bytes().splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if line.lstrip().startswith(b"Frames:"))
    eol = lines[k][len(lines[k].rstrip(b"\r\n")):]
    assert int(lines[k].split()[1]) >= n and lines[k + 1].lstrip().startswith(b"Frame Time:")
    dst.write_bytes(b"".join(lines[:k]) + b"Frames: %d" % n + eol
                    + b"".join(lines[k + 1:k + 2 + n]))


@pytest.fixture(scope="module")
def clips(tmp_path_factory) -> Path:
    """Two real clips, the first 1.3 s of the demo walk (156 frames at 120 fps: two steps,
    ending with both feet down) and of the wave, a corrupt one and a text file. The whole
    walk's solve is kept for the tests that stop a batch while it runs
    (:func:`test_batch_interrupted_leaves_no_partial_file`)."""
    import imesh

    folder = tmp_path_factory.mktemp("clips")
    _first_frames(imesh.demo_clip(), folder / "walk.bvh", 156)
    _first_frames(mocap_path("cmu_141_16_wave_hello.bvh"), folder / "wave.bvh", 156)
    # corrupt: the walk cut off in its hierarchy
    (folder / "cut.bvh").write_bytes(imesh.demo_clip().read_bytes()[:3000])
    (folder / "notes.txt").write_text("not a clip: ignored by the folder search\n")
    return folder


def _records(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / LOG_NAME).read_text().splitlines()]


def _leftovers(out: Path) -> list[str]:
    return sorted(p.name for p in out.iterdir() if p.name.startswith("."))


def test_batch_partial_then_resumed(clips, tmp_path, capsys):
    import imesh

    out = tmp_path / "out"
    status = main(["-q", "batch", str(clips), "--robot", "jvrc1", "-o", str(out),
                   "--workers", "2"])
    assert status == EXIT_PARTIAL
    table = capsys.readouterr().out
    assert "3 clips: 2 done, 0 skipped (up to date), 1 failed" in table
    records = {Path(r["clip"]).name: r for r in _records(out) if "clip" in r}
    assert records["cut.bvh"]["status"] == "error"
    assert records["cut.bvh"]["error_type"] == "MotionFileError"
    assert "cut.bvh" in records["cut.bvh"]["error"]
    settings = BatchSettings(robot="jvrc1")
    for name in ("walk", "wave"):
        assert records[f"{name}.bvh"]["status"] == "ok"
        assert is_done(clips / f"{name}.bvh", out / f"{name}.npz", settings)
        report = imesh.evaluate(out / f"{name}.npz")  # verified: the gates hold
        assert report["limit_violation_frames"]["value"] == 0
    assert not (out / "cut.npz").exists()
    assert _leftovers(out) == []

    # a second run recomputes nothing: done clips are skipped, the corrupt one is reported as
    # failed again without running (no Ray started)
    t0 = time.perf_counter()
    status = main(["-q", "batch", str(clips / "*.bvh"), "--robot", "jvrc1", "-o", str(out)])
    assert status == EXIT_PARTIAL
    last = [r for r in _records(out) if "clip" in r][-3:]
    assert sorted(r["status"] for r in last) == ["error", "skipped", "skipped"]
    assert [r.get("cached") for r in last if r["status"] == "error"] == [True]
    assert time.perf_counter() - t0 < 5
    # --retry-failed runs it again
    status = main(["-q", "batch", str(clips / "cut.bvh"), "--robot", "jvrc1", "-o", str(out),
                   "--retry-failed", "--backend", "processes", "--workers", "1"])
    assert status == EXIT_PARTIAL
    assert "cached" not in _records(out)[-2]

    # changed settings are not up to date
    assert not is_done(clips / "walk.bvh", out / "walk.npz", BatchSettings(robot="jvrc1",
                                                                          fps=25.0))


def test_batch_interrupted_leaves_no_partial_file(tmp_path):
    """SIGTERM while the clips are being solved: nothing half-written; the restart ends with
    the same outputs as an uninterrupted run. (The whole demo walk: its solve outlasts the
    12 s before the signal.)"""
    import imesh

    out = tmp_path / "out"
    single = tmp_path / "in"
    single.mkdir()
    shutil.copy(imesh.demo_clip(), single / "walk.bvh")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-c", "import sys; from imesh.cli import main; sys.exit(main())",
           "-q", "batch", str(single), "--robot", "jvrc1", "-o", str(out), "--workers", "1"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    time.sleep(12)  # Ray started, the clip being solved
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=120)
    assert proc.returncode == 130
    assert not (out / "walk.npz").exists()
    assert _leftovers(out) == []
    result = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert is_done(single / "walk.bvh", out / "walk.npz", BatchSettings(robot="jvrc1"))
    assert _leftovers(out) == []
    with np.load(out / "walk.npz") as f:
        assert f["joint_positions"].shape == (146, 32)


def test_batch_from_the_folder_holding_the_checkout(clips, tmp_path):
    """Run from the folder that holds a checkout named ``imesh`` (no PYTHONPATH): the Ray
    workers import the package, not the checkout folder as an empty namespace package."""
    parent = tmp_path / "parent"
    parent.mkdir()
    (parent / "imesh").symlink_to(ROOT, target_is_directory=True)
    two = tmp_path / "two"
    two.mkdir()
    for name in ("walk.bvh", "wave.bvh"):
        shutil.copy(clips / name, two / name)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    code = (f"import sys; sys.path.insert(0, {str(parent / 'imesh')!r}); "
            "from imesh.cli import main; sys.exit(main())")
    # the workers' imports are the point: the per-frame fit alone (no whole-body solve,
    # written with --force past the gates it does not meet) spares the test 80 s
    result = subprocess.run([sys.executable, "-c", code, "-q", "batch", str(two), "--robot",
                             "jvrc1", "-o", str(tmp_path / "out"), "--workers", "2",
                             "--balance", "none", "--force"],
                            cwd=parent, env=env, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    done = [r for r in _records(tmp_path / "out") if r.get("status") == "ok"]
    assert sorted(Path(r["clip"]).name for r in done) == ["walk.bvh", "wave.bvh"]
    # -q: nothing from Ray (start-up, token authentication) on stderr; plain text out (not a TTY)
    assert "WARNING" not in result.stderr and "Token" not in result.stderr, result.stderr
    assert "\x1b" not in result.stdout
    assert "\x1b" not in (tmp_path / "out" / LOG_NAME).read_text()


@pytest.mark.parametrize("seconds", [0.5, 2.0, 4.0, 6.0, 8.0, 12.0])
def test_batch_sigterm_at_any_moment(tmp_path, seconds):
    """SIGTERM while Python imports the command (0.5 s), around Ray's start-up (2-4 s, where
    ray.init had its own handler: exit 15 without a word before), as the driver's core worker
    starts (6-8 s on a loaded machine: its abseil failure-signal handler printed a C++ stack
    and aborted, -6) and while the clip is solved (12 s): exit 130 with one line on stderr
    (-q: nothing else), no output or temporary file."""
    import imesh

    single = tmp_path / "in"
    single.mkdir()
    shutil.copy(imesh.demo_clip(), single / "walk.bvh")  # the whole walk: solved after 12 s
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "imesh", "-q", "batch", str(single),
                             "--robot", "jvrc1", "-o", str(out), "--workers", "1"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(seconds)
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode in (130, 143), (proc.returncode, stderr)
    assert stderr.splitlines() == ["imesh: interrupted"], stderr
    assert stdout == ""
    assert not (out / "walk.npz").exists()
    assert not out.exists() or _leftovers(out) == []


def test_ray_error_messages_are_plain_text(tmp_path):
    """A real Ray task error (its ``ray::run_clip()`` prefix in ANSI colour) becomes a plain
    one-line message in the record, the JSON log and the table."""
    import traceback

    from ray.exceptions import RayTaskError

    from imesh.pipeline.batch import BatchReport, error_record

    try:
        raise ImportError("cannot import name '__version__' from 'imesh'")
    except ImportError as exc:
        error = RayTaskError("run_clip", traceback.format_exc(), exc)
    assert "\x1b[" in str(error)  # Ray colours it
    record = error_record("walk.bvh", "out/walk.npz", error)
    assert "\x1b" not in record["error"] and "\n" not in record["error"]
    assert "cannot import name '__version__'" in record["error"]
    assert record["error_type"] == "RayTaskError"
    raw = {**record, "error": str(error)}  # a log line of an older version
    assert "\x1b" not in BatchReport((raw,), 1.0).table()



def test_a_sigterm_during_ray_init_is_held_until_it_returns():
    """ray.init installs a handler that raises SystemExit(15) wherever the start-up is: in a
    fork callback it was swallowed and the batch ran on to exit 0. Inside _sigterm_held Ray
    cannot install it, a SIGTERM is only recorded, and the handler set before (here one like
    the CLI's) runs once the block is left; the handlers are as before afterwards."""
    ray = pytest.importorskip("ray")
    from imesh.pipeline.batch import _sigterm_held

    install = ray._private.utils.set_sigterm_handler
    calls = []

    def cli_like(signum, frame):
        calls.append(signum)
        raise KeyboardInterrupt

    before = signal.signal(signal.SIGTERM, cli_like)
    try:
        reached = False
        with pytest.raises(KeyboardInterrupt):
            with _sigterm_held(ray, main_thread=True):
                ray._private.utils.set_sigterm_handler(lambda s, f: sys.exit(s))  # as ray.init
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)  # the Python handler runs at the next bytecode
                reached = True
        assert reached and calls == [signal.SIGTERM]
        assert signal.getsignal(signal.SIGTERM) is cli_like
        assert ray._private.utils.set_sigterm_handler is install
    finally:
        signal.signal(signal.SIGTERM, before)

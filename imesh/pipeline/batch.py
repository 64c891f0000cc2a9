"""``imesh batch``: retarget a folder (or glob) of clips, on Ray.

Each clip runs as one task (the pipeline of ``imesh retarget``, verification included) on a
local Ray runtime with ``--workers`` CPUs (default), on an existing cluster (``--address``,
e.g. ``ray start --head`` then ``--address auto``), or in local processes (``--backend
processes``, no Ray needed). Per clip, in ``OUT_DIR``:

- ``<stem><suffix>``: the motion in ``--format`` (written atomically: a temporary file renamed
  into place, so an interrupted batch leaves no partial file);
- ``<stem><suffix>.imesh.json``: the stamp written after it: the input's SHA-256, the settings'
  hash (robot, format, fps, balance, model file, imesh version), the output's SHA-256, frames
  and time. A clip whose output and stamp agree with its input and the settings is skipped, so a
  batch can be re-run or resumed after an interruption and recomputes only what is missing.
  A clip whose last run failed with the same input bytes and settings is reported as failed
  again without running (``--retry-failed`` runs it).

``OUT_DIR/batch.jsonl`` gets one JSON line per clip and run (``status`` ok / skipped / error,
the error's type and message), and a final ``summary`` line; the summary table is printed.
One bad clip never stops the others. Exit status: 0 every clip done (:data:`EXIT_OK`), 4 some
failed (:data:`EXIT_PARTIAL`), 2 bad usage or no clip found, 130 interrupted (Ctrl-C or
SIGTERM, at any moment: :func:`interrupt`; no partial output stays). Messages in the log and
the table are plain text: the colour codes of Ray's errors are removed (:func:`plain`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import glob
import hashlib
import json
import logging
import multiprocessing
import os
import re
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from threadpoolctl import threadpool_limits
from tqdm import tqdm

from .. import __version__
from ..core.lazy import optional
from ..core.provenance import file_sha256
from ..errors import ImeshError, OptionError
from ..evaluate.verify import verify_motion
from ..io import load_motion
from ..io.atomic import atomic_path
from ..io.formats import FORMATS, write_export
from ..io.robot_motion import save_robot_motion
from ..robot import load_robot
from .retarget import RetargetConfig, retarget

log = logging.getLogger(__name__)

#: Exit statuses of ``imesh batch``: every clip done / some clips failed.
EXIT_OK, EXIT_PARTIAL = 0, 4
#: Suffixes of the clips a folder is searched for.
CLIP_SUFFIXES = (".bvh", ".amc", ".c3d", ".trc")
LOG_NAME = "batch.jsonl"
STAMP_SUFFIX = ".imesh.json"


@dataclass(frozen=True)
class BatchSettings:
    """What decides a clip's output (hashed into its stamp).

    Attributes:
        robot: robot name or robot.toml path (None: jvrc1, or generated from ``urdf``).
        format: output format (:data:`imesh.io.formats.FORMATS`).
        fps: output frame rate [1/s] (None: the pipeline's default, 30).
        balance: ``wholebody``, ``nishiwaki`` or ``none``.
        mjcf: MuJoCo model file for ``format="mujoco"`` (None: the robot's).
        urdf: model file of robots whose model the user provides.
        force: write motions that fail verification.
    """

    robot: str | None = None
    format: str = "npz"
    fps: float | None = None
    balance: str = "wholebody"
    mjcf: str | None = None
    urdf: str | None = None
    force: bool = False

    def digest(self) -> str:
        """SHA-256 of the settings and the imesh version (hex)."""
        data = {**dataclasses.asdict(self), "version": __version__}
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()

    @property
    def suffix(self) -> str:
        return FORMATS[self.format]


def find_clips(pattern: str) -> list[Path]:
    """The clips of a folder (files with :data:`CLIP_SUFFIXES`, sorted) or a glob pattern.

    Raises:
        OptionError: nothing matches, or two clips have the same file stem (their outputs
            would collide).
    """
    p = Path(pattern)
    if p.is_dir():
        clips = sorted(c for c in p.iterdir() if c.is_file() and c.suffix.lower()
                       in CLIP_SUFFIXES)
    else:
        clips = sorted(Path(c) for c in glob.glob(pattern, recursive=True) if Path(c).is_file())
    if not clips:
        raise OptionError("IN_DIR_OR_GLOB", pattern, f"a folder holding clips "
                          f"({', '.join(CLIP_SUFFIXES)}) or a glob pattern matching files")
    stems: dict[str, Path] = {}
    for c in clips:
        if c.stem in stems:
            raise OptionError("clips (two have the same name, their outputs would collide)",
                              f"{stems[c.stem]} and {c}", "clips with distinct file stems")
        stems[c.stem] = c
    return clips


def output_path(clip: Path, out_dir: Path, settings: BatchSettings) -> Path:
    return out_dir / (clip.stem + settings.suffix)


def stamp_path(output: Path) -> Path:
    return output.with_name(output.name + STAMP_SUFFIX)


def is_done(clip: Path, output: Path, settings: BatchSettings) -> bool:
    """True when ``output`` and its stamp match ``clip``'s bytes and ``settings``."""
    stamp = stamp_path(output)
    if not (output.is_file() and stamp.is_file()):
        return False
    try:
        data = json.loads(stamp.read_text())
        return (data.get("input_sha256") == file_sha256(clip)
                and data.get("settings_sha256") == settings.digest()
                and data.get("output_sha256") == file_sha256(output))
    except (OSError, ValueError):
        return False


def known_failures(out_dir: Path) -> dict[str, dict]:
    """The last record of every clip in ``out_dir``'s log whose last run failed."""
    last: dict[str, dict] = {}
    try:
        with open(out_dir / LOG_NAME, encoding="utf-8") as fh:
            for line in fh:
                try:
                    record = json.loads(line)
                except ValueError:
                    continue  # a line cut by a kill
                if "clip" in record:
                    last[record["clip"]] = record
    except OSError:
        return {}
    return {c: r for c, r in last.items() if r.get("status") == "error"}


def remove_stale_temporaries(out_dir: Path) -> list[Path]:
    """Remove temporary files an interrupted batch left (``.<name>.<random><suffix>`` of
    :func:`imesh.io.atomic.atomic_path`); returns them."""
    removed = []
    for f in out_dir.glob(".*"):
        if (f.is_file() and not f.name.startswith(".imesh-probe-") and f.name.count(".") >= 3
                and f.suffix in (".npz", ".csv", ".json", ".bak")):
            try:
                f.unlink()
                removed.append(f)
            except OSError:
                pass
    return removed


# ------------------------------------------------------------------------------ messages
#: ANSI escape sequences (CSI such as the colours of Ray's ``RayTaskError``, and 2-byte ones).
_ANSI = re.compile(r"\x1b\[[0-?]*[ -/]*[@-~]|\x1b[@-Z\\-_]")
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f]")


def plain(text: str, one_line: bool = True) -> str:
    """``text`` without ANSI escape sequences or other control characters (for the log and the
    table); with ``one_line`` its whitespace runs (newlines included) become one space."""
    text = _CONTROL.sub("", _ANSI.sub("", text))
    return " ".join(text.split()) if one_line else text


def error_record(clip: str, output: str, exc: BaseException) -> dict:
    """The record of a clip whose worker failed outside :func:`run_clip` (a Ray task error, a
    crashed process): its type and plain one-line message (at most 2000 characters)."""
    return {"clip": clip, "output": output, "status": "error", "error_type": type(exc).__name__,
            "error": plain(str(exc))[:2000] or repr(exc)}


# ------------------------------------------------------------------------------ one clip
def run_clip(clip: str, output: str, settings: BatchSettings) -> dict:
    """Retarget one clip, verify, write the output and its stamp; never raises.

    Returns:
        A JSON-able record: ``clip``, ``status`` (``ok`` or ``error``), ``output``, ``frames``,
        ``seconds``; for errors ``error_type`` and ``error``.
    """
    t0 = time.perf_counter()
    record: dict = {"clip": str(clip), "output": str(output),
                    "settings_sha256": settings.digest()}
    try:
        record["input_sha256"] = file_sha256(clip)

        with threadpool_limits(1):
            _retarget_clip(Path(clip), Path(output), settings, record)
        record["status"] = "ok"
    except Exception as exc:  # noqa: BLE001 - one bad clip never stops the batch
        record.update(status="error", error_type=type(exc).__name__,
                      error=plain(str(exc)) or repr(exc))
        if not isinstance(exc, ImeshError):
            record["traceback"] = plain(traceback.format_exc(limit=-3), one_line=False)
    record["seconds"] = round(time.perf_counter() - t0, 3)
    return record


def _retarget_clip(clip: Path, output: Path, settings: BatchSettings, record: dict) -> None:
    input_sha = file_sha256(clip)
    robot = load_robot(settings.robot, urdf=settings.urdf)
    config = RetargetConfig(balance=settings.balance)
    if settings.fps is not None:
        config = dataclasses.replace(config, fps=float(settings.fps))
    human = load_motion(clip)
    result = retarget(human, robot, config=config)
    if not settings.force:
        verify_motion(robot, result.motion, adapted=result.adapted, seconds=result.seconds,
                      name=str(clip), balanced=settings.balance != "none", source=human)
    if settings.format == "npz":
        save_robot_motion(output, result.motion, markers=result.adapted)
    else:
        write_export(result.motion, output, settings.format, mjcf=settings.mjcf, robot=robot)
    record.update(frames=result.motion.n_frames, fps=result.motion.fps,
                  robot=result.motion.robot)
    stamp = {"clip": str(clip), "input_sha256": input_sha,
             "settings": dataclasses.asdict(settings), "settings_sha256": settings.digest(),
             "output_sha256": file_sha256(output), "frames": result.motion.n_frames,
             "fps": result.motion.fps, "retarget_seconds": result.seconds}
    with atomic_path(stamp_path(output)) as tmp:
        tmp.write_text(json.dumps(stamp, indent=2) + "\n")


# ------------------------------------------------------------------------------ executors
def _ray_results(jobs: Sequence[tuple[str, str]], settings: BatchSettings, workers: int,
                 address: str | None, quiet: bool = False) -> Iterator[dict]:
    """Run the jobs as Ray tasks, at most ``workers`` at a time; yield records as they end.

    ``quiet``: Ray logs errors only (not its start-up and token-authentication warnings). A
    SIGTERM during ``ray.init`` is held until it returns (:func:`_sigterm_held`), then ends
    the batch as at any other moment; Ray is shut down in every case."""
    # Ray's driver installs abseil's failure-signal handler for SIGTERM too: a SIGTERM that
    # meets it prints a C++ stack and, after our "interrupted", aborts the process (exit -6
    # or -11 in 6 of 8 tries on a loaded machine). Read when Ray is imported: set it first.
    os.environ.setdefault("RAY_DISABLE_FAILURE_SIGNAL_HANDLER", "1")
    ray = optional("ray", "pip install imesh-retarget[batch] (or --backend processes)",
                   "--backend ray")
    env = {"env_vars": {"PYTHONPATH": os.pathsep.join(
        p for p in [str(Path(__file__).resolve().parents[2]), os.environ.get("PYTHONPATH")]
        if p)}}
    level = logging.ERROR if quiet else logging.WARNING
    main_thread = threading.current_thread() is threading.main_thread()
    try:
        with _sigterm_held(ray, main_thread):
            if address:
                ray.init(address=address, runtime_env=env, log_to_driver=False,
                         logging_level=level)
            else:
                ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False,
                         logging_level=level, runtime_env=env)
        task = ray.remote(num_cpus=1, max_retries=0)(run_clip)
        pending: dict = {}
        queue = list(jobs)
        while queue or pending:
            while queue and len(pending) < workers:
                clip, out = queue.pop(0)
                pending[task.remote(clip, out, settings)] = (clip, out)
            done, _ = ray.wait(list(pending), num_returns=1)
            for ref in done:
                clip, out = pending.pop(ref)
                try:
                    yield ray.get(ref)
                except Exception as exc:  # noqa: BLE001 - a worker crash is one clip's error
                    yield error_record(clip, out, exc)
    finally:
        ray.shutdown()


@contextlib.contextmanager
def _sigterm_held(ray, main_thread: bool) -> Iterator[None]:
    """``ray.init`` with SIGTERM held: a SIGTERM that arrives during it is recorded and acted
    on once it returned, as the handler installed before would have (the CLI's raises
    KeyboardInterrupt; the default terminates).

    ``ray.init`` installs its own SIGTERM handler (``sys.exit(15)``) for its duration. Raised
    at an arbitrary point of the start-up, that exit was swallowed when it landed in a fork
    callback ("Exception ignored in: _pin_fork_objects"): the batch then ran to its end and
    exited 0 (2 s into a batch on a loaded machine); or it left Ray half started for
    ``ray.shutdown``. So Ray's handler is not installed (``ray._private.utils
    .set_sigterm_handler``, when this Ray has it) and ours only records the signal."""
    if not main_thread:  # signals are delivered to the main thread only
        yield
        return
    received: list[int] = []
    before = signal.signal(signal.SIGTERM, lambda signum, frame: received.append(signum))
    utils: Any = getattr(getattr(ray, "_private", None), "utils", None)
    install = getattr(utils, "set_sigterm_handler", None)
    if install is not None:
        utils.set_sigterm_handler = lambda handler: None
    try:
        yield
    except SystemExit as exc:  # a Ray without that hook: its handler ran
        if exc.code != signal.SIGTERM:
            raise
        received.append(signal.SIGTERM)
    finally:
        if install is not None:
            utils.set_sigterm_handler = install
        signal.signal(signal.SIGTERM, before if before is not None else signal.SIG_DFL)
    if received:  # what the SIGTERM would have done without Ray
        if callable(before):
            before(signal.SIGTERM, None)  # the CLI's raises KeyboardInterrupt
        elif before != signal.SIG_IGN:
            signal.raise_signal(signal.SIGTERM)  # the default action: terminate


def _process_results(jobs: Sequence[tuple[str, str]], settings: BatchSettings, workers: int
                     ) -> Iterator[dict]:
    with ProcessPoolExecutor(max_workers=workers,
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(run_clip, c, o, settings): (c, o) for c, o in jobs}
        try:
            for fut in as_completed(futures):
                clip, out = futures[fut]
                try:
                    yield fut.result()
                except Exception as exc:  # noqa: BLE001 - a worker crash is one clip's error
                    yield error_record(clip, out, exc)
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise


# ------------------------------------------------------------------------------ the batch
@dataclass(frozen=True)
class BatchReport:
    """The outcome of :func:`run_batch`.

    Attributes:
        records: one dict per clip (``status`` ok / skipped / error), in the clips' order.
        seconds: wall time of the batch [s].
    """

    records: tuple[dict, ...]
    seconds: float

    def count(self, status: str) -> int:
        return sum(r["status"] == status for r in self.records)

    @property
    def complete(self) -> bool:
        return self.count("error") == 0

    def table(self) -> str:
        """The summary table: one row per clip, then the totals."""
        width = max([4, *(len(Path(r["clip"]).name) for r in self.records)])
        lines = [f"{'clip':<{width}}  {'status':<7} {'frames':>6} {'seconds':>8}  detail"]
        for r in self.records:
            detail = (f"{'(failed before, not retried) ' if r.get('cached') else ''}"
                      f"{r.get('error_type')}: {plain(str(r.get('error')))}"
                      if r["status"] == "error" else r.get("output", ""))
            frames = r.get("frames", "")
            secs = f"{r['seconds']:.1f}" if "seconds" in r else ""
            lines.append(f"{Path(r['clip']).name:<{width}}  {r['status']:<7} {frames!s:>6} "
                         f"{secs:>8}  {detail[:160]}")
        lines.append(f"{len(self.records)} clips: {self.count('ok')} done, "
                     f"{self.count('skipped')} skipped (up to date), {self.count('error')} "
                     f"failed in {self.seconds:.1f} s")
        return "\n".join(lines)


def run_batch(inputs: str | Sequence[str | os.PathLike], out_dir: str | os.PathLike,
              settings: BatchSettings = BatchSettings(), *, workers: int = 2,
              address: str | None = None, backend: str = "ray", progress: bool = True,
              retry_failed: bool = False, quiet: bool = False,
              on_record: Callable[[dict], None] | None = None) -> BatchReport:
    """Retarget many clips into ``out_dir`` (module docstring).

    Args:
        inputs: a folder, a glob pattern, or a list of clip paths.
        out_dir: output folder (created).
        settings: robot, format and pipeline settings.
        workers: clips run at the same time (Ray CPUs of the local runtime).
        address: a Ray cluster to join (``"auto"``, ``"HOST:6379"``); None starts a local one.
        backend: ``"ray"`` or ``"processes"`` (concurrent.futures, no Ray).
        progress: show a tqdm bar over the clips (with ETA) on stderr.
        retry_failed: run clips again whose last run failed with the same input bytes and
            settings (by default they are reported as failed again without running: a re-run
            recomputes nothing).
        quiet: Ray's start-up and token warnings silenced (``imesh -q batch``).
        on_record: called with each clip's record as it ends.

    Returns:
        :class:`BatchReport`.
    """
    if workers < 1:
        raise OptionError("--workers", workers, "an integer >= 1")
    if backend not in ("ray", "processes"):
        raise OptionError("--backend", backend, ["ray", "processes"])

    if settings.format not in FORMATS:
        raise OptionError("--format", settings.format, list(FORMATS))
    clips = (find_clips(inputs) if isinstance(inputs, str)
             else [Path(c) for c in inputs])
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    for f in remove_stale_temporaries(out_dir):
        log.info("removed %s left by an interrupted batch", f)
    t0 = time.perf_counter()
    log_file = open(out_dir / LOG_NAME, "a", encoding="utf-8")  # noqa: SIM115
    run_id = time.strftime("%Y-%m-%dT%H:%M:%S") + f"-{os.getpid()}"
    records: dict[str, dict] = {}

    def emit(record: dict) -> None:
        record = {"run": run_id, **record}
        records[record["clip"]] = record
        log_file.write(json.dumps(record) + "\n")
        log_file.flush()
        if on_record is not None:
            on_record(record)

    failures = {} if retry_failed else known_failures(out_dir)
    digest = settings.digest()
    bar = None
    results: Iterator[dict] | None = None
    try:
        jobs = []
        for clip in clips:
            out = output_path(clip, out_dir, settings)
            failed = failures.get(str(clip))
            if is_done(clip, out, settings):
                emit({"clip": str(clip), "output": str(out), "status": "skipped"})
            elif (failed and failed.get("settings_sha256") == digest
                  and failed.get("input_sha256") == file_sha256(clip)):
                emit({**{k: v for k, v in failed.items() if k != "run"}, "cached": True})
            else:
                jobs.append((str(clip), str(out)))
        if jobs:
            target = settings.robot or settings.urdf or "jvrc1"
            bar = tqdm(total=len(jobs), desc=f"batch -> {target}", unit="clip",
                       disable=not progress, file=sys.stderr, smoothing=0)
            results = (_ray_results(jobs, settings, workers, address, quiet)
                       if backend == "ray" else _process_results(jobs, settings, workers))
            for record in results:
                emit(record)
                bar.set_postfix(failed=sum(r["status"] == "error" for r in records.values()))
                bar.update(1)
        report = BatchReport(tuple(records[str(c)] for c in clips if str(c) in records),
                             time.perf_counter() - t0)
        log_file.write(json.dumps({"run": run_id, "summary": {
            "clips": len(clips), "ok": report.count("ok"), "skipped": report.count("skipped"),
            "error": report.count("error"), "seconds": round(report.seconds, 3),
            "settings": dataclasses.asdict(settings)}}) + "\n")
        return report
    finally:
        if results is not None:  # workers stopped (Ray shut down) before the temporaries go
            getattr(results, "close", lambda: None)()
        if bar is not None:
            bar.close()
        log_file.close()
        remove_stale_temporaries(out_dir)


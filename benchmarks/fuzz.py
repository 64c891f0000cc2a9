"""Fuzz every motion reader with mutants of the real clips: only ImeshError may come out.

Formats and seeds (real clips of IMESH_DATA/mocap, cut to a few hundred frames so one load takes
a few milliseconds; the cut keeps the file consistent):

- ``bvh``: cmu_141_16_wave_hello.bvh and cmu_02_01_walk.bvh, ``imesh.io.load_motion``;
- ``asf/amc``: cmu_07_05.amc with cmu_07.asf (either file mutated);
- ``c3d``: ezc3d_Qualisys_gait.c3d and ezc3d_BTS_gait.c3d (whole files);
- ``trc``: roboptim_human_grab_box.trc;
- ``npz``: a robot motion written by ``imesh.io.robot_motion.save_robot_motion`` whose base and
  joint trajectories are the CMU walk's root position and rotation channels,
  ``imesh.io.robot_motion.load_robot_motion``;
- ``csv``: the same robot motion as .csv.

Mutations (:func:`mutate`): byte flips (anywhere or in the header), truncation, numbers replaced
by huge / NaN / inf / negative / overflowing values, header edits (counts, rates, offsets),
deleted / duplicated / swapped lines, inserted junk, and for the binary formats 16/32-bit words
replaced by extreme integers and floats.

Each format runs in a worker process (``nice``-friendly, one at a time by default) under an
address-space limit; a mutant that takes longer than ``--timeout`` seconds is killed and counted
as a hang, a worker that dies is counted as a crash. The table lists per format: mutants, how
many loaded, ImeshError count, other exceptions (must be 0), hangs/crashes, the slowest mutant
and the workers' peak resident memory.

    nice -n 10 python benchmarks/fuzz.py --mutants 10000
"""

from __future__ import annotations

import argparse
import io
import multiprocessing as mp
import re
import resource
import sys
import tempfile
import time
import traceback
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _data import data_root  # noqa: E402

FORMATS = ("bvh", "asf/amc", "c3d", "trc", "npz", "csv")
SPECIAL_NUMBERS = (b"1e17", b"-1e17", b"1e308", b"-1e308", b"1e309", b"nan", b"NaN", b"inf",
                   b"-inf", b"0", b"-1", b"1e-320", b"99999999999999999999999", b"4294967296",
                   b"65535", b"3.4e38", b"-0", b"1e5", b"0.0000001", b"", b"x", b"1.2.3")
SPECIAL_WORDS16 = (0, 1, 0x7FFF, 0x8000, 0xFFFF, 0x0100, 0x00FF, 2, 0x4000)
SPECIAL_FLOATS = (np.nan, np.inf, -np.inf, 1e38, -1e38, 0.0, -1.0, 1e-40, 3e9, 1.0)
_NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


# ----------------------------------------------------------------------------------------------
# seeds: real clips, cut to a consistent shorter file


def _cut_bvh(data: bytes, frames: int) -> bytes:
    text = data.decode("latin-1")
    head, motion = re.split(r"(?m)^MOTION\s*$", text, maxsplit=1)
    lines = motion.strip("\r\n").splitlines()
    rows = [ln for ln in lines[2:] if ln.strip()][:frames]
    return (head + "MOTION\n" + f"Frames: {len(rows)}\n" + lines[1] + "\n" +
            "\n".join(rows) + "\n").encode("latin-1")


def _cut_amc(data: bytes, frames: int) -> bytes:
    text = data.decode("latin-1")
    marks = [m.start() for m in re.finditer(r"(?m)^\d+\s*$", text)]
    end = marks[frames] if len(marks) > frames else len(text)
    return text[:end].encode("latin-1")


def _cut_trc(data: bytes, frames: int) -> bytes:
    lines = data.decode("latin-1").splitlines(keepends=True)
    keys = lines[1].rstrip("\r\n").split("\t")
    values = lines[2].rstrip("\r\n").split("\t")
    values[keys.index("NumFrames")] = str(frames)
    rows = [ln for ln in lines[5:] if ln.strip()][:frames]
    return ("".join(lines[:2]) + "\t".join(values) + "\n" + "".join(lines[3:5]) +
            "".join(rows)).encode("latin-1")


def _robot_motion_file(frames: int, suffix: str) -> bytes:
    """A robot motion .npz or .csv (the imesh writer) from the CMU walk's channels."""
    from imesh.core.robot_motion import RobotMotion
    from imesh.io.robot_motion import save_robot_motion

    text = (data_root() / "mocap" / "cmu_02_01_walk.bvh").read_text()
    rows = text.split("Frame Time:")[1].splitlines()[1:frames + 1]
    channels = np.array([r.split() for r in rows], dtype=float)
    base = channels[:, :3] * 0.0254 / 0.45 * np.array([1.0, 1.0, 1.0])
    yaw = np.deg2rad(channels[:, 4]) / 2
    quat = np.stack([np.zeros_like(yaw), np.zeros_like(yaw), np.sin(yaw), np.cos(yaw)], axis=1)
    joints = np.deg2rad(channels[:, 6:40])
    names = [f"joint_{k:02d}" for k in range(joints.shape[1])]
    motion = RobotMotion.from_parts(base, quat, joints, fps=120.0, robot="cmu_walk",
                                    joint_names=names)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"seed{suffix}"
        save_robot_motion(path, motion)
        return path.read_bytes()


def seeds(fmt: str, frames: int = 200) -> list[dict[str, bytes]]:
    """Seed files of a format: each a dict {file name: bytes} (ASF/AMC: both files)."""
    mocap = data_root() / "mocap"
    if fmt == "bvh":
        return [{"clip.bvh": _cut_bvh((mocap / name).read_bytes(), frames)}
                for name in ("cmu_141_16_wave_hello.bvh", "cmu_02_01_walk.bvh")]
    if fmt == "asf/amc":
        return [{"clip.amc": _cut_amc((mocap / "cmu_07_05.amc").read_bytes(), frames),
                 "clip.asf": (mocap / "cmu_07.asf").read_bytes()}]
    if fmt == "c3d":
        return [{"clip.c3d": (mocap / name).read_bytes()}
                for name in ("ezc3d_Qualisys_gait.c3d", "ezc3d_BTS_gait.c3d")]
    if fmt == "trc":
        return [{"clip.trc": _cut_trc((mocap / "roboptim_human_grab_box.trc").read_bytes(),
                                      frames)}]
    if fmt in ("npz", "csv"):
        return [{f"motion.{fmt}": _robot_motion_file(frames, f".{fmt}")}]
    raise ValueError(f"unknown format {fmt!r}; valid: {', '.join(FORMATS)}")


# ----------------------------------------------------------------------------------------------
# mutations


def _numbers(data: bytes) -> list[tuple[int, int]]:
    return [m.span() for m in _NUMBER.finditer(data)]


@dataclass
class _Seed:
    files: dict[str, bytes]
    spans: dict[str, list[tuple[int, int]]] = field(default_factory=dict)

    def number_spans(self, name: str) -> list[tuple[int, int]]:
        if name not in self.spans:
            self.spans[name] = _numbers(self.files[name])
        return self.spans[name]


def _header_end(name: str, data: bytes) -> int:
    """Bytes at the start of a file that hold its header (where edits matter most)."""
    if name.endswith(".bvh"):
        k = data.find(b"Frame Time")
        return max(k + 40, 64) if k >= 0 else 2048
    if name.endswith(".trc"):
        k = 0
        for _ in range(5):
            k = data.find(b"\n", k) + 1
        return max(k, 64)
    if name.endswith(".amc"):
        return 600
    if name.endswith(".c3d"):
        return min(len(data), 512 * (data[0] + 8)) if data else 0  # header + parameters
    return min(len(data), 400)


def mutate(seed: _Seed, rng: np.random.Generator) -> tuple[dict[str, bytes], str]:
    """One mutant of ``seed`` and a description of what was done."""
    files = dict(seed.files)
    name = list(files)[0] if len(files) == 1 or rng.random() < 0.8 else list(files)[1]
    data = bytearray(files[name])
    binary = name.endswith((".c3d", ".npz"))
    kinds = ["flip", "flip_header", "truncate", "insert", "words", "floats"] if binary else [
        "flip", "flip_header", "truncate", "insert", "number", "number_header", "numbers",
        "line_delete", "line_dup", "line_swap"]
    kind = kinds[int(rng.integers(len(kinds)))]
    head = _header_end(name, bytes(data))
    n = len(data)
    if n == 0:
        return files, "empty seed"
    if kind in ("flip", "flip_header"):
        lim = head if kind == "flip_header" else n
        ks = rng.integers(0, max(lim, 1), int(rng.integers(1, 9)))
        for k in ks:
            data[int(k) % n] = int(rng.integers(256))
        what = f"{kind} at {sorted(int(k) for k in ks)[:4]}"
    elif kind == "truncate":
        k = int(rng.integers(0, n)) if rng.random() < 0.7 else int(rng.integers(0, head + 1))
        data = data[:k]
        what = f"truncate at {k}"
    elif kind == "insert":
        k = int(rng.integers(0, n))
        junk = bytes(rng.integers(0, 256, int(rng.integers(1, 64))).astype(np.uint8))
        if not binary and rng.random() < 0.5:  # a structural token instead of noise
            tokens = (b"\n", b"\t", b" ", b"{", b"}", b"JOINT x {", b":", b"\r\n", b"0 0 0",
                      b"\n1\n", b"End Site", b"\t\t\t")
            junk = tokens[int(rng.integers(len(tokens)))]
        data[k:k] = junk
        what = f"insert {len(junk)} bytes at {k}"
    elif kind in ("number", "number_header", "numbers"):
        spans = seed.number_spans(name)
        if kind == "number_header":
            spans = [s for s in spans if s[0] < head] or spans
        count = int(rng.integers(1, 6)) if kind == "numbers" else 1
        picks = sorted({int(rng.integers(len(spans))) for _ in range(count)}, reverse=True)
        for i in picks:
            a, b = spans[i]
            value = SPECIAL_NUMBERS[int(rng.integers(len(SPECIAL_NUMBERS)))]
            data[a:b] = value
        what = f"{kind} x{len(picks)}"
    elif kind.startswith("line"):
        lines = bytes(data).split(b"\n")
        i = int(rng.integers(len(lines)))
        if rng.random() < 0.5:  # near the header
            i = int(rng.integers(min(len(lines), 40)))
        if kind == "line_delete":
            del lines[i]
        elif kind == "line_dup":
            lines.insert(i, lines[i])
        else:
            j = int(rng.integers(len(lines)))
            lines[i], lines[j] = lines[j], lines[i]
        data = bytearray(b"\n".join(lines))
        what = f"{kind} {i}"
    elif kind == "words":
        k = int(rng.integers(0, max(head - 1, 1))) & ~1 if rng.random() < 0.7 else \
            int(rng.integers(0, n - 1))
        w = SPECIAL_WORDS16[int(rng.integers(len(SPECIAL_WORDS16)))]
        data[k:k + 2] = int(w).to_bytes(2, "little")
        what = f"word {w:#x} at {k}"
    else:  # floats
        k = int(rng.integers(0, max(n - 4, 1)))
        v = SPECIAL_FLOATS[int(rng.integers(len(SPECIAL_FLOATS)))]
        data[k:k + 4] = np.float32(v).tobytes()
        what = f"float {v} at {k}"
    files[name] = bytes(data)
    return files, f"{name}: {what}"


# ----------------------------------------------------------------------------------------------
# running


def load(fmt: str, folder: Path):
    """Load the mutant written in ``folder`` with the public reader of ``fmt``."""
    if fmt in ("npz", "csv"):
        from imesh.io.robot_motion import load_robot_motion

        return load_robot_motion(folder / f"motion.{fmt}")
    from imesh.io import load_motion

    if fmt == "asf/amc":
        return load_motion(folder / "clip.amc", asf=folder / "clip.asf")
    ext = {"bvh": ".bvh", "c3d": ".c3d", "trc": ".trc"}[fmt]
    return load_motion(folder / f"clip{ext}")


@dataclass
class Outcome:
    index: int
    result: str  # "loaded", "imesh", "other"
    seconds: float
    detail: str = ""


def run_mutant(fmt: str, seed_list: list[_Seed], seed: int, index: int, folder: Path
               ) -> Outcome:
    """Build mutant ``index`` (deterministic in seed and index), load it, classify."""
    from imesh.errors import ImeshError

    rng = np.random.default_rng([seed, index])
    base = seed_list[index % len(seed_list)]
    files, what = mutate(base, rng)
    for fname, data in files.items():
        (folder / fname).write_bytes(data)
    t0 = time.perf_counter()
    try:
        load(fmt, folder)
        result, detail = "loaded", what
    except ImeshError as exc:
        result, detail = "imesh", f"{what} -> {type(exc).__name__}: {str(exc)[:160]}"
    except Exception as exc:  # noqa: BLE001 - the point of the harness
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        result = "other"
        detail = (f"{what} -> {type(exc).__name__}: {str(exc)[:160]} at "
                  f"{Path(tb.filename).name}:{tb.lineno}")
    return Outcome(index, result, time.perf_counter() - t0, detail)


def _worker(conn, fmt: str, seed: int, start: int, stop: int, frames: int,
            memory_limit: int) -> None:
    import logging
    import warnings

    logging.disable(logging.CRITICAL)
    warnings.simplefilter("ignore")
    if memory_limit:
        resource.setrlimit(resource.RLIMIT_AS, (memory_limit, memory_limit))
    seed_list = [_Seed(s) for s in seeds(fmt, frames)]
    with tempfile.TemporaryDirectory(prefix="imesh-fuzz-") as tmp:
        folder = Path(tmp)
        conn.send(("rss", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss))
        for index in range(start, stop):
            conn.send(("start", index))
            out = run_mutant(fmt, seed_list, seed, index, folder)
            conn.send(("done", out, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss))
    conn.send(("end", None))


@dataclass
class Row:
    fmt: str
    mutants: int = 0
    loaded: int = 0
    imesh: int = 0
    other: int = 0
    hangs: int = 0
    crashes: int = 0
    max_seconds: float = 0.0
    slowest: str = ""
    peak_rss_mb: float = 0.0
    base_rss_mb: float = 0.0
    examples: list[str] = field(default_factory=list)
    errors: Counter = field(default_factory=Counter)


def fuzz_format(fmt: str, mutants: int, seed: int = 0, frames: int = 200,
                timeout: float = 30.0, memory_limit: int = 6 << 30) -> Row:
    """Run ``mutants`` mutants of ``fmt`` in worker processes; kill and restart on hangs."""
    ctx = mp.get_context("forkserver")
    row = Row(fmt)
    index = 0
    while index < mutants:
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_worker, args=(child, fmt, seed, index, mutants, frames,
                                                 memory_limit), daemon=True)
        proc.start()
        child.close()
        current = index
        while True:
            if not parent.poll(timeout):
                proc.kill()
                proc.join()
                row.hangs += 1
                row.mutants += 1
                row.examples.append(f"mutant {current}: hang (> {timeout:g} s)")
                index = current + 1
                break
            try:
                msg = parent.recv()
            except EOFError:
                proc.join()
                row.crashes += 1
                row.mutants += 1
                row.examples.append(f"mutant {current}: worker died (exit {proc.exitcode})")
                index = current + 1
                break
            if msg[0] == "rss":
                row.base_rss_mb = max(row.base_rss_mb, msg[1] / 1024)
            elif msg[0] == "start":
                current = msg[1]
            elif msg[0] == "done":
                out, rss = msg[1], msg[2]
                row.mutants += 1
                row.peak_rss_mb = max(row.peak_rss_mb, rss / 1024)
                if out.seconds > row.max_seconds:
                    row.max_seconds, row.slowest = out.seconds, out.detail
                if out.result == "loaded":
                    row.loaded += 1
                elif out.result == "imesh":
                    row.imesh += 1
                    row.errors[out.detail.split(" -> ")[1].split(":")[0]] += 1
                else:
                    row.other += 1
                    row.examples.append(f"mutant {out.index}: {out.detail}")
                index = out.index + 1
            elif msg[0] == "end":
                proc.join()
                index = mutants
                break
        parent.close()
    return row


def format_table(rows: list[Row]) -> str:
    head = (f"{'format':<8} {'mutants':>8} {'loaded':>7} {'ImeshError':>10} {'other exc':>9} "
            f"{'hang/crash':>10} {'max s':>7} {'peak MB':>8}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(f"{r.fmt:<8} {r.mutants:>8} {r.loaded:>7} {r.imesh:>10} {r.other:>9} "
                     f"{r.hangs + r.crashes:>10} {r.max_seconds:>7.3f} {r.peak_rss_mb:>8.0f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mutants", type=int, default=10000, help="mutants per format")
    parser.add_argument("--formats", nargs="+", default=list(FORMATS), choices=FORMATS)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--frames", type=int, default=200, help="frames of the cut seeds")
    parser.add_argument("--timeout", type=float, default=30.0,
                        help="seconds after which a mutant counts as a hang")
    parser.add_argument("--jobs", type=int, default=1, help="formats fuzzed at once")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    if args.jobs > 1:
        from concurrent.futures import ThreadPoolExecutor  # each thread drives one worker

        with ThreadPoolExecutor(args.jobs) as pool:
            rows = list(pool.map(lambda f: fuzz_format(f, args.mutants, args.seed, args.frames,
                                                       args.timeout), args.formats))
    else:
        rows = [fuzz_format(f, args.mutants, args.seed, args.frames, args.timeout)
                for f in args.formats]
    buf = io.StringIO()
    print(format_table(rows), file=buf)
    for r in rows:
        print(f"\n{r.fmt}: slowest {r.max_seconds:.3f} s ({r.slowest}); worker baseline "
              f"{r.base_rss_mb:.0f} MB; errors {dict(r.errors.most_common(8))}", file=buf)
        for e in r.examples[:20]:
            print(f"  {e}", file=buf)
    print(f"\n{time.perf_counter() - t0:.0f} s in all", file=buf)
    print(buf.getvalue(), end="")
    bad = sum(r.other + r.hangs + r.crashes for r in rows) + sum(
        r.max_seconds > 5 for r in rows) + sum(r.peak_rss_mb > 1024 for r in rows)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

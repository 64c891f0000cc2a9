"""Do two checkouts of imesh write the same files? The check of a refactor (issue 22).

    python benchmarks/identical.py --base /path/to/other/checkout [--out DIR] [--only NAME ...]

The same command lines (inspect, adapt, retarget on every robot and mode, reduce, evaluate with
and without the DART check, export, robots init) run twice, each process with ``PYTHONPATH`` set
to one checkout, into ``DIR/this`` and ``DIR/base``. Then every output is compared: .npz files
array by array and exactly, .json files without their timing keys, anything else byte by byte.
Prints one row per output and exits 1 when any differs. An ``git worktree add /tmp/base REV``
makes the base checkout of a revision.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _data import data_root

ROOT = Path(__file__).resolve().parents[1]
DATA = data_root()
MOCAP = DATA / "mocap"
HRP4C_URDF = DATA.parent / "robots" / "hrp4c" / "HRP4Cmain_reduced.urdf"
WALK, WAVE = MOCAP / "cmu_02_01_walk.bvh", MOCAP / "cmu_141_16_wave_hello.bvh"
AMC, ASF, TRC = MOCAP / "cmu_07_05.amc", MOCAP / "cmu_07.asf", MOCAP / "roboptim_human_grab_box.trc"
HRP4C = ["--robot", "hrp4c", "--urdf", str(HRP4C_URDF)]

#: name -> (imesh arguments, the outputs it writes, stdout file or None). Each row may use the
#: outputs of the rows above it.
COMMANDS: dict[str, tuple[list[str], list[str], str | None]] = {
    "inspect_bvh": (["inspect", str(WALK), "--json"], [], "inspect_walk.json"),
    "inspect_amc": (["inspect", str(AMC), "--asf", str(ASF), "--json"], [], "inspect_amc.json"),
    "adapt": (["adapt", str(WALK), "--scale", "arms=1.3", "-o", "adapt.npz", "--json",
               "adapt.json"], ["adapt.npz", "adapt.json"], None),
    "walk_jvrc1": (["retarget", str(WALK), "--robot", "jvrc1", "--force", "-o", "walk_jvrc1.npz",
                    "--markers", "walk_jvrc1_markers.npz"],
                   ["walk_jvrc1.npz", "walk_jvrc1_markers.npz"], None),
    "wave_g1": (["retarget", str(WAVE), "--robot", "g1", "--force", "-o", "wave_g1.npz",
                 "--markers", "wave_g1_markers.npz"], ["wave_g1.npz", "wave_g1_markers.npz"], None),
    "walk_hrp4c_nishiwaki": (["retarget", str(WALK), *HRP4C, "--balance", "nishiwaki", "--force",
                              "-o", "walk_hrp4c_nw.npz"], ["walk_hrp4c_nw.npz"], None),
    "amc_g1": (["retarget", str(AMC), "--asf", str(ASF), "--robot", "g1", "--balance", "none",
                "--force", "-o", "amc_g1.npz"], ["amc_g1.npz"], None),
    "trc_hrp4c": (["retarget", str(TRC), *HRP4C, "--force", "-o", "trc_hrp4c.npz"],
                  ["trc_hrp4c.npz"], None),
    "arms_hrp4c": (["retarget", str(WAVE), *HRP4C, "--mode", "arms", "--force", "-o",
                    "arms_hrp4c.npz"], ["arms_hrp4c.npz"], None),
    "reduce": (["reduce", str(WALK), "--robot", "planar_biped", "-o", "reduce.npz", "--json",
                "reduce.json"], ["reduce.npz", "reduce.json"], None),
    "evaluate_physics": (["evaluate", "walk_jvrc1.npz", "--robot", "jvrc1", "--adapted",
                          "walk_jvrc1_markers.npz", "--physics", "--json", "eval_walk.json"],
                         ["eval_walk.json"], None),
    "evaluate": (["evaluate", "wave_g1.npz", "--robot", "g1", "--adapted",
                  "wave_g1_markers.npz", "--json", "eval_wave.json"], ["eval_wave.json"], None),
    "export_csv": (["export", "walk_jvrc1.npz", "--format", "csv", "-o", "walk_jvrc1.csv"],
                   ["walk_jvrc1.csv"], None),
    "robots_init": (["robots", "init", str(HRP4C_URDF), "-o", "gen_hrp4c"],
                    ["gen_hrp4c/robot.toml", "gen_hrp4c/markers.toml", "gen_hrp4c/report.txt"],
                    None),
}

#: Keys of a JSON report that hold times (they differ between any two runs).
TIMING = ("seconds", "time", "elapsed")
#: Keys that hold the checkout's absolute paths.
PATHS = ("source",)


def run(checkout: Path, out: Path, names: list[str]) -> dict[str, float]:
    """Run the commands with ``PYTHONPATH=checkout`` in ``out``; seconds per command."""
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "PYTHONPATH": str(checkout), "IMESH_DATA": str(DATA)}
    seconds = {}
    for name in names:
        args, _, stdout = COMMANDS[name]
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-m", "imesh", "-q", *args], cwd=out, env=env,
                              capture_output=True, text=True)
        seconds[name] = time.perf_counter() - t0
        if stdout is not None:
            (out / stdout).write_text(proc.stdout)
        if proc.returncode not in (0, 3):
            print(f"{checkout.name}: {name} exited {proc.returncode}: "
                  f"{proc.stderr.strip()[-300:]}", file=sys.stderr)
    return seconds


def _strip(value, root: str):
    """A JSON value without timing keys, with the checkout's path replaced."""
    if isinstance(value, dict):
        return {k: _strip(v, root) for k, v in value.items()
                if not any(t in k for t in TIMING) and not k.endswith("_s")}
    if isinstance(value, list):
        return [_strip(v, root) for v in value]
    if isinstance(value, str):
        return value.replace(root, "<checkout>")
    return value


def differences(a: Path, b: Path, root_a: str, root_b: str) -> list[str]:
    """What differs between two outputs (empty: the same)."""
    if not a.exists() or not b.exists():
        return [f"missing in {'this' if not a.exists() else 'base'}"]
    if a.suffix == ".npz":
        x, y = np.load(a), np.load(b)
        out = [f"key {k} only in one" for k in sorted(set(x.files) ^ set(y.files))]
        for k in sorted(set(x.files) & set(y.files)):
            u, v = x[k], y[k]
            same = u.shape == v.shape and u.dtype == v.dtype and np.array_equal(
                u, v, equal_nan=u.dtype.kind == "f")
            if not same:
                out.append(f"{k} differs")
        return out
    if a.suffix == ".json":
        x, y = json.loads(a.read_text()), json.loads(b.read_text())
        sx, sy = _strip(x, root_a), _strip(y, root_b)
        if sx == sy:
            return []
        if isinstance(sx, dict) and isinstance(sy, dict):
            return [f"{k} differs" for k in sorted(set(sx) | set(sy)) if sx.get(k) != sy.get(k)]
        return ["differs"]
    if a.read_bytes() == b.read_bytes():
        return []
    la, lb = a.read_text().splitlines(), b.read_text().splitlines()
    return [f"line {i + 1}: {u!r} / {v!r}" for i, (u, v) in enumerate(zip(la, lb, strict=False))
            if u != v][:3] or ["length differs"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="the other checkout (a folder with imesh/)")
    ap.add_argument("--out", default="out/identical", help="folder of both runs' outputs")
    ap.add_argument("--only", nargs="+", choices=list(COMMANDS), help="a subset of the commands")
    args = ap.parse_args()
    base, out = Path(args.base).resolve(), Path(args.out).resolve()
    names = args.only or list(COMMANDS)
    t_this = run(ROOT, out / "this", names)
    t_base = run(base, out / "base", names)
    print(f"{'command':22s} {'output':28s} {'this s':>7s} {'base s':>7s}  result")
    print("-" * 90)
    bad = 0
    for name in names:
        _, outputs, stdout = COMMANDS[name]
        for k, file in enumerate(outputs + ([stdout] if stdout else [])):
            diff = differences(out / "this" / file, out / "base" / file, str(ROOT), str(base))
            bad += bool(diff)
            times = (f"{t_this[name]:7.1f} {t_base[name]:7.1f}" if k == 0 else " " * 15)
            print(f"{name if k == 0 else '':22s} {file:28s} {times}  "
                  f"{'identical' if not diff else '; '.join(diff)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

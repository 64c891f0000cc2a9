"""``imesh batch`` throughput: the same clips with 1 and with N workers on a local Ray runtime
(or ``--address`` of a cluster); prints wall times, the speed-up, and whether both runs wrote
the same outputs (byte-identical motions).

    IMESH_DATA=/path/to/shared/data python benchmarks/batch.py --workers 1 2 [--robot jvrc1]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: A short clip of the shared data (2.5 s) beside the shipped demo walk (2.9 s); both pass
#: verification on jvrc1 (the CMU 07_05 AMC walk fails its ground-penetration gate there).
CLIPS = ("cmu_141_16_wave_hello.bvh",)


def main() -> int:
    import imesh
    from imesh.pipeline.batch import BatchSettings, run_batch

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--robot", default="jvrc1")
    parser.add_argument("--address", help="a Ray cluster (default: a local runtime)")
    parser.add_argument("--copies", type=int, default=2,
                        help="run each clip this many times (copies under other names)")
    args = parser.parse_args()
    data = Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data")) / "mocap"
    work = Path(tempfile.mkdtemp(prefix="imesh-batch-bench-"))
    clips = work / "clips"
    clips.mkdir()
    sources = [imesh.demo_clip(), *(data / c for c in CLIPS)]
    for k in range(args.copies):
        for src in sources:
            shutil.copy(src, clips / f"{src.stem}_{k}{src.suffix}")
    times = {}
    digests = {}
    for n in args.workers:
        out = work / f"out_{n}"
        report = run_batch(str(clips), out, BatchSettings(robot=args.robot), workers=n,
                           address=args.address, progress=True)
        times[n] = report.seconds
        digests[n] = {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
                      for p in sorted(out.glob("*.npz"))}
        print(report.table())
        print(f"workers={n}: {report.seconds:.1f} s for {len(report.records)} clips "
              f"({report.count('ok')} ok, {report.count('error')} failed)")
    base = args.workers[0]
    for n in args.workers[1:]:
        same = digests[n] == digests[base]
        print(f"speed-up {n} vs {base} workers: {times[base] / times[n]:.2f}x "
              f"(outputs identical: {same})")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

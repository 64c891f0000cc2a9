"""``imesh batch``: the command line of :mod:`imesh.pipeline.batch` (docs/batch.md)."""

from __future__ import annotations

import argparse
import signal
from pathlib import Path

from ..pipeline.batch import EXIT_OK, EXIT_PARTIAL, LOG_NAME, BatchSettings, interrupt, run_batch
from .args import add_robot_arguments


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``imesh batch`` to an argparse subparsers object."""
    p = subparsers.add_parser(
        "batch", help="retarget a folder or glob of clips on Ray (resumable); docs/batch.md",
        description="Retarget every clip of a folder (or a glob pattern) to a robot, on a local "
        "Ray runtime or a cluster. Outputs whose input and settings are unchanged are skipped. "
        "Exit status 0 when every clip is done, 4 when some failed (see OUT_DIR/batch.jsonl).")
    p.add_argument("inputs", metavar="IN_DIR_OR_GLOB", help="folder of clips or glob pattern")
    add_robot_arguments(p)
    p.add_argument("-o", "--output", required=True, help="output folder")
    p.add_argument("--workers", type=int, default=2, help="clips at a time (default 2)")
    p.add_argument("--address", help="join this Ray cluster (e.g. 'auto' after `ray start "
                   "--head`); default: a local Ray runtime")
    p.add_argument("--backend", choices=("ray", "processes"), default="ray",
                   help="ray (default) or local processes (no Ray needed)")
    p.add_argument("--format", choices=("npz", "csv", "mujoco"), default="npz",
                   help="output format (docs/exports.md; default npz)")
    p.add_argument("--mjcf", help="MuJoCo model for --format mujoco")
    p.add_argument("--fps", type=float, help="output frame rate (default 30)")
    p.add_argument("--balance", choices=("wholebody", "nishiwaki", "none"), default="wholebody")
    p.add_argument("--force", action="store_true",
                   help="write motions that fail verification (otherwise such a clip fails)")
    p.add_argument("--retry-failed", action="store_true",
                   help="run clips again that failed before with the same input and settings "
                        "(default: reported as failed again, not recomputed)")
    return p


def run(args) -> int:
    """``imesh batch`` with parsed arguments; returns the exit status."""
    from ..io.atomic import _TRANSACTION

    tx = _TRANSACTION.get()
    if tx is not None:  # finished clips stay when the batch is interrupted
        tx.created_dirs.clear()
    settings = BatchSettings(robot=args.robot, format=args.format, fps=args.fps,
                             balance=args.balance,
                             mjcf=str(Path(args.mjcf).resolve()) if args.mjcf else None,
                             urdf=str(Path(args.urdf).resolve()) if args.urdf else None,
                             force=args.force)

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        report = run_batch(args.inputs, args.output, settings, workers=args.workers,
                           address=args.address, backend=args.backend,
                           progress=not args.quiet, retry_failed=args.retry_failed)
    finally:
        signal.signal(signal.SIGTERM, previous)
    print(report.table())
    print(f"log: {Path(args.output) / LOG_NAME}")
    return EXIT_OK if report.complete else EXIT_PARTIAL

"""``imesh batch IN_DIR_OR_GLOB -o OUT_DIR``: the command line of :mod:`imesh.pipeline.batch`
(docs/batch.md)."""

from __future__ import annotations

from pathlib import Path

from ..io.atomic import _TRANSACTION
from ..pipeline.batch import EXIT_OK, EXIT_PARTIAL, LOG_NAME, BatchSettings, run_batch


def run(args) -> int:
    """``imesh batch`` with parsed arguments; returns the exit status."""
    tx = _TRANSACTION.get()
    if tx is not None:  # finished clips stay when the batch is interrupted
        tx.created_dirs.clear()
    settings = BatchSettings(robot=args.robot, format=args.format, fps=args.fps,
                             balance=args.balance,
                             mjcf=str(Path(args.mjcf).resolve()) if args.mjcf else None,
                             urdf=str(Path(args.urdf).resolve()) if args.urdf else None,
                             force=args.force)

    # SIGTERM is handled like Ctrl-C from the start of the command (imesh.cli.app.main)
    report = run_batch(args.inputs, args.output, settings, workers=args.workers,
                       address=args.address, backend=args.backend,
                       progress=not args.quiet, quiet=args.quiet,
                       retry_failed=args.retry_failed)
    print(report.table())
    print(f"log: {Path(args.output) / LOG_NAME}")
    return EXIT_OK if report.complete else EXIT_PARTIAL

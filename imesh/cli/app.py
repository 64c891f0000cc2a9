"""The ``imesh`` command line: the parser, the dispatch to the command modules and the handling
of errors.

``main(argv)`` returns the exit status, so it can be tested in-process. Any ImeshError is printed
as one line (``imesh: error: ...``) with exit status 2; no traceback. Every output path is checked
before the command starts, and the outputs of one command are kept together or not at all
(:mod:`imesh.cli.outputs`). Exit statuses: docs/errors.md.

Each command is a module of :mod:`imesh.cli` with ``run(args) -> int`` (:data:`COMMANDS`) that
imports its library at its top; this module imports it only when the command runs
(:func:`_cli_module`), so that ``imesh --help`` builds every parser (:mod:`imesh.cli.parsers`)
without scipy, pinocchio or the solvers.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
from collections.abc import Sequence
from importlib import import_module
from types import ModuleType
from typing import NoReturn

from .. import __version__
from ..errors import ImeshError
from . import parsers

#: Command -> the module of :mod:`imesh.cli` that runs it, in the order of ``imesh --help``:
#: (function adding its parser, module with ``run(args) -> int``).
COMMANDS = {
    "inspect": (parsers.add_inspect, "inspect"), "rig": (parsers.add_rig, "rig"),
    "adapt": (parsers.add_adapt, "adapt"), "retarget": (parsers.add_retarget, "retarget"),
    "robots": (parsers.add_robots, "robots"), "export": (parsers.add_export, "export"),
    "batch": (parsers.add_batch, "batch"), "evaluate": (parsers.add_evaluate, "evaluate"),
    "reduce": (parsers.add_reduce, "reduction"), "view": (parsers.add_view, "view"),
    "demo": (parsers.add_demo, "demo"),
}

#: Exit statuses: 0 success, 2 bad input or usage, 3 reserved for an output that was written but
#: failed its verification; 130 interrupted; 141 (128 + SIGPIPE) when the reader of the standard
#: output went away (``imesh ... | head``).
EXIT_OK, EXIT_USAGE, EXIT_VERIFY, EXIT_INTERRUPTED, EXIT_PIPE = 0, 2, 3, 130, 141


def build_parser() -> argparse.ArgumentParser:
    """The ``imesh`` parser: the global options and every command."""
    parser = argparse.ArgumentParser(
        prog="imesh",
        description="Adapt human motion capture to humanoid robots with the interaction mesh.")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="log decisions (-v) and solver steps (-vv)")
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    parser.add_argument("--version", action="version", version=f"imesh {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for add_parser, _ in COMMANDS.values():
        add_parser(sub)
    return parser


def _cli_module(name: str) -> ModuleType:
    """The module ``imesh.cli.<name>``, imported now: the one lazy import of the command line
    (a command's module imports scipy, pinocchio or the solvers; ``imesh --help`` must not)."""
    return import_module(f"{__package__}.{name}")


def _setup_logging(verbose: int) -> None:
    """Warnings by default, decisions with -v, solver steps with -vv."""
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    logging.getLogger("imesh").setLevel(level)


def _stdout_gone() -> int:
    """The reader of stdout closed it: no traceback, no message (as ``cat`` and ``git``)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # Python's final flush must not fail again
    except (OSError, ValueError):  # stdout is not a real file (in-process tests)
        pass
    return EXIT_PIPE


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 2 on any ImeshError, see
    :data:`EXIT_OK` ...)."""
    args = build_parser().parse_args(argv)
    previous = _sigterm_like_ctrl_c() if args.command == "batch" else None
    _setup_logging(args.verbose)
    try:
        with _cli_module("outputs").command_outputs(args):
            return _cli_module(COMMANDS[args.command][1]).run(args)
    except ImeshError as exc:
        one_line = " ".join(str(exc).split())  # names read from a file may hold newlines
        print(f"imesh: error: {one_line}", file=sys.stderr)
        return getattr(exc, "exit_status", EXIT_USAGE)  # VerificationError: EXIT_VERIFY
    except BrokenPipeError:
        return _stdout_gone()
    except KeyboardInterrupt:
        print("imesh: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


_TERMINATED = {"set": False}


def _on_sigterm(signum, frame) -> None:
    """SIGTERM as Ctrl-C, once: later SIGTERMs while the command cleans up are ignored."""
    if not _TERMINATED["set"]:
        _TERMINATED["set"] = True
        raise KeyboardInterrupt


def _sigterm_like_ctrl_c():
    """``imesh batch``: SIGTERM raises KeyboardInterrupt (exit 130, one line, no partial file)
    from here on, before the command's imports and Ray's start-up; returns the previous
    handler (None off the main thread, where signals cannot be handled)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return None
    _TERMINATED["set"] = False
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    return signal.SIG_DFL if previous is None else previous


def exit_with(status: int) -> NoReturn:
    """Exit the process with ``status``.

    After an interrupt (:data:`EXIT_INTERRUPTED`) the process ends with ``os._exit`` once the
    logs and the standard streams are flushed (the command's ``finally`` blocks have removed
    its temporary files and shut Ray down): a SIGTERM 0.5 s into ``python -m imesh batch``,
    while the command imports its modules, made CPython 3.11 end the process by SIGINT (-2)
    after our "interrupted" and a ``sys.exit(130)``, in 3 of 8 tries.
    """
    if status == EXIT_INTERRUPTED:
        logging.shutdown()
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # closed, or a reader that went away
                pass
        os._exit(status)
    sys.exit(status)


def entry_point() -> None:
    """The console script ``imesh``: :func:`main` on ``sys.argv``, then exit with its status."""
    try:
        status = main()
        sys.stdout.flush()
    except BrokenPipeError:
        status = _stdout_gone()
    exit_with(status)


if __name__ == "__main__":
    entry_point()

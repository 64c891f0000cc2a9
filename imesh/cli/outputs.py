"""The output files of every command, checked before it starts and kept together or not at all
(:mod:`imesh.io.atomic`)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from ..io.atomic import Output, check_outputs, output_transaction

_MOTION = (".npz", ".csv")
_EXPORT = (*_MOTION, ".pkl")  # a GMR pickle (--format gmr)
_JSON = (".json",)
_HTML = (".html", ".htm")
_FOLDER = None
#: The output options of each command, checked before it starts: (attribute of the parsed
#: arguments, option, valid extensions or _FOLDER for an output folder). A new output option
#: must be listed here.
OUTPUTS: dict[str, tuple[tuple[str, str, tuple[str, ...] | None], ...]] = {
    "adapt": (("output", "-o", _MOTION), ("report", "--json", _JSON)),
    "retarget": (("output", "-o", _EXPORT), ("report", "--json", _JSON),
                 ("markers", "--markers", _MOTION), ("plots", "--plots", _FOLDER),
                 ("report_html", "--report", _HTML)),
    "evaluate": (("report", "--json", _JSON), ("plot", "--plot", (".png", ".pdf", ".svg")),
                 ("report_html", "--report", _HTML)),
    "view": (("html", "--html", _HTML), ("video", "--video", (".mp4",))),
    "reduce": (("output", "-o", (".npz",)), ("report", "--json", _JSON),
               ("plots", "--plots", _FOLDER)),
    "demo": (("output", "-o", _FOLDER),),
    "rig": (("output", "-o", (".toml",)),),
    "export": (("output", "-o", _EXPORT),),
    "batch": (("output", "-o", _FOLDER),),
}


def check_command_outputs(args) -> None:
    """Check every output path of the parsed command (extension, folder exists and is
    writable) before any work; raises :class:`~imesh.errors.OutputPathError`."""
    check_outputs(Output(getattr(args, attr), option, exts or (), folder=exts is None)
                  for attr, option, exts in OUTPUTS.get(args.command, ())
                  if getattr(args, attr, None))


@contextlib.contextmanager
def command_outputs(args) -> Iterator[None]:
    """Around a command: its outputs checked first, then kept together or not at all (those
    written are removed again when the command fails, :func:`imesh.io.atomic.output_transaction`).
    """
    with output_transaction():
        check_command_outputs(args)
        yield

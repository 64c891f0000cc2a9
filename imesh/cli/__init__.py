"""The ``imesh`` command line: one module per command (argument parsing and the command), the
parser and the dispatch in :mod:`imesh.cli.app`. The library never imports this package.

``main(argv)`` runs a command and returns its exit status; ``entry_point()`` is the console
script.
"""

from .app import entry_point, main

__all__ = ["entry_point", "main"]

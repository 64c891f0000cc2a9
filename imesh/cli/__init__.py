"""The ``imesh`` command line: the parser, the dispatch and the error handling in
:mod:`imesh.cli.app`, every command's arguments in :mod:`imesh.cli.parsers` (light, for
``imesh --help``), one module per command with ``run(args)`` (``imesh.cli.retarget`` ...),
imported when its command runs. The library never imports this package.

``main(argv)`` runs a command and returns its exit status; ``entry_point()`` is the console
script.
"""

from .app import entry_point, main

__all__ = ["entry_point", "main"]

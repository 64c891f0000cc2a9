"""``python -m imesh ...``: the ``imesh`` command."""

from .cli.app import entry_point

entry_point()

"""``python -m imesh.cli ...``: the ``imesh`` command (as ``python -m imesh``)."""

from .app import entry_point

entry_point()

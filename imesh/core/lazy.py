"""Lazy public names of a package (PEP 562): a package lists which submodule defines each of
its public names, and the submodule is imported on first access. ``import imesh`` and
``imesh --help`` then start without scipy, pinocchio or the solvers (issue 19: --help <= 0.3 s).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import import_module


def lazy_exports(package: str, names: Mapping[str, str], namespace: dict
                 ) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for a package whose public ``names`` map to the (relative)
    submodule defining each; a looked-up name is cached in the package's ``namespace``.

    Example:
        >>> __getattr__, __dir__ = lazy_exports(__name__, {"solve_morph": ".morph.solver"},
        ...                                     globals())  # doctest: +SKIP
    """

    def __getattr__(name: str):
        if name in names:
            value = getattr(import_module(names[name], package), name)
            namespace[name] = value
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(names))

    return __getattr__, __dir__

"""Lazy imports, in one place.

- :func:`lazy_exports`: the public names of a package (PEP 562): a package lists which submodule
  defines each of its public names, and the submodule is imported on first access. ``import
  imesh`` and ``imesh --help`` then start without scipy, pinocchio or the solvers (--help <=
  0.3 s).
- :func:`optional`: a heavy or optional dependency (pinocchio, DART, matplotlib, Playwright,
  MuJoCo, Ray, ...) imported when a feature first needs it; when it is missing the error names
  the feature and the pip command that installs it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from importlib import import_module
from types import ModuleType

from ..errors import MissingDependencyError


def optional(module: str, pip: str, feature: str) -> ModuleType:
    """Import ``module`` for ``feature``, or raise an error that says how to install it.

    Args:
        module: dotted module name (``"dartpy"``, ``"matplotlib.pyplot"``).
        pip: the install command (``"pip install dartpy"``,
            ``"pip install 'imesh-retarget[viz]'"``).
        feature: what needs it, for the message (``"the physics check"``).

    Raises:
        MissingDependencyError: the module (or one it needs) cannot be imported.

    Example:
        >>> np = optional("numpy", "pip install numpy", "arrays")
        >>> np.__name__
        'numpy'
    """
    try:
        return import_module(module)
    except ImportError as exc:
        raise MissingDependencyError(module, pip, feature) from exc


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

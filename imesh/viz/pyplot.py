"""matplotlib for the figures: imported when a figure is first drawn, with the Agg backend (PNG
files, no display), through :func:`imesh.core.lazy.optional`."""

from __future__ import annotations

from types import ModuleType

from ..core.lazy import optional


def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` with the Agg backend.

    Raises:
        MissingDependencyError: matplotlib is not installed (names ``pip install matplotlib``).
    """
    optional("matplotlib", "pip install matplotlib", "a figure").use("Agg")
    return optional("matplotlib.pyplot", "pip install matplotlib", "a figure")

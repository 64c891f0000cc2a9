"""The lazy pinocchio import and name lookups in a pinocchio model.

pinocchio is imported on first use (:func:`_pinocchio`), so importing imesh works without it;
the error names the pip command that installs it.
"""

from __future__ import annotations

from types import ModuleType

from ..core.lazy import optional


def _pinocchio() -> ModuleType:
    """The pinocchio module, imported on first use.

    Raises:
        MissingDependencyError: pinocchio is not installed (naming ``pip install pin``).
    """
    return optional("pinocchio", "pip install pin", "a robot model")


def frame_names(model) -> list[str]:
    """Every frame name of a pinocchio model, each once, in frame order."""
    return list(dict.fromkeys(f.name for f in model.frames))


def find_frame(model, name: str) -> int:
    """Frame index by name, preferring link (BODY) frames; -1 when absent.

    A URDF joint and a link may share a name; the link frame is the one points and geometry
    are attached to, so it wins.
    """
    pin = _pinocchio()
    if model.existFrame(name, pin.FrameType.BODY):
        return int(model.getFrameId(name, pin.FrameType.BODY))
    idx = [i for i, f in enumerate(model.frames) if f.name == name]
    return idx[0] if idx else -1

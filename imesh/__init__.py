"""imesh: adapt human motion capture to humanoid robots with the interaction mesh.

Data flow: ``load_motion`` (BVH, ASF/AMC, C3D, TRC) -> ``to_standard`` (standard marker set)
-> ``build_morph_problem`` / ``solve_morph`` (interaction mesh, spacetime morph) -> robots,
fitting, balance and physics (later stages). ``adapt_motion`` runs the marker-level pipeline.

The top-level API (:mod:`imesh.api`)::

    import imesh

    result = imesh.retarget(imesh.demo_clip(), "jvrc1", output="walk.npz")  # RetargetResult
    report = imesh.evaluate("walk.npz")                # metric name -> {"value", "unit", ...}
    imesh.export_motion("walk.npz", "walk.csv", "csv")  # LAFAN1-layout CSV (imesh.io.formats)
    robot = imesh.load_robot("g1")
    motion = imesh.load_robot_motion("walk.npz")      # RobotMotion
    clip = imesh.load_motion(imesh.demo_clip())       # a human clip (MarkerMotion)
"""

import sys as _sys
import types as _types

from .core.lazy import lazy_exports
from .errors import (
    ConstraintError,
    ImeshError,
    InvalidMotionError,
    MarkerMappingError,
    MissingMarkerError,
    MotionFileError,
    OptionError,
    SolverError,
    UnsupportedFormatError,
)

#: Public names defined in submodules, imported on first use (PEP 562) so that ``import imesh``
#: and ``imesh --help`` do not pay for scipy, pinocchio and the solvers.
_LAZY = {
    "AdaptResult": ".morph.adapt", "adapt_motion": ".morph.adapt",
    "fill_gaps": ".human.gaps",
    "load_motion": ".io",
    **dict.fromkeys(("STANDARD_BONES", "STANDARD_MARKERS"), ".human.markerset"),
    "to_standard": ".human.standard",
    "InteractionMesh": ".mesh.interaction", "build_interaction_mesh": ".mesh.interaction",
    "MorphConfig": ".morph.problem", "MorphProblem": ".morph.problem",
    "MorphWeights": ".morph.problem", "LagrangianOptions": ".morph.problem",
    "build_morph_problem": ".morph.problem",
    "MorphResult": ".morph.solver", "solve_morph": ".morph.solver",
    "MarkerMotion": ".core.motion",
    "RobotMotion": ".core.robot_motion",
    "RetargetConfig": ".pipeline.retarget", "RetargetResult": ".pipeline.retarget",
    "retarget": ".api", "evaluate": ".api", "load_robot": ".api", "load_robot_motion": ".api",
    "export_motion": ".api", "demo_clip": ".api",
}

#: Public functions named like a subpackage (``imesh.evaluate``, the package of the evaluator):
#: importing the subpackage must not replace the function (the import system sets the package
#: attribute).
_FUNCTIONS_OVER_MODULES = frozenset({"evaluate"})


class _Package(_types.ModuleType):
    """The ``imesh`` module: keeps ``imesh.evaluate`` the API function when the package
    ``imesh/evaluate/`` is imported (it stays in ``sys.modules``: ``from imesh.evaluate import
    evaluate_motion`` works)."""

    def __setattr__(self, name: str, value) -> None:
        if name in _FUNCTIONS_OVER_MODULES and isinstance(value, _types.ModuleType):
            return
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _Package


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())

#: The version (single source: pyproject.toml reads it from here).
__version__ = "0.1.0"

__all__ = [
    "AdaptResult", "ConstraintError", "ImeshError", "InteractionMesh", "InvalidMotionError",
    "LagrangianOptions", "MarkerMappingError", "MarkerMotion", "MissingMarkerError", "MorphConfig",
    "MorphProblem", "MorphResult", "MorphWeights", "MotionFileError", "OptionError",
    "RetargetConfig", "RetargetResult", "RobotMotion", "STANDARD_BONES", "STANDARD_MARKERS",
    "SolverError", "UnsupportedFormatError", "__version__", "adapt_motion",
    "build_interaction_mesh", "build_morph_problem", "demo_clip", "evaluate", "export_motion",
    "fill_gaps", "load_motion", "load_robot", "load_robot_motion", "retarget", "solve_morph",
    "to_standard",
]

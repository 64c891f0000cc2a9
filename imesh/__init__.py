"""imesh: adapt human motion capture to humanoid robots with the interaction mesh.

Data flow: ``load_motion`` (BVH, ASF/AMC, C3D, TRC) -> ``to_standard`` (standard marker set)
-> ``build_morph_problem`` / ``solve_morph`` (interaction mesh, spacetime morph) -> robots,
fitting, balance and physics (later stages). ``adapt_motion`` runs the marker-level pipeline.
"""

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
from .lazy import lazy_exports

#: Public names defined in submodules, imported on first use (PEP 562) so that ``import imesh``
#: and ``imesh --help`` do not pay for scipy, pinocchio and the solvers.
_LAZY = {
    "AdaptResult": ".adapt", "adapt_motion": ".adapt",
    "fill_gaps": ".gaps",
    "load_motion": ".io",
    "STANDARD_BONES": ".markerset", "STANDARD_MARKERS": ".markerset", "to_standard": ".markerset",
    "InteractionMesh": ".mesh.interaction", "build_interaction_mesh": ".mesh.interaction",
    "MorphConfig": ".morph.problem", "MorphProblem": ".morph.problem",
    "build_morph_problem": ".morph.problem",
    "MorphResult": ".morph.solver", "solve_morph": ".morph.solver",
    "MarkerMotion": ".motion",
}


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())

__version__ = "0.1.0"

__all__ = [
    "AdaptResult", "ConstraintError", "ImeshError", "InteractionMesh", "InvalidMotionError",
    "MarkerMappingError", "MarkerMotion", "MissingMarkerError", "MorphConfig", "MorphProblem",
    "MorphResult", "MotionFileError", "OptionError", "STANDARD_BONES", "STANDARD_MARKERS",
    "SolverError", "UnsupportedFormatError", "adapt_motion", "build_interaction_mesh",
    "build_morph_problem", "fill_gaps", "load_motion", "solve_morph", "to_standard",
]

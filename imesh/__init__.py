"""imesh: adapt human motion capture to humanoid robots with the interaction mesh.

Data flow: ``load_motion`` (BVH, ASF/AMC, C3D, TRC) -> ``to_standard`` (standard marker set)
-> ``build_morph_problem`` / ``solve_morph`` (interaction mesh, spacetime morph) -> robots,
fitting, balance and physics (later stages). ``adapt_motion`` runs the marker-level pipeline.
"""

from .adapt import AdaptResult, adapt_motion
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
from .gaps import fill_gaps
from .io import load_motion
from .markerset import STANDARD_BONES, STANDARD_MARKERS, to_standard
from .mesh.interaction import InteractionMesh, build_interaction_mesh
from .morph.problem import MorphConfig, MorphProblem, build_morph_problem
from .morph.solver import MorphResult, solve_morph
from .motion import MarkerMotion

__version__ = "0.1.0"

__all__ = [
    "AdaptResult", "ConstraintError", "ImeshError", "InteractionMesh", "InvalidMotionError",
    "MarkerMappingError", "MarkerMotion", "MissingMarkerError", "MorphConfig", "MorphProblem",
    "MorphResult", "MotionFileError", "OptionError", "STANDARD_BONES", "STANDARD_MARKERS",
    "SolverError", "UnsupportedFormatError", "adapt_motion", "build_interaction_mesh",
    "build_morph_problem", "fill_gaps", "load_motion", "solve_morph", "to_standard",
]

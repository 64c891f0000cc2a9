"""The whole-body spacetime solve (DESIGN.md, "Whole-body spacetime solve"; docs/wholebody.md).

``plan_whole_body`` fixes footprints, polygons, targets and limits; ``solve_whole_body`` runs the
sequential QP over all frames; ``add_lead`` adds the standing lead-in and lead-out.
"""

from .config import (
    CollisionOptions,
    CostWeights,
    FootOptions,
    ForceOptions,
    LimitMargins,
    SlackPrices,
    SqpOptions,
    WholeBodyConfig,
    WindowOptions,
    ZmpOptions,
)
from .footprints import Footprint, plan_footprints
from .initial import smooth_initializer
from .lead import Lead, LeadFeet, add_lead, lead_feet
from .problem import build_qp
from .qp import SOLVERS, QpProblem, QpSolution, solve_qp
from .sqp import IterationReport, WholeBodySolution, plan_whole_body, solve_whole_body

__all__ = ["SOLVERS", "CollisionOptions", "CostWeights", "FootOptions", "Footprint",
           "ForceOptions", "IterationReport", "Lead", "LeadFeet", "LimitMargins", "QpProblem",
           "QpSolution", "SlackPrices", "SqpOptions", "WholeBodyConfig", "WholeBodySolution",
           "WindowOptions", "ZmpOptions",
           "add_lead", "build_qp", "lead_feet", "plan_footprints", "plan_whole_body",
           "smooth_initializer", "solve_qp", "solve_whole_body"]

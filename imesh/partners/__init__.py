"""Two people, two robots: a partner dance retargeted in one interaction mesh (docs/partners.md).

Ho, Komura & Tai 2010 put several characters in one interaction mesh: the tetrahedra that join
one person's markers to the other's carry their spatial relation through the morph. Here the
two people are arranged in one world (:mod:`.world`), morphed together (:mod:`.mesh`), and each
robot is solved with its own feet, limits, balance and self-collision; the second robot also
keeps out of the first one's capsules and meets its hands where the people hold hands
(:mod:`.holds`, :mod:`.pair`). :mod:`.evaluate` scores a pair.
"""

from .evaluate import PairMetrics, evaluate_pair
from .holds import Holds, detect_holds
from .pair import PairConfig, PairResult, PartnerError, retarget_pair

__all__ = ["Holds", "PairConfig", "PairMetrics", "PairResult", "PartnerError", "detect_holds",
           "evaluate_pair", "retarget_pair"]

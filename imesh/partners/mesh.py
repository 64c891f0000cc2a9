"""Two people morphed in one interaction mesh (Ho, Komura & Tai 2010, sec. 4 and 6).

Each person is arranged for its own robot (:func:`imesh.pipeline.retarget.prepare`); the two
arranged marker sets are put side by side, ``V = [V_a; V_b]`` per frame, and one spacetime morph
solves them together (Nakaoka & Komura 2012, eq. 1-6, :mod:`imesh.morph`): the Delaunay
tetrahedralization of every frame spans both people, so the Laplacian coordinates
``L(p_j) = p_j - sum_{l in N_j} w_l p_l`` of a hand near the partner's hand or back have the
partner's markers among the neighbours N_j, and the deformation energy ``E_L`` keeps that
relation while each person's bones go to its own robot's lengths (eq. 3-4, the bone pairs of
the two people never mixed) and its support feet to their targets (eq. 4). This is the
multi-character mesh of Ho et al.: the relation is carried by the inter-person edges, not by
an extra term.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..morph.adapt import PERSON_PREFIXES
from ..morph.planes import BendPlanes, standard_planes
from ..morph.problem import MorphConfig, build_morph_problem
from ..morph.solver import MorphResult, solve_morph
from ..pipeline.retarget import Prepared


def _stack(a: np.ndarray | None, b: np.ndarray | None, shape_a: tuple, shape_b: tuple,
           fill: float) -> np.ndarray | None:
    """``a`` and ``b`` side by side along the marker axis (a missing one filled)."""
    if a is None and b is None:
        return None
    a = np.full(shape_a, fill) if a is None else a
    b = np.full(shape_b, fill) if b is None else b
    return np.concatenate([a, b], axis=1)


def morph_together(a: Prepared, b: Prepared, config: MorphConfig, progress=None
                   ) -> tuple[MorphResult, MorphResult, MorphResult]:
    """One spacetime morph of both people's arranged markers (see the module docstring).

    Args:
        a, b: the two people's :class:`~imesh.pipeline.retarget.Prepared` stages (same frames).
        config: the morph's settings.
        progress: passed to :func:`imesh.morph.solver.solve_morph`.

    Returns:
        (person a's part, person b's part, the joint result): each part is the joint
        result with only that person's markers (``positions_m`` (T, M_x, 3) [m]); residuals
        and timings are the joint solve's.
    """
    sa, sb = a.source, b.source
    both = sa.concat_markers(sb, *PERSON_PREFIXES)
    Ma, Mb, T = sa.n_markers, sb.n_markers, sa.n_frames
    hard = _stack(a.hard, b.hard, (T, Ma, 3), (T, Mb, 3), np.nan)
    soft = _stack(a.soft, b.soft, (T, Ma, 3), (T, Mb, 3), np.nan)
    soft_w = _stack(a.soft_w, b.soft_w, (T, Ma), (T, Mb), 0.0)
    pairs = np.concatenate([a.arrangement.pairs, b.arrangement.pairs + Ma])
    lengths = np.concatenate([a.arrangement.target_lengths_m, b.arrangement.target_lengths_m],
                             axis=-1)
    problem = build_morph_problem(both, pairs=pairs, target_lengths_m=lengths,
                                  hard_positions_m=hard, soft_positions_m=soft,
                                  soft_weights=soft_w, config=config,
                                  planes=BendPlanes.concat(
                                      standard_planes(sa.names),
                                      standard_planes(sb.names).shifted(Ma)))
    joint = solve_morph(problem, progress=progress)
    part_a = dataclasses.replace(joint, positions_m=joint.positions_m[:, :Ma])
    part_b = dataclasses.replace(joint, positions_m=joint.positions_m[:, Ma:])
    return part_a, part_b, joint

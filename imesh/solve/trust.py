"""The whole-body SQP's trust region: one radius per frame and tangent coordinate.

The QP of an iteration (:func:`imesh.solve.problem.build_qp`) bounds each coordinate of the
update ``dq_t`` by its radius (:func:`imesh.solve.limits.bounds`), so the linearization stays
valid. The radii start at ``SqpOptions.trust_region`` (the base's translation at
``base_trust`` of it) and follow what the line search of
:func:`imesh.solve.sqp.solve_whole_body` finds along each step:

* no merit decrease at any step length: every radius shrinks to a quarter;
* the whole step taken: every radius doubles, up to its nominal value;
* a part ``alpha < 1`` of the step taken with the soles near their footprints (within
  :data:`NEAR_M`) and the swing feet clear: no radius exceeds ``2 alpha`` times the step's
  largest coordinate (relative to its nominal radius). Near a feasible point the cut measures
  the model's missing curvature (the ZMP's): the linearization held over about that part, and a
  QP bounded to it picks a better direction than the longer step cut short (the G1 walk with
  the bend planes: steps taken at 1/8 over iterations 8-20 with the ZMP 9.0 -> 5.4 mm outside
  its shrunk polygon; bounded, 2 iterations to 3.9 mm). Far from it the L1 penalty's decrease
  along a cut step is still large, and radii shrunk to the parts taken held the G1 veer, which
  starts with the soles 180 mm off, at 19 mm steps (soles still 339 mm off after 20
  iterations);
* a coordinate whose update reached half its radius or more against the previous step's
  direction, twice in a row: its radius halves. The QP has no curvature along it (a term the
  linearization leaves out), so it crosses the valley from wall to wall (the JVRC-1 veer: a
  knee of the lead-in at +-0.3 rad on alternate iterations, 11-20, taken at half with the soles
  stuck 4.3 mm off their footprints). One reversal is an overshoot corrected: halving on it
  changed the HRP-4C veer's path to 20 iterations instead of 15.

A frame in self-collision has every radius capped at
``SqpOptions.collision_trust`` (:meth:`TrustRegion.capped`): the distance rows are linear in
the update, the capsules round, so a long step along a row's tangent plane sinks the links
into each other again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import SqpOptions

#: The soles this near their footprints [m] make the part of a step taken bound the radii. The
#: JVRC-1 wash's soles hovered 2.0-2.1 mm off over iterations 10-16 with steps taken at 1/4
#: (1.23 mm after its 20); bounded from 5 mm on, it stops at 17 with them within 1 mm.
NEAR_M = 5e-3

#: An update reversing the previous one counts towards a bounce once it reaches this part of
#: its radius. The G1 veer's lead-in knee went 0.17-0.3 rad back and forth on iterations
#: 13-20, mostly short of its 0.3 rad radius (the straight knee's second-order effect on the
#: sole, which the linearization leaves out), its soles still 1.6 mm off after 20 iterations;
#: counted from half the radius, it stops at 16 with them within 1 mm.
REACH = 0.5


def nominal_radii(options: SqpOptions, nv: int) -> np.ndarray:
    """(nv,) the largest change of each tangent coordinate in one iteration [m or rad]: the
    base's translation ``trust_region * base_trust``, every other one ``trust_region``."""
    radii = np.full(nv, options.trust_region)
    # the base's translation moves every link: its vertical second difference enters the
    # ZMP's denominator (g + c_z''), so it gets a tighter region
    radii[:3] *= options.base_trust
    return radii


@dataclass(frozen=True)
class TrustRegion:
    """The radii of one SQP iteration's QP.

    Attributes:
        radii: (nv,) nominal radii [m or rad] (:func:`nominal_radii`).
        scale: (T, nv) each frame's and coordinate's radius as a fraction of its nominal one.
        previous: (T, nv) the QP's update of the last accepted step, or None before one.
        reversals: (T, nv) how many accepted updates in a row reached :data:`REACH` of their
            radius against the one before.
    """

    radii: np.ndarray
    scale: np.ndarray
    previous: np.ndarray | None
    reversals: np.ndarray

    @classmethod
    def start(cls, options: SqpOptions, n_frames: int, nv: int) -> TrustRegion:
        """Every radius at its nominal value."""
        return cls(nominal_radii(options, nv), np.ones((n_frames, nv)), None,
                   np.zeros((n_frames, nv), dtype=int))

    @property
    def radius(self) -> np.ndarray:
        """(T, nv) the radii [m or rad]."""
        return self.scale * self.radii

    @property
    def largest(self) -> float:
        """The largest radius [m or rad]."""
        return float(self.radius.max(initial=0.0))

    def capped(self, frames: np.ndarray, cap: float) -> np.ndarray:
        """(T, nv) the radii [m or rad], those of ``frames`` ((T,) bool) at most ``cap`` (0:
        unchanged)."""
        radius = self.radius
        if cap > 0 and frames.any():
            radius[frames] = np.minimum(radius[frames], cap)
        return radius

    def shrink(self) -> TrustRegion:
        """After a step no length of which lowered the merit: every radius to a quarter."""
        return TrustRegion(self.radii, 0.25 * self.scale, self.previous, self.reversals)

    def follow(self, dq: np.ndarray, alpha: float, sole_error_m: float,
               swing_clear: bool) -> TrustRegion:
        """After a step the line search took a part ``alpha`` of.

        Args:
            dq: (T, nv) the QP's update (before the line search).
            alpha: the part of ``dq`` taken.
            sole_error_m: the new iterate's largest sole distance to its footprint [m].
            swing_clear: the new iterate's swing feet clear the ground. The part taken bounds
                the radii only with the soles within :data:`NEAR_M` and the swing feet clear.
        """
        relative = np.abs(dq) / self.radii
        # far towards the radius (:data:`REACH`; a joint limit nearer than that leaves the
        # update short of it) and reversed against the previous step
        reversed_ = np.zeros(dq.shape, dtype=bool) if self.previous is None else (
            (relative >= REACH * self.scale) & (dq * self.previous < 0.0))
        reversals = np.where(reversed_, self.reversals + 1, 0)
        if alpha == 1.0:
            scale = np.minimum(2.0 * self.scale, 1.0)
        elif sole_error_m < NEAR_M and swing_clear:
            scale = np.minimum(self.scale, 2.0 * alpha * float(relative.max(initial=0.0)))
        else:
            scale = self.scale
        scale = np.where(reversals >= 2, 0.5 * scale, scale)
        return TrustRegion(self.radii, scale, dq, reversals)

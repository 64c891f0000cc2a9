"""Joint limits and the options that say which of them a solver enforces (Kim, Kim & Oh 2005).

One robot's limits for a set of joints are a :class:`JointLimits`: position (eq. 9), velocity
(eq. 13) and acceleration (eq. 14) limits, one value per joint. :class:`LimitOptions` are the
switches that the initial fit (:class:`imesh.fit.FitConfig`) and the arm imitation
(:class:`imesh.arms.ArmsConfig`) share, with the same defaults; their schemes (the look-ahead
projection or Kim's per-frame boxes, the warm start) stay in each configuration, which picks
its own. :func:`imesh.fit.limits.joint_limits` builds the limits of a robot under the options,
:mod:`imesh.fit.limits` turns them into each frame's box.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import OptionError

#: [rad] a joint value this close to a bound counts as on it, and as inside the limits.
BOUND_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class JointLimits:
    """Position, velocity and acceleration limits of ``n`` joints (Kim, Kim & Oh 2005, eqs 9,
    13, 14: ``q_min <= q <= q_max``, ``|v| <= v_max``, ``|a| <= a_max``).

    Attributes:
        lower, upper: (n,) float [rad] position limits q_min, q_max (-inf / inf: unbounded).
        v_max: (n,) float [rad/s] velocity limits (> 0; inf: unbounded or not enforced).
        a_max: (n,) float [rad/s^2] acceleration limits (> 0; inf: unbounded or not enforced).
    """

    lower: np.ndarray
    upper: np.ndarray
    v_max: np.ndarray
    a_max: np.ndarray

    def take(self, index: np.ndarray) -> JointLimits:
        """The limits of the joints ``index`` (integer indices into the n joints)."""
        return JointLimits(lower=self.lower[index], upper=self.upper[index],
                           v_max=self.v_max[index], a_max=self.a_max[index])

    def position_only(self) -> JointLimits:
        """The same position limits without velocity and acceleration limits (eq. 9 only)."""
        n = len(self.lower)
        return JointLimits(lower=self.lower, upper=self.upper, v_max=np.full(n, np.inf),
                           a_max=np.full(n, np.inf))


@dataclass(frozen=True)
class LimitOptions:
    """Which joint limits a solver enforces, and how.

    Attributes:
        enforce_velocity: apply the velocity limits (Kim eq. 13); off: ``v_max`` = inf.
        enforce_acceleration: apply the acceleration limits (Kim eq. 14); off: ``a_max`` = inf.
        acceleration_limit: overrides the robot's ``a_max`` [rad/s^2]: one number for all
            joints or one per joint; None keeps the robot's (inf = unbounded).
        brake_before_limits: with the acceleration limits on, also keep every joint slow enough
            to stop before its position limits at ``a_max`` (a braking-distance bound, lowest
            priority, counted as a position bound): without it a joint racing towards its
            limit meets a position/acceleration conflict.

    Raises:
        OptionError: an ``acceleration_limit`` that is not one positive number or one per joint.
    """

    enforce_velocity: bool = True
    enforce_acceleration: bool = True
    acceleration_limit: float | Sequence[float] | None = None
    brake_before_limits: bool = True

    def __post_init__(self) -> None:
        if self.acceleration_limit is not None:
            arr = np.asarray(self.acceleration_limit, dtype=np.float64)
            if arr.ndim > 1 or np.any(np.isnan(arr)) or np.any(arr <= 0):
                raise OptionError("LimitOptions.acceleration_limit", self.acceleration_limit,
                                  "one positive number or one per joint [rad/s^2]")

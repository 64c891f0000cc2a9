"""Ground contact conditions of the biped (sec. IV-C.1, Fig. 5).

At every sample one foot is the *base* link (its toe pad on the ground, fixed) and the other the
*moving* link (its heel roller on the ground, sliding). The walk decides which: the base foot is
the one the human stands on, switching to the other foot when the standing foot's toe leaves the
ground (toe-off). (The paper's moon-walk rule, theta_0 <= theta_6 - pi on the human foot angles,
picks the foot standing on its toe; in walking the swing foot is the more tilted one right after
toe-off, so the toe-off events are used instead.)

The foot angles are given, not optimized (eq. 35: theta_0 and theta_6 come from the contact
condition):

- base foot: 0 -> pad angle alpha (quintic; case ii: point contact at the ball), alpha held
  (case i: toe line contact), alpha -> 0 (case ii) before the switch;
- moving foot: 0 -> -beta (toe up, quintic), -beta held, -beta -> 0 before the switch.

At the switch both feet are at 0, where a foot touches the ground with its ball and its roller:
the old base foot rolls on, the new one pivots about its ball. With a flat sole (pad angle 0,
3D robots) the base foot stays flat (case i throughout).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import OptionError


@dataclass(frozen=True, eq=False)
class ContactSchedule:
    """Which foot is the base and how it touches the ground, per sample.

    Attributes:
        base: (n,) 0 = left foot is the base link, 1 = right foot.
        case: (n,) 1 = toe line contact (two vertical forces on the base pad), 2 = toe point
            contact at the ball (the base foot turns freely).
        feet: (n, 2) given foot angles [rad], left and right (LINKS indices 0 and 6).
        feet_d1, feet_d2: (n, 2) their exact first and second derivatives per sample
            [rad/sample, rad/sample^2] (divide by dt, dt^2): the paper's foot-link rates "from
            the time-derivative of theta_0 and theta_6".
        switches: samples at which the base foot changes (0 and the left-to-right switch).
        pad_angle: (2,) [rad] alpha per foot.
        moving_angle: beta [rad].
        transition: samples of each quintic transition.
    """

    base: np.ndarray
    case: np.ndarray
    feet: np.ndarray
    feet_d1: np.ndarray
    feet_d2: np.ndarray
    switches: tuple[int, ...]
    pad_angle: np.ndarray
    moving_angle: float
    transition: int

    @property
    def n(self) -> int:
        return int(self.base.shape[0])


def quintic(s: np.ndarray, order: int = 0) -> np.ndarray:
    """Quintic blend 0 -> 1 on s in [0, 1] with zero first and second derivatives at the ends
    (``order`` 1, 2: its derivatives w.r.t. s; 0 outside [0, 1])."""
    s = np.asarray(s, float)
    inside = (s > 0.0) & (s < 1.0)
    c = np.clip(s, 0.0, 1.0)
    if order == 0:
        return c ** 3 * (10.0 - 15.0 * c + 6.0 * c * c)
    if order == 1:
        return np.where(inside, 30.0 * c ** 2 * (1.0 - c) ** 2, 0.0)
    return np.where(inside, 60.0 * c * (1.0 - c) * (1.0 - 2.0 * c), 0.0)


def contact_schedule(n: int, switch: int, pad_angle: np.ndarray, moving_angle: float = 0.17,
                     transition_fraction: float = 0.2) -> ContactSchedule:
    """The contact schedule of one gait cycle of n samples.

    Args:
        n: samples per cycle.
        switch: sample at which the right foot becomes the base (left toe-off); the left foot
            is the base on [0, switch) (the cycle starts at the right toe-off).
        pad_angle: (2,) toe-pad angle alpha of each foot [rad] (0 for a flat sole).
        moving_angle: beta, toe-up angle of the sliding foot [rad].
        transition_fraction: length of each quintic transition as a fraction of its half cycle.
    """
    if not 0 < switch < n:
        raise OptionError("base-foot switch sample", switch, f"1..{n - 1}")
    if not 0 < transition_fraction <= 0.5:
        raise OptionError("transition fraction", transition_fraction, "(0, 0.5]")
    pad = np.broadcast_to(np.asarray(pad_angle, float), (2,))
    base = np.zeros(n, int)
    base[switch:] = 1
    case = np.ones(n, int)
    feet = np.zeros((n, 2))
    d1 = np.zeros((n, 2))
    d2 = np.zeros((n, 2))
    tr_all = []
    for b, (s0, s1) in enumerate(((0, switch), (switch, n))):
        m = 1 - b
        length = s1 - s0
        tr = max(2, int(round(transition_fraction * length)))
        tr_all.append(tr)
        i = np.arange(length, dtype=float)
        su, sd = i / tr, (length - i) / tr           # rising at the start, falling at the end
        up, down = quintic(su), quintic(sd)
        first = up <= down
        shape = np.where(first, up, down)
        dshape = np.where(first, quintic(su, 1) / tr, -quintic(sd, 1) / tr)
        ddshape = np.where(first, quintic(su, 2) / tr ** 2, quintic(sd, 2) / tr ** 2)
        for foot, amp in ((b, pad[b]), (m, -moving_angle)):
            feet[s0:s1, foot] = amp * shape
            d1[s0:s1, foot] = amp * dshape
            d2[s0:s1, foot] = amp * ddshape
        if pad[b] > 0:
            case[s0:s1][shape < 1.0 - 1e-12] = 2
    return ContactSchedule(base=base, case=case, feet=feet, feet_d1=d1, feet_d2=d2,
                           switches=(0, switch), pad_angle=pad.copy(),
                           moving_angle=float(moving_angle), transition=int(max(tr_all)))

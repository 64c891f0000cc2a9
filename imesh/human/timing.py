"""Whether a clip's frame rate is the rate it was captured at, told by the performer's balance.

A wrong header rate makes every velocity wrong by its factor and every acceleration by its
square: CMU's salsa couple (60_10 / 61_10, the Second Life release) says 120 fps where the CMU
listing gives 60, and at 120 fps the dance asks a robot for four times the accelerations the
dancers made. The clip itself tells the rate: a performer standing on their feet keeps their
zero-moment point near them. Read at the header's rate, the salsa's ZMP is more than 0.3
body heights from both feet in 33 % (partner A) and 51 % (B) of the frames in which the body
does not fall freely; at 60 fps in 6 % and 3 %; the walks, the wave and the wash at their
rates 0-1 %, a leap dance 12 %, a kick and a run 14 %.

The ZMP is that of point masses at the segments' centres of mass (de Leva 1996, adjusted
Zatsiorsky-Seluyanov parameters: masses in percent of the body's, centres as fractions of the
segment from its proximal joint) on the 21 standard markers:

    p_zmp = sum_i m_i (x_i (z_i'' + g) - z_i x_i'') / sum_i m_i (z_i'' + g)      (x: x and y)

(the multibody ZMP with each segment's own rotation neglected), the second derivatives from a
cubic Savitzky-Golay fit over ``window_s``. Frames whose vertical force is under
``flight_fraction`` of the body weight (a fall, a flight) have no ZMP and are not counted. The
distance to the feet is to the nearer of the two ankle-toe lines.

The check assumes the feet carry the performer: a clip in which the hands or a partner carry
weight for long (climbing, a lift) is read at the header's rate whenever the slower rate does
not bring the ZMP to the feet, and an explicit rate (``fps=`` of :func:`imesh.io.load_motion`,
``--source-fps``) skips the check.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.checks import require_finite
from ..core.motion import MarkerMotion
from ..errors import ImeshError, OptionError

GRAVITY = 9.81

#: Body segments as (proximal marker, distal marker, centre of mass as a fraction of the way from
#: proximal to distal, mass in percent of the body's): de Leva 1996 (male), the trunk in its
#: three parts, the head and neck at the head marker (the skull base).
SEGMENTS: tuple[tuple[str, str, float, float], ...] = (
    ("neck", "head", 1.0, 6.94),
    ("pelvis", "spine", 0.5, 11.17),
    ("spine", "chest", 0.5, 16.33),
    ("chest", "neck", 0.5, 15.96),
) + tuple(
    seg for s in "lr" for seg in (
        (f"shoulder_{s}", f"elbow_{s}", 0.58, 2.71),
        (f"elbow_{s}", f"wrist_{s}", 0.46, 1.62),
        (f"wrist_{s}", f"hand_{s}", 0.5, 0.61),
        (f"hip_{s}", f"knee_{s}", 0.41, 14.16),
        (f"knee_{s}", f"ankle_{s}", 0.44, 4.33),
        (f"ankle_{s}", f"toe_{s}", 0.44, 1.37),
    )
)


@dataclass(frozen=True)
class TimingConfig:
    """When a clip is read at a lower rate than its header's (see the module docstring).

    Attributes:
        reach_fraction: a frame is off balance when its ZMP is farther than this many body
            heights from both feet ...
        header_fraction: ... and the header's rate is doubted when at least this fraction of
            the counted frames are ...
        corrected_fraction: ... and replaced by the header's divided by a factor at which at
            most this fraction are (the walks' 0-1 %).
        factors: the rate errors tried, in order (2: a 120 fps header on a 60 fps capture).
        min_duration_s: clips shorter than this at the header's rate are not checked (too
            few frames to tell a style from a wrong rate).
        probe_s: :func:`imesh.io.load_motion` checks the first this many seconds (at the
            header's rate) of a longer clip.
        window_s: the Savitzky-Golay window of the accelerations [s].
        flight_fraction: frames whose vertical force is below this fraction of the body's
            weight have no ZMP (not counted).
    """

    reach_fraction: float = 0.3
    header_fraction: float = 0.25
    corrected_fraction: float = 0.1
    factors: tuple[float, ...] = (2.0,)
    min_duration_s: float = 2.0
    probe_s: float = 60.0
    window_s: float = 0.1
    flight_fraction: float = 0.3

    def __post_init__(self) -> None:
        require_finite(self, ("reach_fraction", "header_fraction", "corrected_fraction",
                              "min_duration_s", "probe_s", "window_s", "flight_fraction"),
                       positive=True)
        if not self.factors or any(not np.isfinite(f) or f <= 1.0 for f in self.factors):
            raise OptionError("timing factors", self.factors, "numbers above 1 (2: half rate)")


@dataclass(frozen=True)
class TimingCheck:
    """The rate a clip is read at and why.

    Attributes:
        header_fps: the file's rate [1/s].
        fps: the rate chosen [1/s] (the header's unless the balance says otherwise).
        off_balance: (rate [1/s], fraction of the counted frames whose ZMP is beyond
            ``reach_fraction`` body heights from both feet) per rate tried, the header's first.
        reason: one sentence for logs and ``meta["fps_reason"]``.
    """

    header_fps: float
    fps: float
    off_balance: tuple[tuple[float, float], ...]
    reason: str

    @property
    def corrected(self) -> bool:
        return self.fps != self.header_fps


def _cubic_fit(x: np.ndarray, window: int, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Value and second derivative of a least-squares cubic over ``window`` (odd) frames
    centred on each frame of ``x`` (T, ...) with ``window // 2`` frames either side (a
    Savitzky-Golay filter on the interior frames; numpy only: scipy.signal costs seconds to
    import): two (T - window + 1, ...) arrays."""
    h = window // 2
    offsets = np.arange(-h, h + 1) * dt
    rows = np.linalg.pinv(np.vander(offsets, 4, increasing=True))  # (4, window): c0..c3
    n = len(x) - window + 1
    value = np.zeros((n,) + x.shape[1:])
    accel = np.zeros_like(value)
    for k in range(window):  # a sum over the window's offsets, each one vectorized
        value += rows[0, k] * x[k:k + n]
        accel += 2.0 * rows[2, k] * x[k:k + n]
    return value, accel


def off_balance_fraction(standard: MarkerMotion, fps: float, config: TimingConfig) -> float:
    """Fraction of the frames with a ZMP in which it is beyond ``config.reach_fraction`` body
    heights from both feet when ``standard`` (on the 21 standard markers, every marker valid)
    is played at ``fps`` (the first and last half window of frames are not counted)."""
    names = list(standard.names)
    p = standard.positions_m
    prox = p[:, [names.index(a) for a, _, _, _ in SEGMENTS]]
    dist = p[:, [names.index(b) for _, b, _, _ in SEGMENTS]]
    f = np.array([s[2] for s in SEGMENTS])[None, :, None]
    m = np.array([s[3] for s in SEGMENTS]) / 100.0                 # (S,)
    window = max(5, int(round(fps * config.window_s)) | 1)
    x, acc = _cubic_fit(prox + f * (dist - prox), window, 1.0 / fps)  # (T', S, 3) centres
    p = p[window // 2:window // 2 + len(x)]
    lift = acc[..., 2] + GRAVITY                                   # (T', S)
    weight = lift @ m                                              # (T',) per unit mass
    carried = weight > config.flight_fraction * GRAVITY
    zmp = (np.einsum("s,tsk->tk", m, x[..., :2] * lift[..., None] - x[..., 2:3] * acc[..., :2])
           / np.where(carried, weight, 1.0)[:, None])
    # distance to the nearer ankle-toe line: (T', 2) closest points of the two feet
    ankles = p[:, [names.index("ankle_l"), names.index("ankle_r")], :2]
    foot = p[:, [names.index("toe_l"), names.index("toe_r")], :2] - ankles
    rel = zmp[:, None] - ankles
    s = np.clip(np.sum(rel * foot, axis=-1) / np.maximum(np.sum(foot * foot, axis=-1), 1e-12),
                0.0, 1.0)
    reach = np.linalg.norm(rel - s[..., None] * foot, axis=-1).min(axis=1)  # (T',)
    if not carried.any():
        return 0.0
    return float(np.mean(reach[carried] > config.reach_fraction * standard.height_m))


def check_timing(motion: MarkerMotion, config: TimingConfig | None = None) -> TimingCheck:
    """The rate ``motion`` was captured at, judged by its performer's balance.

    Args:
        motion: a clip as read (any marker names: it is mapped onto the standard markers here),
            at its header's rate.
        config: thresholds.

    Returns:
        The check; ``fps`` is the header's unless the header's rate puts the ZMP off the feet
        in at least ``header_fraction`` of the frames and a rate ``factors`` times lower in at
        most ``corrected_fraction``. Clips that cannot be mapped onto the standard markers,
        that have gaps or are shorter than ``min_duration_s`` keep the header's rate.
    """
    from .standard import to_standard

    config = config or TimingConfig()
    header = float(motion.fps)
    if motion.n_frames < config.min_duration_s * header:
        return TimingCheck(header, header, (), "the file's (too short to check the timing)")
    try:
        standard = to_standard(motion)
    except ImeshError:
        return TimingCheck(header, header, (), "the file's (timing not checked: the markers "
                           "do not map onto the standard set)")
    if not np.all(standard.valid):
        return TimingCheck(header, header, (), "the file's (timing not checked: marker gaps)")
    rates = [header] + [header / k for k in config.factors]
    fractions = [off_balance_fraction(standard, r, config) for r in rates]
    checked = tuple(zip(rates, fractions, strict=True))
    reach = f"{config.reach_fraction:g} body heights"
    if fractions[0] < config.header_fraction:
        return TimingCheck(header, header, checked,
                           f"the file's (the performer's ZMP beyond {reach} of the feet in "
                           f"{fractions[0]:.0%} of the frames)")
    for rate, frac in checked[1:]:
        if frac <= config.corrected_fraction:
            return TimingCheck(
                header, rate, checked,
                f"{rate:.6g} fps, not the file's {header:.6g}: at the file's rate the "
                f"performer's ZMP is beyond {reach} of both feet in {fractions[0]:.0%} of the "
                f"frames, at {rate:.6g} fps in {frac:.0%} (give the rate, --source-fps, to "
                "read it at another)")
    return TimingCheck(header, header, checked,
                       f"the file's (the performer's ZMP beyond {reach} of the feet in "
                       f"{fractions[0]:.0%} of the frames; no slower rate tried does better "
                       f"than {min(fractions[1:]):.0%})")

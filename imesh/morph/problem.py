"""MorphProblem: what one spacetime morph sequence must achieve, validated once.

A morph moves the markers of all frames from the source motion towards target bone lengths and
positional constraints over ``steps`` morph steps (Nakaoka & Komura 2012, sec. III, eq. 6):

    min_V'  sum_i  E_L(V'_i) + w_A E_A + E_C + w_D E_D + w_P E_P    s.t.  H_i V'_i = h_i

with E_L the Laplacian deformation energy (eq. 2), E_A the acceleration energy, E_C the soft
positional constraints (eq. 5), E_D the close pairs' distances, E_P the bend planes
(:mod:`imesh.morph.planes`; not in the paper), and the hard constraints H_i V'_i = h_i made of
linearized bone lengths (eq. 3) and positional constraints (eq. 4).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.checks import NonNegative, require_count, require_finite
from ..core.motion import MarkerMotion
from ..errors import ConstraintError, InvalidMotionError, OptionError
from ..mesh.bones import bone_lengths, check_target_lengths
from ..mesh.interaction import WEIGHTINGS
from .planes import NO_PLANES, BendPlanes, bend_angles, bend_weights


@dataclass(frozen=True)
class MorphWeights(NonNegative):
    """The morph's energy: its terms' weights and the Laplacian's (eq. 2, 5, 6).

    Attributes:
        accel: w_A, weight of the acceleration energy, defined on the change of the per-frame
            second difference relative to the source motion, normalized to 30 fps:
            E_A = w_A (fps/30)^4 / 2 sum_i |(V'-V)_{i-1} - 2 (V'-V)_i + (V'-V)_{i+1}|^2, so a given
            w_A means the same smoothing at any frame rate.
        anchor: small proximal weight pulling every marker towards its position of the
            previous morph step; removes the null space (a translation linear in time costs no
            Laplacian or acceleration energy) without biasing the result towards the source.
        soft: default weight of soft positional constraints (eq. 5).
        contact: w_D, weight of the soft term that keeps the source distance of close marker
            pairs (closer than ``contact_fraction`` x body height in the source frame, not
            joined by a constrained pair): w_D (1 - d/d_max) (|p'_a - p'_b| - s d)^2 / 2,
            linearized like the bones, with s the median target/source length ratio. Hands
            that touch keep touching; 0 turns it off (pure Laplacian energy of eq. 2).
        contact_fraction: closeness threshold relative to the body height.
        plane: w_P, weight of the bend planes (:mod:`imesh.morph.planes`): a chain's middle
            marker (the pelvis about the hip axis, a knee about its hip-ankle line) keeps the
            direction it has in the source; 0 turns them off.
        weighting: Laplacian weights, "inverse_distance" or "uniform".
    """

    accel: float = 1.0
    anchor: float = 1e-3
    soft: float = 1.0
    contact: float = 30.0
    contact_fraction: float = 0.15
    plane: float = 30.0
    weighting: str = "inverse_distance"

    def __post_init__(self) -> None:
        super().__post_init__()
        require_finite(self, ("anchor",), positive=True)
        if self.weighting not in WEIGHTINGS:
            raise OptionError("weighting", self.weighting, WEIGHTINGS)


@dataclass(frozen=True)
class LagrangianOptions:
    """The augmented-Lagrangian solve of the hard constraints in every morph step
    (:meth:`imesh.morph.kkt.KktSystem.solve`).

    Attributes:
        tolerance_m: residual of the linearized hard constraints per solve [m].
        fail_tolerance_m: at the final targets, a residual still above this after
            ``max_iterations`` means conflicting hard constraints (SolverError) [m].
        penalty: penalty relative to the mean diagonal of the Hessian.
        max_iterations: limit on multiplier updates per solve.
    """

    tolerance_m: float = 1e-10
    fail_tolerance_m: float = 1e-5
    penalty: float = 1e5
    max_iterations: int = 30

    def __post_init__(self) -> None:
        require_finite(self, ("tolerance_m", "fail_tolerance_m", "penalty"), positive=True)
        require_count(self, ("max_iterations",))


@dataclass(frozen=True)
class MorphConfig:
    """Settings of the spacetime morph.

    Attributes:
        steps: number of morph steps K; targets move linearly from source to final over them.
        weights: the energy's weights.
        lagrangian: the hard constraints' solve.
        bone_tolerance_m: every constrained length ends within this of its target: after the K
            steps, up to ``max_polish_steps`` re-solves at the final targets, then a Newton
            projection onto the exact lengths (``projection.project_lengths``).
        max_polish_steps: re-solves of the whole problem at the final targets.
        window_frames: clips longer than this are solved in windows (memory stays bounded).
        window_lookahead: frames a window solves beyond what it keeps, so its end is not
            shaped by the artificial window boundary.
        threads: BLAS threads for the banded factorization (None: 1, see
            ``solver.default_threads``).
    """

    steps: int = 10
    weights: MorphWeights = field(default_factory=MorphWeights)
    lagrangian: LagrangianOptions = field(default_factory=LagrangianOptions)
    bone_tolerance_m: float = 1e-9
    max_polish_steps: int = 1
    window_frames: int = 2000
    window_lookahead: int = 60
    threads: int | None = None

    def __post_init__(self) -> None:
        require_count(self, ("steps",))
        require_count(self, ("max_polish_steps",), minimum=0)
        require_finite(self, ("bone_tolerance_m",), positive=True)
        if self.window_frames < 8 or not (0 <= self.window_lookahead < self.window_frames // 2):
            raise OptionError("window_frames/window_lookahead",
                              (self.window_frames, self.window_lookahead),
                              "window_frames >= 8 and 0 <= window_lookahead < window_frames / 2")


@dataclass(frozen=True, eq=False)
class MorphProblem:
    """A validated morph: source motion, final targets and constraints.

    Attributes:
        source: (T, M, 3) source positions [m], complete (no NaN).
        fps: frame rate [1/s].
        names: (M,) marker names.
        bones: (B, 2) marker pairs whose lengths are hard-constrained (skeleton bones and any
            extra pairs that make segments rigid).
        source_lengths_m: (T, B) bone lengths of the source.
        target_lengths_m: (T, B) final target bone lengths.
        hard_positions_m: (T, M, 3) final hard positional targets, NaN where free (eq. 4).
        soft_positions_m: (T, M, 3) final soft positional targets, NaN where free (eq. 5).
        soft_weights: (T, M) weights of the soft targets.
        height_m: body height of the source (median vertical extent) [m].
        config: MorphConfig.
        planes: the bend planes held (:mod:`imesh.morph.planes`).
        plane_angles_rad: (T, H) their source angles [rad].
        plane_weights: (T, H) their weight scales in [0, 1] (0 where the source chain is
            straight).
    """

    source: np.ndarray
    fps: float
    names: tuple[str, ...]
    bones: np.ndarray
    source_lengths_m: np.ndarray
    target_lengths_m: np.ndarray
    hard_positions_m: np.ndarray
    soft_positions_m: np.ndarray
    soft_weights: np.ndarray
    height_m: float
    config: MorphConfig
    planes: BendPlanes = NO_PLANES
    plane_angles_rad: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    plane_weights: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def n_frames(self) -> int:
        return len(self.source)

    @property
    def n_markers(self) -> int:
        return len(self.names)

    def frames(self, start: int, stop: int) -> MorphProblem:
        """The sub-problem of frames start:stop (for windowed solves)."""
        sl = slice(start, stop)
        return MorphProblem(
            source=self.source[sl], fps=self.fps, names=self.names, bones=self.bones,
            source_lengths_m=self.source_lengths_m[sl], target_lengths_m=self.target_lengths_m[sl],
            hard_positions_m=self.hard_positions_m[sl], soft_positions_m=self.soft_positions_m[sl],
            soft_weights=self.soft_weights[sl], height_m=self.height_m, config=self.config,
            planes=self.planes, plane_angles_rad=self.plane_angles_rad[sl],
            plane_weights=self.plane_weights[sl],
        )


def _position_array(name: str, value, shape: tuple[int, int, int], names) -> np.ndarray:
    if value is None:
        return np.full(shape, np.nan)
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise ConstraintError(f"{name} must have shape {shape} (NaN where free), got {arr.shape}")
    if np.isinf(arr).any():
        t, j, _ = np.argwhere(np.isinf(arr))[0]
        raise ConstraintError(f"{name} is infinite at frame {t}, marker {names[j]}")
    return arr


def build_morph_problem(motion: MarkerMotion, *, pairs: np.ndarray | None = None,
                        target_lengths_m: np.ndarray | None = None,
                        hard_positions_m: np.ndarray | None = None,
                        soft_positions_m: np.ndarray | None = None,
                        soft_weights: np.ndarray | float | None = None,
                        config: MorphConfig | None = None,
                        planes: BendPlanes | None = None) -> MorphProblem:
    """Assemble and validate a morph problem.

    Args:
        motion: source motion with ``bones``; must be complete (see ``imesh.human.gaps.fill_gaps``).
        pairs: (B, 2) length-constrained marker pairs; default ``motion.bones``. Extra pairs
            (e.g. hip-hip, shoulder-neck) make segments rigid (Nakaoka & Komura sec. IV-A).
        target_lengths_m: (T, B) or (B,) final lengths of the pairs [m]; default: the source
            lengths.
        hard_positions_m: (T, M, 3) final hard targets [m], NaN for free coordinates.
        soft_positions_m: (T, M, 3) final soft targets [m], NaN for free coordinates.
        soft_weights: (T, M) or scalar weight of the soft targets (default config.weights.soft).
        config: MorphConfig (defaults if None).
        planes: bend planes whose source directions the morph keeps (``MorphWeights.plane``;
            :func:`imesh.morph.planes.standard_planes` of the arranged markers); None: none.

    Raises:
        InvalidMotionError: the motion has gaps or no bones.
        ConstraintError: targets of the wrong shape, non-finite, or zero bone lengths.
    """
    config = config or MorphConfig()
    src = motion.positions_m
    if not motion.valid.all():
        t, j = np.argwhere(~motion.valid)[0]
        raise InvalidMotionError(
            f"{motion.source}: marker {motion.names[j]} is missing at frame {t}; fill gaps "
            "before morphing (imesh.human.gaps.fill_gaps)"
        )
    pairs = motion.bones if pairs is None else np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        raise InvalidMotionError(f"{motion.source}: the motion has no bones to morph")
    if pairs.min() < 0 or pairs.max() >= motion.n_markers or (pairs[:, 0] == pairs[:, 1]).any():
        raise ConstraintError(f"length pairs must join two different markers in "
                              f"[0, {motion.n_markers})")
    shape = src.shape
    src_len = bone_lengths(src, pairs)
    check_target_lengths(src_len, pairs, motion.names, motion.n_frames)
    if target_lengths_m is None:
        target = src_len.copy()
    else:
        target = np.array(check_target_lengths(target_lengths_m, pairs, motion.names,
                                               motion.n_frames))
    hard = _position_array("hard_positions_m", hard_positions_m, shape, motion.names)
    soft = _position_array("soft_positions_m", soft_positions_m, shape, motion.names)
    if soft_weights is None:
        soft_weights = config.weights.soft
    w = np.broadcast_to(np.asarray(soft_weights, dtype=float), shape[:2]).copy()
    if not (np.isfinite(w).all() and (w >= 0).all()):
        raise ConstraintError("soft_weights must be finite and >= 0")
    planes = NO_PLANES if planes is None or config.weights.plane == 0 else planes
    if len(planes) and (planes.markers.max() >= motion.n_markers
                        or planes.references.max() >= motion.n_markers):
        raise ConstraintError(f"bend planes must name markers in [0, {motion.n_markers})")
    return MorphProblem(source=src, fps=motion.fps, names=motion.names, bones=pairs,
                        source_lengths_m=src_len, target_lengths_m=target, hard_positions_m=hard,
                        soft_positions_m=soft, soft_weights=w, height_m=motion.height_m,
                        config=config, planes=planes,
                        plane_angles_rad=bend_angles(src, planes),
                        plane_weights=bend_weights(src, planes))

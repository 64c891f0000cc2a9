"""Spacetime morphing: K morph steps, each one exact constrained solve over all frames.

``solve_morph(problem)`` runs the morph of Nakaoka & Komura 2012 (sec. III, eq. 6). Each step:

1. targets move a fraction s/K of the way from the source (bone lengths, eq. 3; positional
   constraints, eq. 4; soft targets, eq. 5);
2. bone lengths are linearized at the current solution, u . (p'_a - p'_b) = l(s);
3. one constrained solve over all frames of the window (``kkt.solve_constrained``).

After step K the constraints are re-linearized at the final targets until every bone length is
within ``bone_tolerance_m`` (Newton on the nonlinear constraint). The Hessian (eq. 6) does not
change across steps: the interaction mesh and its Laplacian come from the source motion.

Long clips are solved in windows of ``window_frames``; each window after the first fixes its two
first frames to the previous window's solution at the same morph step, which makes the
acceleration energy across the seam exact (the second difference only reaches two frames back),
and solves ``window_lookahead`` frames beyond what it keeps.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from threadpoolctl import threadpool_limits

from ..mesh.bones import bone_directions, bone_lengths
from ..mesh.interaction import build_interaction_mesh
from .kkt import BandedKKT
from .planes import plane_normals
from .problem import MorphProblem
from .projection import project_lengths

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class MorphStepReport:
    """One morph step of one window.

    Attributes:
        window: window index.
        step: 1..K for morph steps, > K for the re-linearizations at the final targets.
        alpha: fraction of the way to the final targets.
        bone_residual_m: max | |p_a - p_b| - l(alpha) | after the step (nonlinear).
        linear_residual_m: max |A x - c| of the linearized hard constraints.
        al_iterations: multiplier updates used.
        seconds: wall time of the step.
    """

    window: int
    step: int
    alpha: float
    bone_residual_m: float
    linear_residual_m: float
    al_iterations: int
    seconds: float


@dataclass(frozen=True, eq=False)
class MorphResult:
    """Adapted positions and the evidence that the constraints hold.

    Attributes:
        positions_m: (T, M, 3) adapted marker positions [m].
        bone_residual_m: max over frames and bones of | |p_a - p_b| - target | [m].
        position_residual_m: max over hard positional constraints of |p - target| [m].
        steps: per-step reports (all windows).
        windows: number of windows solved.
        seconds: wall time [s] of the whole morph.
        timings: seconds per stage: "mesh", "assemble", "solve", "projection".
    """

    positions_m: np.ndarray
    bone_residual_m: float
    position_residual_m: float
    steps: tuple[MorphStepReport, ...]
    windows: int
    seconds: float
    timings: dict

    @property
    def morph_steps(self) -> int:
        """Morph steps plus re-linearizations of the longest window."""
        return max((s.step for s in self.steps), default=0)


def default_threads() -> int:
    """BLAS threads for the band factorization: 1.

    Measured here: a second thread gains ~10 % on ``dpbtrf`` at 40 markers, while two processes
    that each run two OpenBLAS threads on two cores slowed single steps down 10-40x (busy-waiting
    thread pools). One thread is the robust default; ``MorphConfig.threads`` overrides it.
    """
    return 1


def _second_difference(n: int) -> sp.csr_matrix:
    """(n-2, n) second difference operator (empty for n < 3)."""
    if n < 3:
        return sp.csr_matrix((0, n))
    i = np.arange(n - 2)
    return sp.csr_matrix(
        (np.tile([1.0, -2.0, 1.0], n - 2), (np.repeat(i, 3), (i[:, None] + [0, 1, 2]).ravel())),
        shape=(n - 2, n),
    )


class _Window:
    """The fixed parts of one window's problem: Hessian, its band, constant gradient."""

    def __init__(self, problem: MorphProblem, fixed_frames: int):
        cfg = problem.config
        t0 = time.perf_counter()
        n, m = problem.n_frames, problem.n_markers
        self.problem = problem
        self.fixed_frames = fixed_frames
        mesh = build_interaction_mesh(problem.source, weighting=cfg.weights.weighting)
        t1 = time.perf_counter()
        lap = mesh.laplacian
        w_accel = cfg.weights.accel * (problem.fps / 30.0) ** 4
        d2 = _second_difference(n)
        h_scalar = (lap.T @ lap + w_accel * sp.kron(d2.T @ d2, sp.identity(m))).tocsr()
        h_shape = sp.kron(h_scalar, sp.identity(3), format="csr")
        self.v_src = problem.source.reshape(-1)
        self.h_shape = h_shape
        soft_mask = np.isfinite(problem.soft_positions_m)
        self.soft_w = (problem.soft_weights[..., None] * soft_mask).reshape(-1)
        self.soft_target_final = np.where(soft_mask, problem.soft_positions_m,
                                          problem.source).reshape(-1)
        self.anchor = cfg.weights.anchor
        diag = self.anchor + self.soft_w
        hessian = (h_shape + sp.diags(diag)).tocsr()
        self.hessian = hessian
        # Hard positional rows: user targets, plus every coordinate of the fixed seam frames.
        hard = np.isfinite(problem.hard_positions_m)
        hard[:fixed_frames] = True
        self.pos_cols = np.flatnonzero(hard.reshape(-1))
        self.pos_final = np.where(np.isfinite(problem.hard_positions_m), problem.hard_positions_m,
                                  problem.source).reshape(-1)[self.pos_cols]
        # Bone rows on all frames that are not fixed (fixed frames are pinned entirely).
        self.bone_frames = np.arange(fixed_frames, n)
        b = problem.bones
        fr = self.bone_frames
        marker_cols = (fr[:, None, None] * m + b[None, :, :])  # (F, B, 2)
        bone_cols = marker_cols[..., None] * 3 + np.arange(3)  # (F, B, 2, 3)
        self._build_contacts(problem)
        self._build_planes(problem)
        # Constraint rows couple 2 markers of one frame: inside the 6M band of the Hessian.
        kd = 6 * m if n >= 3 else 3 * m - 1
        self.kkt = BandedKKT(hessian, kd, bone_cols.reshape(-1, 2, 3), self.pos_cols,
                             cfg.lagrangian.penalty,
                             soft_cols=np.concatenate([self.contact_cols, self.plane_cols]))
        self.seconds_mesh = t1 - t0
        self.seconds_assemble = time.perf_counter() - t1

    def _build_contacts(self, problem: MorphProblem) -> None:
        """Soft pair rows for close non-constrained marker pairs of every source frame."""
        cfg = problem.config
        m = problem.n_markers
        ratio = problem.target_lengths_m / problem.source_lengths_m
        self.shape_scale = float(np.median(ratio))
        self.contact_frames = np.zeros(0, dtype=np.int64)
        self.contact_pairs = np.zeros((0, 2), dtype=np.int64)
        self.contact_cols = np.zeros((0, 2, 3), dtype=np.int64)
        self.contact_d0 = self.contact_w = np.zeros(0)
        if cfg.weights.contact <= 0:
            return
        i, j = np.triu_indices(m, k=1)
        joined = np.zeros((m, m), dtype=bool)
        joined[problem.bones[:, 0], problem.bones[:, 1]] = True
        joined |= joined.T
        keep = ~joined[i, j]
        pairs = np.stack([i[keep], j[keep]], axis=1)
        d = np.linalg.norm(problem.source[:, pairs[:, 0]] - problem.source[:, pairs[:, 1]],
                           axis=2)  # (T, P)
        d_max = cfg.weights.contact_fraction * problem.height_m
        fr, k = np.nonzero(d < d_max)
        self.contact_frames = fr
        self.contact_pairs = pairs[k]
        self.contact_d0 = d[fr, k]
        self.contact_w = cfg.weights.contact * (1.0 - self.contact_d0 / d_max)
        marker_cols = fr[:, None] * m + self.contact_pairs  # (R, 2)
        self.contact_cols = marker_cols[..., None] * 3 + np.arange(3)

    def _build_planes(self, problem: MorphProblem) -> None:
        """Soft pair rows of the bend planes (:mod:`.planes`): per frame and chain, (middle,
        end a) then (middle, end b), each with half the chain's weight."""
        planes = problem.planes
        n, m = problem.n_frames, problem.n_markers
        self.plane_cols = np.zeros((0, 2, 3), dtype=np.int64)
        self.plane_w = np.zeros(0)
        if not len(planes):
            return
        mid = planes.markers[:, 1]
        pairs = np.stack([np.stack([mid, planes.markers[:, 0]], 1),
                          np.stack([mid, planes.markers[:, 2]], 1)])  # (2, H, 2)
        marker_cols = (np.arange(n)[None, :, None, None] * m + pairs[:, None])  # (2, T, H, 2)
        self.plane_cols = (marker_cols[..., None] * 3 + np.arange(3)).reshape(-1, 2, 3)
        w = 0.5 * problem.config.weights.plane * problem.plane_weights  # (T, H)
        self.plane_w = np.concatenate([w.reshape(-1), w.reshape(-1)])

    def soft_terms(self, current: np.ndarray, alpha: float
                   ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """(directions (R_s, 3), weights (R_s,), gaps (R_s,)) of the soft pair rows at
        fraction alpha: the close pairs' distances (gap: target - current distance), then the
        bend planes (gap: -n . v, which puts the middle marker in its plane)."""
        if not len(self.contact_frames) and not len(self.plane_cols):
            return None, None, None
        pos = current.reshape(self.problem.source.shape)
        d = pos[self.contact_frames, self.contact_pairs[:, 0]] - pos[
            self.contact_frames, self.contact_pairs[:, 1]]
        length = np.linalg.norm(d, axis=1)
        u = d / np.maximum(length, 1e-12)[:, None]
        target = self.contact_d0 * (1.0 - alpha + alpha * self.shape_scale)
        if not len(self.plane_cols):
            return u, self.contact_w, target - length
        p = self.problem
        normal, gap = plane_normals(pos, p.planes, p.plane_angles_rad)
        normal, gap = normal.reshape(-1, 3), gap.reshape(-1)
        return (np.concatenate([u, normal, normal]),
                np.concatenate([self.contact_w, self.plane_w]),
                np.concatenate([target - length, gap, gap]))

    def targets(self, alpha: float, seam: np.ndarray | None) -> np.ndarray:
        """c (R,): bone lengths then positional targets at fraction alpha."""
        p = self.problem
        fr = self.bone_frames
        lengths = (1 - alpha) * p.source_lengths_m[fr] + alpha * p.target_lengths_m[fr]
        pos_target = (1 - alpha) * self.v_src[self.pos_cols] + alpha * self.pos_final
        if seam is not None:
            k = self.fixed_frames * p.n_markers * 3
            is_seam = self.pos_cols < k
            pos_target[is_seam] = seam.reshape(-1)[self.pos_cols[is_seam]]
        return np.concatenate([lengths.reshape(-1), pos_target])

    def directions(self, current: np.ndarray) -> np.ndarray:
        """(R_b, 3) unit bone directions at the current solution (the linearization point)."""
        p = self.problem
        return bone_directions(current.reshape(p.source.shape)[self.bone_frames],
                               p.bones).reshape(-1, 3)

    def residual_gradient(self, x: np.ndarray, alpha: float) -> np.ndarray:
        """-(gradient of the step's objective) at x: the right-hand side for the increment.

        E = 1/2 |V' - s V|_{H_shape}^2 + soft + anchor(V' - x), whose anchor gradient vanishes
        at x. The reference shape grows with the overall target scale s (Laplacian coordinates
        and accelerations are not scale invariant; a uniformly scaled skeleton costs nothing).
        Written as H_shape (s V - x) so an identity morph gives exactly zero.
        """
        shape_scale = 1.0 - alpha + alpha * self.shape_scale
        soft_target = (1 - alpha) * self.v_src + alpha * self.soft_target_final
        return self.h_shape @ (shape_scale * self.v_src - x) + self.soft_w * (soft_target - x)


def _run_window(problem: MorphProblem, index: int, seams: list | None, keep_frames: int,
                progress: Callable[[MorphStepReport], None] | None = None,
                ) -> tuple[np.ndarray, list[MorphStepReport], list[np.ndarray], dict]:
    """All morph steps of one window.

    Args:
        problem: the window's frames.
        index: window index (for reports).
        seams: per step (K entries, then the final), the (2, M, 3) positions of the window's
            first two frames from the previous window; None for the first window.
        keep_frames: frames of this window that are kept; the two before that index are the
            next window's seam, recorded at every step.

    Returns:
        (positions (T_w, M, 3), step reports, seam snapshots for the next window, timings).
    """
    cfg = problem.config
    fixed = 2 if seams is not None else 0
    win = _Window(problem, fixed)
    x = win.v_src.copy()
    lam = None
    reports: list[MorphStepReport] = []
    snapshots: list[np.ndarray] = []
    shape = problem.source.shape
    solve_seconds = 0.0
    step = 0
    polish = 0
    while True:
        step += 1
        alpha = min(1.0, step / cfg.steps)
        seam = None
        if seams is not None:
            seam = seams[min(step, len(seams)) - 1]
        t0 = time.perf_counter()
        u_soft, w_soft, gap_soft = win.soft_terms(x, alpha)
        win.kkt.factor(win.directions(x), u_soft, w_soft)
        a = win.kkt.constraint_matrix
        rhs = win.residual_gradient(x, alpha)
        if u_soft is not None:
            assert w_soft is not None and gap_soft is not None  # all three or none
            rhs += win.kkt.soft_matrix.T @ (np.sqrt(w_soft) * gap_soft)
        # Solve for the increment dx = x' - x: for an identity morph it is exactly zero, and
        # round-off scales with the step, not with the distance of the markers from the origin.
        sol = win.kkt.solve(rhs, win.targets(alpha, seam) - a @ x, multipliers=lam,
                            tolerance=cfg.lagrangian.tolerance_m,
                            # intermediate targets (linear in alpha) need not be exactly
                            # consistent, and the first solve at the final targets starts
                            # from a stale linearization; only the last solve must succeed
                            fail_tolerance=(cfg.lagrangian.fail_tolerance_m
                                            if step >= cfg.steps + cfg.max_polish_steps
                                            else np.inf),
                            max_iterations=cfg.lagrangian.max_iterations)
        x, lam = x + sol.x, sol.multipliers
        pos = x.reshape(shape)
        target = (1 - alpha) * problem.source_lengths_m + alpha * problem.target_lengths_m
        bone_res = float(np.abs(bone_lengths(pos, problem.bones) - target)[fixed:].max())
        dt = time.perf_counter() - t0
        solve_seconds += dt
        reports.append(MorphStepReport(index, step, alpha, bone_res, sol.residual,
                                       sol.iterations, dt))
        if progress is not None:
            progress(reports[-1])
        log.debug("window %d step %d alpha %.3f: bone residual %.3g m, %d AL iterations, %.3f s",
                  index, step, alpha, bone_res, sol.iterations, dt)
        if step <= cfg.steps:
            snapshots.append(pos[keep_frames - 2:keep_frames].copy())
        if step >= cfg.steps and (bone_res <= cfg.bone_tolerance_m
                                  or polish >= cfg.max_polish_steps):
            break
        if step >= cfg.steps:
            polish += 1
    final = x.reshape(shape)
    snapshots[-1] = final[keep_frames - 2:keep_frames].copy()
    timings = {"mesh": win.seconds_mesh, "assemble": win.seconds_assemble, "solve": solve_seconds}
    return final, reports, snapshots, timings


def window_layout(n_frames: int, window: int, lookahead: int) -> list[tuple[int, int, int]]:
    """(start, stop, keep_stop) per window; window k keeps frames [start + 2, keep_stop) for
    k > 0 and [0, keep_stop) for k = 0; consecutive windows share exactly two (fixed) frames."""
    if n_frames <= window:
        return [(0, n_frames, n_frames)]
    layout = []
    start = 0
    while True:
        stop = min(n_frames, start + window)
        keep = stop if stop == n_frames else stop - lookahead
        layout.append((start, stop, keep))
        if stop == n_frames:
            return layout
        start = keep - 2


def solve_morph(problem: MorphProblem,
                progress: Callable[[MorphStepReport], None] | None = None) -> MorphResult:
    """Run the morph steps of ``problem`` over all frames (windowed for long clips).

    Args:
        problem: the validated problem (``build_morph_problem``).
        progress: called with each step's report as it completes (progress bars).

    Returns:
        MorphResult with positions, final residuals and per-step reports.

    Raises:
        SolverError: a solve failed to meet ``constraint_tolerance_m``.
    """
    cfg = problem.config
    t_start = time.perf_counter()
    out = np.empty_like(problem.source)
    reports: list[MorphStepReport] = []
    timings = {"mesh": 0.0, "assemble": 0.0, "solve": 0.0}
    layout = window_layout(problem.n_frames, cfg.window_frames, cfg.window_lookahead)
    seams = None
    with threadpool_limits(limits=cfg.threads or default_threads(), user_api="blas"):
        for k, (start, stop, keep) in enumerate(layout):
            sub = problem.frames(start, stop)
            pos, rep, snaps, tim = _run_window(sub, k, seams, keep - start, progress)
            first = 0 if k == 0 else 2
            out[start + first:keep] = pos[first:keep - start]
            reports.extend(rep)
            seams = snaps
            for key in timings:
                timings[key] += tim[key]
    hard = np.isfinite(problem.hard_positions_m)
    t_proj = time.perf_counter()
    out, proj_iter, bone_res = project_lengths(out, problem.bones, problem.target_lengths_m,
                                               hard, tolerance_m=cfg.bone_tolerance_m)
    timings["projection"] = time.perf_counter() - t_proj
    if bone_res > cfg.bone_tolerance_m:
        log.warning("morph: bone residual %.3g m after %d projection iterations (tolerance "
                    "%.3g m)", bone_res, proj_iter, cfg.bone_tolerance_m)
    pos_res = float(np.abs(out[hard] - problem.hard_positions_m[hard]).max()) if hard.any() else 0.0
    seconds = time.perf_counter() - t_start
    log.info("morph: %d frames x %d markers, %d window(s), %d steps: bone residual %.2e m, "
             "position residual %.2e m, %.2f s", problem.n_frames, problem.n_markers, len(layout),
             cfg.steps, bone_res, pos_res, seconds)
    return MorphResult(positions_m=out, bone_residual_m=bone_res, position_residual_m=pos_res,
                       steps=tuple(reports), windows=len(layout), seconds=seconds, timings=timings)

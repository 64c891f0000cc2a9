"""The interaction mesh and the spacetime morph solver: invariants and exact answers."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from imesh import (
    ConstraintError,
    MarkerMotion,
    MorphConfig,
    MorphWeights,
    build_interaction_mesh,
    build_morph_problem,
    fill_gaps,
    load_motion,
    solve_morph,
    to_standard,
)
from imesh.io.synthetic import synthetic_walk_clap
from imesh.mesh.bones import bone_lengths
from imesh.morph.adapt import adapt_motion
from imesh.morph.solver import _Window, window_layout


@pytest.fixture(scope="module")
def walk(mocap):
    return fill_gaps(to_standard(load_motion(mocap("cmu_02_01_walk.bvh"))))


@pytest.fixture(scope="module")
def synthetic():
    return synthetic_walk_clap()


def test_laplacian_rows_sum_to_zero_and_weights_are_inverse_distance(walk):
    mesh = build_interaction_mesh(walk.positions_m[:50])
    lap = mesh.laplacian
    np.testing.assert_allclose(lap @ np.ones(lap.shape[0]), 0.0, atol=1e-12)
    # row of marker 0 in frame 0: off-diagonal weights proportional to 1 / distance
    row = lap.getrow(0).toarray().ravel()[: walk.n_markers]
    nbrs = np.flatnonzero(row[1:] != 0) + 1
    d = np.linalg.norm(walk.positions_m[0, nbrs] - walk.positions_m[0, 0], axis=1)
    w = -row[nbrs]
    np.testing.assert_allclose(w, (1 / d) / (1 / d).sum(), rtol=1e-12)
    # every marker has neighbours in every frame
    assert all(len(np.unique(e)) == walk.n_markers for e in mesh.edges)


def test_degenerate_coplanar_frames_are_meshed():
    rng = np.random.default_rng(1)
    pos = rng.standard_normal((6, 12, 3))
    pos[..., 2] = 0.5  # every frame flat
    mesh = build_interaction_mesh(pos)
    assert mesh.degenerate_frames == tuple(range(6))
    assert all(len(np.unique(e)) == 12 for e in mesh.edges)


@pytest.mark.parametrize("name", ["walk", "synthetic"])
def test_identity_morph_returns_input(name, walk, synthetic):
    motion = {"walk": walk, "synthetic": synthetic}[name]
    result = solve_morph(build_morph_problem(motion))
    assert np.abs(result.positions_m - motion.positions_m).max() <= 1e-9
    assert result.bone_residual_m <= 1e-9


def test_one_step_matches_dense_kkt_solution(walk):
    """The banded multiplier method returns the exact solution of the step's KKT system."""
    motion = walk.frames(0, 40)
    cfg = MorphConfig(steps=1, max_polish_steps=0, weights=MorphWeights(contact=0.0),
                      bone_tolerance_m=1.0)
    target = bone_lengths(motion.positions_m, motion.bones) * 1.2
    problem = build_morph_problem(motion, target_lengths_m=target, config=cfg)
    result = solve_morph(problem)
    win = _Window(problem, 0)
    x0 = win.v_src
    win.kkt.factor(win.directions(x0))
    a = win.kkt.constraint_matrix
    h = win.hessian
    # the step's QP in x: min 1/2 x^T H x - g^T x, g = H x0 + residual_gradient(x0)
    g = h @ x0 + win.residual_gradient(x0, 1.0)
    c = win.targets(1.0, None)
    kkt = sp.bmat([[h, a.T], [a, None]], format="csc")
    sol = sp.linalg.spsolve(kkt, np.concatenate([g, c]))
    x_dense = sol[: h.shape[0]].reshape(motion.positions_m.shape)
    # the solver's own result also went through the final projection (micrometres)
    assert np.abs(result.positions_m - x_dense).max() < 1e-4
    # without projection the multiplier method reproduces the dense solve; the penalty makes
    # K ill-conditioned along global translations (which no constraint sees), so agreement is
    # to a fraction of a micrometre, while the constraints themselves hold to 1e-12 m
    x = x0 + win.kkt.solve(g - h @ x0, c - a @ x0, tolerance=1e-12).x
    assert np.abs(x - sol[: h.shape[0]]).max() < 1e-6
    assert np.abs(a @ x - c).max() < 1e-12


def test_zero_target_length_is_a_constraint_error(walk):
    target = bone_lengths(walk.positions_m, walk.bones)
    target[7, 3] = 0.0
    with pytest.raises(ConstraintError, match=r"bone .* at frame 7"):
        build_morph_problem(walk, target_lengths_m=target)


def test_nan_target_length_is_a_constraint_error(walk):
    target = bone_lengths(walk.positions_m, walk.bones)[0].copy()
    target[2] = np.nan
    with pytest.raises(ConstraintError, match="finite"):
        build_morph_problem(walk, target_lengths_m=target)


def test_uniform_scale_costs_nothing(walk):
    """Scaling every bone by 1.2 keeps every height-normalized distance (a similarity)."""
    result = adapt_motion(walk, scales={"all": 1.2})
    rep = result.report()
    assert rep["bone_residual_m"] <= 1e-6
    assert rep["close_pair_error"] < 1e-4


def test_hard_positions_and_bones_hold_together(walk):
    """Arms 1.3x with the pelvis pinned to a shifted trajectory: both hold to 1e-6 m."""
    hard = np.full(walk.positions_m.shape, np.nan)
    pelvis = walk.index("pelvis")
    hard[:, pelvis] = walk.positions_m[:, pelvis] + [0.0, 0.0, -0.05]
    result = adapt_motion(walk, scales={"arms": 1.3}, hard_positions_m=hard)
    assert result.morph.bone_residual_m <= 1e-6
    assert result.morph.position_residual_m <= 1e-6
    lengths = bone_lengths(result.adapted.positions_m, walk.bones)
    src = bone_lengths(walk.positions_m, walk.bones)
    arm = [k for k, (_, b) in enumerate(walk.bones) if walk.names[b] == "elbow_l"][0]
    np.testing.assert_allclose(lengths[:, arm], 1.3 * src[:, arm], atol=1e-6)


def test_window_layout_covers_every_frame_once():
    layout = window_layout(1000, 300, 40)
    kept = []
    for k, (start, stop, keep) in enumerate(layout):
        kept.extend(range(start + (2 if k else 0), keep))
        assert stop - start <= 300
    assert kept == list(range(1000))


def test_windowed_solve_is_continuous_and_close_to_the_full_solve(synthetic):
    target = bone_lengths(synthetic.positions_m, synthetic.bones) * 1.25
    full = solve_morph(build_morph_problem(synthetic, target_lengths_m=target))
    cfg = MorphConfig(window_frames=150, window_lookahead=30)
    win = solve_morph(build_morph_problem(synthetic, target_lengths_m=target, config=cfg))
    assert win.windows > 2
    assert win.bone_residual_m <= 1e-6
    assert np.abs(win.positions_m - full.positions_m).max() < 5e-3
    # no jump at the seams: second differences there are like those elsewhere
    acc = np.linalg.norm(np.diff(win.positions_m, 2, axis=0), axis=2).max(axis=1)
    acc_full = np.linalg.norm(np.diff(full.positions_m, 2, axis=0), axis=2).max(axis=1)
    assert acc.max() <= 1.5 * acc_full.max() + 1e-6


def test_marker_motion_rejects_bad_shapes():
    from imesh import InvalidMotionError

    with pytest.raises(InvalidMotionError, match=r"\(T, M, 3\)"):
        MarkerMotion(positions_m=np.zeros((3, 4)), fps=30, names=list("abcd"),
                     valid=np.ones((3, 4), bool))

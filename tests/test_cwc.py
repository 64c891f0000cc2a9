"""The contact wrench cone (imesh.balance.cwc), its rows in the whole-body QP (imesh.solve.cwc)
and the evaluator's test (imesh.metrics.cwc)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import nnls

from imesh.balance.cwc import (
    ConeError,
    contact_wrench_cone,
    pyramid_generators,
    required_wrench,
    sole_wrench_cone,
    sole_yaw_ratio,
)
from imesh.solve.cwc import ConePlan, cone_violation, plan_cones, wrench_rows
from imesh.solve.operators import Layout, gradient_operator
from imesh.solve.plan import Linearization

# the G1's soles (170 x 60 mm) side by side, 0.2 m apart, on the floor
SOLE = np.array([[a, b, 0.0] for a in (-0.085, 0.085) for b in (-0.03, 0.03)])
FEET = np.concatenate([SOLE + [0.0, 0.1, 0.0], SOLE + [0.0, -0.1, 0.0]])
# two hands on a box top 0.742 m high (box1 at the G1's scale), 0.45 m ahead of the feet
HANDS = np.array([[0.45, 0.15, 0.742], [0.45, -0.15, 0.742]])
UP = np.array([0.0, 0.0, 1.0])
MASS = 35.0


def _cone(points):
    return contact_wrench_cone(points, np.tile(UP, (len(points), 1)))


def test_face_form_agrees_with_the_span_form():
    """The hull's faces say inside exactly where a non-negative combination of the generators
    reaches the wrench (NNLS residual 0), on random contact sets and wrenches."""
    rng = np.random.default_rng(3)
    disagree, inside = 0, 0
    for _ in range(150):
        k = int(rng.integers(1, 4))
        p = rng.uniform(-0.5, 0.5, (k, 3))
        n = np.tile(UP, (k, 1))
        n[:, :2] += rng.uniform(-0.3, 0.3, (k, 2))
        cone = contact_wrench_cone(p, n)
        V = pyramid_generators(p, n, cone.ref_m)
        # half inside by construction (a non-negative combination, nudged), half anywhere
        w = V.T @ rng.exponential(size=len(V)) if rng.random() < 0.5 else rng.normal(size=6)
        w = w + 0.05 * rng.normal(size=6)
        lam, res = nnls(V.T, w)
        ins = cone.violation(w) <= 1e-9
        inside += ins
        disagree += ins != (res < 1e-7)
    assert disagree == 0
    assert 20 < inside < 130  # both cases were exercised


def test_the_sole_yaw_ratio_is_the_cones_yaw_rows():
    """``sole_yaw_ratio`` <= 1 exactly where a wrench meeting the sole cone's other rows meets
    its yaw rows too, on random wrenches of a 170 x 60 mm sole (mu 0.7); a pure yaw moment on a
    centred load reads |m_z| / (mu (X + Y) f_z)."""
    rng = np.random.default_rng(5)
    C = sole_wrench_cone(0.085, 0.03, 0.7)
    yaw_rows = np.arange(8, 16)
    other = np.r_[np.arange(8), 16]
    checked = inside = 0
    for _ in range(400):
        fz = rng.uniform(50.0, 500.0)
        w = np.r_[rng.uniform(-0.6, 0.6, 2) * fz, fz, rng.uniform(-0.028, 0.028) * fz,
                  rng.uniform(-0.08, 0.08) * fz, rng.uniform(-0.1, 0.1) * fz]
        if np.any(C[other] @ w > 0):
            continue
        checked += 1
        r = float(sole_yaw_ratio(w, 0.085, 0.03, 0.7))
        ok = bool(np.all(C[yaw_rows] @ w <= 1e-9))
        inside += ok
        assert ok == (r <= 1.0 + 1e-9), (w, r)
    assert checked > 100 and 10 < inside < checked  # both cases were exercised
    pure = np.array([0.0, 0.0, 200.0, 0.0, 0.0, -8.0])
    assert float(sole_yaw_ratio(pure, 0.085, 0.03, 0.7)) == pytest.approx(8.0 / (0.7 * 0.115 * 200))


def test_a_scaled_sole_cone_holds_that_fraction_of_the_yaw_moment():
    """The whole-body solve's single-support yaw rows (``ForceOptions.yaw_sole_scale``): the
    cone of a sole scaled by s about its centre holds s times the yaw moment of the whole
    sole's at the same normal force (the largest pure yaw moment inside each cone)."""
    from imesh.robot import load_robot

    robot = load_robot("g1")
    T = 3
    support = np.zeros((T, 2), dtype=bool)
    support[:, 0] = True
    pose = np.eye(4)
    pose[:3, 3] = [0.1, 0.2, 0.0]
    targets = np.full((T, 2, 4, 4), np.nan)
    targets[:, 0] = pose
    centre = pose[:3, :3] @ robot.soles["left"].center + pose[:3, 3]

    def largest_yaw(scale):
        cone = plan_cones(robot, support, targets, None, None, np.arange(T),
                          sole_scale=scale).cones[0]
        lo, hi = 0.0, 50.0  # per unit mass, at 1 g of normal force, about the sole centre
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            w = np.r_[0.0, 0.0, 9.81, np.cross(centre - cone.ref_m, [0.0, 0.0, 9.81])
                      + [0.0, 0.0, mid]]
            lo, hi = (mid, hi) if cone.violation(w) <= 0 else (lo, mid)
        return lo

    full = largest_yaw(1.0)
    assert full > 0.05
    assert largest_yaw(0.5) == pytest.approx(0.5 * full, rel=1e-6)


def test_leaning_on_the_hands_is_inside_only_with_the_hands():
    """A static pose leaning onto a box: the CoM 0.25 m ahead of the soles' front edge at
    0.6 m. With the hands on the box top the gravito-inertial wrench is inside the cone; the
    same pose on the feet alone is outside (its ZMP would be 0.25 m ahead of the soles)."""
    com = np.array([0.25, 0.0, 0.6])
    both = _cone(np.concatenate([FEET, HANDS]))
    feet = _cone(FEET)
    w_both = required_wrench(com, np.zeros(3), np.zeros(3), MASS, both.ref_m)
    w_feet = required_wrench(com, np.zeros(3), np.zeros(3), MASS, feet.ref_m)
    assert both.violation(w_both) < -0.5
    # outside by the moment: 9.81 x (0.25 - 0.085) per unit row, about 1.6
    assert feet.violation(w_feet) == pytest.approx(1.6, abs=0.1)
    # standing upright over the feet is inside either way
    upright = np.array([0.0, 0.0, 0.6])
    assert feet.violation(required_wrench(upright, np.zeros(3), np.zeros(3), MASS,
                                          feet.ref_m)) < -0.5


def test_two_hands_alone_span_five_dimensions():
    """Hanging on two point contacts: no moment about the line through them (one equality
    row); the CoM right under the line is on the cone, 5 cm beside it is not."""
    cone = _cone(HANDS)
    assert cone.equalities.shape == (1, 6)
    under = required_wrench(np.array([0.45, 0.0, 0.3]), np.zeros(3), np.zeros(3), MASS,
                            cone.ref_m)
    beside = required_wrench(np.array([0.40, 0.0, 0.3]), np.zeros(3), np.zeros(3), MASS,
                             cone.ref_m)
    assert cone.violation(under) == pytest.approx(0.0, abs=1e-9)
    assert cone.violation(beside) > 0.4


def test_a_contact_not_pushing_up_is_refused():
    with pytest.raises(ConeError):
        contact_wrench_cone(HANDS, np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))


def _linearization(com, acc, ldot):
    """A Linearization carrying what the cone rows read (the CoM, its acceleration, the
    angular momentum's rate, the mass); the rest empty."""
    fields = {f.name: None for f in dataclasses.fields(Linearization)
              if f.default is dataclasses.MISSING}
    fields.update(com=com, com_acceleration=acc, angular_momentum_rate=ldot, mass=MASS)
    return Linearization(**fields)


def test_cone_rows_jacobian_matches_finite_differences():
    """The QP's map from the CoM and momentum auxiliaries (x, y and the cone's z) to the
    wrench's change (:func:`imesh.solve.cwc.wrench_rows`) against finite differences of the
    exact wrench ``w(c, k)`` with ``c'' = D c``, ``Ld = grad k``."""
    T, fps, nv = 12, 30.0, 4
    lay = Layout(n_frames=T, nv=nv, cone=True)
    grad = gradient_operator(T, 1.0 / fps)
    Dacc = (grad @ grad).tocsr()
    rng = np.random.default_rng(7)
    c = np.c_[0.1 * np.sin(np.arange(T) / 3), 0.05 * np.cos(np.arange(T) / 2),
              0.6 + 0.02 * np.arange(T)]
    k = rng.normal(size=(T, 3))

    def exact(c_, k_):
        return np.asarray(Dacc @ c_), np.asarray(grad @ k_)

    acc, ld = exact(c, k)
    cones = ConePlan(frames=np.arange(T), cone=np.zeros(T, dtype=int),
                     cones=(_cone(np.concatenate([FEET, HANDS])),))
    plan = type("P", (), {"cones": cones})  # the only field wrench_rows reads of a plan
    w0, dw = wrench_rows(_linearization(c, acc, ld), plan, lay, grad, Dacc)
    assert np.abs(w0 - required_wrench(c, acc, ld, MASS, cones.refs(T))).max() == 0.0
    assert all(sp.issparse(m) for m in dw)
    direction_c, direction_k = rng.normal(size=(T, 3)), rng.normal(size=(T, 3))
    base = np.arange(T) * lay.nx
    errors = []
    for eps in (1e-4, 5e-5):
        x = np.zeros(lay.n)
        for i in range(3):
            x[base + lay.offset["com"] + i] = eps * direction_c[:, i]
        for i, name in enumerate(("momentum", "momentum", "momentum_z")):
            x[base + lay.offset[name] + (i if i < 2 else 0)] = eps * direction_k[:, i]
        acc1, ld1 = exact(c + eps * direction_c, k + eps * direction_k)
        change = required_wrench(c + eps * direction_c, acc1, ld1, MASS, cones.refs(T)) - w0
        predicted = np.stack([m @ x for m in dw], axis=1)
        assert np.abs(change).max() > 1e-2 * eps / 1e-4  # the perturbation moves the wrench
        errors.append(np.abs(predicted - change).max() / np.abs(change).max())
    # the rows are the exact first order: what is left is the product dc x dc'' (second order)
    assert errors[0] < 1e-3
    assert errors[1] / errors[0] == pytest.approx(0.5, rel=0.05)


def test_cone_violation_is_what_the_slack_covers():
    """On a static lean the merit's per-frame violation is 0 with the hands and the face
    value plus the margin without them."""
    T = 3
    com = np.tile([0.25, 0.0, 0.6], (T, 1))
    zero = np.zeros((T, 3))
    lin = _linearization(com, zero, zero)
    for points, expect_zero in ((np.concatenate([FEET, HANDS]), True), (FEET, False)):
        cone = _cone(points)
        plan = type("P", (), {"cones": ConePlan(frames=np.arange(T),
                                                cone=np.zeros(T, dtype=int), cones=(cone,))})
        v = cone_violation(lin, plan)
        if expect_zero:
            assert (v == 0.0).all()
        else:
            w = required_wrench(com[0], zero[0], zero[0], MASS, cone.ref_m)
            assert v == pytest.approx(cone.violation(w) + 0.05, abs=1e-12)


# JVRC-1's hand and knee contacts in a frame of the holosoma climb seq_1 (the whole sequence
# retargeted with the boxes): the hand's two proxy points at rows 3 and 5 are 1.2e-7 m apart
NEAR_DUPLICATE = np.array([
    [-0.6033662228057804, -0.6717101802012845, 0.8680271938302162],
    [0.09210791023820178, -0.5031565379077061, 0.8644920032635973],
    [0.07949693104103742, -0.5952978295297688, 0.8644857820718254],
    [0.07129939313116858, -0.4730574649164343, 0.8684048980351422],
    [0.06519734016639929, -0.5176417143176628, 0.8684018877977052],
    [0.07129939703664197, -0.4730573572711654, 0.8684048384644245]])


def test_a_contact_listed_twice_is_one_contact():
    """Two contacts a fraction of a micrometre apart (which made Qhull stop with a "dupridge"
    topology error and the evaluator with a traceback) give the cone of one: the same faces as
    without the duplicate, about the same reference point; a duplicated sole corner likewise."""
    cone = _cone(NEAR_DUPLICATE)
    alone = contact_wrench_cone(NEAR_DUPLICATE[:5], np.tile(UP, (5, 1)),
                                ref_m=NEAR_DUPLICATE.mean(axis=0))
    np.testing.assert_allclose(cone.ref_m, alone.ref_m)
    np.testing.assert_allclose(cone.faces, alone.faces, atol=1e-9)
    twice = _cone(np.vstack([FEET, FEET[:1]]))
    once = contact_wrench_cone(FEET, np.tile(UP, (len(FEET), 1)),
                               ref_m=np.vstack([FEET, FEET[:1]]).mean(axis=0))
    np.testing.assert_allclose(twice.faces, once.faces, atol=1e-12)

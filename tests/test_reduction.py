"""Motion reduction with dynamical consistency (imesh.reduction, Okada & Miyazaki)."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from imesh.errors import OptionError
from imesh.reduction.chain import LINKS, rot
from imesh.reduction.contact import contact_schedule, quintic
from imesh.reduction.diff import (
    circulant,
    derivative_gain,
    derivative_matrices,
    impulse_response,
    reversal,
)
from imesh.reduction.dynamics import ChainDynamics, planar_biped_chain
from imesh.reduction.pca import pca_basis

# ----------------------------------------------------------------------------------------------
# differentiation matrices (eqs 14-22)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_f1_f2_differentiate_a_sinusoid_within_1_percent(k):
    n, dt, cutoff = 128, 1 / 120, 40.0
    t = np.arange(n) * dt
    w = 2 * np.pi * k / (n * dt)                     # k cycles per window: 0.94 .. 2.8 Hz
    assert w / (2 * np.pi) <= 0.075 * cutoff          # "away from the cut-off"
    x = np.sin(w * t + 0.3)[None, :]
    F1, F2 = derivative_matrices(n, dt, cutoff)
    d1 = (x @ F1)[0]
    d2 = (x @ F2)[0]
    assert np.max(np.abs(d1 - w * np.cos(w * t + 0.3))) <= 0.01 * w
    assert np.max(np.abs(d2 + w * w * np.sin(w * t + 0.3))) <= 0.01 * w * w
    # measured gain = the documented gain (zero phase) at any frequency
    for kk in (k, 8 * k):
        wk = 2 * np.pi * kk / (n * dt)
        dk = (np.sin(wk * t + 0.3)[None, :] @ F1)[0]
        assert np.allclose(dk, derivative_gain(wk / (2 * np.pi), dt, cutoff) * wk
                           * np.cos(wk * t + 0.3), atol=1e-9 * wk)


def test_f1_is_the_papers_construction():
    n, dt, cutoff = 40, 0.01, 8.0
    g_sf = impulse_response("sf", n, dt, cutoff)
    g_f = impulse_response("f", n, dt, cutoff)
    F_sf, F_f, R = circulant(g_sf), circulant(g_f), reversal(n)
    assert np.allclose(F_sf[0], g_sf) and np.allclose(F_sf[1], np.roll(g_sf, 1))   # eq. 17
    F1, F2 = derivative_matrices(n, dt, cutoff)
    assert np.allclose(F1, F_sf @ R @ F_f @ R)                                        # eq. 21
    assert np.allclose(F2, F1 @ F1)                                                   # eq. 22
    assert np.allclose(F1 + F1.T, 0, atol=1e-12)      # zero phase: an antisymmetric operator
    assert np.allclose(np.ones(n) @ F1, 0, atol=1e-12)  # constants have no derivative
    # a zig-zag at the Nyquist frequency is invisible to the filter differentiator
    assert np.allclose((np.array([1.0, -1.0] * (n // 2)) @ F1), 0, atol=1e-9)
    with pytest.raises(OptionError):
        derivative_matrices(2, dt, cutoff)


# ----------------------------------------------------------------------------------------------
# PCA (eqs 23-29)


def test_pca_round_trip_and_gradient():
    rng = np.random.default_rng(0)
    n = 60
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    theta = np.stack([np.sin(t), 0.5 * np.cos(t), np.sin(t) + 0.2, 0.1 * np.sin(3 * t),
                      1.0 + 0 * t]) + 1e-3 * rng.normal(size=(5, n))
    full = pca_basis(theta, None)
    assert np.allclose(full.restore(full.reduce(theta)), theta)
    for r in (1, 2, 3):
        b = pca_basis(theta, r)
        hat = b.reduce(theta)
        assert hat.shape == (r, n)
        err = np.linalg.norm(theta - b.restore(hat))
        assert err == pytest.approx(np.sqrt(np.sum(b.singular_values[r:] ** 2)), rel=1e-9)
        assert np.allclose(b.reduce(b.restore(hat)), hat)           # Q1^T Q1 = I
        # eq. 28: dE/dTheta_hat = Q1^T dE/dTheta for E = 0.5 |Theta - T0|^2
        target = rng.normal(size=theta.shape)
        g = b.gradient(b.restore(hat) - target)
        d = 1e-6 * rng.normal(size=hat.shape)

        def E(h, b=b, target=target):
            return 0.5 * np.sum((b.restore(h) - target) ** 2)
        assert (E(hat + d) - E(hat - d)) / 2 == pytest.approx(np.sum(g * d), rel=1e-6)
    centred = pca_basis(theta, 2, center=True)
    assert np.allclose(centred.restore(centred.reduce(theta)).mean(axis=1), theta.mean(axis=1))
    with pytest.raises(OptionError):
        pca_basis(theta, 6)


# ----------------------------------------------------------------------------------------------
# the planar biped and its dynamics


@pytest.fixture(scope="module")
def chain():
    return planar_biped_chain()


@pytest.fixture(scope="module")
def dyn(chain):
    return ChainDynamics(chain)


def test_planar_biped_urdf_loads_in_pinocchio_and_dart(chain):
    import dartpy as dart
    import pinocchio as pin

    from imesh.physics.reduction import planar_urdf_text
    from imesh.reduction.dynamics import PLANAR_BIPED_URDF

    model = pin.buildModelFromUrdf(str(PLANAR_BIPED_URDF), pin.JointModelFreeFlyer())
    assert model.nv == 12 and pin.computeTotalMass(model) == pytest.approx(8.4)
    assert chain.total_mass == pytest.approx(8.4)
    assert chain.height == pytest.approx(0.61, abs=0.005)
    assert np.degrees(chain.pad_angle) == pytest.approx([20.0, 20.0], abs=0.01)
    loader = dart.utils.DartLoader()
    opts = dart.utils.DartLoader.Options()
    tiny = dart.dynamics.Inertia()
    tiny.setMass(1e-6)
    opts.mDefaultInertia = tiny
    loader.setOptions(opts)
    skel = loader.parseSkeletonString(planar_urdf_text(), "")
    assert skel.getNumDofs() == 9 and skel.getMass() == pytest.approx(8.4, abs=1e-4)


def test_closure_matches_pinocchio_kinematics(chain, dyn):
    import pinocchio as pin

    rng = np.random.default_rng(1)
    for base in (0, 1):
        r = dyn.rooted[base]
        for _ in range(5):
            phi = rng.normal(0, 0.4, 7)
            y, dy = chain.closure(phi[None], base)
            q = dyn.configuration(phi, base)
            pin.forwardKinematics(r.chain.model, r.chain.data, q)
            roller = r.chain.data.oMi[9].act(r.roller_local)
            assert y[0] == pytest.approx(roller[2] - chain.roller_radius[1 - base], abs=1e-12)
            eps = 1e-7
            num = [(chain.closure((phi + eps * e)[None], base)[0][0]
                    - chain.closure((phi - eps * e)[None], base)[0][0]) / (2 * eps)
                   for e in np.eye(7)]
            assert np.allclose(dy[0], num, atol=1e-8)


def test_motion_condition_derivatives(chain):
    rng = np.random.default_rng(2)
    phi, phid = rng.normal(0, 0.3, (4, 7)), rng.normal(0, 1.0, (4, 7))
    base = np.array([0, 1, 0, 1])
    v, dq, dv = chain.slip_velocity(phi, phid, base)
    d, dd = chain.step_length(phi, base)
    eps = 1e-6
    for k in range(7):
        e = np.zeros(7)
        e[k] = eps
        assert np.allclose((chain.slip_velocity(phi + e, phid, base)[0]
                            - chain.slip_velocity(phi - e, phid, base)[0]) / (2 * eps),
                           dq[:, k], atol=1e-7)
        assert np.allclose((chain.slip_velocity(phi, phid + e, base)[0]
                            - chain.slip_velocity(phi, phid - e, base)[0]) / (2 * eps),
                           dv[:, k], atol=1e-7)
        assert np.allclose((chain.step_length(phi + e, base)[0]
                            - chain.step_length(phi - e, base)[0]) / (2 * eps),
                           dd[:, k], atol=1e-7)
    # the slip velocity is the time derivative of the roller's horizontal position
    h = 1e-6
    x = lambda p: chain.chain_points(p, base)[:, 7, 0]   # noqa: E731
    assert np.allclose((x(phi + h * phid) - x(phi - h * phid)) / (2 * h), v, atol=1e-7)


def test_forward_dynamics_derivatives(dyn):
    rng = np.random.default_rng(3)
    T = 4
    phi, phid = rng.normal(0, 0.3, (T, 7)), rng.normal(0, 1.0, (T, 7))
    u = rng.normal(0, 2.0, (T, 6))
    base, case = np.array([0, 1, 0, 1]), np.array([1, 1, 2, 2])
    r = dyn.forward(phi, phid, u, base, case)
    eps = 1e-6
    for name, X, D, G in (("phi", phi, r.dacc_dphi, r.dgrf_dphi),
                          ("phid", phid, r.dacc_dphid, r.dgrf_dphid),
                          ("torque", u, r.dacc_du, r.dgrf_du)):
        for k in range(X.shape[1]):
            args = {"phi": phi, "phid": phid, "torque": u}
            Xp, Xm = X.copy(), X.copy()
            Xp[:, k] += eps
            Xm[:, k] -= eps
            args[name] = Xp
            rp = dyn.forward(**args, base=base, case=case, derivatives=False)
            args[name] = Xm
            rm = dyn.forward(**args, base=base, case=case, derivatives=False)
            scale = 1 + np.abs(D).max()
            assert np.allclose((rp.acc - rm.acc) / (2 * eps), D[:, :, k], atol=1e-5 * scale)
            assert np.allclose((rp.grf - rm.grf) / (2 * eps), G[:, :, k],
                               atol=1e-5 * (1 + np.abs(G).max()))
    # case (i) holds the base foot; case (ii) lets it turn
    assert np.allclose(r.acc[base == 0, 0][case[base == 0] == 1], 0)
    assert np.allclose(r.acc[1, 6], 0)


@pytest.mark.parametrize("case", [1, 2])
def test_rnea_torque_matches_finite_difference_of_the_dynamics(dyn, case):
    """Integrate the constrained forward dynamics under known smooth torques, finite-difference
    the trajectory, and recover the torques with the RNEA-based inverse dynamics."""
    dt, steps = 2e-4, 200
    u_of_t = lambda t: np.array([1.0, -2.0, 0.5, -1.0, 1.5, -0.3]) * np.cos(8 * t) \
        + np.array([0.5, 1.0, 0.2, 0.4, -0.6, 0.1])             # noqa: E731
    phi = np.array([0.35, 0.15, -0.05, -0.1, 0.1, 0.3, -0.15]) if case == 1 else \
        np.array([0.1, 0.15, -0.05, -0.1, 0.1, 0.3, -0.15])
    phid = np.array([0.0, 0.3, -0.2, 0.1, 0.2, -0.4, 0.5])

    def f(p, v, t):
        return dyn.forward(p[None], v[None], u_of_t(t)[None], 0, case, derivatives=False).acc[0]

    P, V = [phi], [phid]
    for i in range(steps):
        t = i * dt
        k1v, k1p = f(phi, phid, t), phid
        k2v = f(phi + 0.5 * dt * k1p, phid + 0.5 * dt * k1v, t + 0.5 * dt)
        k2p = phid + 0.5 * dt * k1v
        k3v = f(phi + 0.5 * dt * k2p, phid + 0.5 * dt * k2v, t + 0.5 * dt)
        k3p = phid + 0.5 * dt * k2v
        k4v = f(phi + dt * k3p, phid + dt * k3v, t + dt)
        k4p = phid + dt * k3v
        phi = phi + dt / 6 * (k1p + 2 * k2p + 2 * k3p + k4p)
        phid = phid + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
        P.append(phi)
        V.append(phid)
    P, V = np.array(P), np.array(V)
    idx = np.arange(10, steps - 10, 20)
    acc_fd = (V[idx + 1] - V[idx - 1]) / (2 * dt)           # finite difference of the motion
    u_true = np.array([u_of_t(i * dt) for i in idx])
    u_id, _ = dyn.inverse(P[idx], V[idx], acc_fd, 0, case, torque_ref=u_true)
    # within 0.2 % of the torque scale (the integration drifts off the closed loop slowly)
    tol = 2e-3 * np.max(np.abs(u_true))
    assert np.max(np.abs(u_id - u_true)) < tol
    if case == 2:                                           # unique: no reference needed
        u_free, _ = dyn.inverse(P[idx], V[idx], acc_fd, 0, case)
        assert np.max(np.abs(u_free - u_true)) < tol


# ----------------------------------------------------------------------------------------------
# contact schedule


def test_contact_schedule_and_quintic():
    s = np.linspace(0, 1, 101)
    assert quintic(s)[0] == 0 and quintic(s)[-1] == 1
    assert np.allclose(np.gradient(quintic(s), s)[5:-5], quintic(s, 1)[5:-5], atol=1e-3)
    sch = contact_schedule(100, 48, np.radians([20, 20]), 0.17, 0.3)
    assert np.all(sch.base[:48] == 0) and np.all(sch.base[48:] == 1)
    assert sch.feet[0].tolist() == [0, 0] and sch.feet[48].tolist() == [0, 0]
    assert np.allclose(sch.feet[:48, 0].max(), np.radians(20))     # base foot on its toe pad
    assert np.allclose(sch.feet[:48, 1].min(), -0.17)              # moving foot toe-up
    assert set(sch.case[sch.feet[:, 0] == np.radians(20)].tolist()) == {1}
    assert np.allclose(np.gradient(sch.feet[:, 0])[2:46], sch.feet_d1[2:46, 0], atol=2e-3)
    flat = contact_schedule(100, 50, [0.0, 0.0])
    assert np.all(flat.case == 1)
    with pytest.raises(OptionError):
        contact_schedule(100, 0, [0.3, 0.3])


# ----------------------------------------------------------------------------------------------
# the whole method on a real walking cycle (acceptance 1, 2)


@pytest.fixture(scope="module")
def walk(mocap):
    from imesh.io import load_motion

    return load_motion(mocap("cmu_02_01_walk.bvh"))


@pytest.fixture(scope="module")
def reduced(walk):
    from imesh.reduction import ReductionConfig, SolverConfig, SubspaceConfig, reduce_motion

    config = ReductionConfig(subspace=SubspaceConfig(rank=3),
                             solver=SolverConfig(max_iterations=80))
    return reduce_motion(walk, "planar_biped", config)


def test_cyclic_motion_of_a_real_walk(reduced):
    rep = reduced.cyclic.report
    assert 1.0 < rep.period_s < 1.2                          # CMU 02_01: ~1.1 s gait cycle
    assert len(rep.cycles) >= 2
    assert rep.lowpass_rms_deg < 1.0
    assert 0.4 < rep.left_toe_off_fraction < 0.6
    assert reduced.report()["cyclic"] == rep.as_dict()
    assert reduced.capture.ik_rms_m < 0.01
    a = reduced.cyclic.angles
    assert np.allclose(a[0], a[-1] + (a[-1] - a[-2]), atol=np.radians(2))  # wraps smoothly


def test_reduction_meets_the_acceptance_numbers(reduced):
    rep = reduced.report()
    assert rep["J_m_initial"] / rep["J_m_final"] >= 100
    assert rep["closure_error_mm"] <= 1.0
    assert rep["min_vertical_grf_N"] > 0
    assert rep["angle_violations"] == 0 and rep["torque_violations"] == 0
    assert rep["friction_ratio_max"] <= 0.5 + 1e-6
    assert rep["slip_at_switch_m_s"] < 0.05
    assert rep["stride_m"] > 0.15                            # still a walk, not stepping in place
    h = rep["history"]
    assert len(h) == rep["iterations"] + 1 and {"J_m", "J_r"} <= set(h[0])
    # the forces reported are those of the torques through the dynamics
    o = reduced.optimization
    assert np.all(o.final.dyn.grf[o.final.dyn.grf_active] > 0)


def test_dart_run_does_not_fall(reduced):
    from imesh.physics.reduction import DartConfig, simulate_planar

    rep = simulate_planar(reduced, DartConfig(cycles=3))
    assert not rep.fell, rep.fall_reason
    assert rep.tracking_rms_rad < 0.03
    assert rep.feedback_share < 0.3
    assert abs(rep.distance_m - rep.planned_distance_m) < 0.25 * rep.planned_distance_m


def test_cli_writes_motion_and_report(tmp_path, mocap):
    from imesh.cli.parsers import add_reduce as add_parser
    from imesh.cli.reduction import run
    from imesh.reduction.pipeline import NPZ_KEYS

    parser = argparse.ArgumentParser()
    add_parser(parser.add_subparsers(dest="command"))
    out, rep = tmp_path / "walk.npz", tmp_path / "walk.json"
    args = parser.parse_args(["reduce", str(mocap("cmu_02_01_walk.bvh")), "-o", str(out),
                              "--json", str(rep), "--rank", "full", "--max-iterations", "3"])
    args.quiet = True
    assert run(args) == 0
    report = json.loads(rep.read_text())
    for key in ("J_m_initial", "J_m_final", "J_r_final", "min_vertical_grf_N",
                "angle_violations", "torque_violations", "closure_error_mm", "iterations",
                "seconds"):
        assert key in report
    assert report["iterations"] == 3 and report["rank"] is None
    with np.load(out) as data:
        assert set(NPZ_KEYS) <= set(data.files)
        assert data["link_angles"].shape[1] == 7 and list(data["link_names"]) == list(LINKS)
    with pytest.raises(SystemExit):
        parser.parse_args(["reduce", "x.bvh", "-o", "y.npz", "--rank", "7"])


def test_rot_matches_pinocchio_ry():
    import pinocchio as pin

    R = pin.utils.rotate("y", 0.7)
    v = np.array([0.3, -0.2])
    assert np.allclose(rot(0.7, v), (R @ np.array([v[0], 0, v[1]]))[[0, 2]])


@pytest.mark.parametrize("name", ["jvrc1", "g1"])
def test_3d_robot_chain_has_the_robots_sagittal_dynamics(name):
    """The lumped 7-link chain of a 3D robot (sagittal joints free, the rest locked) has the
    same kinetic and potential energy as the full 3D pinocchio model in any sagittal motion,
    hence the same sagittal equations of motion."""
    from imesh.reduction.dynamics import chain_from_robot, energies
    from imesh.robot import ROBOTS_DIR, load_robot, load_robot_config
    from imesh.robot.registry import package_available

    if not package_available(load_robot_config(ROBOTS_DIR / name / "robot.toml")):
        pytest.skip(f"{name} model package not installed")
    robot = load_robot(name)
    ch = chain_from_robot(robot)
    assert ch.total_mass == pytest.approx(robot.mass)
    rng = np.random.default_rng(4)
    pe = []
    for base in (0, 1):
        for _ in range(2):
            phi, phid = rng.normal(0, 0.3, 7), rng.normal(0, 1.0, 7)
            e = energies(robot, ch, phi, phid, base)
            assert e["kinetic_chain"] == pytest.approx(e["kinetic_robot"], rel=1e-6)
            pe.append(e["potential_chain"] - e["potential_robot"])
    assert np.ptp(pe) < 1e-9

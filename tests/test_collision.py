"""Self-collision capsules, their distances and Jacobians, the ignore lists, the solve's rows."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from conftest import load_test_robot

from imesh.robot.capsules.fit import capsule_excess, fit_capsules
from imesh.robot.capsules.model import segment_closest_points
from imesh.robot.capsules.pairs import NOMINAL_CLEARANCE_M, pairs_file, read_pairs_toml
from imesh.robot.capsules.robot import capsule_ignore_rule, fit_robot_capsules
from imesh.solve.collision import (
    colliding_frames,
    collision_qp_rows,
    collision_violation,
    linearize_collisions,
)
from imesh.solve.qp import QpProblem, solve_qp

ROBOTS = ("jvrc1", "g1", "hrp4c")
#: G1 left arm pose whose forearm (left_elbow_link) is inside the torso capsule
G1_FOREARM_IN_TORSO = {"left_shoulder_pitch_joint": -0.5, "left_shoulder_roll_joint": -0.5,
                       "left_shoulder_yaw_joint": 0.6, "left_elbow_joint": 0.5}


def _pose(robot, joints: dict) -> np.ndarray:
    q = robot.q_nominal.copy()
    for name, value in joints.items():
        q[7 + robot.joint_index(name)] = value
    return q


def _distances(robot, q: np.ndarray) -> np.ndarray:
    m = robot.capsule_model()
    return m.distances(robot.trajectory_kinematics(np.atleast_2d(q), m.frames).placements
                       ).distance


def test_segment_closest_points_against_sampling():
    rng = np.random.default_rng(1)
    p1, q1, p2, q2 = (rng.normal(size=(200, 3)) for _ in range(4))
    q2[:20] = p2[:20]  # degenerate segments (points)
    q1[20:40] = p1[20:40] + 1e-3 * (q2[20:40] - p2[20:40])  # nearly parallel, short
    c1, c2 = segment_closest_points(p1, q1, p2, q2)
    s = np.linspace(0, 1, 401)
    a = p1[:, None] + s[None, :, None] * (q1 - p1)[:, None]
    b = p2[:, None] + s[None, :, None] * (q2 - p2)[:, None]
    brute = np.linalg.norm(a[:, :, None] - b[:, None, :], axis=-1).min(axis=(1, 2))
    got = np.linalg.norm(c1 - c2, axis=-1)
    assert np.all(got <= brute + 1e-12)
    assert np.allclose(got, brute, atol=5e-3)


def outside_m(caps, pts) -> float:
    """How far [m] the farthest point lies outside every capsule (<= 0: all enclosed)."""
    d = np.full(len(pts), np.inf)
    for a, b, r in caps:
        ab = b - a
        t = np.clip((pts - a) @ ab / max(ab @ ab, 1e-12), 0, 1)
        d = np.minimum(d, np.linalg.norm(pts - (a + t[:, None] * ab), axis=1) - r)
    return float(d.max())


def test_fitted_capsules_enclose_the_points():
    rng = np.random.default_rng(2)
    pts = rng.uniform(-1, 1, size=(500, 3)) * [0.05, 0.1, 0.2]  # a flat box
    caps = fit_capsules(pts)
    assert all(r > 0 for _, _, r in caps)
    assert outside_m(caps, pts) <= 1e-9


def test_split_by_excess_follows_a_tapered_body():
    """A frustum (60 mm radius at the top, 30 mm at the bottom, like HRP-4C's shin): one
    capsule wastes 11 mm on average around it; split by excess, the capsules still enclose
    every point and waste at most 85 % of that."""
    from scipy.spatial import ConvexHull

    angles = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    z = np.linspace(0.0, 0.3, 7)
    pts = np.array([[(0.06 - 0.1 * h) * np.cos(t), (0.06 - 0.1 * h) * np.sin(t), h]
                    for h in z for t in angles])
    tris = pts[ConvexHull(pts).simplices]
    one = fit_capsules(pts, triangles=tris)
    assert len(one) == 1 and capsule_excess(one, pts) > 0.01
    split = fit_capsules(pts, triangles=tris, split_excess=0.85)
    assert len(split) >= 2
    assert capsule_excess(split, pts) <= 0.85 * capsule_excess(one, pts)
    assert outside_m(caps=split, pts=pts) <= 1e-9


@pytest.mark.parametrize("name", ["jvrc1", "g1"])
def test_distance_jacobians_match_finite_differences(name):
    robot = load_test_robot(name)
    m = robot.capsule_model()
    rng = np.random.default_rng(3)
    q = robot.random_configuration(rng, 0.5)
    kin = robot.trajectory_kinematics(q[None], m.frames)
    lin = linearize_collisions(m, kin.placements, kin.jacobians, np.inf)
    assert len(lin.frames) == len(m.pairs)
    eps = 1e-6
    fd = np.zeros_like(lin.rows)
    for k in range(robot.nv):
        dv = np.zeros(robot.nv)
        dv[k] = eps
        fd[:, k] = (_distances(robot, robot.integrate(q, dv))[0]
                    - _distances(robot, robot.integrate(q, -dv))[0]) / (2 * eps)
    assert np.abs(fd - lin.rows).max() < 1e-6 * max(1.0, np.abs(fd).max())


def _random_poses(robot, n: int, seed: int) -> np.ndarray:
    """(n, nq) poses with every joint drawn within half its range about the nominal pose."""
    rng = np.random.default_rng(seed)
    q = np.repeat(robot.q_nominal[None], n, axis=0)
    draw = robot.q_lower + rng.random((n, len(robot.q_lower))) * (robot.q_upper - robot.q_lower)
    q[:, 7:] = robot.q_nominal[7:] + 0.5 * (draw - robot.q_nominal[7:])
    return q


@pytest.mark.parametrize("name", ROBOTS)
def test_hulls_bound_the_geometry_closer_than_the_capsules(name):
    """On 60 random poses, every body pair whose capsules are within 5 cm: the larger of the
    capsule and hull distances is still at most the URDF geometry's distance the evaluator
    scores (0.6 mm over it at worst on G1, whose sampled primitives the hull is inscribed
    in), and the hulls give back a large part of what the capsules cost."""
    from imesh.robot.capsules.hulls import BodyHulls
    from imesh.robot.capsules.mesh_check import MeshCollisionChecker

    robot = load_test_robot(name)
    m = robot.capsule_model()
    hulls, mesh = BodyHulls(m.hulls), MeshCollisionChecker(robot)
    q = _random_poses(robot, 60, seed=0)
    P = robot.trajectory_kinematics(q, m.frames).placements
    caps = m.distances(P).distance
    over, gain = [], []
    for t in range(len(q)):
        least: dict = {}
        for key, d in zip(m.pair_bodies, caps[t], strict=True):
            least[key] = min(least.get(key, np.inf), d)
        near = [k for k, d in least.items() if d < 0.05]
        placements = robot.frame_placements(q[t], mesh.frames)
        for a, b in near:
            ia, ib = m.frames.index(a), m.frames.index(b)
            hull = hulls.distances(P[t, [ia]], P[t, [ib]], [a], [b])[0]
            bound = max(hull, least[a, b])
            over.append(bound - mesh.pair_distance(placements, (a, b)))
            gain.append(bound - least[a, b])
    assert len(over) > 50
    assert max(over) < 1e-3
    assert np.median(gain) > 0.005


def test_the_rows_take_the_hulls_distance():
    """``linearize_collisions`` with the hulls on 12 random G1 poses: each sample's distance is
    the larger of its capsules' and its bodies' hulls' (a wrist 24 mm into the torso's capsule
    reads 31 mm, its hull distance); along a step the shift stays the iterate's (a sample
    without one keeps its capsule distance), and ``refresh_hull_shift`` takes the new pose's."""
    from imesh.robot.capsules.hulls import BodyHulls
    from imesh.solve.collision import refresh_hull_shift

    robot = load_test_robot("g1")
    m = robot.capsule_model()
    hulls = BodyHulls(m.hulls)
    q = _random_poses(robot, 12, seed=0)

    def expected(q: np.ndarray, frames: np.ndarray, pairs: np.ndarray) -> np.ndarray:
        P = robot.trajectory_kinematics(q, m.frames).placements
        caps = m.distances(P).distance[frames, pairs]
        a, b = m.pairs[pairs, 0], m.pairs[pairs, 1]
        hull = hulls.distances(P[frames, m.frame_index[a]], P[frames, m.frame_index[b]],
                               [m.capsules[i].body for i in a], [m.capsules[i].body for i in b])
        return np.maximum(caps, hull)

    kin = robot.trajectory_kinematics(q, m.frames)
    lin = linearize_collisions(m, kin.placements, kin.jacobians, 0.02, hulls)
    np.testing.assert_allclose(lin.distance, expected(q, lin.frames, lin.pairs), atol=1e-6)
    bodies = m.pair_body_index[lin.pairs]
    key = m.pair_body_index[m.pair_bodies.index(("right_wrist_roll_link", "torso_link"))]
    wrist = (lin.frames == 9) & (bodies == key)
    assert lin.capsule_distance[wrist].min() < -0.02
    assert lin.distance[wrist].min() == pytest.approx(0.0307, abs=5e-4)
    # a step: every joint 0.05 rad further; the iterate's shift is kept, then refreshed
    q2 = q.copy()
    q2[:, 7:] += 0.05
    kin2 = robot.trajectory_kinematics(q2, m.frames)
    step = linearize_collisions(m, kin2.placements, kin2.jacobians, 0.02, hulls, lin.shift)
    assert step.shift is lin.shift and step.capsule_distance is not None
    old = {(int(t), int(p)): d - c for t, p, d, c in zip(
        lin.frames, lin.pairs, lin.distance, lin.capsule_distance, strict=True)}
    kept = np.array([old.get((int(t), int(p)), 0.0) for t, p in zip(step.frames, step.pairs,
                                                                     strict=True)])
    np.testing.assert_allclose(step.distance, step.capsule_distance + kept, atol=1e-12)
    fresh = refresh_hull_shift(step, m, hulls)
    np.testing.assert_allclose(fresh.distance, expected(q2, step.frames, step.pairs), atol=1e-6)


@pytest.mark.parametrize("name", ROBOTS)
def test_pairs_file_equals_the_rule(name):
    robot = load_test_robot(name)
    path = pairs_file(robot)
    assert path.is_file(), f"regenerate with: imesh robots {name} --collisions --write"
    assert read_pairs_toml(path) == set(capsule_ignore_rule(robot))
    rule = capsule_ignore_rule(robot)
    feet = [k for k, why in rule.items() if why == "feet"]
    assert len(feet) == 1


@pytest.mark.parametrize("name", ROBOTS)
def test_nominal_pose_has_no_collision(name):
    from imesh.metrics.collision import check_capsule_collisions, check_self_collisions

    robot = load_test_robot(name)
    d = _distances(robot, robot.q_nominal)[0]
    assert d.min() >= NOMINAL_CLEARANCE_M  # every checked pair is clear
    assert check_capsule_collisions(robot, robot.q_nominal[None], 0.0).n_frames == 0
    mesh = check_self_collisions(robot, robot.q_nominal[None], 0.0, broad_m=np.inf).mesh
    assert mesh.n_frames == 0


def test_hrp4c_is_scored_on_its_visual_meshes():
    """HRP-4C's URDF collision boxes are 1.4-2x its links' volume: its capsules and the mesh
    check use the visual meshes (docs/collision.md); G1 keeps its collision elements."""
    from imesh.robot.capsules.mesh_check import MeshCollisionChecker

    hrp4c = MeshCollisionChecker(load_test_robot("hrp4c"))
    assert hrp4c.source == "visual"
    assert type(hrp4c.items["BODY"][0][2]).__name__.startswith("BVHModel")  # not its box
    assert MeshCollisionChecker(load_test_robot("g1")).source == "collision"


def test_forearm_through_torso_has_the_right_depth():
    import coal

    from imesh.metrics.collision import check_capsule_collisions, check_self_collisions

    robot = load_test_robot("g1")
    m = robot.capsule_model()
    q = _pose(robot, G1_FOREARM_IN_TORSO)
    report = check_capsule_collisions(robot, q[None])
    assert report.n_frames == 1
    hits = {p.frames: p.max_depth_m for p in report.pairs}
    assert ("left_elbow_link", "torso_link") in hits
    assert all("torso_link" in key and any("left_" in b for b in key) for key in hits)
    depth = hits[("left_elbow_link", "torso_link")]
    assert 0.02 < depth < 0.06
    # the same capsules as coal capsules: the same signed distance
    M = dict(zip(m.frames, robot.frame_placements(q, m.frames), strict=True))
    objs = []
    for c in m.capsules:
        if c.body in ("left_elbow_link", "torso_link"):
            a, b = (M[c.frame][:3, :3] @ p + M[c.frame][:3, 3] for p in (c.a, c.b))
            z = (b - a) / max(np.linalg.norm(b - a), 1e-12)
            x = np.cross(z, [1.0, 0, 0]) if abs(z[0]) < 0.9 else np.cross(z, [0, 1.0, 0])
            x /= np.linalg.norm(x)
            R = np.column_stack([x, np.cross(z, x), z])
            objs.append((c.body, coal.Capsule(c.radius, float(np.linalg.norm(b - a))),
                         coal.Transform3s(R, (a + b) / 2)))
    arm = [o for o in objs if o[0] == "left_elbow_link"]
    torso = [o for o in objs if o[0] == "torso_link"]
    coal_d = min(coal.distance(g1, t1, g2, t2, coal.DistanceRequest(), coal.DistanceResult())
                 for _, g1, t1 in arm for _, g2, t2 in torso)
    assert coal_d == pytest.approx(-depth, abs=1e-6)
    # the URDF meshes inside the capsules collide too, less deeply
    mesh = check_self_collisions(robot, q[None], 0.0).mesh
    hit = {p.frames: p.max_depth_m for p in mesh.pairs}
    assert 0 < hit[("left_elbow_link", "torso_link")] <= depth + 1e-6


def test_two_frame_solve_stops_at_the_margin():
    """Two frames pulled towards targets (nominal, forearm in the torso) with the solve's
    elastic collision rows: the unconstrained solution collides, the constrained one stops at
    the margin, and the frame without collision stays on its target."""
    robot = load_test_robot("g1")
    m = robot.capsule_model()
    targets = np.stack([robot.q_nominal, _pose(robot, G1_FOREARM_IN_TORSO)])
    margin, price = 0.005, 1e4
    assert _distances(robot, targets).min(axis=1)[1] < -0.02  # unconstrained: collides
    nv, T = robot.nv, 2
    nx = nv + 1
    q = targets.copy()
    for _ in range(20):
        kin = robot.trajectory_kinematics(q, m.frames)
        lin = linearize_collisions(m, kin.placements, kin.jacobians, 0.02)
        G, lo, hi = collision_qp_rows(lin, T, nx, nv, margin)
        e = np.stack([robot.difference(q[t], targets[t]) for t in range(T)])
        diag = np.tile(np.r_[np.ones(nv), 0.0], T)
        c = np.concatenate([np.r_[-e[t], price] for t in range(T)])
        x_l = np.tile(np.r_[np.full(nv, -0.1), 0.0], T)
        x_u = np.tile(np.r_[np.full(nv, 0.1), np.inf], T)
        qp = QpProblem(P=sp.diags(diag + 1e-9).tocsc(), c=c, A=sp.csc_matrix((0, T * nx)),
                       b=np.zeros(0), G=G.tocsc(), l=lo, u=hi, x_l=x_l, x_u=x_u)
        dq = solve_qp(qp, "piqp", 1e-9).x.reshape(T, nx)[:, :nv]
        q = np.stack([robot.integrate(q[t], dq[t]) for t in range(T)])
        if np.abs(dq).max() < 1e-7:
            break
    d = _distances(robot, q).min(axis=1)
    assert d[1] == pytest.approx(margin, abs=2e-4)
    assert np.abs(robot.difference(q[0], targets[0])).max() < 1e-6
    kin = robot.trajectory_kinematics(q, m.frames)
    final = linearize_collisions(m, kin.placements, kin.jacobians, 0.02)
    assert collision_violation(final, margin) < 2e-4


def test_frames_in_collision_are_the_ones_the_sqp_caps():
    """The SQP caps the trust radii of the frames whose self-collision distance is more than
    1 mm inside the margin (``colliding_frames``): of the G1 standing, the forearm in the
    torso and the forearm at the margin, only the second."""
    from imesh.solve import WholeBodyConfig

    robot = load_test_robot("g1")
    m = robot.capsule_model()
    config = WholeBodyConfig()
    margin = config.collision.margin_m
    inside = _pose(robot, G1_FOREARM_IN_TORSO)
    q = np.stack([robot.q_nominal, inside, inside])
    # the third frame: the arm on its way from the nominal pose to the torso, where its
    # distance is the margin (bisection on the way)
    lo, hi = 0.0, 1.0
    assert _distances(robot, robot.q_nominal).min() > margin
    for _ in range(40):
        q[2] = robot.q_nominal + 0.5 * (lo + hi) * (inside - robot.q_nominal)
        lo, hi = (0.5 * (lo + hi), hi) if _distances(robot, q[2]).min() > margin else (
            lo, 0.5 * (lo + hi))
    kin = robot.trajectory_kinematics(q, m.frames)
    collision = linearize_collisions(m, kin.placements, kin.jacobians, 0.02)
    assert collision.min_distance[1] < -0.02
    assert collision.min_distance[2] == pytest.approx(margin, abs=1e-4)
    np.testing.assert_array_equal(colliding_frames(collision, 3, margin), [False, True, False])
    np.testing.assert_array_equal(colliding_frames(None, 3, margin), [False] * 3)


def test_capsule_cache_round_trip(tmp_path, monkeypatch, caplog):
    """The fit is stored under IMESH_CACHE_DIR/capsules, read back bit for bit, fitted again
    when the file is damaged, and not stored when the variable is empty."""
    from imesh.core.cache import CACHE_ENV

    robot = load_test_robot("jvrc1")
    fresh = fit_robot_capsules(robot, cache=False)

    def same(a, b):
        return len(a) == len(b) and all(
            x.name == y.name and x.body == y.body and x.frame == y.frame
            and np.array_equal(x.a, y.a) and np.array_equal(x.b, y.b) and x.radius == y.radius
            for x, y in zip(a, b, strict=True))

    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    assert same(fit_robot_capsules(robot), fresh)
    files = list((tmp_path / "capsules").glob("capsules-*.npz"))
    assert len(files) == 1 and not list((tmp_path / "capsules").glob("*.tmp"))
    assert same(fit_robot_capsules(robot), fresh)  # read back
    files[0].write_bytes(files[0].read_bytes()[:100])  # a truncated zip
    with caplog.at_level("WARNING", logger="imesh.robot.capsules.robot"):
        assert same(fit_robot_capsules(robot), fresh)
    assert "unreadable" in caplog.text
    assert same(fit_robot_capsules(robot), fresh)  # rewritten
    monkeypatch.setenv(CACHE_ENV, "")
    files[0].unlink()
    assert same(fit_robot_capsules(robot), fresh)
    assert not list((tmp_path / "capsules").glob("capsules-*.npz"))


def test_cli_robots_collisions_prints_capsules_and_pairs(capsys):
    from imesh.cli import main

    assert main(["robots", "g1", "--collisions"]) == 0
    out = capsys.readouterr().out
    assert "capsules on 30 bodies" in out and "matches the rule" in out
    assert "left_ankle_roll_link - right_ankle_roll_link: feet" in out


@pytest.mark.parametrize("name, in_solve", [("jvrc1", True), ("g1", True), ("hrp4c", True)])
def test_capsules_enter_the_solve_where_the_robot_allows(name, in_solve):
    """Every shipped robot's capsules are in the whole-body solve by default (a robot.toml may
    keep them out with collision.in_solve = false, docs/collision.md)."""
    from imesh.fit.targets import compile_targets
    from imesh.solve import WholeBodyConfig
    from imesh.solve.sqp import _Frames

    robot = load_test_robot(name)
    assert robot.config.collision.in_solve is in_solve
    names = robot.keypoint_arrays()[0]
    frames = _Frames(robot, compile_targets(robot, names, None, [], source="test"),
                     WholeBodyConfig())
    assert (frames.capsules is not None) is in_solve
    assert (len(frames.capsule_frames) > 0) is in_solve


def test_in_solve_must_be_a_boolean(tmp_path):
    from imesh.robot.config import load_robot_config
    from imesh.robot.errors import RobotConfigError

    src = load_test_robot("g1").config.path
    text = src.read_text().replace("[collision]", "[collision]\nin_solve = 1", 1)
    bad = tmp_path / "robot.toml"
    bad.write_text(text)
    with pytest.raises(RobotConfigError, match="collision.in_solve must be true or false"):
        load_robot_config(bad)


def test_proxy_fits_cached_bit_for_bit(tmp_path, monkeypatch):
    """The primitive proxies fitted to meshes come back from imesh's cache folder identical,
    and a damaged cache file is fitted again."""
    from imesh.robot import load_robot
    from imesh.robot import model as robot_model

    monkeypatch.setenv("IMESH_CACHE_DIR", str(tmp_path))
    # load_robot keeps built models per process: a fresh build each time
    monkeypatch.setattr(robot_model, "_CACHE", {})

    def shapes():
        robot_model._CACHE.clear()
        return load_robot("jvrc1").collision_shapes

    fresh = shapes()
    files = list((tmp_path / "proxies").glob("*.npz"))
    assert len(files) == 1
    for damaged in (False, True):
        if damaged:
            files[0].write_bytes(b"not a zip")
        again = shapes()
        assert [(s.frame, s.kind, s.dims) for s in again] == \
            [(s.frame, s.kind, s.dims) for s in fresh]
        assert all(np.array_equal(a.placement, b.placement)
                   for a, b in zip(again, fresh, strict=True))


# ------------------------------------------------------------------------------------------
# one self-collision check: the evaluator's figure, the mesh check and the viewer (issue 33)


@pytest.fixture(scope="module")
def jvrc1_wave(mocap):
    """A real motion: the first 2 s of the CMU wave retargeted to JVRC-1 (per-frame fit, two
    morph steps, no lead-in: about 1 s), and the same motion with the left arm driven into the
    torso over frames 20-39 (shoulder roll to -1 rad, pitch -0.6 rad at frame 30)."""
    import dataclasses

    from imesh.io import load_motion
    from imesh.pipeline.retarget import RetargetConfig, retarget

    robot = load_test_robot("jvrc1")
    config = RetargetConfig()
    config = dataclasses.replace(config, balance="none", lead_s=0.0,
                                 morph=dataclasses.replace(config.morph, steps=2))
    clip = load_motion(mocap("cmu_141_16_wave_hello.bvh"))
    motion = retarget(clip.frames(0, 240), robot, config=config).motion
    q = motion.q.copy()
    s = np.zeros(len(q))
    s[20:40] = np.sin(np.linspace(0, np.pi, 20)) ** 2
    roll, pitch = (7 + robot.joint_index(j) for j in ("L_SHOULDER_R", "L_SHOULDER_P"))
    q[:, roll] += (-1.0 - q[:, roll]) * s
    q[:, pitch] += -0.6 * s
    return robot, motion, dataclasses.replace(motion, q=q)


def test_evaluator_counts_the_mesh_collisions(jvrc1_wave):
    """``self_collision_frames`` is the URDF-geometry figure (coal), the capsules' beside it;
    0 on the clean motion; the broad phase loses nothing against coal on every pair."""
    from imesh.evaluate.scoreboard import evaluate_motion
    from imesh.metrics.collision import check_self_collisions

    robot, clean, hit = jvrc1_wave
    assert clean.n_frames == 60
    entry = evaluate_motion(robot, clean)["self_collision_frames"]
    assert (entry["value"], entry["deepest_mm"], entry["capsule_frames"]) == (0, 0.0, 0)
    assert check_self_collisions(robot, clean.q).mesh.n_frames == 0

    check = check_self_collisions(robot, hit.q)
    mesh = check.mesh
    assert mesh.geometry == "collision" and check.capsules.geometry == "capsules"
    assert mesh.n_frames == 13 and list(np.flatnonzero(mesh.colliding)) == list(range(24, 37))
    assert mesh.pairs[0].frames == ("L_ELBOW_P_S", "WAIST_R_S")
    assert mesh.deepest_mm == pytest.approx(1e3 * mesh.pairs[0].max_depth_m)
    # 61.8 mm (88.2 before the morph's bend planes and the trunk's key points at weight 1,
    # 101.2 before the neck and head key points moved to their markers' body points: the
    # fitted trunk under the driven arm changed)
    assert 57.0 < mesh.deepest_mm < 67.0
    assert mesh.pairs[0].n_frames == 10
    assert check.capsules.n_frames >= mesh.n_frames  # the capsules enclose the geometry
    assert check.capsules.deepest_mm >= mesh.deepest_mm
    entry = evaluate_motion(robot, hit)["self_collision_frames"]
    assert entry["value"] == mesh.n_frames
    assert entry["deepest_mm"] == round(mesh.deepest_mm, 2)
    assert entry["worst_pairs"][0]["pair"] == ["L_ELBOW_P_S", "WAIST_R_S"]
    assert entry["capsule_frames"] == check.capsules.n_frames
    # coal on every pair in every frame: the same frames, pairs and depths
    full = check_self_collisions(robot, hit.q, broad_m=np.inf)
    assert full.mesh_queries > 10 * check.mesh_queries
    np.testing.assert_array_equal(full.mesh.colliding, mesh.colliding)
    np.testing.assert_allclose(full.mesh.max_depth_m, mesh.max_depth_m, atol=1e-12)
    assert full.mesh.frame_hits() == mesh.frame_hits()


def test_viewer_marks_the_evaluators_frames(jvrc1_wave):
    """The viewer's red bodies are the evaluator's check: the same frames and pairs."""
    from imesh.metrics.collision import check_self_collisions
    from imesh.viz.scene import build_scene, robot_view

    robot, _, hit = jvrc1_wave
    scene = robot_view(build_scene(robot, hit))
    mesh = check_self_collisions(robot, hit.q).mesh
    marked = [t for t, c in enumerate(scene["collisions"]) if c]
    assert marked == list(np.flatnonzero(mesh.colliding))
    bodies = [b["name"] for b in scene["collision_bodies"]]
    for t, (hits, expected) in enumerate(zip(scene["collisions"], mesh.frame_hits(),
                                             strict=True)):
        assert [(bodies[a], bodies[b], d) for a, b, d in hits] == \
            [(a, b, round(1e3 * d, 1)) for a, b, d in expected], t
    # the painted links of the worst pair's bodies are the robot's links of those bodies
    elbow = scene["collision_bodies"][bodies.index("L_ELBOW_P_S")]["links"]
    assert [scene["links"][k] for k in elbow] == ["L_ELBOW_P_S"]

"""Two people, two robots (imesh.partners, issue 35): the joint mesh, holds, robot-robot rows,
the pair's evaluation and the command line, on the CMU salsa couple."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from conftest import load_test_robot

from imesh.cli.app import main
from imesh.io.clip import read_pair
from imesh.morph.adapt import PERSON_PREFIXES
from imesh.partners import PairConfig, PartnerError, detect_holds, evaluate_pair, retarget_pair
from imesh.partners.holds import HAND_MARKERS
from imesh.partners.mesh import morph_together
from imesh.partners.world import shared_world
from imesh.pipeline.retarget import RetargetConfig, prepare, working_markers
from imesh.robot.capsules.obstacles import Obstacles
from imesh.solve.obstacles import linearize_obstacles

SALSA_A = "cmu_60_10_salsa_partnerA_sl_scaled.bvh"
SALSA_B = "cmu_61_10_salsa_partnerB_sl_scaled.bvh"
#: clip frames around the couple's hand hold (504-611): 3 s at their capture rate, 60 fps
HOLD_WINDOW = (460, 640)


@pytest.fixture(scope="module")
def couple(mocap):
    a, b = read_pair(mocap(SALSA_A), mocap(SALSA_B))
    return a.frames(*HOLD_WINDOW), b.frames(*HOLD_WINDOW)


def test_holds_are_the_source_frames_with_hands_within_10_cm(couple):
    config = RetargetConfig()
    ha, hb = (working_markers(m, config) for m in couple)
    holds = detect_holds(ha, hb, 0.10)
    assert len(holds) > 10  # the couple's hold: a's left hand in b's right
    for t, ma, mb, d in zip(holds.frames, holds.marker_a, holds.marker_b,
                            holds.source_distance_m, strict=True):
        assert ma in HAND_MARKERS and mb in HAND_MARKERS
        real = np.linalg.norm(ha.positions_m[t, ha.index(ma)] - hb.positions_m[t, hb.index(mb)])
        assert d == pytest.approx(real) and d < 0.10
    assert set(holds.summary()) == {f"{a}-{b}" for a, b in zip(holds.marker_a, holds.marker_b,
                                                                strict=True)}
    # one hold per hand of b and frame
    keys = list(zip(holds.frames, holds.marker_b, strict=True))
    assert len(keys) == len(set(keys))
    assert len(detect_holds(ha, hb, 0.01)) < len(holds)


def test_one_mesh_keeps_the_partners_relation_better_than_two(couple):
    """The joint morph (Ho et al. 2010's multi-character mesh) changes the inter-person
    distances of close marker pairs less than morphing each person alone, with each person's
    bones at its own robot's lengths either way."""
    g1, jvrc1 = load_test_robot("g1"), load_test_robot("jvrc1")
    config = RetargetConfig()
    ha, hb = (working_markers(m, config) for m in couple)
    world = shared_world(ha, hb, g1, jvrc1)
    assert world.scale == pytest.approx(np.sqrt(world.own_scales[0] * world.own_scales[1]))
    pa = prepare(couple[0], g1, config, human=ha, scale=world.scale, centre_m=world.centre_m)
    pb = prepare(couple[1], jvrc1, config, human=hb, scale=world.scale, centre_m=world.centre_m)
    ma, mb, joint = morph_together(pa, pb, config.morph)
    assert joint.bone_residual_m < 1e-6
    assert ma.positions_m.shape == pa.source.positions_m.shape
    assert np.array_equal(np.concatenate([ma.positions_m, mb.positions_m], axis=1),
                          joint.positions_m)
    from imesh.morph.problem import build_morph_problem
    from imesh.morph.solver import solve_morph

    def alone(p):
        return solve_morph(build_morph_problem(
            p.source, pairs=p.arrangement.pairs, target_lengths_m=p.arrangement.target_lengths_m,
            hard_positions_m=p.hard, soft_positions_m=p.soft, soft_weights=p.soft_w,
            config=config.morph)).positions_m

    src = pa.source.concat_markers(pb.source, *PERSON_PREFIXES)
    pairs = np.array([[i, pa.source.n_markers + j] for i in range(pa.source.n_markers)
                      for j in range(pb.source.n_markers)])
    d0 = np.linalg.norm(src.positions_m[:, pairs[:, 0]] - src.positions_m[:, pairs[:, 1]], axis=2)
    close = d0 < 0.15 * src.height_m
    assert close.sum() > 50

    def err(pos):
        d = np.linalg.norm(pos[:, pairs[:, 0]] - pos[:, pairs[:, 1]], axis=2)
        return float(np.mean(np.abs(d - d0)[close]))

    e_joint = err(joint.positions_m)
    e_alone = err(np.concatenate([alone(pa), alone(pb)], axis=1))
    assert e_joint < 0.7 * e_alone, (e_joint, e_alone)


def test_obstacle_rows_are_the_distance_gradient():
    """The obstacle rows are the derivative of the exact capsule-obstacle distance along a
    tangent step (finite differences on G1)."""
    robot = load_test_robot("g1")
    model = robot.capsule_model()
    rng = np.random.default_rng(3)
    q = robot.q_nominal.copy()
    ids = [robot.frame_id(f) for f in model.frames]
    M = robot.frame_placements(q, ids)[None]
    J = robot.frame_jacobians(q, ids)[None]
    # an obstacle capsule 3 cm in front of the left hand's capsule
    hand = [k for k, c in enumerate(model.capsules) if "left_wrist" in c.body or
            "left_rubber" in c.body][0]
    seg = model.world_segments(M)[0, hand]
    obs = Obstacles(segments_m=(seg + [0.0, 0.0, 0.0] + [model.radius[hand] + 0.05, 0.0, 0.0]
                                )[None, None], radius_m=np.array([0.02]))
    lin = linearize_obstacles(model, M, J, obs, activation=0.1)
    assert len(lin.frames) >= 1 and np.isfinite(lin.min_distance).all()
    dv = rng.normal(size=robot.nv) * 1e-6
    q2 = robot.integrate(q, dv)
    lin2 = linearize_obstacles(model, robot.frame_placements(q2, ids)[None],
                               robot.frame_jacobians(q2, ids)[None], obs, activation=0.1)
    for r in range(len(lin.frames)):
        k = np.flatnonzero((lin2.capsules == lin.capsules[r])
                           & (lin2.obstacles == lin.obstacles[r]))[0]
        assert lin2.distance[k] - lin.distance[r] == pytest.approx(lin.rows[r] @ dv, rel=1e-3,
                                                                   abs=1e-11)


def test_partners_of_different_lengths_are_refused_before_work(couple):
    a, b = couple
    with pytest.raises(PartnerError, match="same frame count"):
        retarget_pair(a, b.frames(0, b.n_frames - 4), load_test_robot("g1"),
                      load_test_robot("g1"))
    with pytest.raises(Exception, match="wholebody"):
        PairConfig(retarget=RetargetConfig(balance="none"))


@pytest.fixture(scope="module")
def short_pair(couple):
    """G1 + G1 on 1.2 s of the hold (36 frames at 30 fps, 0.5 s lead-in and out): together,
    together without the avoidance, alone."""
    a, b = (m.frames(60, 132) for m in couple)  # clip frames 520-592 at 60 fps
    config = PairConfig(retarget=dataclasses.replace(RetargetConfig(), lead_s=0.5))
    robot = load_test_robot("g1")
    return {name: evaluate_pair(retarget_pair(a, b, robot, robot, config=c))
            for name, c in (("together", config),
                            ("no-avoid", dataclasses.replace(config, avoid=False)),
                            ("alone", dataclasses.replace(config, together=False)))}


def test_pair_holds_hands_and_avoids(short_pair):
    """Measured (docs/partners.md): the shared mesh with the holds keeps the held hands' distance
    and the inter-person relations better than two retargets alone (held hands 38.3 mm off their
    scaled distance on average against 52.8 alone, the couple on its shared floor); the
    avoidance keeps robot b out of robot a."""
    together, no_avoid, alone = (short_pair[k] for k in ("together", "no-avoid", "alone"))
    assert together.hold_frames == alone.hold_frames >= 10  # 10 frames at 30 fps here
    assert no_avoid.hold_error_mean_mm < 0.8 * alone.hold_error_mean_mm, \
        (no_avoid.summary(), alone.summary())
    assert no_avoid.inter_close_pair_error < alone.inter_close_pair_error, \
        (no_avoid.summary(), alone.summary())
    assert together.robot_penetration_mm < alone.robot_penetration_mm
    assert together.penetration_frames <= alone.penetration_frames
    for m in short_pair.values():
        for rep in (m.robot_a, m.robot_b):
            assert rep["limit_violation_frames"]["value"] == 0
        assert len(m.hold_distance_m) == len(m.hold_target_m) == m.hold_frames


def test_retarget_partner_command_line_writes_both_robots(tmp_path, mocap):
    out = tmp_path / "pair.npz"
    status = main(["-q", "retarget", str(mocap(SALSA_A)), "--partner", str(mocap(SALSA_B)),
                   "--robot", "g1", "--partner-robot", "jvrc1", "--frames", "520:580",
                   "--no-lead", "--force", "-o", str(out)])
    assert status == 0
    report = json.loads((tmp_path / "pair.pair.json").read_text())
    assert report["robots"] == {"a": "g1", "b": "jvrc1"}
    for f in (out, tmp_path / "pair.partner.npz"):
        with np.load(f) as z:
            # 60 clip frames at the couple's capture rate, 60 fps (imesh.human.timing) -> 30
            assert z["joint_positions"].shape[0] == 30
    assert report["pair_metrics"]["hold_frames"] > 0
    # imesh evaluate --pair scores the written files as the retarget did
    assert main(["-q", "evaluate", str(out), "--pair", str(tmp_path / "pair.pair.json"),
                 "--json", str(tmp_path / "eval.json")]) == 0
    again = json.loads((tmp_path / "eval.json").read_text())["pair_metrics"]
    for key in ("hold_frames", "inter_close_pairs", "penetration_frames"):
        assert again[key] == report["pair_metrics"][key]
    for key in ("inter_close_pair_error", "robot_penetration_mm", "hold_error_mean_mm"):
        assert again[key] == pytest.approx(report["pair_metrics"][key], abs=1e-6)
    assert main(["-q", "retarget", str(mocap(SALSA_A)), "--partner", str(mocap(SALSA_B)),
                 "--frames", "640:520", "-o", str(tmp_path / "x.npz")]) == 2
    assert not (tmp_path / "x.npz").exists()


def test_pair_options_without_partner_are_refused(tmp_path, mocap):
    out = tmp_path / "x.npz"
    assert main(["-q", "retarget", str(mocap(SALSA_A)), "--frames", "0:100", "-o",
                 str(out)]) == 2
    assert main(["-q", "retarget", str(mocap(SALSA_A)), "--partner", str(mocap(SALSA_B)),
                 "--physics", "-o", str(out)]) == 2
    assert not out.exists()

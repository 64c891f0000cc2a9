"""Hands and knees on prop tops (imesh.contacts.effectors), their held points in the solve
(imesh.solve.touches) and the evaluator's contact wrench cone test (imesh.metrics.cwc), on the
holosoma climb seq_1 (source frames 200-799 at 120 fps, the person pulling up onto box1)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import climb_window

from imesh.contacts.effectors import detect_effector_contacts, effector_targets
from imesh.contacts.phases import runs
from imesh.human.arrange import arrange_for_robot
from imesh.human.filtering import lowpass
from imesh.metrics.cwc import cwc_balance
from imesh.morph.adapt import prepare_markers
from imesh.scene.surfaces import scene_planes
from imesh.solve.touches import plan_contact_points, touch_violation


@pytest.fixture(scope="module")
def climb():
    window, robot, scene = climb_window(200, 800)
    # the markers as the retarget arranges them (30 fps, 8 Hz low-pass, the robot's scale)
    source = arrange_for_robot(lowpass(prepare_markers(window).resample(30.0), 8.0),
                               robot).motion
    return robot, scene, source, detect_effector_contacts(source, scene)


def test_hands_and_knee_on_box1_top(climb):
    """The person's hands rest on box1 (0.742 m at the G1's scale) from clip frame 25 on (the
    MANIFEST: hands on top from about source frame 290), the right knee from frame 72 (source
    485, the MANIFEST's 485-720); nothing on box2 (0.141 m), where only the feet stand."""
    _, scene, source, found = climb
    assert found.effectors == ("hand_l", "hand_r", "knee_l", "knee_r")
    i = {e: k for k, e in enumerate(found.effectors)}
    assert runs(found.contact[:, i["hand_l"]]) == [(25, 150)]
    assert runs(found.contact[:, i["hand_r"]])[0][0] == 28
    knee = runs(found.contact[:, i["knee_r"]])
    assert knee and abs(knee[0][0] - 72) <= 3 and knee[0][1] - knee[0][0] >= 40
    assert set(found.prop[found.contact]) == {0}  # box1
    np.testing.assert_allclose(found.top_m[found.contact], scene.props[0].top_m)
    # the morph's targets hold a resting hand still, on or above the top
    soft, w = effector_targets(source, found, 1e3)
    hand = source.index("hand_l")
    held = soft[25:150, hand]
    assert (w[25:150, hand] == 1e3).all() and (w[:25, hand] == 0).all()
    assert np.ptp(held, axis=0).max() == 0.0 and held[0, 2] >= scene.props[0].top_m


def test_held_points_sit_on_the_top(climb):
    """One held point per contact run, on a link of the effector, anchored 5 mm (the prop
    rows' margin) above box1's top, inside its edges; a trajectory whose points are there has
    no touch violation, one 3 cm off has exactly 3 cm."""
    robot, scene, _, found = climb
    planes = scene_planes(scene)
    q = np.repeat(robot.q_nominal[None], len(found.prop), axis=0)
    points = plan_contact_points(robot, q, found, planes, scene.tops_m(), 0.005)
    assert points is not None and len(points.names) >= 3
    np.testing.assert_allclose(points.anchor_m[:, 2], scene.props[0].top_m + 0.005, atol=0.03)
    box1 = planes[0]
    inside = points.anchor_m.copy()
    inside[:, 2] = scene.props[0].top_m - 0.03
    assert (inside @ box1[:, :3].T - box1[:, 3] <= -0.019).all(axis=1).all()
    hand_frames = {f for n, f in zip(points.names, points.frames, strict=True)
                   if n.startswith("hand")}
    assert hand_frames <= {"left_rubber_hand", "right_rubber_hand", "left_wrist_yaw_link",
                           "right_wrist_yaw_link"}
    at = np.broadcast_to(points.anchor_m, (len(q),) + points.anchor_m.shape).copy()
    assert touch_violation(at, points).max() == 0.0
    at[..., 0] += 0.03
    assert touch_violation(at, points)[points.active.any(axis=1)] == pytest.approx(0.03)


def test_cwc_metric_standing_and_lifted(climb):
    """The evaluator's test on the G1's nominal pose held still on the floor: every frame
    inside its soles' cone; the same pose 5 cm up (no contact, not falling): every frame
    outside, by the whole weight (9.81 m/s^2)."""
    robot, scene, _, _ = climb
    planes = scene_planes(scene)
    q = np.repeat(robot.q_nominal[None], 20, axis=0)
    q[:, :2] = [-1.5, 0.5]  # beside the boxes
    standing = cwc_balance(robot, q, 30.0, planes)
    assert standing.fraction == 1.0 and (standing.contacts == 8).all()
    assert standing.violation.max() < -0.1
    q[:, 2] += 0.05
    lifted = cwc_balance(robot, q, 30.0, planes)
    assert lifted.fraction == 0.0 and (lifted.contacts == 0).all()
    np.testing.assert_allclose(lifted.violation, 9.81, atol=1e-6)

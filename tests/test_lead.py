"""The standing lead-in and lead-out around a clip (imesh.solve.add_lead)."""

from __future__ import annotations

import numpy as np
import pytest

from imesh.solve import add_lead


def _clip(first_down: int, last_down: int, T: int = 20) -> np.ndarray:
    """(T, 2) support: the right foot always down, the left down from ``first_down`` to
    ``last_down`` (inclusive)."""
    support = np.zeros((T, 2), bool)
    support[:, 1] = True
    support[first_down:last_down + 1, 0] = True
    return support


def _lead(support: np.ndarray, land_frames: int):
    T = len(support)
    return add_lead(np.zeros((T, 7)), np.zeros((T, 1, 3)), support, 10, 10, step_frames=4,
                    land_frames=land_frames)


def test_a_swing_ending_at_the_clips_start_stands_through():
    """The left foot lands 2 frames into the clip (the CMU walk): with land_frames >= 2 it
    stands from the lead-in through its landing; both feet carry the robot in every lead
    frame, so no step is taken out of the lead-in."""
    lead = _lead(_clip(2, 19), land_frames=4)
    assert lead.support[:12].all()  # 10 lead-in frames + the 2 clip frames before landing
    assert lead.support[10 + 20:].all()


def test_a_swing_far_from_the_clips_start_steps_out_of_the_lead():
    """The left foot lands 6 frames into the clip, beyond land_frames: it lifts over the
    lead-in's last step_frames (4) frames and swings into the clip as it has it."""
    lead = _lead(_clip(6, 19), land_frames=4)
    left = lead.support[:, 0]
    assert left[:6].all() and not left[6:16].any() and left[16:].all()


@pytest.mark.parametrize("land", [0, 3])
def test_a_lift_at_the_clips_end(land):
    """The left foot lifts 3 frames before the clip's end: with land_frames 3 it stays down
    into the lead-out, with 0 it swings over the lead-out's first 4 frames."""
    lead = _lead(_clip(0, 16), land_frames=land)
    left = lead.support[:, 0]
    if land:
        assert left.all()
    else:
        assert left[:10 + 17].all() and not left[27:34].any() and left[34:].all()


@pytest.fixture(scope="module")
def g1():
    from imesh.robot import load_robot
    return load_robot("g1")


def _g1_lifted(robot) -> np.ndarray:
    """(2, nq) G1 standing on its left foot with the right foot lifted and pitched toe down
    (the CMU veer starts so: the right sole 50 mm up and pitched 85 deg)."""
    q = robot.q_nominal.copy()
    for name, angle in (("right_hip_pitch_joint", -0.4), ("right_knee_joint", 1.2),
                        ("right_ankle_pitch_joint", 0.5)):
        q[7 + robot.joint_index(name)] += angle
    return np.repeat(q[None], 2, axis=0)


def test_a_foot_put_down_in_the_lead_carries_its_markers(g1):
    """The markers of the right foot, lifted at the clip's first frame, stand with its sole
    level on the ground through the lead-in and follow a smooth swing to where the clip has
    them: no frame moves them more than 1.6 times the mean step (smoothstep: 1.5), and the
    sole's corners stay above the ground throughout the swing."""
    from imesh.fit.targets import compile_targets, robot_targets
    from imesh.solve.lead import _swing_poses, lead_feet

    kps, dirs = robot_targets(g1)
    names = sorted({k.marker for k in kps} | {m for d in dirs for m in (d.from_marker,
                                                                         d.to_marker)})
    targets = compile_targets(g1, names, None, None)
    q = _g1_lifted(g1)
    at = g1.frame_positions(q[0], [k.frame for k in targets.keypoints], targets.kp_offsets)
    markers = np.zeros((2, len(names), 3))
    markers[:, targets.kp_markers] = at
    feet = lead_feet(g1, q, targets)
    right = [names[i] for i in feet.markers[1]]
    assert right == ["ankle_r", "toe_r"]
    support = np.array([[True, False], [True, True]])
    lead = add_lead(q, markers, support, 30, 0, step_frames=15, feet=feet)
    toe = lead.markers[:, names.index("toe_r")]
    # standing: the toe marker where the level footprint has it (the sole on z = 0)
    down = feet.down_first[1] @ np.linalg.inv(feet.first[1])
    np.testing.assert_allclose(toe[:15], np.repeat((down[:3, :3] @ toe[30] + down[:3, 3])[None],
                                                   15, axis=0), atol=1e-12)
    corners = g1.sole_corners(q[0], "right")
    assert corners[:, 2].min() > 0.03  # the pose is lifted
    steps = np.linalg.norm(np.diff(toe[14:31], axis=0), axis=1)
    assert steps.max() <= 1.6 * np.linalg.norm(toe[30] - toe[14]) / 16
    poses = _swing_poses(feet.down_first[1], feet.first[1], feet.corners[1], 15)
    low = np.min(np.einsum("nij,kj->nki", poses[:, :3, :3], feet.corners[1])[..., 2]
                 + poses[:, None, 2, 3], axis=1)
    assert low.min() >= 0.0


def test_a_foot_put_down_over_a_prop_stands_on_its_top_with_its_markers(g1):
    """A foot the lead-in puts down over a prop's top (``heights_m``, the top the plan's lead
    footprint stands on: :func:`imesh.pipeline.retarget.lead_heights`) stands there, and so do
    its markers: on the holosoma seq_0 window the lead-out put the right sole on box2's top
    (0.367 m at the G1's scale) and its ankle and toe markers on the floor under it, 367 mm
    below the footprint the solve held the sole on."""
    from imesh.fit.targets import compile_targets, robot_targets
    from imesh.solve.lead import lead_feet

    kps, dirs = robot_targets(g1)
    names = sorted({k.marker for k in kps} | {m for d in dirs for m in (d.from_marker,
                                                                         d.to_marker)})
    targets = compile_targets(g1, names, None, None)
    q = _g1_lifted(g1)
    q[:, 2] += 0.5  # the robot above a 0.367 m top, its right foot lifted
    at = g1.frame_positions(q[0], [k.frame for k in targets.keypoints], targets.kp_offsets)
    markers = np.zeros((2, len(names), 3))
    markers[:, targets.kp_markers] = at
    top = 0.367
    floor = lead_feet(g1, q, targets)
    feet = lead_feet(g1, q, targets, np.array([[top, top], [top, top]]))
    np.testing.assert_allclose(feet.down_first[..., 2, 3] - floor.down_first[..., 2, 3], top)
    lead = add_lead(q, markers, np.array([[True, False], [True, True]]), 30, 0,
                    step_frames=15, feet=feet)
    corners = np.einsum("ij,kj->ki", feet.down_first[1][:3, :3], feet.corners[1]) \
        + feet.down_first[1][:3, 3]
    np.testing.assert_allclose(corners[:, 2], top, atol=1e-9)  # the sole level on the top
    toe = lead.markers[:15, names.index("toe_r")]
    carried = feet.down_first[1] @ np.linalg.inv(feet.first[1])
    expected = carried[:3, :3] @ lead.markers[30, names.index("toe_r")] + carried[:3, 3]
    np.testing.assert_allclose(toe, np.repeat(expected[None], 15, axis=0), atol=1e-12)
    ankle_above_sole = (lead.markers[0, names.index("ankle_r"), 2] - top)
    assert 0.0 < ankle_above_sole < 0.1  # on the top, not 0.367 m under it
    # on a top the footprint stays under the foot and the initializer keeps the clip's leg:
    # moved within the leg's reach it left the top (holosoma seq_1: 37 -> 158 mm into box1)
    from imesh.solve.footprints import level_placement
    level = g1.frame_rotations(g1.q_nominal, [g1.soles["right"].frame])[0]
    under = level_placement(g1.soles["right"], level, feet.first[1][None])
    np.testing.assert_allclose(feet.down_first[1][:2, 3], under[:2, 3], atol=1e-12)
    np.testing.assert_array_equal(feet.q_first[1], q[0])
    np.testing.assert_array_equal(lead.q[:30], np.repeat(q[:1], 30, axis=0))


def test_a_foot_kicked_up_behind_is_stood_down_in_the_initializer(g1):
    """A running clip's first frame has the rear foot kicked up behind the body, its sole
    pitched past 90 degrees (the Bandai Namco run on G1: 109), so its x axis points back. The
    lead puts it down with the heading of the shortest rotation that levels it (the other
    foot's, not turned round), and the initializer's right leg alone stands that sole on its
    footprint through the lead-in (as near as it reaches from the clip's hips), then blends
    into the clip's over the swing: the SQP's trust region would need more iterations than it
    has to unfold the knee (the sole was still 370 mm off after 20)."""
    from imesh.fit.targets import compile_targets, robot_targets
    from imesh.solve.lead import lead_feet

    kps, dirs = robot_targets(g1)
    names = sorted({k.marker for k in kps} | {m for d in dirs for m in (d.from_marker,
                                                                         d.to_marker)})
    targets = compile_targets(g1, names, None, None)
    q = g1.q_nominal.copy()
    for name, angle in (("right_hip_pitch_joint", 0.6), ("right_knee_joint", 2.0),
                        ("right_ankle_pitch_joint", 0.3)):
        q[7 + g1.joint_index(name)] += angle
    q = np.repeat(g1.clip(q)[None], 2, axis=0)
    frames = [g1.soles[s].frame for s in ("left", "right")]
    R = g1.frame_rotations(q[0], frames) @ np.transpose(
        g1.frame_rotations(g1.q_nominal, frames), (0, 2, 1))
    assert np.degrees(np.arccos(R[1, 2, 2])) > 95  # the right sole pitched past 90 deg
    feet = lead_feet(g1, q, targets)
    yaw = [np.arctan2(d[1, 0], d[0, 0]) for d in feet.down_first]
    assert abs(yaw[1] - yaw[0]) < 0.05  # not turned round (pi with the x axis's heading)
    # the footprint stays under the clip's foot; from the clip's hips the leg reaches it level
    # within 43 mm (the clip's sole: 627 mm off, pitched 166 deg), the SQP lowers the hips
    from imesh.solve.footprints import level_placement
    level = g1.frame_rotations(g1.q_nominal, [frames[1]])[0]
    under = level_placement(g1.soles["right"], level, feet.first[1][None])
    np.testing.assert_allclose(feet.down_first[1][:2, 3], under[:2, 3], atol=1e-12)
    stood = g1.frame_placements(feet.q_first[1], frames)
    assert np.linalg.norm(stood[1][:3, 3] - feet.down_first[1][:3, 3]) < 0.05
    tilt = np.arccos(np.clip((np.trace(stood[1][:3, :3].T @ feet.down_first[1][:3, :3]) - 1) / 2,
                             -1.0, 1.0))
    assert np.degrees(tilt) < 0.1
    legs = np.zeros(g1.nq, bool)
    legs[7 + feet.legs[1]] = True
    np.testing.assert_array_equal(feet.q_first[1][~legs], q[0][~legs])  # the right leg alone
    lead = add_lead(q, np.zeros((2, len(names), 3)), np.array([[True, False], [True, True]]),
                    30, 0, step_frames=15, feet=feet)
    np.testing.assert_array_equal(lead.q[:15], np.repeat(feet.q_first[1][None], 15, axis=0))
    np.testing.assert_array_equal(lead.q[30:], q)
    steps = np.abs(np.diff(lead.q[14:31, 7:], axis=0)).max(axis=1)
    assert steps.max() <= 1.6 * np.abs(q[0, 7:] - feet.q_first[1][7:]).max() / 16

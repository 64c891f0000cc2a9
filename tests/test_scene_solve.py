"""Issue 34, part 3: the props in the method (supports on a prop's top, no link inside a prop).

Geometry and rows on constructed boxes (exact answers known), the G1's kinematics for the
rows' gradients; the retarget of a real climbing window is in tests/test_scene_retarget.py.
"""

from __future__ import annotations

import numpy as np
import trimesh
from conftest import load_test_robot

from imesh.contacts.surfaces import phase_heights
from imesh.scene import Prop, Scene, prop_planes
from imesh.scene.surfaces import surface_heights
from imesh.solve.footprints import raised
from imesh.solve.props import linearize_props, pad_planes, segment_distances


def box(name: str, lo, hi) -> Prop:
    b = trimesh.creation.box(bounds=np.array([lo, hi], dtype=float))
    return Prop(name, np.asarray(b.vertices), np.asarray(b.faces))


def test_segment_distance_is_the_least_over_the_segment():
    """The exact minimum of ``max_k (n_k . p - d_k)`` along a segment, against 20001 samples."""
    rng = np.random.default_rng(3)
    planes = prop_planes(box("b", [-0.2, -0.3, 0.0], [0.2, 0.3, 0.5]))
    a = rng.uniform(-0.6, 0.8, size=(400, 3))
    b = rng.uniform(-0.6, 0.8, size=(400, 3))
    phi, s, normal = segment_distances(a, b, np.broadcast_to(planes, (400,) + planes.shape))
    grid = np.linspace(0, 1, 20001)
    pts = a[:, None] + grid[None, :, None] * (b - a)[:, None]
    brute = np.max(pts @ planes[:, :3].T - planes[:, 3], axis=-1).min(axis=1)
    assert np.abs(phi - brute).max() < 1e-4  # grid spacing x segment length
    assert (phi <= brute + 1e-12).all()  # never above a sampled value: the exact minimum
    at = a + s[:, None] * (b - a)
    reached = np.max(at @ planes[:, :3].T - planes[:, 3], axis=-1)
    np.testing.assert_allclose(reached, phi, atol=1e-12)
    # the normal is the gradient of phi for a translation of the segment (a face's normal, or
    # two faces' weighted where the minimum sits on their crossing)
    delta = rng.normal(scale=1e-6, size=(400, 3))
    moved, _, _ = segment_distances(a + delta, b + delta,
                                    np.broadcast_to(planes, (400,) + planes.shape))
    np.testing.assert_allclose(moved - phi, np.sum(normal * delta, axis=1), atol=1e-11)


def test_surface_under_a_foot():
    """A point over a box top, up to ``below_m`` under it, stands on it; beside it, deep under
    it (inside the box) or over the floor: the floor."""
    scene = Scene((box("low", [0, 0, 0], [1, 1, 0.2]), box("high", [1.5, 0, 0], [2, 1, 0.6])))
    pts = np.array([[0.2, 0.5, 0.25], [0.2, 0.5, 0.17], [0.2, 0.5, 0.1], [1.2, 0.5, 0.25],
                    [1.7, 0.5, 0.62], [1.7, 0.5, 0.3], [-0.1, 0.5, 0.0]])
    np.testing.assert_allclose(surface_heights(scene, pts, below_m=0.05),
                               [0.2, 0.2, 0.0, 0.0, 0.6, 0.0, 0.0])


def test_phase_heights_hold_into_the_swings_to_their_middle():
    support = np.zeros((20, 2), dtype=bool)
    support[2:6, 0] = support[12:18, 0] = True
    heights = np.zeros((20, 2))
    heights[12:18, 0] = 0.3
    heights[14, 0] = 0.0  # one noisy frame: the median holds the phase's height
    out = phase_heights(support, heights)
    np.testing.assert_allclose(out[:, 0], [0.0] * 9 + [0.3] * 11)
    np.testing.assert_allclose(out[:, 1], 0.0)


def test_raised_footprint_is_level_at_the_height():
    from imesh.solve.footprints import Footprint

    pose = np.eye(4)
    pose[:3, 3] = [0.1, 0.2, 0.035]
    c = np.array([0.1, 0.2, 0.0])
    f = Footprint(side="left", start=0, stop=5, frame_pose=pose, center_m=c,
                  corners_m=np.tile(c, (4, 1)), polygon_m=np.tile(c, (4, 1)))
    g = raised(f, 0.367)
    assert g.center_m[2] == 0.367 and g.frame_pose[2, 3] == 0.035 + 0.367
    np.testing.assert_array_equal(g.frame_pose[:3, :3], pose[:3, :3])


def test_prop_rows_are_the_gradients_of_the_distances():
    """Every capsule and foot point of the G1 against a box at its right hand and one under its
    left foot: the rows' first-order prediction of the distances after a small random motion
    matches the exact distances (errors second order), and a supporting foot is not checked."""
    from imesh.solve.sqp import foot_ground_points

    robot = load_test_robot("g1")
    model = robot.capsule_model()
    rng = np.random.default_rng(0)
    # off the symmetric nominal pose, where segments parallel to a face make the least
    # distance along them flat (a kink of the distance, no gradient)
    q0 = robot.integrate(robot.q_nominal, rng.normal(scale=0.05, size=robot.nv))
    hand = robot.frame_placements(q0, ["right_wrist_yaw_link"])[0][:3, 3]
    planes = pad_planes([prop_planes(box("b", hand + [-0.1, -0.1, -0.3], hand + [0.2, 0.1, 0.02])),
                         prop_planes(box("floor_box", [-0.5, -0.5, -0.3], [0.5, 0.5, 0.08]))])
    corners_local = foot_ground_points(robot)  # (2, P, 3)
    soles = [robot.soles[s].frame for s in ("left", "right")]

    def measure(qs, support):
        T = len(qs)
        frames = model.frames + soles
        kin = robot.trajectory_kinematics(qs, [robot.frame_id(f) for f in frames])
        M, J = kin.placements, kin.jacobians
        F = len(model.frames)
        Mc, Jc = M[:, :F][:, model.frame_index], J[:, :F][:, model.frame_index]
        Ms, Js = M[:, F:], J[:, F:]
        pts = np.einsum("tsij,spj->tspi", Ms[..., :3, :3], corners_local) + Ms[:, :, None, :3, 3]
        n_pts = corners_local.shape[1]
        skip = np.array([c.frame in soles for c in model.capsules])
        return linearize_props(planes, model.world_segments(M[:, :F]), model.radius,
                               Mc[..., :3, 3], Jc, np.broadcast_to(skip, (T, len(skip))),
                               pts.reshape(T, -1, 3), np.repeat(Ms[..., :3, 3], n_pts, axis=1),
                               np.repeat(Js, n_pts, axis=1),
                               np.repeat(support, n_pts, axis=1), activation=np.inf)

    support = np.array([[False, False]])
    lin = measure(q0[None], support)
    assert lin.min_distance[0] < 0  # the hand in its box
    dq = rng.normal(scale=1e-3, size=robot.nv)
    q1 = robot.integrate(q0, dq)
    after = measure(q1[None], support)
    pred = lin.distance + lin.rows @ dq
    key0 = {(x, p): d for x, p, d in zip(lin.proxies, lin.props, pred, strict=True)}
    key1 = {(x, p): d for x, p, d in zip(after.proxies, after.props, after.distance,
                                         strict=True)}
    common = sorted(set(key0) & set(key1))
    err = np.array([key0[k] - key1[k] for k in common])
    moved = np.array([key1[k] - lin.distance[list(zip(lin.proxies, lin.props,
                                                      strict=True)).index(k)] for k in common])
    assert len(common) > 100 and np.abs(moved).max() > 1e-3
    assert np.abs(err).max() < 0.02 * np.abs(moved).max()
    # a supporting left foot: its points are not checked against any prop
    held = measure(q0[None], np.array([[True, False]]))
    C, P = len(model.radius), corners_local.shape[1]
    assert not np.any((held.proxies >= C) & (held.proxies < C + P))
    assert np.any((lin.proxies >= C) & (lin.proxies < C + P))


def test_support_is_cut_where_the_surface_changes():
    """A foot carried from a box top onto a higher one within one detected support run is
    given a swing of 0.1 s either side of the change, so each phase has one height."""
    from imesh.contacts.phases import Contacts
    from imesh.contacts.surfaces import split_at_surface_changes

    support = np.ones((40, 2), dtype=bool)
    heights = np.zeros((40, 2))
    heights[20:, 0] = 0.367  # the left foot steps onto the higher top at frame 20
    out = split_at_surface_changes(Contacts(support=support, fps=30.0,
                                            sliding=support.copy()), heights)
    np.testing.assert_array_equal(np.flatnonzero(~out.support[:, 0]), np.arange(17, 23))
    assert out.support[:, 1].all() and not out.sliding[17:23, 0].any()
    levels = phase_heights(out.support, heights)[:, 0]
    assert (levels[:17] == 0).all() and (levels[23:] == 0.367).all()


def test_a_foot_far_above_its_surface_is_not_a_support():
    """Frames whose foot the detection calls support (its fallback for frames neither on the
    ground nor falling) while it is far above the surface under it lose the support."""
    from imesh.contacts.phases import Contacts
    from imesh.contacts.surfaces import drop_hanging
    from imesh.core.motion import MarkerMotion

    T = 30
    pos = np.zeros((T, 4, 3))
    pos[:, :, 2] = 0.03  # toes and ankles resting
    pos[10:20, 0:2, 2] = 0.5  # the left foot hangs 47 cm up in frames 10-19
    motion = MarkerMotion(positions_m=pos, fps=30.0, names=("toe_l", "ankle_l", "toe_r",
                                                             "ankle_r"),
                          valid=np.ones((T, 4), dtype=bool))
    support = np.ones((T, 2), dtype=bool)
    out = drop_hanging(Contacts(support=support, fps=30.0), motion, above_m=0.15)
    np.testing.assert_array_equal(np.flatnonzero(~out.support[:, 0]), np.arange(10, 20))
    assert out.support[:, 1].all()

"""Levelling a clip on the plane of its planted feet (imesh.io.floor, applied by load_motion).

Real cases: the CMU walks are captured on a floor tilted about 1 degree along the walk (planted
toes rise 16-18 mm per metre); the wave tells no slope; a person climbing boxes does not stand on
one plane. Invariants on the synthetic walk, whose floor is exactly level: any tilt given to it
is found and undone, up to a translation, and the props of a scene move with the clip.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import data_root

from imesh.io import load_motion
from imesh.io.floor import MAX_TILT_RAD, MIN_TILT_RAD, fit_floor
from imesh.io.synthetic import synthetic_walk_clap
from imesh.metrics.props import signed_distance
from imesh.scene import human_scene, load_scene
from imesh.scene.props import prop_planes


def tilted(angle_rad: float, heading_rad: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The synthetic walk's positions turned to ``heading`` (about +Z) and then tilted by
    ``angle`` about the horizontal axis across the walk: the floor rises along the walk."""
    walk = synthetic_walk_clap(steps=6)
    c, s = np.cos(heading_rad), np.sin(heading_rad)
    yaw = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    axis = yaw @ [0.0, -1.0, 0.0]  # right of the walk: a positive angle raises the floor ahead
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    tilt = np.eye(3) + np.sin(angle_rad) * k + (1 - np.cos(angle_rad)) * (k @ k)
    return walk.positions_m @ yaw.T, walk.positions_m @ (tilt @ yaw).T


def save_joints(path, positions: np.ndarray) -> None:
    walk = synthetic_walk_clap(steps=6)
    np.savez(path, positions=positions, names=np.array(walk.names), fps=np.float64(walk.fps))


@pytest.mark.parametrize("angle_deg, heading_deg", [(1.0, 0.0), (-0.6, 30.0), (1.8, -120.0)])
def test_a_tilted_floor_is_found_and_levelled(tmp_path, angle_deg, heading_deg):
    """The fit recovers the tilt and its direction within 0.01 degree; the loaded clip equals
    the level walk up to a translation (levelling turns it about its own floor) within 0.5 mm
    (the planted samples include the lowest marker of heel-rise frames, 0.1 mm RMS off the
    floor, so the fitted tilt is not exact)."""
    level, tilt = tilted(np.deg2rad(angle_deg), np.deg2rad(heading_deg))
    walk = synthetic_walk_clap(steps=6)
    fit = fit_floor(tilt, walk.valid, walk.fps)
    assert fit.levelled, fit.reason
    assert np.rad2deg(fit.tilt_rad) == pytest.approx(abs(angle_deg), abs=0.01)
    uphill = np.array([np.cos(np.deg2rad(heading_deg)), np.sin(np.deg2rad(heading_deg))])
    assert np.sign(fit.slope @ uphill) == np.sign(angle_deg)
    assert fit.residual_rms_m < 1e-3
    save_joints(tmp_path / "tilted.npz", tilt)
    motion = load_motion(tmp_path / "tilted.npz")
    assert np.rad2deg(motion.meta["floor_tilt_rad"]) == pytest.approx(abs(angle_deg), abs=0.01)
    shift = (motion.positions_m - level).reshape(-1, 3)
    np.testing.assert_allclose(shift - shift.mean(axis=0), 0.0, atol=5e-4)
    assert abs(shift[:, :2].mean(axis=0)).max() < 0.01  # turned about the walk's own floor
    again = fit_floor(motion.positions_m, motion.valid, motion.fps)
    assert np.rad2deg(again.tilt_rad) < 0.005


def test_a_level_walk_and_a_ramp_are_kept(tmp_path):
    """Below 0.25 degree the clip is kept as it is; beyond 2 degrees the plane is a slope (a
    ramp, not a calibration) and is kept too, with the reason logged in ``meta``."""
    for angle in (0.0, 0.8 * MIN_TILT_RAD, 1.5 * MAX_TILT_RAD):
        _, tilt = tilted(angle)
        save_joints(tmp_path / "clip.npz", tilt)
        motion = load_motion(tmp_path / "clip.npz")
        assert motion.meta["floor_tilt_rad"] == 0.0
        assert motion.meta["floor_level_reason"].startswith("not levelled")
        assert "floor_level_rotation" not in motion.meta
        lift = motion.positions_m - tilt
        np.testing.assert_allclose(lift[..., :2], 0.0, atol=1e-12)  # not turned
        np.testing.assert_allclose(lift[..., 2], lift[0, 0, 2], atol=1e-12)  # only shifted
    none = load_motion(tmp_path / "clip.npz", ground="none")
    assert "floor_level_reason" not in none.meta
    np.testing.assert_array_equal(none.positions_m, tilted(1.5 * MAX_TILT_RAD)[1])


@pytest.mark.parametrize("clip, tilt_deg", [("cmu_02_01_walk.bvh", 0.93), ("cmu_07_05.amc", 1.04)])
def test_the_cmu_walks_are_levelled(clip, tilt_deg):
    """The CMU walks' planted toes lie on a plane tilted about 1 degree (3-4 mm RMS from it);
    after loading, the same fit finds their floor level."""
    motion = load_motion(data_root() / "mocap" / clip)
    assert np.rad2deg(motion.meta["floor_tilt_rad"]) == pytest.approx(tilt_deg, abs=0.02)
    again = fit_floor(motion.positions_m, motion.valid, motion.fps)
    assert np.rad2deg(again.tilt_rad) < 0.01
    assert again.residual_rms_m < 0.005


@pytest.mark.parametrize("clip, why", [
    ("mocap/cmu_141_16_wave_hello.bvh", "tells no slope"),
    ("mocap/cmu_16_11_walk_veer_left.bvh", "< 0.25 deg"),
    ("interaction/holosoma_climb/mocap_climb_seq_0/"
     "mocap_climb_seq_0_joint_positions_f900-3700.npy", "not one floor"),
])
def test_clips_without_a_tilted_floor_are_kept(clip, why):
    """A wave stands in place (no slope to tell), the veer's floor tilts 0.17 degree, and a
    person climbing boxes stands on several heights (0.3 m from any one plane)."""
    motion = load_motion(data_root() / clip, fps=120 if clip.endswith(".npy") else None)
    assert motion.meta["floor_tilt_rad"] == 0.0
    assert why in motion.meta["floor_level_reason"]


def test_props_are_levelled_with_the_clip(tmp_path):
    """A box beside the tilted walk keeps every marker's signed distance to its faces (1e-9 m)
    once both are loaded: the scene takes the clip's levelling and floor shift (its top,
    level in the file, tilts by the clip's correction)."""
    trimesh = pytest.importorskip("trimesh")
    _, tilt = tilted(np.deg2rad(1.2))
    save_joints(tmp_path / "tilted.npz", tilt)
    box = trimesh.creation.box(extents=(0.4, 0.4, 0.3))
    box.apply_translation([1.2, 0.5, 0.2])
    box.export(tmp_path / "box.obj")
    motion = load_motion(tmp_path / "tilted.npz")
    assert motion.meta["floor_tilt_rad"] > 0.0
    raw = load_scene([tmp_path / "box.obj"])
    loaded = human_scene(raw, motion.meta)
    toe = synthetic_walk_clap(steps=6).index("toe_r")
    before = signed_distance(tilt[:, toe], prop_planes(raw.props[0]))
    after = signed_distance(motion.positions_m[:, toe], prop_planes(loaded.props[0]))
    np.testing.assert_allclose(after, before, atol=1e-9)
    top = prop_planes(loaded.props[0])[:, :3].max(axis=0)[2]  # the box's top normal, z
    assert np.arccos(top) == pytest.approx(motion.meta["floor_tilt_rad"], rel=1e-6)  # turned


def test_a_pair_is_put_on_one_floor():
    """The salsa partners, captured together: read as a pair they share one levelling and one
    floor shift, so every distance between their markers is the files' (1e-9 m); grounded
    one by one, partner B's floor shift (its lowest markers 55 mm up) and A's (kept) would
    move them 55 mm apart vertically. Read at the headers' 120 fps (their planted feet fit one
    plane tilted 0.34 deg; at the 60 fps the timing check picks, slower feet count as planted
    and the plane's 13.7 mm residual leaves the pair unlevelled)."""
    from imesh.io.clip import read_clip, read_pair

    path_a = data_root() / "mocap" / "cmu_60_10_salsa_partnerA_sl_scaled.bvh"
    path_b = data_root() / "mocap" / "cmu_61_10_salsa_partnerB_sl_scaled.bvh"
    header = {"source_fps": 120.0048}
    a, b = read_pair(path_a, path_b, header, header)
    assert a.meta["floor_offset_m"] == b.meta["floor_offset_m"]
    assert a.meta["floor_level_rotation"] == b.meta["floor_level_rotation"]
    assert "with the partner" in a.meta["floor_level_reason"]
    raw_a, raw_b = (read_clip(p, header, ground="none") for p in (path_a, path_b))
    pelvis_a, pelvis_b = a.index("hip"), b.index("hip")
    gap = np.linalg.norm(a.positions_m[:, pelvis_a] - b.positions_m[:, pelvis_b], axis=1)
    gap_file = np.linalg.norm(raw_a.positions_m[:, pelvis_a] - raw_b.positions_m[:, pelvis_b],
                              axis=1)
    np.testing.assert_allclose(gap, gap_file, atol=1e-9)
    alone_a, alone_b = read_clip(path_a, header), read_clip(path_b, header)
    shift = alone_a.meta["floor_offset_m"] - alone_b.meta["floor_offset_m"]
    assert abs(shift) > 0.05
    low = min(np.nanmin(a.positions_m[..., 2]), np.nanmin(b.positions_m[..., 2]))
    assert -0.1 < low < 0.0  # the shared floor at z = 0: the 2nd percentile, some frames below


def test_adapt_people_puts_both_performers_on_one_floor(tmp_path, capsys):
    """`imesh adapt A --people B` morphs the couple in one mesh on their shared floor: the
    height between their pelvises is the pair reader's within 5 mm (the morph's filtering),
    not the one of each clip on its own floor (11-70 mm off: each clip's own levelling and
    floor shift)."""
    from conftest import run_cli

    from imesh.human.standard import to_standard
    from imesh.io.clip import read_clip, read_pair
    from imesh.io.npz import load_marker_motion

    path_a = data_root() / "mocap" / "cmu_60_10_salsa_partnerA_sl_scaled.bvh"
    path_b = data_root() / "mocap" / "cmu_61_10_salsa_partnerB_sl_scaled.bvh"
    out = tmp_path / "pair.npz"
    status, _ = run_cli(capsys, "-q", "adapt", path_a, "--people", path_b, "--fps", "30",
                        "-o", out)
    assert status == 0
    written = load_marker_motion(out)
    gap = (written.positions_m[:, written.index("a:pelvis"), 2]
           - written.positions_m[:, written.index("b:pelvis"), 2])
    a, b = (to_standard(m.resample(30.0)) for m in read_pair(path_a, path_b))
    pair_gap = a.positions_m[:, a.index("pelvis"), 2] - b.positions_m[:, b.index("pelvis"), 2]
    alone_a, alone_b = (to_standard(read_clip(p).resample(30.0)) for p in (path_a, path_b))
    alone_gap = (alone_a.positions_m[:, alone_a.index("pelvis"), 2]
                 - alone_b.positions_m[:, alone_b.index("pelvis"), 2])
    assert np.abs(gap - pair_gap).max() < 0.005  # the morph's smoothing: within 5 mm
    assert np.abs(gap - alone_gap).max() > 0.05  # each on its own floor: 11-70 mm off


def test_scattered_planted_samples_tell_no_floor():
    """Planted samples spread 0.5 m up and down are not one floor (0.29 m from the best
    plane): the fit says so and leaves the clip as it is."""
    from imesh.io.floor import fit_plane

    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(0, 3, 200), rng.uniform(-0.1, 0.1, 200),
                           rng.uniform(-0.5, 0.5, 200)])
    fit = fit_plane(pts)
    assert not fit.levelled and fit.rotation.tolist() == np.eye(3).tolist()
    assert "not one floor" in fit.reason and fit.residual_rms_m > 0.2

"""The marker model arranged for a robot (imesh.human.arrange): the robot-shaped segments.

Real clips from IMESH_DATA on the three robots; numbers the morph and the fit depend on.
"""

from __future__ import annotations

import itertools
import shutil

import numpy as np
import pytest
from conftest import hrp4c_urdf, load_test_robot, mocap_path

from imesh.human.arrange import ArrangementError, _pelvis_angle, arrange_for_robot
from imesh.io import load_motion
from imesh.morph.adapt import prepare_markers
from imesh.robot import ROBOTS_DIR, RobotConfigError, load_markers_config, load_robot

ROBOTS = ["jvrc1", "g1", "hrp4c"]


@pytest.fixture(scope="module")
def walk():
    return prepare_markers(load_motion(mocap_path("cmu_02_01_walk.bvh")))


def with_segments(tmp_path, name: str, segments: str):
    """A copy of a shipped robot whose markers.toml has ``segments = <segments>``."""
    folder = tmp_path / name
    folder.mkdir()
    shutil.copy(ROBOTS_DIR / name / "robot.toml", folder)
    text = (ROBOTS_DIR / name / "markers.toml").read_text()
    text = "\n".join(line for line in text.splitlines() if not line.startswith("segments ="))
    (folder / "markers.toml").write_text(
        text.replace("[arrangement]\n", f"[arrangement]\nsegments = {segments}\n", 1))
    return folder / "robot.toml"


@pytest.mark.parametrize("name", ROBOTS)
def test_segments_take_the_robot_shape_in_every_frame(name, walk, tmp_path):
    """Every pair of a segment's markers is at the robot's distance in every frame, and the
    segment hangs from its parent marker at the robot's bone length (G1 ships its torso
    segment; JVRC-1 and HRP-4C are given one here)."""
    if name == "g1":
        robot = load_test_robot(name)
    else:
        urdf = hrp4c_urdf() if name == "hrp4c" else None
        robot = load_robot(with_segments(tmp_path, name,
                                         '[["chest", "neck", "shoulder_l", "shoulder_r"]]'),
                           urdf=urdf)
    arr = arrange_for_robot(walk, robot)
    names = list(arr.motion.names)
    pos, pts = arr.motion.positions_m, arr.robot_points_m
    assert robot.markers.segments
    for seg in robot.markers.segments:
        for a, b in itertools.combinations(seg, 2):
            i, j = names.index(a), names.index(b)
            d = np.linalg.norm(pos[:, i] - pos[:, j], axis=1)
            assert np.abs(d - np.linalg.norm(pts[i] - pts[j])).max() < 1e-9, (a, b)
            assert (a, b) in arr.pair_names or (b, a) in arr.pair_names  # rigid in the morph
    chest, pelvis = names.index("chest"), names.index("pelvis")
    d = np.linalg.norm(pos[:, chest] - pos[:, pelvis], axis=1)
    assert np.abs(d - np.linalg.norm(pts[chest] - pts[pelvis])).max() < 1e-9


def test_the_g1_walk_keeps_its_pelvis_upright_through_the_morph(walk):
    """The G1's trunk is long for its legs (hip to shoulder 400 mm, the leg-scaled human's about
    366): with the robot-shaped torso the morph has no trunk to lengthen, so the pelvis marker
    stays near the robot's 15 degrees about the hip axis (it was turned to 53-96 degrees)."""
    from imesh.pipeline.retarget import RetargetConfig, retarget

    robot = load_test_robot("g1")
    res = retarget(load_motion(mocap_path("cmu_02_01_walk.bvh")), robot,
                   config=RetargetConfig(balance="none"))
    names = list(res.adapted.names)
    angle = np.degrees(_pelvis_angle(res.adapted.positions_m, names.index("pelvis"),
                                     names.index("hip_l"), names.index("hip_r"))[0])
    robot_angle = np.degrees(_pelvis_angle(res.arrangement.robot_points_m,
                                           names.index("pelvis"), names.index("hip_l"),
                                           names.index("hip_r"))[0])
    assert np.abs(angle - robot_angle).max() < 25.0
    assert np.abs(np.median(angle) - robot_angle) < 8.0


def test_a_segment_that_is_not_rigid_on_the_robot_is_refused(tmp_path, walk):
    robot = load_robot(with_segments(tmp_path, "jvrc1", '[["chest", "neck", "shoulder_l", '
                                     '"shoulder_r"], ["elbow_l", "wrist_l", "hand_l"]]'))
    with pytest.raises(ArrangementError,
                       match=r"segment \['elbow_l', 'wrist_l', 'hand_l'\] is not rigid on jvrc1: "
                             r"the distance of elbow_l and \w+ changes by \d+ mm"):
        arrange_for_robot(walk, robot)


@pytest.mark.parametrize("segments, message", [
    ('[["chest", "neck"]]', r"needs three different markers"),
    ('[["chest", "neck", "shoulder_l"], ["neck", "shoulder_r", "head"]]',
     r"marker 'neck' is in two segments"),
    ('[["chest", "neck", "spine"]]', r"unknown or removed marker 'spine'"),
    ('["chest"]', r"must be a list of names"),
])
def test_bad_segments_name_the_key(tmp_path, segments, message):
    path = with_segments(tmp_path, "jvrc1", segments).parent / "markers.toml"
    with pytest.raises(RobotConfigError, match=r"arrangement\.segments.*" + message
                       + "|" + message):
        load_markers_config(path)

"""The viewer, its page and the report with two robots of a pair and with a scene's props.

Real files, made once per module: the CMU salsa couple's hand hold (clip frames 520-580, 30
frames at 30 fps, no lead-in) retargeted by ``imesh retarget --partner`` to G1 + JVRC-1 with
``--report`` (about 25 s here), and a step up onto the holosoma boxes retargeted to the G1 with
``--scene`` (the initial fit only, about 5 s). Browser tests skip only when Chromium or
Playwright is not installed (CI installs both: .ci/run).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import data_root, run_cli
from scipy.spatial.transform import Rotation

from imesh.cli import main

SALSA_A = "cmu_60_10_salsa_partnerA_sl_scaled.bvh"
SALSA_B = "cmu_61_10_salsa_partnerB_sl_scaled.bvh"
CLIMB = "interaction/holosoma_climb/mocap_climb_seq_0"


@pytest.fixture(scope="module")
def pair_files(tmp_path_factory, mocap):
    """``imesh retarget A --partner B --report``: the folder with salsa.npz,
    salsa.partner.npz, salsa.pair.json and salsa.html."""
    out = tmp_path_factory.mktemp("pair")
    assert main(["-q", "retarget", str(mocap(SALSA_A)), "--partner", str(mocap(SALSA_B)),
                 "--robot", "g1", "--partner-robot", "jvrc1", "--frames", "520:580",
                 "--no-lead", "--force", "-o", str(out / "salsa.npz"),
                 "--report", str(out / "salsa.html")]) == 0
    return out


@pytest.fixture(scope="module")
def props_motion(tmp_path_factory):
    """``imesh retarget WINDOW --scene box1.obj ... --report g1.html`` (160 frames at 120 fps of
    the person stepping onto box2, ``--balance none``): the motion file, with g1.scene.npz and
    the report beside it."""
    seq = data_root() / CLIMB
    if not seq.is_dir():
        pytest.skip(f"{seq} not found (IMESH_DATA)")
    out = tmp_path_factory.mktemp("props")
    names = (seq.parent / "joint_names.txt").read_text().split()
    window = out / "step_up.npz"
    np.savez(window, positions=np.load(seq / "mocap_climb_seq_0_joint_positions_f900-3700.npy")
             [300:460], names=np.array(names), fps=np.float64(120))
    argv = ["-q", "retarget", str(window), "--robot", "g1", "--balance", "none", "--force",
            "-o", str(out / "g1.npz"), "--report", str(out / "g1.html")]
    for box in sorted((seq / "box_models").glob("*.obj")):
        argv += ["--scene", str(box)]
    assert main(argv) == 0
    return out / "g1.npz"


def _browser():
    """Skip when the browser stack is not installed."""
    pytest.importorskip("playwright.sync_api", reason="pip install 'imesh[viz]'")
    from imesh.viz.browser import find_chromium

    if find_chromium() is None:
        pytest.skip("chromium not installed (apt-get install chromium)")


def _assert_forward_kinematics(robot, q: np.ndarray, view: dict) -> None:
    """The scene's link poses of a robot are its forward kinematics of ``q`` at every
    frame."""
    from imesh.viz.scene import decode

    poses = decode(view["link_poses"])
    assert poses.shape == (len(q), len(view["links"]), 7)
    ids = [robot.frame_id(n) for n in view["links"]]
    M = np.stack([robot.frame_placements(row, ids) for row in q])  # (T, L, 4, 4)
    assert np.abs(poses[..., :3] - M[..., :3, 3]).max() < 1e-5
    R = Rotation.from_quat(poses[..., 3:].reshape(-1, 4)).as_matrix().reshape(M[..., :3, :3].shape)
    assert np.abs(R - M[..., :3, :3]).max() < 1e-5


# ----------------------------------------------------------------------------------------------
# the scene


def test_pair_scene_holds_both_robots_as_written(pair_files):
    """``imesh view OUT.pair.json``'s scene: both robots where their files put them (forward
    kinematics of each file's q), each with its adapted markers and person, one timeline, the
    pair's figures and its distance per frame."""
    from imesh.cli.view import pair_scene
    from imesh.evaluate.motion_files import load_motion_file
    from imesh.partners.holds import HAND_MARKERS
    from imesh.robot import load_robot
    from imesh.viz.scene import decode, robot_view

    manifest = json.loads((pair_files / "salsa.pair.json").read_text())
    scene = pair_scene(pair_files / "salsa.pair.json", source=True)
    assert scene["frames"] == 30 and scene["fps"] == pytest.approx(manifest["pair"]["a"]["fps"])
    assert [r["label"] for r in scene["robots"]] == ["a g1", "b jvrc1"]
    assert sorted(scene["models"]) == ["g1", "jvrc1"]
    for k, key in enumerate(("a", "b")):
        robot = load_robot(manifest["robots"][key])
        motion = load_motion_file(pair_files / f"salsa{'.partner' if k else ''}.npz", robot)
        assert motion.n_frames == 30
        view = robot_view(scene, k)
        _assert_forward_kinematics(robot, motion.q, view)
        np.testing.assert_allclose(decode(view["markers"]["positions"]),
                                   motion.adapted.positions_m, atol=1e-6)
        assert decode(view["source"]["positions"]).shape[:2] == (30, len(view["source"]["names"]))
        assert len(view["collisions"]) == len(view["limits"]) == 30
    # the pair's figures and, per frame, the robots' distance (its least is the penetration)
    pair = scene["pair"]
    assert pair["metrics"] == manifest["pair_metrics"]
    distance, held = decode(pair["distance_mm"]), decode(pair["held"]).astype(bool)
    assert distance.shape == held.shape == (30,) and np.isfinite(distance).any()
    assert max(-distance.min(), 0.0) == pytest.approx(
        manifest["pair_metrics"]["robot_penetration_mm"], abs=1e-3)
    assert 0 < held.sum() <= manifest["pair_metrics"]["hold_frames"]
    # both people are drawn in the pair's one world (its shared scale about its one point):
    # in the held frames their hands are as close as the source's (10 cm) scaled
    a, b = (scene["robots"][k]["source"] for k in (0, 1))
    pa, pb = decode(a["positions"])[held], decode(b["positions"])[held]
    hands_a = [a["names"].index(n) for n in HAND_MARKERS if n in a["names"]]
    hands_b = [b["names"].index(n) for n in HAND_MARKERS if n in b["names"]]
    gap = np.linalg.norm(pa[:, hands_a, None] - pb[:, None, hands_b], axis=-1).min(axis=(1, 2))
    assert gap.max() < 0.10 * manifest["pair"]["scale"] + 1e-3, gap


def test_robots_of_one_scene_share_a_timeline(pair_files):
    from imesh.errors import ImeshError
    from imesh.evaluate.motion_files import load_motion_file
    from imesh.robot import load_robot
    from imesh.viz.scene import SceneRobot, build_robots_scene

    robot = load_robot("g1")
    motion = load_motion_file(pair_files / "salsa.npz", robot)
    with pytest.raises(ImeshError, match="one timeline"):
        build_robots_scene([SceneRobot(robot, motion), SceneRobot(robot, motion.frames(0, 10))],
                           title="x")


def test_props_in_the_scene_are_the_saved_scene(props_motion, tmp_path):
    """The props the viewer draws are the motion's OUT.scene.npz, vertex for vertex; ``imesh
    view`` and the report of ``imesh retarget --scene --report`` find and draw them."""
    from imesh.evaluate.motion_files import load_motion_file
    from imesh.robot import load_robot
    from imesh.scene import load_saved_scene, scene_path_for
    from imesh.viz.scene import build_scene, decode, robot_view

    saved = load_saved_scene(scene_path_for(props_motion))
    robot = load_robot("g1")
    motion = load_motion_file(props_motion, robot)
    scene = build_scene(robot, motion, props=saved)
    assert [p["name"] for p in scene["props"]] == ["box1", "box2", "box3"]
    for entry, prop in zip(scene["props"], saved.props, strict=True):
        np.testing.assert_allclose(decode(entry["vertices"]), prop.vertices_m, atol=1e-6)
        assert (decode(entry["faces"]) == prop.faces).all()
    _assert_forward_kinematics(robot, motion.q, robot_view(scene))
    # the command line finds the scene beside the motion; --source alone draws the clip the
    # motion names
    page = tmp_path / "v.html"
    assert main(["-q", "view", str(props_motion), "--source", "--html", str(page)]) == 0
    text = page.read_text()
    assert '"props":[{"name":"box1"' in text and '"source":{' in text
    # the reports' viewer draws them too: retarget --scene --report, and evaluate --report (which
    # failed on a motion with a scene: its table took the scene's figures for a metric)
    assert main(["-q", "evaluate", str(props_motion), "--report", str(tmp_path / "e.html")]) == 0
    for report in (props_motion.with_name("g1.html"), tmp_path / "e.html"):
        text = report.read_text()
        assert "props</td><td>3 (box1, box2, box3)" in text, report
        assert "&quot;props&quot;:[{&quot;name&quot;:&quot;box1&quot;" in text, report


# ----------------------------------------------------------------------------------------------
# the command line and the report


def test_view_command_refuses_what_a_pair_does_not_take(pair_files, tmp_path, capsys):
    manifest = pair_files / "salsa.pair.json"
    status, err = run_cli(capsys, "view", manifest, "--robot", "g1", "--html", tmp_path / "x.html")
    assert status == 2 and "--robot" in err and str(manifest) in err
    status, err = run_cli(capsys, "view", manifest, "--source", "a.bvh", "--html",
                          tmp_path / "x.html")
    assert status == 2 and "--source alone" in err
    bad = tmp_path / "bad.pair.json"
    bad.write_text('{"files": {}}')
    status, err = run_cli(capsys, "view", bad, "--html", tmp_path / "x.html")
    assert status == 2 and str(bad) in err and "OUT.pair.json" in err
    assert not (tmp_path / "x.html").exists()


def test_pair_report_has_both_robots_and_the_pair(pair_files):
    """``imesh retarget --partner --report``: the pair's figures and each robot's table hold the
    manifest's numbers; the embedded viewer has both robots."""
    from imesh.viz.report import table_values

    manifest = json.loads((pair_files / "salsa.pair.json").read_text())
    report = pair_files / "salsa.html"
    for key in ("a", "b"):
        expected = {k: v["value"] for k, v in manifest["metrics"][key].items()}
        assert table_values(report, key) == expected, key
    assert table_values(report, "pair") == manifest["pair_metrics"]
    assert table_values(report) == {}  # no table of one robot
    text = report.read_text()
    assert "Robot a: g1 (salsa.npz)" in text and "Robot b: jvrc1 (salsa.partner.npz)" in text
    assert text.count('src="data:image/png;base64,') >= 8  # each robot's figures
    assert "<iframe" in text and text.count("&quot;model&quot;:") == 2


# ----------------------------------------------------------------------------------------------
# the page in Chromium


def test_pair_page_shows_two_robots(pair_files, tmp_path):
    """``imesh view OUT.pair.json --source --html F``: the page loads with no error and no
    request leaving the machine, draws both robots at their files' poses, both people, and
    lists each robot's support and the pair's distance."""
    _browser()
    from imesh.viz.browser import chromium_page, open_viewer
    from imesh.viz.scene import decode

    page_path = tmp_path / "pair.html"
    assert main(["-q", "view", str(pair_files / "salsa.pair.json"), "--source", "--html",
                 str(page_path)]) == 0
    scene = json.loads(page_path.read_text().split('id="imesh-scene">')[1].split("</script>")[0])
    with chromium_page() as (page, errors):
        requests: list[str] = []
        page.on("request", lambda r: requests.append(r.url))
        open_viewer(page, page_path.as_uri())
        assert page.evaluate("window.imeshViewer.frames") == 30
        page.evaluate("window.imeshViewer.setFrame(7)")
        robots = page.evaluate("window.imeshViewer.robots()")
        assert [(r["name"], r["label"]) for r in robots] == [("g1", "a g1"), ("jvrc1", "b jvrc1")]
        for r, entry in zip(robots, scene["robots"], strict=True):
            model = scene["models"][entry["model"]]
            root = model["links"].index(model["root_link"])
            assert r["markers"] and r["source"] and r["meshes"] == len(model["meshes"])
            np.testing.assert_allclose(r["root"], decode(entry["link_poses"])[7, root, :3],
                                       atol=1e-5)
        info = page.locator("#info").inner_text()
        assert "a g1: support" in info and "b jvrc1: support" in info
        assert "pair: hands held" in info and "robots: " in info and "(hands held)" in info
        assert page.locator("#legend-b").is_visible()
        assert not page.locator("#opt-props").is_visible()  # no props in this pair
        assert not errors, errors
    outside = [u for u in requests if not u.startswith(("file:", "data:", "blob:"))]
    assert not outside, outside


def test_page_draws_the_props(props_motion, tmp_path):
    """The props are on the screenshot (translucent tan) and the checkbox hides them."""
    _browser()
    import io

    from PIL import Image

    from imesh.viz.browser import chromium_page, open_viewer

    def tan(png: bytes) -> int:
        img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        return int(((r - b > 35) & (g - b > 15) & (r > g)).sum())

    page_path = tmp_path / "props.html"
    assert main(["-q", "view", str(props_motion), "--html", str(page_path)]) == 0
    with chromium_page() as (page, errors):
        open_viewer(page, page_path.as_uri())
        props = page.evaluate("window.imeshViewer.props()")
        assert [(p["name"], p["vertices"], p["visible"]) for p in props] == \
            [("box1", 8, True), ("box2", 8, True), ("box3", 8, True)]
        shown = tan(page.locator("#view").screenshot())
        page.locator("#opt-props").click()
        assert not any(p["visible"] for p in page.evaluate("window.imeshViewer.props()"))
        hidden = tan(page.locator("#view").screenshot())
        assert shown - hidden > 2000, (shown, hidden)
        assert not errors, errors


def test_pair_video(pair_files, tmp_path):
    """``imesh view OUT.pair.json --video``: the pair's 1 s at 5 fps is 5 frames."""
    _browser()
    pytest.importorskip("imageio_ffmpeg", reason="pip install 'imesh[viz]'")
    import imageio_ffmpeg

    video = tmp_path / "pair.mp4"
    assert main(["-q", "view", str(pair_files / "salsa.pair.json"), "--video", str(video),
                 "--video-fps", "5"]) == 0
    reader = imageio_ffmpeg.read_frames(str(video))
    meta = reader.__next__()
    assert sum(1 for _ in reader) == 5 and meta["fps"] == pytest.approx(5)

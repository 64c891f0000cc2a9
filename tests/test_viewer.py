"""The demo, the HTML report, the 3D viewer (served and self-contained) and the video, with the
DART check's simulated robot beside the reference.

The demo runs once per module (the real retarget of the shipped CMU walk to JVRC-1, with its
DART check); the other tests use its output. Browser tests drive Debian's Chromium with
Playwright; they skip only when Chromium or Playwright is not installed (CI installs both:
.ci/run).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import modules_after

from imesh.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    """Run ``imesh demo`` once: (output folder, its standard output). Its time is measured
    in benchmarks, not here."""
    out = tmp_path_factory.mktemp("demo")
    proc = subprocess.run([sys.executable, "-c", "import sys; from imesh.cli import main; "
                           "sys.exit(main())", "-q", "demo", "-o", str(out)],
                          capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout


@pytest.fixture(scope="module")
def physics(demo):
    """(robot, written motion, PhysicsResult) of the DART check of the demo's motion.npz."""
    from imesh.evaluate.motion_files import load_motion_file
    from imesh.physics import simulate_motion
    from imesh.robot import load_robot

    robot = load_robot("jvrc1")
    motion = load_motion_file(demo[0] / "motion.npz", robot)
    return robot, motion, simulate_motion(robot, motion)


def _browser():
    """Skip when the browser stack is not installed."""
    pytest.importorskip("playwright.sync_api", reason="pip install 'imesh[viz]'")
    from imesh.viz.browser import find_chromium

    if find_chromium() is None:
        pytest.skip("chromium not installed (apt-get install chromium)")


# ----------------------------------------------------------------------------------------------
# the demo and the report


def test_demo_writes_motion_report_and_viewer(demo):
    out, stdout = demo
    for name in ("motion.npz", "report.html", "viewer.html", "report.json"):
        assert (out / name).is_file() and str(out / name) in stdout, name
    assert "passed every gate" in stdout and "imesh view" in stdout
    # the DART check ran and is reported plainly, whether the robot fell or not (exit 0 above)
    line = next(s for s in stdout.splitlines() if s.startswith("physics check (wbc): "))
    assert ("FELL at" in line or "stood through" in line) and "mm RMS" in line, line
    assert "of which the physics check" in stdout and "--physics" in stdout
    with np.load(out / "motion.npz") as f:
        assert str(f["robot"]) == "jvrc1"
        # the shipped 2.9 s clip at 30 fps and 1 s of standing lead-in and lead-out
        assert f["joint_positions"].shape == (86 + 60, 32)
    report = json.loads((out / "report.json").read_text())
    # the solve stops on its own (soles on their footprints, the margins held within
    # SqpOptions.margin_use: test_wholebody.py::test_default_pipeline_walk), 12 iterations
    wb = report["wholebody"]
    assert wb["converged"] and wb["sole_error_mm"] < 1.0 and wb["iterations"] < 20
    assert report["verification"]["passed"]
    assert report["physics_check"]["ran"] and report["physics_check"]["verdict"] == line
    assert report["metrics"]["physics_fell"]["value"] is not None


def test_demo_clip_is_shipped_with_its_terms():
    from imesh.api import demo_clip

    clip = demo_clip()
    assert clip.is_file() and clip.stat().st_size < 1_000_000
    terms = (clip.parent / "CMU_TERMS.txt").read_text()
    assert "mocap.cs.cmu.edu" in terms and "NSF EIA-0196217" in terms
    toml = (ROOT / "pyproject.toml").read_text()
    assert '"data/demo/*"' in toml and '"viz/static/*"' in toml


def test_report_table_equals_evaluate_json(demo, tmp_path):
    """The numbers of the demo's report (table and report.json's physics figures) and of
    ``evaluate --report`` are those ``imesh evaluate --physics --json`` writes for the same
    file."""
    from imesh.viz.report import table_values

    out = demo[0]
    js, html_path = tmp_path / "e.json", tmp_path / "e.html"
    assert main(["-q", "evaluate", str(out / "motion.npz"), "--physics", "--json", str(js),
                 "--report", str(html_path)]) == 0
    evaluated = json.loads(js.read_text())
    expected = {k: v["value"] for k, v in evaluated.items()}
    assert expected["physics_fell"] is not None
    for report in (out / "report.html", html_path):
        got = table_values(report)
        assert list(got) == list(expected)
        assert got == expected, report
    # report.json: the same physics entries, details too (but the wall-clock speed)
    demo_metrics = json.loads((out / "report.json").read_text())["metrics"]
    for name in ("physics_fell", "physics_survived_s", "tracking_rms_rad", "torque_ratio_max"):
        a, b = ({k: v for k, v in e[name].items() if k != "real_time_factor"}
                for e in (demo_metrics, evaluated))
        assert a == b, name
    assert demo_metrics["physics_fell"]["keypoint_rms_mm"] > 0
    text = (out / "report.html").read_text()
    assert text.count('src="data:image/png;base64,') == 6  # the five figures and DART's
    assert "passes every gate" in text and "<iframe" in text
    # the demo's walk falls in the check: the verdict says so beside the passed gates
    fell = demo_metrics["physics_fell"]["value"]
    assert ("fell in the DART check" in text) == bool(fell)
    assert 'id="physics-verdict"' in text and "--physics --json" in text


def test_retarget_writes_a_report(mocap, tmp_path):
    from imesh.viz.report import table_values

    out, page = tmp_path / "m.npz", tmp_path / "r.html"
    assert main(["-q", "retarget", str(mocap("cmu_141_16_wave_hello.bvh")), "--robot", "jvrc1",
                 "--balance", "none", "--no-lead", "-o", str(out), "--report", str(page)]) == 0
    js = tmp_path / "e.json"
    assert main(["-q", "evaluate", str(out), "--json", str(js)]) == 0
    expected = {k: v["value"] for k, v in json.loads(js.read_text()).items()}
    assert table_values(page) == expected


def test_report_refuses_a_wrong_extension(tmp_path, capsys):
    out = tmp_path / "m.npz"
    assert main(["-q", "evaluate", str(out), "--report", str(tmp_path / "r.pdf")]) == 2
    assert "--report" in capsys.readouterr().err


# ----------------------------------------------------------------------------------------------
# the viewer in Chromium


def _robot_pixels(png: bytes) -> np.ndarray:
    """(H, W) bool: the JVRC-1's orange body parts (URDF colour 1, 0.5, 0 under lighting)."""
    import io

    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r > 140) & (g > 0.3 * r) & (g < 0.75 * r) & (b < 0.35 * r)


def _check_page(page, errors, url: str) -> None:
    """No console errors, the robot on the screenshot, scrubbing changes the picture, no
    request leaves the machine."""
    from imesh.viz.browser import open_viewer

    requests: list[str] = []
    page.on("request", lambda r: requests.append(r.url))
    open_viewer(page, url)
    page.evaluate("() => { const el = document.getElementById('opt-sim'); "
                  "if (el.offsetParent && el.checked) el.click(); }")  # the reference alone
    frames = page.evaluate("window.imeshViewer.frames")
    assert frames == 146
    first = page.locator("#view").screenshot()
    robot0 = _robot_pixels(first)
    assert robot0.sum() > 800, "the robot is not on the screenshot"
    page.evaluate("window.imeshViewer.setFrame(100)")
    assert page.evaluate("window.imeshViewer.frame()") == 100
    assert page.locator("#label").inner_text().startswith("100 /")
    later = page.locator("#view").screenshot()
    robot1 = _robot_pixels(later)
    assert robot1.sum() > 800
    changed = np.mean(robot0 != robot1)
    assert changed > 0.002, f"scrubbing changed only {changed:.4f} of the robot's pixels"
    # the slider scrubs too
    page.locator("#frame").fill("20")
    assert page.evaluate("window.imeshViewer.frame()") == 20
    assert not errors, errors
    outside = [u for u in requests if not u.startswith(("file:", "data:", "blob:",
                                                        "http://127.0.0.1"))]
    assert not outside, outside


def test_html_viewer_is_self_contained_and_shows_the_robot(demo, tmp_path):
    _browser()
    from imesh.viz.browser import chromium_page

    page_path = demo[0] / "viewer.html"
    text = page_path.read_text()
    assert "<script src" not in text and "http://" not in text.split("imesh-scene")[0]
    with chromium_page() as (page, errors):
        _check_page(page, errors, page_path.as_uri())
        page.screenshot(path=str(tmp_path / "viewer.png"))


def _sim_pixels(png: bytes) -> np.ndarray:
    """(H, W) bool: pixels of the simulated copy's blue tint (the background is grey)."""
    import io

    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (b > r + 25) & (b > g + 10)


def test_viewer_shows_and_hides_the_simulation(demo):
    """The demo page draws the DART simulation beside the reference; the checkbox and the key s
    hide and show it; "go to the fall" jumps to the fall, after which the last pose is held."""
    _browser()
    from imesh.viz.browser import chromium_page, open_viewer

    with chromium_page() as (page, errors):
        open_viewer(page, (demo[0] / "viewer.html").as_uri())
        page.evaluate("window.imeshViewer.setFrame(20)")
        sim = page.evaluate("window.imeshViewer.simulation()")
        assert sim["visible"] and not sim["held"] and sim["banner"].startswith("DART check")
        assert page.locator("#banner").is_visible()
        assert page.locator("#legend-sim").is_visible()
        shown = _sim_pixels(page.locator("#view").screenshot()).sum()
        page.locator("#opt-sim").click()  # the checkbox hides it
        assert not page.evaluate("window.imeshViewer.simulation()")["visible"]
        hidden = _sim_pixels(page.locator("#view").screenshot()).sum()
        assert shown - hidden > 800, (shown, hidden)
        page.locator("#view").click()
        page.keyboard.press("s")  # the key shows it again
        assert page.evaluate("window.imeshViewer.simulation()")["visible"]
        if sim["fallFrame"] >= 0:
            page.locator("#to-fall").click()
            assert page.evaluate("window.imeshViewer.frame()") == sim["fallFrame"]
            assert page.evaluate("window.imeshViewer.simulation()")["held"]
            assert "FELL at" in page.locator("#info").inner_text()
        assert not errors, errors


def test_view_html_command(demo, tmp_path):
    page_path = tmp_path / "v.html"
    assert main(["-q", "view", str(demo[0] / "motion.npz"), "--html", str(page_path)]) == 0
    text = page_path.read_text()
    assert "window.imeshViewer" in text and '"frames":146' in text
    assert '"simulation":' not in text  # no DART check asked


def test_demo_page_has_the_simulation_and_its_toggle(demo):
    text = (demo[0] / "viewer.html").read_text()
    assert '"simulation":{' in text and 'id="opt-sim"' in text and 'id="legend-sim"' in text


def test_view_physics_command(demo, tmp_path, capsys):
    page_path = tmp_path / "v.html"
    assert main(["-q", "view", str(demo[0] / "motion.npz"), "--physics", "--html",
                 str(page_path)]) == 0
    assert "physics check (wbc): " in capsys.readouterr().out
    assert '"simulation":{"controller":"wbc"' in page_path.read_text()


def test_scene_simulation_is_the_forward_kinematics_of_the_check(physics):
    """The page's simulated links are the robot's forward kinematics of the PhysicsResult's q at
    the motion's frames; frames after the fall or the end hold the last simulated pose."""
    from scipy.spatial.transform import Rotation

    from imesh.viz.scene import build_scene, decode, robot_view

    robot, motion, res = physics
    scene = robot_view(build_scene(robot, motion, physics=res))
    sim = scene["simulation"]
    poses = decode(sim["link_poses"])
    T = motion.n_frames
    assert poses.shape == (T, len(scene["links"]), 7)
    simulated = decode(sim["simulated"]).astype(bool)
    assert simulated[0] and (simulated == np.isfinite(res.q[:, 0])).all()
    assert sim["fell"] == res.fell and sim["survived_s"] == res.survived_s
    last = int(np.flatnonzero(simulated)[-1])
    ids = [robot.frame_id(n) for n in scene["links"]]
    for t in (0, last // 2, T - 1):  # the last frame is held after a fall
        M = robot.frame_placements(res.q[min(t, last)], ids)
        assert np.abs(poses[t, :, :3] - M[:, :3, 3]).max() < 1e-5, t
        R = Rotation.from_quat(poses[t, :, 3:]).as_matrix()
        assert np.abs(R - M[:, :3, :3]).max() < 1e-5, t
    err = decode(sim["keypoint_error_mm"])
    assert np.isfinite(err[simulated]).all() and np.isnan(err[~simulated]).all()
    assert np.sqrt(np.mean(err[simulated] ** 2)) == pytest.approx(res.keypoint_rms_mm, rel=1e-4)
    assert sim["keypoint_rms_mm"] == res.keypoint_rms_mm


def test_held_frames_hold_the_last_simulated_pose():
    from imesh.viz.scene import held_frames

    q = np.arange(12.0).reshape(6, 2)
    q[[0, 3, 4, 5]] = np.nan
    held, simulated = held_frames(q)
    assert simulated.tolist() == [False, True, True, False, False, False]
    assert (held[:, 0] == [2, 2, 4, 4, 4, 4]).all()


def test_served_viewer_shows_the_robot(demo):
    """``imesh view`` serves the page on 127.0.0.1 until stopped."""
    _browser()
    from imesh.viz.browser import chromium_page

    proc = subprocess.Popen([sys.executable, "-c", "import sys; from imesh.cli import main; "
                             "sys.exit(main())", "view", str(demo[0] / "motion.npz"),
                             "--no-browser", "--port", "0"],
                            stdout=subprocess.PIPE, text=True, cwd=ROOT)
    try:
        line = proc.stdout.readline()
        assert line.startswith("viewer: http://127.0.0.1:"), line
        url = line.split()[1]
        with chromium_page() as (page, errors):
            _check_page(page, errors, url)
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_video_has_the_motions_duration(demo, tmp_path):
    _browser()
    pytest.importorskip("imageio_ffmpeg", reason="pip install 'imesh[viz]'")
    import imageio_ffmpeg

    video = tmp_path / "walk.mp4"  # with the simulated robot beside the reference
    assert main(["-q", "view", str(demo[0] / "motion.npz"), "--video", str(video),
                 "--video-fps", "10", "--physics"]) == 0
    reader = imageio_ffmpeg.read_frames(str(video))
    meta = reader.__next__()
    frames = [np.frombuffer(f, np.uint8) for f in reader]
    # 146 frames at 30 fps = 4.87 s -> 49 frames at 10 fps
    assert len(frames) == round(146 / 30 * 10) == 49
    assert meta["fps"] == pytest.approx(10)
    w, h = meta["size"]
    first, last = (f.reshape(h, w, 3) for f in (frames[0], frames[-1]))
    assert np.mean(np.abs(first.astype(int) - last.astype(int)) > 30) > 0.002


# ----------------------------------------------------------------------------------------------
# pieces


def test_video_frames_cover_the_duration():
    from imesh.viz.video import video_frames

    k = video_frames(146, 30.0, 30.0)
    assert len(k) == 146 and (k == np.arange(146)).all()
    k = video_frames(146, 30.0, 24.0)
    assert len(k) == round(146 / 30 * 24) and k[-1] <= 145 and (np.diff(k) >= 1).all()


def test_scene_arrays_round_trip_and_lead_frames():
    from imesh.viz.scene import decode, encode, lead_frames

    a = np.random.default_rng(0).normal(size=(5, 4, 3)).astype(np.float32)
    assert (decode(encode(a)) == a).all()
    m = np.zeros((20, 3, 3))
    m[4:15] = np.arange(11)[:, None, None] * 0.01 + 0.01
    m[15:] = m[14]
    assert lead_frames(m) == (3, 5)


def test_solvers_do_not_import_the_viewer():
    assert modules_after("import imesh.pipeline.retarget, imesh.solve, imesh.fit, imesh.morph",
                         "m.startswith('imesh.viz') or m in ('playwright', 'imageio_ffmpeg')"
                         ) == []


def test_decimation_keeps_the_shape():
    import trimesh

    from imesh.viz.scene import decimate

    sphere = trimesh.creation.icosphere(subdivisions=5, radius=0.1)
    v, f = decimate(sphere.vertices, sphere.faces, 0.01)
    assert len(f) < len(sphere.faces) / 4 and f.max() < len(v)
    r = np.linalg.norm(v, axis=1)
    assert np.all(np.abs(r - 0.1) < 0.01)

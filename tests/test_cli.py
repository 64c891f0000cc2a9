"""The command-line contract: inspect, adapt, and clean failures (demo: test_viewer.py)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from imesh.cli import main

BAD_BVH = {
    "truncated": "MOTION\nFrames: 3\nFrame Time: 0.01\n0 0 0 0 0 0\n0 0 0 0 0 0\n",
    "nan": "MOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0 0 0 0\n0 nan 0 0 0 0\n",
    "inf": "MOTION\nFrames: 2\nFrame Time: 0.01\n0 0 0 0 0 0\n0 0 inf 0 0 0\n",
    "empty": "MOTION\nFrames: 0\nFrame Time: 0.01\n",
}
HIERARCHY = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  End Site
  {
    OFFSET 0 10 0
  }
}
"""


def test_inspect_json(mocap, capsys):
    assert main(["inspect", str(mocap("cmu_02_01_walk.bvh")), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"frames", "fps", "fps_reason", "markers", "height_m", "units",
                         "up_axis", "missing_fraction", "rig"}
    assert data["frames"] == 343 and data["fps"] == pytest.approx(120.0, rel=1e-3)
    assert data["fps_reason"].startswith("the file's (the performer's ZMP beyond 0.3 body")
    assert 1.3 < data["height_m"] < 1.5 and data["units"] == "cmu" and data["up_axis"] == "+Y"
    assert data["missing_fraction"] == 0.0


def test_inspect_reports_gaps(mocap, capsys):
    assert main(["inspect", str(mocap("ezc3d_BTS_gait.c3d")), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["missing_fraction"] == pytest.approx(0.52, abs=0.01)


def test_adapt_writes_markers_and_report(mocap, tmp_path):
    out, rep = tmp_path / "a.npz", tmp_path / "a.json"
    code = main(["-q", "adapt", str(mocap("cmu_141_16_wave_hello.bvh")), "--scale", "arms=1.3",
                 "--scale", "legs=0.9", "-o", str(out), "--json", str(rep)])
    assert code == 0 and out.is_file()
    report = json.loads(rep.read_text())
    for key in ("bone_residual_m", "close_pair_error", "naive_close_pair_error", "morph_steps",
                "seconds"):
        assert key in report
    assert report["bone_residual_m"] <= 1e-6
    assert not list(tmp_path.glob(".*"))  # no temp files left behind


@pytest.mark.parametrize("kind", sorted(BAD_BVH))
def test_bad_bvh_fails_cleanly_without_output(kind, tmp_path, capsys):
    bad = tmp_path / f"{kind}.bvh"
    bad.write_text(HIERARCHY + BAD_BVH[kind])
    out = tmp_path / "out.npz"
    assert main(["-q", "adapt", str(bad), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("imesh: error: ") and str(bad) in err
    assert "\n" not in err and "Traceback" not in err
    assert not out.exists()


def test_unknown_channel_fails_cleanly(tmp_path, capsys):
    bad = tmp_path / "chan.bvh"
    bad.write_text(HIERARCHY.replace("Yrotation", "Wrotation")
                   + "MOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0 0 0 0\n")
    assert main(["-q", "inspect", str(bad)]) == 2
    assert "Wrotation" in capsys.readouterr().err


def test_bad_scale_group_lists_valid_groups(mocap, tmp_path, capsys):
    out = tmp_path / "o.npz"
    assert main(["-q", "adapt", str(mocap("cmu_141_16_wave_hello.bvh")), "--scale", "tail=2",
                 "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "tail" in err and "arms" in err and "forearms" in err
    assert not out.exists()


def test_help_imports_no_heavy_module():
    """``imesh --help`` and ``imesh retarget --help`` build the parsers without importing numpy,
    scipy, pinocchio or the solvers (the package's public names are lazy, the command modules
    are imported when their command runs), so they start in a fraction of a second."""
    for argv in (["--help"], ["retarget", "--help"]):
        code = ("import sys; from imesh.cli import main\n"
                f"try:\n    main({argv!r})\nexcept SystemExit:\n    pass\n"
                "heavy = sorted(m for m in ('numpy', 'scipy', 'pinocchio', 'dartpy', "
                "'imesh.solve', 'imesh.fit', 'imesh.evaluate', 'imesh.cli.retarget') "
                "if m in sys.modules)\n"
                "print('HEAVY', heavy)")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             check=True).stdout
        assert "HEAVY []" in out, (argv, out)


def test_parser_side_names_agree_with_the_library():
    """The light parser module repeats two names of the library it must not import."""
    from imesh.api import demo_clip
    from imesh.arms.config import SOLVERS
    from imesh.cli.parsers import ARM_SOLVERS, DEMO_CLIP

    assert ARM_SOLVERS == SOLVERS
    assert demo_clip().name == DEMO_CLIP


def test_lazy_public_names():
    import imesh
    import imesh.arms
    import imesh.reduction

    assert imesh.adapt_motion.__module__ == "imesh.morph.adapt"
    assert imesh.arms.imitate_arms.__module__ == "imesh.arms.solve"
    assert imesh.reduction.reduce_motion.__module__ == "imesh.reduction.pipeline"
    assert set(imesh.__all__) <= set(dir(imesh))
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        _ = imesh.nonsense

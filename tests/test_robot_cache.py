"""The robot cache (imesh.robot.model_cache): a robot read from it is the robot built from its
files, a changed URDF, configuration or mesh is built again, a damaged entry is never trusted."""

from __future__ import annotations

import os
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import hrp4c_urdf, modules_after

from imesh.core.cache import CACHE_ENV
from imesh.robot import ROBOTS_DIR, load_robot
from imesh.robot import model as robot_model
from imesh.robot.build import resolve_urdf
from imesh.robot.config import load_robot_config
from imesh.robot.model_cache import CAPSULES_KIND, MODELS_KIND
from imesh.robot.registry import package_available


def _available(name: str) -> bool:
    return name == "hrp4c" or package_available(load_robot_config(ROBOTS_DIR / name /
                                                                  "robot.toml"))


ROBOTS = [pytest.param(n, marks=pytest.mark.skipif(not _available(n), reason=f"{n} model "
                                                                              "not installed"))
          for n in ("jvrc1", "g1", "hrp4c")]


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """An empty cache folder for this test, and no robot kept in the process."""
    folder = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV, str(folder))
    monkeypatch.setattr(robot_model, "_CACHE", {})
    return folder


def _load(name_or_toml, urdf=None):
    robot_model._CACHE.clear()  # a new process: only the disk cache remains
    return load_robot(name_or_toml, urdf=urdf)


def _entries(folder: Path, kind: str) -> list[Path]:
    return sorted((folder / kind).glob("*.npz")) if (folder / kind).is_dir() else []


def assert_same_robot(a, b) -> None:
    """Everything a Robot exposes, bit for bit: sizes, names, masses, limits, nominal pose,
    soles, proxies, ignored pairs, forward kinematics, CoM and inverse dynamics."""
    assert (a.nq, a.nv, a.joint_names) == (b.nq, b.nv, b.joint_names)
    assert a.frame_names == b.frame_names
    assert a.mass == b.mass
    assert [i.mass for i in a.model.inertias] == [i.mass for i in b.model.inertias]
    for attr in ("q_lower", "q_upper", "v_max", "a_max", "effort_max", "q_nominal"):
        np.testing.assert_array_equal(getattr(a, attr), getattr(b, attr), err_msg=attr)
    assert a.soles.keys() == b.soles.keys()
    for side in a.soles:
        sa, sb = a.soles[side], b.soles[side]
        assert sa.frame == sb.frame
        for f in ("center", "half_extents", "normal"):
            np.testing.assert_array_equal(getattr(sa, f), getattr(sb, f))
    assert len(a.collision_shapes) == len(b.collision_shapes)
    for sa, sb in zip(a.collision_shapes, b.collision_shapes, strict=True):
        assert (sa.frame, sa.kind, sa.dims) == (sb.frame, sb.kind, sb.dims)
        np.testing.assert_array_equal(sa.placement, sb.placement)
    rng = np.random.default_rng(0)
    frames = list(range(len(a.model.frames)))
    for q in [a.q_nominal] + [a.random_configuration(rng) for _ in range(3)]:
        np.testing.assert_array_equal(a.frame_placements(q, frames), b.frame_placements(q, frames))
        np.testing.assert_array_equal(a.com(q), b.com(q))
        v, acc = rng.normal(size=a.nv), rng.normal(size=a.nv)
        np.testing.assert_array_equal(a.inverse_dynamics(q, v, acc),
                                      b.inverse_dynamics(q, v, acc))
        np.testing.assert_array_equal(a.shape_poses(q), b.shape_poses(q))


def assert_same_capsules(a, b) -> None:
    """Two capsule models: the same capsules, ignored body pairs and checked pairs."""
    assert [(c.name, c.body, c.frame, c.radius) for c in a.capsules] == \
        [(c.name, c.body, c.frame, c.radius) for c in b.capsules]
    for ca, cb in zip(a.capsules, b.capsules, strict=True):
        np.testing.assert_array_equal(ca.a, cb.a)
        np.testing.assert_array_equal(ca.b, cb.b)
    assert a.ignored == b.ignored
    np.testing.assert_array_equal(a.pairs, b.pairs)
    assert a.pair_bodies == b.pair_bodies


@pytest.mark.parametrize("name", ROBOTS)
def test_cached_load_equals_fresh_load(name, cache, monkeypatch):
    """The second load reads the soles, proxies, nominal pose and pairs from the cache without
    reading a mesh, and is the robot of the first (fresh) load and of a load with the cache
    off, bit for bit."""
    urdf = hrp4c_urdf() if name == "hrp4c" else None
    fresh = _load(name, urdf)
    assert fresh._built.geometry is not None  # built from the meshes
    assert len(_entries(cache, MODELS_KIND)) == 1
    cached = _load(name, urdf)
    assert cached._built is not fresh._built
    assert cached._built.geometry is None  # no mesh read
    assert_same_robot(cached, fresh)
    monkeypatch.setenv(CACHE_ENV, "")
    off = _load(name, urdf)
    assert off._built.cache_key == "" and off._built.geometry is not None
    assert_same_robot(cached, off)


def test_cached_capsule_model_equals_the_built_one(cache):
    """The capsule model (capsules, ignore list, checked pairs) read from the robot cache is
    the one built from the meshes; reading it reads no mesh."""
    fresh = _load("jvrc1")
    built = fresh.capsule_model()
    assert len(_entries(cache, CAPSULES_KIND)) == 1
    cached = _load("jvrc1")
    read = cached.capsule_model()
    assert cached._built.geometry is None
    assert_same_capsules(read, built)
    # the meshes are still there for what needs them, on first use
    assert set(cached.link_geometry()) == set(fresh.link_geometry())


def _jvrc1_copy(tmp_path: Path) -> tuple[Path, Path]:
    """A copy of JVRC-1's robot folder and of its URDF and meshes (``package://`` resolves to
    the copy): (robot.toml, URDF)."""
    config = load_robot_config(ROBOTS_DIR / "jvrc1" / "robot.toml")
    urdf, _ = resolve_urdf(config, None)
    pkg = tmp_path / "pkg" / "jvrc_description"
    shutil.copytree(urdf.parents[1] / "meshes", pkg / "meshes")
    (pkg / "urdf").mkdir()
    shutil.copy(urdf, pkg / "urdf" / urdf.name)
    folder = tmp_path / "jvrc1"
    folder.mkdir()
    for f in ("robot.toml", "markers.toml", "collision_pairs.toml"):
        if (ROBOTS_DIR / "jvrc1" / f).is_file():
            shutil.copy(ROBOTS_DIR / "jvrc1" / f, folder)
    return folder / "robot.toml", pkg / "urdf" / urdf.name


def _raise_feet_geometry(urdf: Path, dz_m: float) -> None:
    """Move the foot links' collision geometry up by ``dz_m`` in the URDF."""
    tree = ET.parse(urdf)
    for link in tree.getroot().iter("link"):
        if link.get("name") in ("L_ANKLE_P_S", "R_ANKLE_P_S"):
            for origin in link.findall("collision/origin"):
                xyz = [float(x) for x in origin.get("xyz", "0 0 0").split()]
                origin.set("xyz", f"{xyz[0]} {xyz[1]} {xyz[2] + dz_m}")
    tree.write(urdf)


def test_changed_urdf_config_or_mesh_is_built_again(tmp_path, cache, monkeypatch):
    """A changed URDF, robot.toml or mesh file is a cache miss: the robot is built again, as
    a load with the cache off builds it, and not the one stored before."""
    toml, urdf = _jvrc1_copy(tmp_path)
    first = _load(toml, urdf)
    assert len(_entries(cache, MODELS_KIND)) == 1
    assert _load(toml, urdf)._built.geometry is None  # a hit

    _raise_feet_geometry(urdf, 0.01)
    moved = _load(toml, urdf)
    assert moved._built.geometry is not None  # a miss: built from the meshes
    assert len(_entries(cache, MODELS_KIND)) == 2
    assert moved.soles["left"].center[2] == pytest.approx(first.soles["left"].center[2] + 0.01)
    with monkeypatch.context() as m:
        m.setenv(CACHE_ENV, "")
        assert_same_robot(moved, _load(toml, urdf))

    toml.write_text(toml.read_text().replace("L_SHOULDER_R = 0.15", "L_SHOULDER_R = 0.25"))
    bent = _load(toml, urdf)
    assert bent._built.geometry is not None
    assert len(_entries(cache, MODELS_KIND)) == 3
    assert not np.array_equal(bent.q_nominal, moved.q_nominal)
    with monkeypatch.context() as m:
        m.setenv(CACHE_ENV, "")
        assert_same_robot(bent, _load(toml, urdf))

    # a mesh file changed under the same URDF: built again, into the same entry
    assert _load(toml, urdf)._built.geometry is None
    mesh = next((urdf.parents[1] / "meshes").glob("*.dae"))
    st = mesh.stat()
    os.utime(mesh, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert _load(toml, urdf)._built.geometry is not None
    assert _load(toml, urdf)._built.geometry is None  # stored again with the new time


@pytest.mark.parametrize("damage", ["garbage", "truncated", "other joints"])
def test_damaged_entry_is_built_again(damage, cache):
    """An entry that does not read, or was made for another model, is never used: the robot is
    built again (equal to the first) and the entry rewritten so that it reads."""
    fresh = _load("jvrc1")
    fresh.capsule_model()
    (entry,) = _entries(cache, MODELS_KIND)
    (capsules,) = _entries(cache, CAPSULES_KIND)
    if damage == "garbage":
        entry.write_bytes(b"not a zip file")
        capsules.write_bytes(b"\x00" * 100)
    elif damage == "truncated":
        entry.write_bytes(entry.read_bytes()[:200])
        capsules.write_bytes(capsules.read_bytes()[:-50])
    else:
        with np.load(entry) as z:
            data = {k: z[k] for k in z.files}
        data["joint_names"] = data["joint_names"][::-1]
        np.savez(entry, **data)
    again = _load("jvrc1")
    assert again._built.geometry is not None  # built, not read
    assert_same_robot(again, fresh)
    assert_same_capsules(again.capsule_model(), fresh.capsule_model())
    read = _load("jvrc1")  # the rewritten entries read again
    assert read._built.geometry is None
    assert_same_robot(read, fresh)
    assert_same_capsules(read.capsule_model(), fresh.capsule_model())


def test_cache_off_writes_nothing(tmp_path, monkeypatch):
    """``IMESH_CACHE_DIR=""``: every load builds from the meshes and nothing is stored."""
    monkeypatch.setenv(CACHE_ENV, "")
    monkeypatch.setattr(robot_model, "_CACHE", {})
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setenv("HOME", str(tmp_path))
    robot = _load("jvrc1")
    assert robot._built.geometry is not None and robot._built.cache_key == ""
    assert not (tmp_path / "imesh" / MODELS_KIND).exists()
    assert not (tmp_path / ".cache" / "imesh" / MODELS_KIND).exists()


def test_a_cached_robot_loads_without_scipy_fcl_or_meshes(tmp_path, monkeypatch):
    """Start-up: importing imesh.robot imports no scipy; a robot read from the cache imports
    neither scipy nor fcl (its proxies' distances and its meshes wait for their first use); the
    retarget command's module does not import scipy.signal (the low-pass imports it)."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    heavy = "m.split('.')[0] in ('scipy', 'fcl', 'trimesh', 'matplotlib')"
    assert modules_after("import imesh.robot", heavy) == []
    load = "from imesh.robot import load_robot; load_robot('jvrc1')"
    modules_after(load, "False")  # fills the cache
    assert modules_after(load, heavy) == []
    assert modules_after("import imesh.cli.retarget",
                         "m in ('scipy.signal', 'scipy.stats')") == []

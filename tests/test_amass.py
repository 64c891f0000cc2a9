"""AMASS input (issue 32): SMPL-X / SMPL-H parameters in an .npz with the user's body model.

The body models cannot be shipped, so the tests build small synthetic ones in the official file
layout (``smplx/SMPLX_NEUTRAL.npz``: v_template, shapedirs of 300 shape + 100 expression
columns, posedirs, J_regressor whose rows sum to 1, kintree_table of the real 55-joint SMPL-X
tree, weights, f, and an object array like the real files' ``part2num``). Their template's
joints sit at SMPL's human proportions (1.7 m), so clips made with them retarget like a person.
"""

from __future__ import annotations

import pickle
import re
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_errors import run  # one line per error, no traceback: the CLI's contract

from imesh.errors import ImeshError, MotionFileError, UnsupportedFormatError
from imesh.io import load_motion, read_raw
from imesh.io.amass import (
    MODELS,
    BodyModelError,
    find_body_model,
    is_amass,
    load_body_model,
    rest_joints_m,
)

#: SMPL-like rest joints [m] (the model's frame: Y up, +Z the body's front, +X its left).
BODY_REST = {
    "pelvis": (0.0, -0.223, 0.028), "left_hip": (0.070, -0.314, 0.024),
    "right_hip": (-0.070, -0.314, 0.024), "spine1": (0.0, -0.109, -0.001),
    "left_knee": (0.104, -0.676, 0.030), "right_knee": (-0.104, -0.676, 0.030),
    "spine2": (0.0, 0.019, 0.001), "left_ankle": (0.087, -1.100, -0.015),
    "right_ankle": (-0.087, -1.100, -0.015), "spine3": (0.0, 0.073, 0.029),
    "left_foot": (0.121, -1.157, 0.109), "right_foot": (-0.121, -1.157, 0.109),
    "neck": (0.0, 0.289, -0.017), "left_collar": (0.080, 0.195, -0.006),
    "right_collar": (-0.080, 0.195, -0.006), "head": (0.0, 0.352, 0.042),
    "left_shoulder": (0.177, 0.230, -0.017), "right_shoulder": (-0.177, 0.230, -0.017),
    "left_elbow": (0.445, 0.222, -0.043), "right_elbow": (-0.445, 0.222, -0.043),
    "left_wrist": (0.709, 0.232, -0.043), "right_wrist": (-0.709, 0.232, -0.043),
    "jaw": (0.0, 0.390, 0.060), "left_eye_smplhf": (0.032, 0.440, 0.100),
    "right_eye_smplhf": (-0.032, 0.440, 0.100),
}
#: First knuckle of each finger from the wrist (left hand; mirrored in x for the right) and the
#: length of its next two bones [m].
FINGERS = {"index": ((0.088, 0.008, 0.027), 0.030), "middle": ((0.094, 0.006, 0.004), 0.033),
           "pinky": ((0.072, -0.005, -0.038), 0.020), "ring": ((0.085, 0.002, -0.018), 0.030),
           "thumb": ((0.025, -0.012, 0.025), 0.025)}
SOLE_BELOW_FOOT_M = 0.045  # the mesh's sole below the foot (toe) joint
UINT32_ROOT = 4294967295  # kintree_table[0, 0] of the official files


def template_joints(kind: str = "smplx") -> np.ndarray:
    """(J, 3) rest joints of the synthetic model [m]."""
    out = np.zeros((len(MODELS[kind].joints), 3))
    for j, name in enumerate(MODELS[kind].joints):
        if name in BODY_REST:
            out[j] = BODY_REST[name]
            continue
        side, rest = name.split("_", 1)
        (first, step), k = FINGERS[rest[:-1]], int(rest[-1])
        sign = np.array([1.0 if side == "left" else -1.0, 1.0, 1.0])
        out[j] = (np.array(BODY_REST[f"{side}_wrist"]) + np.array(first) * sign
                  + (k - 1) * step * sign * [1.0, 0.0, 0.0])
    return out


def write_body_model(folder: Path, kind: str = "smplx", gender: str = "neutral", *,
                     columns: int | None = None, suffix: str = ".npz", seed: int = 0) -> Path:
    """A synthetic body model in the official layout; returns the file.

    Each joint is regressed from 4 vertices near it (random positive weights summing to 1,
    vertices moved so the weighted mean is the template joint exactly); 30 more vertices have
    no weight. Shape component 0 grows the body 5 % per unit about the origin; the others move
    vertices by a few millimetres at random.
    """
    rng = np.random.default_rng(seed)
    spec = MODELS[kind]
    joints = template_joints(kind)
    n_j = len(joints)
    columns = columns or (400 if kind == "smplx" else 16)
    verts = np.repeat(joints, 4, axis=0) + rng.normal(0.0, 0.02, (4 * n_j, 3))
    verts = np.vstack([verts, rng.normal(0.0, 0.3, (30, 3))])
    regressor = np.zeros((n_j, len(verts)))
    for j in range(n_j):
        w = rng.uniform(0.2, 1.0, 4)
        w /= w.sum()
        regressor[j, 4 * j:4 * j + 4] = w
        verts[4 * j:4 * j + 4] += joints[j] - w @ verts[4 * j:4 * j + 4]
    shapedirs = rng.normal(0.0, 0.003, (len(verts), 3, columns))
    shapedirs[:, :, 0] = 0.05 * verts
    parents = np.array(spec.parents, dtype=np.int64)
    parents[0] = UINT32_ROOT
    arrays = {
        "v_template": verts, "shapedirs": shapedirs, "J_regressor": regressor,
        "kintree_table": np.vstack([parents, np.arange(n_j)]),
        "posedirs": rng.normal(0.0, 0.001, (len(verts), 3, 9 * (n_j - 1))),
        "weights": np.eye(n_j)[np.minimum(np.arange(len(verts)) // 4, n_j - 1)],
        "f": rng.integers(0, len(verts), (40, 3)).astype(np.uint32),
    }
    path = folder / kind / f"{spec.file_stem}_{gender.upper()}{suffix}"
    path.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".npz":
        np.savez(path, **arrays, part2num=np.array({"global": 0}, dtype=object))
    else:  # the .pkl files hold the regressor as a scipy sparse matrix
        from scipy import sparse

        arrays["J_regressor"] = sparse.csc_matrix(regressor)
        path.write_bytes(pickle.dumps(arrays, protocol=2))
    return path


def write_amass(path: Path, poses: np.ndarray, trans: np.ndarray, *, betas=None,
                gender: str = "neutral", fps: float = 60.0, fps_key: str = "mocap_frame_rate",
                **extra) -> Path:
    """An AMASS-layout .npz (SMPL-X-N keys by default)."""
    arrays = {"poses": poses, "trans": trans, "betas": np.zeros(16) if betas is None else betas,
              "gender": np.array(gender), fps_key: np.array(fps), **extra}
    np.savez(path, **arrays)
    return path


def rotvec(*parts: tuple[str, float]) -> np.ndarray:
    """Axis-angle of a product of rotations about x/y/z by degrees, applied right to left."""
    r = Rotation.identity()
    for axis, deg in parts:
        r = r * Rotation.from_euler(axis, deg, degrees=True)
    return r.as_rotvec()


#: AMASS's root rotation: the model's Y up to Z up, its front (+Z) to world +X.
ROOT_UP = Rotation.from_euler("z", 90, degrees=True) * Rotation.from_euler("x", 90, degrees=True)


def _leg_ik(a: np.ndarray, b: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Hip and knee rotations putting the ankle at ``d`` (T, 3) from the hip, model frame.

    The hip turns the leg by ``R_z(roll) R_x(flexion)``, the knee by ``R_x(bend)``; ``a`` and
    ``b`` are the rest thigh and shank (hip to knee, knee to ankle). Closed form: the bend
    gives the hip-ankle distance, the flexion the height along the model's z, the roll the
    rest. Returns (hip rotations (T,), knee angles (T,) [rad]).
    """
    dist2 = np.sum(d * d, axis=1)
    ayz, byz = np.hypot(a[1], a[2]), np.hypot(b[1], b[2])
    beta = np.arctan2(a[1] * b[2] - a[2] * b[1], a[1:] @ b[1:])  # the rest knee's bend
    cos = (dist2 - a @ a - b @ b - 2 * a[0] * b[0]) / (2 * ayz * byz)
    bend = np.arccos(np.clip(cos, -1.0, 1.0)) - beta
    c, s_ = np.cos(bend), np.sin(bend)
    v = a + np.column_stack([np.full_like(bend, b[0]), b[1] * c - b[2] * s_, b[1] * s_ + b[2] * c])
    w_y = -np.sqrt(np.maximum(np.sum(v * v, axis=1) - v[:, 0] ** 2 - d[:, 2] ** 2, 0.0))
    flexion = np.arctan2(d[:, 2], w_y) - np.arctan2(v[:, 2], v[:, 1])
    roll = np.arctan2(d[:, 1], d[:, 0]) - np.arctan2(w_y, v[:, 0])
    hip = (Rotation.from_euler("z", roll[:, None]) * Rotation.from_euler("x", flexion[:, None]))
    return hip, bend


def walk_parameters(seconds: float = 2.5, fps: float = 60.0, period_s: float = 1.1,
                    speed_m_s: float = 0.9, sway_m: float = 0.03
                    ) -> tuple[np.ndarray, np.ndarray]:
    """A plausible walk: (poses (T, 165), trans (T, 3)) for the synthetic SMPL-X model.

    Designed from the feet, as a walk is: the pelvis moves forward (world +X) at a constant
    speed and height, swaying 3 cm towards the stance foot; each foot stands still on the floor
    for 60 % of the cycle (sole on z = 0; 20 % double support) and swings to its next
    footprint in the other 40 % on minimum-jerk profiles (8 cm high), so feet start and stop
    without a jump in acceleration. Hip and knee rotations come from the inverse kinematics of
    each leg, the ankle keeps the foot level and forward; arms hang at 75 degrees, swing
    against the legs, elbows bent 20 degrees. So the stance foot neither slides nor sinks, the
    swing foot clears the floor, and the centre of mass moves over the support.
    """
    spec = MODELS["smplx"]
    idx = {name: j for j, name in enumerate(spec.joints)}
    rest = template_joints("smplx")
    n = int(round(seconds * fps))
    t = np.arange(n) / fps
    stance_part = 0.6  # of the cycle
    reach = speed_m_s * period_s * stance_part / 2  # the stance ankle from +reach to -reach [m]
    ankle_z = SOLE_BELOW_FOOT_M + rest[idx["left_ankle"], 1] - rest[idx["left_foot"], 1]
    trans = np.zeros((n, 3))
    trans[:, 0] = speed_m_s * t
    trans[:, 1] = sway_m * np.sin(2 * np.pi * (t / period_s - 0.05))  # over the left foot
    a = rest[idx["left_knee"]] - rest[idx["left_hip"]]
    b = rest[idx["left_ankle"]] - rest[idx["left_knee"]]
    hip_above_ankle = np.sqrt((0.97 * np.linalg.norm(a + b)) ** 2 - reach ** 2 - sway_m ** 2)
    hip_rest = ROOT_UP.apply(rest[idx["left_hip"]] - rest[0]) + rest[0]
    trans[:, 2] = ankle_z + hip_above_ankle - hip_rest[2]
    poses = np.zeros((n, len(spec.joints), 3))
    for side, shift in (("left", 0.0), ("right", 0.5)):
        hip_j, knee_j = idx[f"{side}_hip"], idx[f"{side}_knee"]
        s = (t / period_s + shift) % 1.0  # stance, then swing
        stance = s < stance_part
        u = np.where(stance, s / stance_part, (s - stance_part) / (1 - stance_part))
        jerk = u ** 3 * (10 - 15 * u + 6 * u ** 2)  # minimum jerk 0 -> 1
        forward = np.where(stance, reach * (1 - 2 * u),  # ankle ahead of the hip [m]
                           -reach + speed_m_s * period_s * (jerk - (1 - stance_part) * u))
        lift = np.where(stance, 0.0, 0.08 * 64 * (u * (1 - u)) ** 3)
        hip_world = ROOT_UP.apply(rest[hip_j] - rest[0]) + rest[0] + trans
        ankle_world = np.column_stack([
            hip_world[:, 0] + forward,
            np.full(n, (ROOT_UP.apply(rest[idx[f"{side}_ankle"]] - rest[0]) + rest[0])[1]),
            ankle_z + lift])
        d = ROOT_UP.inv().apply(ankle_world - hip_world)
        leg_a = rest[knee_j] - rest[hip_j]
        leg_b = rest[idx[f"{side}_ankle"]] - rest[knee_j]
        hip, knee = _leg_ik(leg_a, leg_b, d)
        poses[:, hip_j] = hip.as_rotvec()
        poses[:, knee_j, 0] = knee
        poses[:, idx[f"{side}_ankle"]] = (hip * Rotation.from_euler("x", knee[:, None])
                                          ).inv().as_rotvec()  # the foot stays level
        sign = 1.0 if side == "left" else -1.0
        # the arm swings back (+x in the model) while its side's foot is ahead
        swing_deg = 0.6 * np.degrees(np.arctan2(forward, hip_above_ankle))
        poses[:, idx[f"{side}_shoulder"]] = np.array(
            [rotvec(("x", a_), ("z", -75.0 * sign)) for a_ in swing_deg])
        poses[:, idx[f"{side}_elbow"], 1] = np.radians(-20.0 * sign)
    poses[:, 0] = ROOT_UP.as_rotvec()
    return poses.reshape(n, -1), trans


# ----------------------------------------------------------------------------------------------
# joints against a hand computation


@pytest.fixture(scope="module")
def models(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("body_models")
    for gender in ("neutral", "male"):
        write_body_model(folder, "smplx", gender)
    write_body_model(folder, "smplh", "female", seed=1)
    return folder


def zero_poses(n: int = 2, kind: str = "smplx") -> np.ndarray:
    return np.zeros((n, MODELS[kind].pose_width))


def test_rest_joints_follow_betas_as_shapedirs_say(models):
    """J = J_regressor @ (v_template + shapedirs @ betas): zero betas give the template joints,
    beta 0 = 1 grows them by 5 % (shape component 0 is 0.05 x the vertices), and any betas give
    the hand computation; expression columns (300..399) are not shape."""
    path = find_body_model(models, "smplx", "neutral")
    assert path == models / "smplx" / "SMPLX_NEUTRAL.npz"
    model = load_body_model(path, "smplx", "neutral")
    assert model.n_shape == 300
    template = template_joints()
    np.testing.assert_allclose(rest_joints_m(model, np.zeros(16)), template, atol=1e-12)
    np.testing.assert_allclose(rest_joints_m(model, np.eye(16)[0]), 1.05 * template,
                               atol=1e-12)
    with np.load(path) as f:
        v, sd, jr = f["v_template"], f["shapedirs"], f["J_regressor"]
    betas = np.linspace(-2.0, 2.0, 16)
    by_hand = np.einsum("jv,vc->jc", jr, v + np.einsum("vcs,s->vc", sd[:, :, :16], betas))
    np.testing.assert_allclose(rest_joints_m(model, betas), by_hand, atol=1e-12)
    assert np.abs(by_hand - template).max() > 0.05  # the betas moved the joints


def test_elbow_bend_of_90_degrees_puts_the_wrist_where_computed_by_hand(models, tmp_path):
    """Left elbow rotated -90 degrees about y (the model's front is +z, the arm along +x): the
    forearm (0.264, 0.010, 0) turns to (0, 0.010, 0.264), the wrist ends in front of the
    elbow; the root translation adds to every joint; nothing else moves."""
    spec = MODELS["smplx"]
    j = {name: k for k, name in enumerate(spec.joints)}
    poses = zero_poses(3).reshape(3, -1, 3)
    poses[1:, j["left_elbow"]] = (0.0, -np.pi / 2, 0.0)
    trans = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 2.0, 3.0]])
    raw = read_raw(write_amass(tmp_path / "elbow.npz", poses.reshape(3, -1), trans),
                   body_model=models)
    assert raw.format == "amass" and raw.rig == "smplx" and raw.names == spec.joints
    assert raw.declared_units == "m" and raw.declared_up == "+Z" and raw.fps == 60.0
    rest = template_joints()
    np.testing.assert_allclose(raw.positions[0], rest, atol=1e-12)
    elbow = rest[j["left_elbow"]]
    np.testing.assert_allclose(raw.positions[1, j["left_wrist"]], elbow + (0.0, 0.010, 0.264),
                               atol=1e-12)
    # fingers turn with the wrist: index1 at the elbow + R_y(-90) (index1 - elbow)
    d = rest[j["left_index1"]] - elbow
    np.testing.assert_allclose(raw.positions[1, j["left_index1"]], elbow + (-d[2], d[1], d[0]),
                               atol=1e-12)
    moved = np.flatnonzero(np.abs(raw.positions[1] - rest).max(axis=1) > 1e-12)
    assert {spec.joints[k] for k in moved} == {"left_wrist", *spec.joints[25:40]}
    np.testing.assert_allclose(raw.positions[2], raw.positions[1] + (1.0, 2.0, 3.0), atol=1e-12)
    assert len(raw.bones) == 54 and tuple(raw.bones[0]) == (0, 1)


def test_amass_root_rotation_stands_the_body_up_in_z(models, tmp_path):
    """AMASS's root rotation (+90 degrees about x) maps the model's Y up to Z up: loaded with
    no option the body stands along +Z, metres declared, the floor under its feet."""
    poses = zero_poses(20)
    poses[:, :3] = ROOT_UP.as_rotvec()
    trans = np.tile([0.0, 0.0, 1.2], (20, 1))
    motion = load_motion(write_amass(tmp_path / "stand.npz", poses, trans), body_model=models)
    assert motion.meta["up_axis"] == "+Z" and motion.meta["units"] == "m"
    assert motion.meta["format"] == "amass" and motion.meta["gender"] == "neutral"
    head, pelvis = motion.positions_m[0, motion.indices(["head", "pelvis"])]
    assert head[2] - pelvis[2] == pytest.approx(0.352 + 0.223, abs=1e-9)
    assert motion.positions_m[..., 2].min() == pytest.approx(0.0, abs=1e-9)  # floor shifted
    assert 1.4 < motion.height_m < 1.8


def test_smplh_in_amass_own_layout_and_a_pkl_model(models, tmp_path):
    """SMPL-H poses (T, 156) with ``mocap_framerate`` read the model from AMASS's own layout
    (smplh/female/model.npz); a .pkl model with a scipy sparse regressor gives the same joints
    as its .npz."""
    folder = tmp_path / "amass_layout"
    (folder / "smplh" / "female").mkdir(parents=True)
    src = find_body_model(models, "smplh", "female")
    (folder / "smplh" / "female" / "model.npz").write_bytes(src.read_bytes())
    poses = zero_poses(4, "smplh")
    poses[:, 18 * 3 + 1] = -np.pi / 2  # the left elbow (joint 18)
    clip = write_amass(tmp_path / "h.npz", poses, np.zeros((4, 3)), gender="female",
                       fps=120.0, fps_key="mocap_framerate", dmpls=np.zeros((4, 8)))
    raw = read_raw(clip, body_model=folder)
    assert raw.rig == "smplh" and raw.fps == 120.0 and len(raw.names) == 52
    assert raw.meta["body_model"].endswith("smplh/female/model.npz")
    rest = template_joints("smplh")
    np.testing.assert_allclose(raw.positions[0, 20], rest[18] + (0.0, 0.010, 0.264), atol=1e-12)

    pkl = write_body_model(tmp_path / "pkl", "smplx", "neutral", suffix=".pkl")
    from_pkl = load_body_model(pkl, "smplx", "neutral")
    np.testing.assert_allclose(rest_joints_m(from_pkl, np.linspace(0, 1, 16)),
                               rest_joints_m(load_body_model(
                                   find_body_model(models, "smplx", "neutral"), "smplx",
                                   "neutral"), np.linspace(0, 1, 16)), atol=1e-12)


def test_model_pickles_run_no_code(tmp_path):
    """A body-model pickle is unpickled with an allow-list: chumpy objects (old SMPL files) are
    refused with the way out, anything else (os.system) is refused before it runs."""
    chumpy = tmp_path / "smplx" / "SMPLX_NEUTRAL.pkl"
    chumpy.parent.mkdir()
    chumpy.write_bytes(b"\x80\x02cchumpy.ch\nCh\nq\x00.")
    with pytest.raises(BodyModelError, match=r"chumpy.*\.npz"):
        load_body_model(chumpy, "smplx", "neutral")
    evil = tmp_path / "evil.pkl"
    evil.write_bytes(b"cos\nsystem\n(S'touch " + str(tmp_path / "ran").encode() + b"'\ntR.")
    with pytest.raises(BodyModelError, match="os.system is not allowed"):
        load_body_model(evil, "smplx", "neutral")
    assert not (tmp_path / "ran").exists()


def test_matches_the_smplx_package(models, tmp_path):
    """Cross-check with the smplx package (torch), when installed: same joints for random poses
    and betas (the package's first 55 joints, float32)."""
    smplx = pytest.importorskip("smplx")
    torch = pytest.importorskip("torch")
    rng = np.random.default_rng(3)
    poses = rng.normal(0.0, 0.4, (5, 165))
    betas = rng.normal(0.0, 1.0, 16)
    trans = rng.normal(0.0, 0.5, (5, 3))
    raw = read_raw(write_amass(tmp_path / "r.npz", poses, trans, betas=betas), body_model=models)
    model = smplx.create(str(models), "smplx", gender="neutral", use_pca=False, ext="npz",
                         flat_hand_mean=True, num_betas=16, batch_size=5)
    f = torch.tensor
    out = model(betas=f(np.tile(betas, (5, 1)), dtype=torch.float32),
                global_orient=f(poses[:, :3], dtype=torch.float32),
                body_pose=f(poses[:, 3:66], dtype=torch.float32),
                jaw_pose=f(poses[:, 66:69], dtype=torch.float32),
                leye_pose=f(poses[:, 69:72], dtype=torch.float32),
                reye_pose=f(poses[:, 72:75], dtype=torch.float32),
                left_hand_pose=f(poses[:, 75:120], dtype=torch.float32),
                right_hand_pose=f(poses[:, 120:165], dtype=torch.float32),
                transl=f(trans, dtype=torch.float32))
    np.testing.assert_allclose(raw.positions, out.joints[:, :55].detach().numpy(), atol=1e-5)


# ----------------------------------------------------------------------------------------------
# bad input: one line naming the file and what is valid, before any work




def _walk_file(folder: Path, frames: int = 20, **kwargs) -> Path:
    poses = zero_poses(frames)
    poses[:, :3] = ROOT_UP.as_rotvec()
    return write_amass(folder / kwargs.pop("name", "clip.npz"), poses,
                       np.tile([0.0, 0.0, 1.2], (frames, 1)), **kwargs)


def _edit(folder: Path, **changes) -> Path:
    """The standing clip with keys replaced (None drops a key)."""
    with np.load(_walk_file(folder, name="base.npz")) as f:
        arrays = {k: f[k] for k in f.files}
    for key, value in changes.items():
        if value is None:
            arrays.pop(key)
        else:
            arrays[key] = value
    np.savez(folder / "bad.npz", **arrays)
    return folder / "bad.npz"


def _nan_frame(folder: Path) -> Path:
    poses = zero_poses(20)
    poses[7, 40] = np.nan
    return _edit(folder, poses=poses)


@pytest.mark.parametrize(("make", "model", "expected"), [
    (lambda d: _walk_file(d), None,
     r"error: \S+clip.npz: an AMASS SMPLX motion needs the SMPLX body model, which imesh "
     r"cannot ship; valid: --body-model DIR"),
    (lambda d: _walk_file(d), "nowhere",
     r"body model '.*nowhere': no such folder; valid: the folder holding "
     r"smplx/SMPLX_NEUTRAL.npz"),
    (lambda d: _walk_file(d, gender="female"), "models",
     r"no SMPLX model of gender 'female' \(looked for smplx/SMPLX_FEMALE.npz, .*model files "
     r"found: smplh/SMPLH_FEMALE.npz, smplx/SMPLX_MALE.npz, smplx/SMPLX_NEUTRAL.npz\)"),
    (lambda d: _walk_file(d, gender="robot"), "models",
     r"clip.npz: gender 'robot'; valid: neutral, male, female"),
    (lambda d: _edit(d, poses=np.zeros((20, 72))), "models",
     r"bad.npz: poses has shape \(20, 72\); valid: \(T, 165\) for SMPLX or \(T, 156\) for "
     r"SMPLH"),
    (_nan_frame, "models", r"bad.npz, frame 7: poses has non-finite values"),
    (lambda d: _edit(d, betas=None), "models", r"missing keys \['betas'\] of an AMASS motion"),
    (lambda d: _edit(d, trans=np.zeros((19, 3))), "models",
     r"trans has shape \(19, 3\), poses \(20, 165\)"),
    (lambda d: _edit(d, mocap_frame_rate=None), "models", r"no frame rate .*--source-fps"),
    (lambda d: _edit(d, poses=np.zeros((20, 156))), "models",
     r"no SMPLH model of gender 'neutral'"),
])
def test_bad_input_is_one_line_before_any_work(capsys, tmp_path, models, make, model,
                                               expected):
    clip = make(tmp_path)
    out = tmp_path / "out.npz"
    folder = None if model is None else (models if model == "models" else tmp_path / model)
    extra = [] if folder is None else ["--body-model", folder]
    t0 = time.perf_counter()
    status, line = run(capsys, "retarget", clip, "-o", out, *extra)
    assert status == 2 and re.search(expected, line), line
    assert time.perf_counter() - t0 < 5.0 and not out.exists()


def test_body_model_files_that_do_not_fit(models, tmp_path):
    """An SMPL-H file where the SMPL-X one should be, a v1.0 SMPL-X model (10 shape columns)
    for 16 non-zero betas, a model that is not an archive: BodyModelError naming the file."""
    wrong = tmp_path / "wrong"
    h = write_body_model(wrong, "smplh", "neutral")
    (wrong / "smplx").mkdir()
    h.rename(wrong / "smplx" / "SMPLX_NEUTRAL.npz")
    clip = _walk_file(tmp_path)
    with pytest.raises(BodyModelError, match=r"SMPLX_NEUTRAL.npz': shapes .*J_regressor "
                       r"\(52, .*valid: a SMPLX body model: .*\(55, V\)"):
        read_raw(clip, body_model=wrong)
    old = tmp_path / "v1_0"
    write_body_model(old, "smplx", "neutral", columns=20)
    with pytest.raises(BodyModelError, match=r"10 shape components, the motion has 16 non-zero "
                       r"betas; valid: a model with at least 16"):
        read_raw(_walk_file(tmp_path, name="b.npz", betas=np.full(16, 0.1)), body_model=old)
    assert read_raw(_walk_file(tmp_path, name="c.npz", betas=np.eye(16)[0]), body_model=old)
    broken = tmp_path / "broken" / "smplx"
    broken.mkdir(parents=True)
    (broken / "SMPLX_NEUTRAL.npz").write_bytes(b"not a zip")
    with pytest.raises(BodyModelError, match="not readable"):
        read_raw(clip, body_model=broken)  # the smplx folder itself is accepted too


def test_other_npz_files_are_not_clips(tmp_path):
    """An .npz without poses/trans (a robot motion, imesh markers) is no AMASS clip."""
    path = tmp_path / "robot.npz"
    np.savez(path, joint_positions=np.zeros((3, 2)), fps=np.array(30.0))
    assert not is_amass(path) and is_amass(_walk_file(tmp_path))
    with pytest.raises(UnsupportedFormatError, match="must be an AMASS motion"):
        load_motion(path)
    with pytest.raises(MotionFileError, match="no such file"):
        load_motion(tmp_path / "gone.npz", body_model=tmp_path)
    assert issubclass(BodyModelError, ImeshError)


# ----------------------------------------------------------------------------------------------
# acceptance 6: an AMASS-layout file with the synthetic body model retargets end to end


def test_amass_walk_retargets_end_to_end(capsys, models, tmp_path):
    """``imesh retarget WALK.npz --body-model DIR`` on the default robot: the walk (2 s at
    60 fps, 0.8 m/s, shape beta 0 = 0.3) passes every gate, the motion records the body model
    in its provenance, and ``imesh evaluate --source`` reads the clip again through it."""
    import json

    from imesh.io.robot_motion import load_robot_motion

    poses, trans = walk_parameters(seconds=2.0, speed_m_s=0.8, period_s=1.2)
    clip = write_amass(tmp_path / "walk.npz", poses, trans, betas=0.3 * np.eye(16)[0])
    out, report = tmp_path / "walk_jvrc1.npz", tmp_path / "walk.json"
    status, text = run(capsys, "-q", "retarget", clip, "--body-model", models, "-o", out,
                       "--json", report)
    assert status == 0, text
    result = json.loads(report.read_text())
    metrics = {k: v["value"] for k, v in result["metrics"].items()}
    assert result["verification"]["passed"] and result["robot"] == "jvrc1"
    assert metrics["marker_rms_mm"] < 100.0 and metrics["ground_penetration_mm"] < 10.0
    assert metrics["limit_violation_frames"] == 0 and metrics["zmp_inside_fraction"] >= 0.95
    assert metrics["foot_skid_mm_per_frame"] < 1.0  # the synthetic feet do not slide
    provenance = load_robot_motion(out).provenance
    assert provenance is not None
    assert provenance.source.load["body_model"] == str(models)
    assert provenance.source.frames == 120 and provenance.source.fps == 60.0
    status, text = run(capsys, "evaluate", out, "--source", clip)
    assert status == 0 and "close_pair_error" in text, text
    # a body-model folder that moved: --body-model overrides the provenance's
    moved = tmp_path / "moved"
    models.rename(moved)
    try:
        status, line = run(capsys, "evaluate", out, "--source", clip)
        assert status == 2 and "no such folder" in line, line
        status, again = run(capsys, "evaluate", out, "--source", clip, "--body-model", moved)
        assert status == 0 and again.splitlines()[1:] == text.splitlines()[1:], again
    finally:
        moved.rename(models)

"""Synthetic (procedurally generated) human motion: the built-in default input of the demo.

Nothing here is captured data. :func:`synthetic_walk_clap` builds a joint-centre skeleton in the
standard marker set (:data:`imesh.human.markerset.STANDARD_MARKERS`) by forward kinematics of a
simple joint-angle body plus analytic two-link inverse kinematics for the limbs, so every bone
length is exactly constant over frames. Everything is a closed-form, vectorised function of time
built from smooth blends (quintic smoothsteps, squared-cosine windows and piecewise cubic Hermite
curves), so the trajectories are C1 or better.

Conventions: metres, world Z up, X forward (walking direction), Y to the performer's left, floor
at z = 0.
"""

from __future__ import annotations

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import OptionError
from ..human.markerset import STANDARD_BONES, STANDARD_MARKERS

__all__ = ["synthetic_walk_clap"]

# ---------------------------------------------------------------------------------------------
# Body proportions, as fractions of stature before normalisation. The final positions are scaled
# so that the standing joint extent (head centre to toe marker) equals the requested height.
# Segment ratios follow the usual anthropometric tables (Drillis & Contini / Winter).
_THIGH = 0.245  # hip -> knee
_SHANK = 0.246  # knee -> ankle
_ANKLE_Z = 0.055  # ankle joint centre above the floor, foot flat
_TOE = np.array([0.100, 0.0, -0.041])  # ankle -> toe marker (toe marker 0.014 above the floor)
_HEEL = np.array([-0.035, 0.0, -0.055])  # ankle -> heel contact point (virtual, on the floor)
_HIP = np.array([0.0, 0.085, -0.040])  # pelvis -> left hip (mirror y for the right)
_FOOT_Y = 0.080  # lateral position of the foot prints
_SPINE = 0.090  # pelvis -> spine
_CHEST = 0.120  # spine -> chest
_NECK = 0.080  # chest -> neck (base of the neck)
_HEAD = 0.080  # neck -> head centre
_SHOULDER = np.array([0.0, 0.125, 0.030])  # chest -> left shoulder
_UPPER_ARM = 0.186  # shoulder -> elbow
_FOREARM = 0.146  # elbow -> wrist
_HAND = 0.055  # wrist -> hand centre
_PELVIS_X = 0.020  # pelvis ahead of the ankles when standing
_KNEE_STAND = 0.997  # standing hip-ankle distance / leg length (knees slightly unlocked)

# Gait (times in seconds, lengths in normalised units).
_STEP_LENGTH = 0.33  # distance between consecutive foot prints along X
_STEP_TIME = 0.55  # time between consecutive heel strikes
_SWING_TIME = 0.44  # toe-off -> heel strike
_HEEL_RISE_TIME = 0.25  # heel rise (pivot about the toe) before toe-off
_HEEL_ROCK_TIME = 0.12  # heel strike -> foot flat (pivot about the heel)
_TOE_OFF_PITCH = 0.50  # foot pitch at toe-off [rad], toes down
_HEEL_STRIKE_PITCH = -0.25  # foot pitch at heel strike [rad], toes up
_SWING_LIFT = 0.040  # extra ankle lift at mid-swing
_PELVIS_DROP = 0.035  # mean pelvis lowering while walking
_PELVIS_BOB = 0.012  # pelvis rise at mid-stance
_PELVIS_SWAY = 0.020  # lateral pelvis shift towards the support foot
_PELVIS_YAW = 0.07  # pelvis rotation [rad]
_TRUNK_LEAN = 0.05  # forward trunk lean while walking [rad]
_ARM_SWING = 0.30  # shoulder flexion amplitude [rad]

# Timeline [s].
_STAND_START = 0.5  # standing still at the start
_WALK_LEAD = 0.1  # weight shift before the first heel rise
_SETTLE = 0.25  # pelvis comes to rest this long after the last heel strike
_RAISE_TIME = 0.7  # arms: rest -> clap pose
_CLAP_PERIOD = 0.5  # one clap
_N_CLAPS = 3
_LOWER_TIME = 0.7  # arms: clap pose -> rest
_STAND_END = 0.6  # standing still at the end

# Claps (metres, converted to normalised units with the body scale).
_CLAP_GAP_MIN_M = 0.015  # hand-centre distance at contact
_CLAP_GAP_OPEN_M = 0.30  # hand-centre distance with the hands apart
_CLAP_CENTRE = np.array([0.17, 0.0, -0.02])  # chest -> centre between the hands (chest frame)


# ------------------------------------------------------------------------------------ helpers
def _smoothstep(u: np.ndarray) -> np.ndarray:
    """Quintic smoothstep of ``clip(u, 0, 1)``: 0 -> 1 with zero 1st and 2nd derivatives."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (u * (6.0 * u - 15.0) + 10.0)


def _cos2_window(t: np.ndarray, centre: float, half_width: float) -> np.ndarray:
    """``cos^2(pi/2 * (t - centre) / half_width)`` inside ``|t - centre| < half_width``, else 0.

    C1: value 1 and slope 0 at the centre, value 0 and slope 0 at the edges. Windows of one
    half-width spaced by half_width with alternating signs sum to a cosine; with equal signs and
    spacing ``2 * half_width`` they tile into a raised cosine.
    """
    x = (t - centre) / half_width
    return np.where(np.abs(x) < 1.0, np.cos(0.5 * np.pi * x) ** 2, 0.0)


def _hermite(t: np.ndarray, knots: np.ndarray, values: np.ndarray,
             slopes: np.ndarray) -> np.ndarray:
    """Piecewise cubic Hermite curve through ``(knots, values)`` with the given slopes.

    Args:
        t: (T,) query times.
        knots: (K,) strictly increasing times.
        values: (K,) values at the knots.
        slopes: (K,) derivatives at the knots. Outside the knot range the end values are held
            (C1 only when the end slopes are zero).

    Returns:
        (T,) curve values.
    """
    knots = np.asarray(knots, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    slopes = np.asarray(slopes, dtype=np.float64)
    if knots.size == 1:
        return np.full_like(t, values[0])
    i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, knots.size - 2)
    h = knots[i + 1] - knots[i]
    s = np.clip((t - knots[i]) / h, 0.0, 1.0)
    s2, s3 = s * s, s * s * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    return (h00 * values[i] + h10 * h * slopes[i] + h01 * values[i + 1]
            + h11 * h * slopes[i + 1])


def _catmull_rom_slopes(knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Finite-difference slopes for :func:`_hermite`, zero at both ends (start/stop at rest)."""
    slopes = np.zeros_like(values)
    if values.size > 2:
        slopes[1:-1] = (values[2:] - values[:-2]) / (knots[2:] - knots[:-2])
    return slopes


def _rot_y(theta: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about +Y by ``theta`` [rad] (positive tips +X towards -Z)."""
    c, s = np.cos(theta), np.sin(theta)
    z, o = np.zeros_like(theta), np.ones_like(theta)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1),
                     np.stack([-s, z, c], -1)], -2)


def _rot_z(psi: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotations about +Z by ``psi`` [rad] (counter-clockwise seen from above)."""
    c, s = np.cos(psi), np.sin(psi)
    z, o = np.zeros_like(psi), np.ones_like(psi)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1),
                     np.stack([z, z, o], -1)], -2)


def _apply(rot: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Rotate (3,) or (T, 3) ``vec`` by (T, 3, 3) ``rot``; returns (T, 3)."""
    vec = np.broadcast_to(vec, rot.shape[:-1])
    return np.einsum("tij,tj->ti", rot, vec)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _two_link(root: np.ndarray, target: np.ndarray, l1: float, l2: float,
              hint: np.ndarray, what: str) -> np.ndarray:
    """Middle joint of a two-link chain reaching ``target`` from ``root`` (analytic IK).

    Args:
        root: (T, 3) root joint (hip, shoulder).
        target: (T, 3) end joint (ankle, wrist).
        l1: root -> middle length.
        l2: middle -> end length.
        hint: (T, 3) or (3,) direction the middle joint bends towards (knee forward, ...).
        what: chain name for the error message.

    Returns:
        (T, 3) middle joint, exactly ``l1`` from ``root`` and ``l2`` from ``target``.
    """
    d_vec = target - root
    d = np.linalg.norm(d_vec, axis=-1)
    if d.max() > (l1 + l2) * (1 - 1e-9) or d.min() < abs(l1 - l2) * (1 + 1e-9):
        raise RuntimeError(f"synthetic {what}: target out of reach (internal error)")
    u = d_vec / d[:, None]
    a = (l1 * l1 - l2 * l2 + d * d) / (2 * d)
    r = np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))
    hint = np.broadcast_to(hint, u.shape)
    p = _unit(hint - np.sum(hint * u, axis=-1, keepdims=True) * u)
    return root + a[:, None] * u + r[:, None] * p


# ------------------------------------------------------------------------------------ gait plan
def _foot_trajectory(t: np.ndarray, prints: list[np.ndarray],
                     swings: list[tuple[float, float, float, float, float]]
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Ankle position and foot pitch of one foot.

    Args:
        t: (T,) times [s].
        prints: ankle positions (3,) of the successive flat foot prints (``len(swings) + 1``).
        swings: per swing ``(t_heel_rise, t_toe_off, t_heel_strike, t_foot_flat, pitch_scale)``.

    Returns:
        ankle (T, 3) and pitch (T,) [rad]. The foot is flat on print ``j`` between swings; it
        pivots about the toe during heel rise, about the heel from heel strike to foot flat.
    """
    knots, vals, slopes = [t[0] - 1.0], [0.0], [0.0]
    for t_hr, t_to, t_hs, t_ff, k in swings:
        # plantarflexion still increasing at toe-off, dorsiflexion decreasing at heel strike
        knots += [t_hr, t_to, t_hs, t_ff]
        vals += [0.0, k * _TOE_OFF_PITCH, k * _HEEL_STRIKE_PITCH, 0.0]
        slopes += [0.0, 0.3 * k * _TOE_OFF_PITCH / (t_to - t_hr),
                   -1.2 * k * _HEEL_STRIKE_PITCH / (t_ff - t_hs), 0.0]
    pitch = _hermite(t, np.array(knots), np.array(vals), np.array(slopes))
    rot = _rot_y(pitch)
    toe_off = _apply(rot, _TOE)
    heel_off = _apply(rot, _HEEL)

    ankle = np.broadcast_to(prints[0], (t.size, 3)).copy()
    for j, (t_hr, t_to, t_hs, t_ff, _) in enumerate(swings):
        a0, a1 = prints[j], prints[j + 1]
        rise = (t >= t_hr) & (t < t_to)
        ankle[rise] = (a0 + _TOE - toe_off)[rise]
        swing = (t >= t_to) & (t < t_hs)
        u = (t - t_to) / (t_hs - t_to)
        w = _smoothstep(u)[:, None]
        lift = _SWING_LIFT * np.sin(np.pi * np.clip(u, 0, 1)) ** 2
        from_toe = a0 + _TOE - toe_off
        from_heel = a1 + _HEEL - heel_off
        moving = (1 - w) * from_toe + w * from_heel
        moving[:, 2] += lift
        ankle[swing] = moving[swing]
        rock = (t >= t_hs) & (t < t_ff)
        ankle[rock] = from_heel[rock]
        ankle[t >= t_ff] = a1
    return ankle, pitch


# ------------------------------------------------------------------------------------ public
def synthetic_walk_clap(*, steps: int = 4, fps: float = 60.0, height_m: float = 1.45,
                        seed: int | None = None) -> MarkerMotion:
    """Synthetic clip: stand, walk ``steps`` steps along +X, stop, clap three times, stand.

    The performer is a procedural joint-centre skeleton in the standard marker set, not captured
    data. Timeline (``steps = 4``: 6.68 s, 402 frames at 60 fps): stand 0.5 s; weight shift and gait
    initiation with the right foot; ``steps`` footfalls 0.55 s apart, alternating right/left, each
    with heel rise (pivot about the toe), toe-off, a swing clearing the floor by a few cm, heel
    strike and heel rocker (pivot about the heel); the last footfall closes beside the other foot;
    arms swing in counter-phase with the legs, the pelvis bobs, sways towards the support foot and
    rotates; then the hands rise in front of the chest (0.7 s), clap three times (0.5 s each, hand
    centres within 1.5 cm at each clap), lower (0.7 s), and the body stands for 0.6 s.

    Support feet are exactly static on the floor (foot flat and heel rise keep the toe marker
    fixed). Bone lengths are exactly constant (forward kinematics plus analytic two-link IK).
    Foot prints are ``step_length_m`` apart along X; since the first step starts from and the
    last step ends in a side-by-side stance, the forward progress is
    ``(steps - 1) * step_length_m`` (reported in ``meta["forward_progress_m"]``).

    Args:
        steps: number of footfalls, >= 1.
        fps: sampling rate [1/s], > 0.
        height_m: body height [m]: the standing joint extent (head centre to toe marker); the
            proportions are scaled to it. Between 0.5 and 2.5.
        seed: None for the canonical deterministic clip. An integer adds small reproducible
            variability (standard deviations, clipped at two: step lengths 2.5 %, sway and arm
            swing amplitudes 10 %, clap position 1 cm); it perturbs the motion parameters, not
            the markers, so bones stay rigid and support feet stay fixed.

    Returns:
        MarkerMotion with ``positions_m`` (T, 21, 3) [m] in ``STANDARD_MARKERS`` order, all
        samples valid, ``bones = STANDARD_BONES``, ``source = "synthetic:walk_clap"`` and
        ``meta`` with units, up axis, ``synthetic = True``, step length, forward progress, the
        heel-strike and clap times [s] and the phase boundaries [s].

    Raises:
        OptionError: for an invalid ``steps``, ``fps`` or ``height_m``.
    """
    if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 1:
        raise OptionError("steps", steps, "an integer >= 1")
    if not (isinstance(fps, int | float) and np.isfinite(fps) and fps > 0):
        raise OptionError("fps", fps, "a positive number of frames per second")
    if not (isinstance(height_m, int | float) and np.isfinite(height_m)
            and 0.5 <= height_m <= 2.5):
        raise OptionError("height_m", height_m, "a height in metres between 0.5 and 2.5")
    steps = int(steps)
    rng = np.random.default_rng(seed) if seed is not None else None

    def jitter(rel: float, size: int | None = None) -> np.ndarray | float:
        if rng is None:
            return np.ones(size) if size is not None else 1.0
        return 1.0 + rel * np.clip(rng.standard_normal(size), -2.0, 2.0)

    leg = _THIGH + _SHANK
    hip_stand = np.array([_PELVIS_X, _HIP[1] - _FOOT_Y, 0.0])
    hip_z = _ANKLE_Z + np.sqrt((_KNEE_STAND * leg) ** 2 - hip_stand[0] ** 2 - hip_stand[1] ** 2)
    pelvis_z = hip_z - _HIP[2]
    head_z = pelvis_z + _SPINE + _CHEST + _NECK + _HEAD
    scale = height_m / (head_z - (_ANKLE_Z + _TOE[2]))  # metres per normalised unit

    # ---- footfall plan: right foot first; the last footfall closes beside the other foot
    step_len = _STEP_LENGTH * np.asarray(jitter(0.025, steps))
    x_print = np.zeros(steps + 1)  # x_print[k] = ankle x of footfall k (k = 0: start stance)
    for k in range(1, steps + 1):
        x_print[k] = x_print[k - 1] + (step_len[k - 1] if k < steps else 0.0)
    if steps >= 2:
        x_print[steps] = x_print[steps - 1]
    t_first = _STAND_START + _WALK_LEAD + _HEEL_RISE_TIME + _SWING_TIME
    t_strike = t_first + _STEP_TIME * np.arange(steps)  # heel strike of footfall k+1
    side = np.where(np.arange(1, steps + 1) % 2 == 1, -1.0, 1.0)  # -1 right, +1 left

    feet = {}
    for foot_side in (1.0, -1.0):
        prints = [np.array([0.0, foot_side * _FOOT_Y, _ANKLE_Z])]
        swings = []
        prev_x = 0.0
        for k in range(1, steps + 1):
            if side[k - 1] != foot_side:
                continue
            t_hs = t_strike[k - 1]
            t_to = t_hs - _SWING_TIME
            travel = x_print[k] - prev_x
            pitch_scale = 0.6 + 0.4 * min(1.0, travel / (2 * _STEP_LENGTH))
            swings.append((t_to - _HEEL_RISE_TIME, t_to, t_hs, t_hs + _HEEL_ROCK_TIME,
                           pitch_scale))
            prints.append(np.array([x_print[k], foot_side * _FOOT_Y, _ANKLE_Z]))
            prev_x = x_print[k]
        feet[foot_side] = (prints, swings)

    t_walk_end = t_strike[-1] + max(_SETTLE, _HEEL_ROCK_TIME)
    t_raise = t_walk_end
    t_clap = t_raise + _RAISE_TIME
    t_clap_end = t_clap + _N_CLAPS * _CLAP_PERIOD
    t_rest = t_clap_end + _LOWER_TIME
    duration = t_rest + _STAND_END
    n_frames = int(np.floor(duration * fps + 1e-9)) + 1
    t = np.arange(n_frames) / fps

    # ---- feet
    ankle, pitch = {}, {}
    for foot_side, (prints, swings) in feet.items():
        ankle[foot_side], pitch[foot_side] = _foot_trajectory(t, prints, swings)
    toe = {s: ankle[s] + _apply(_rot_y(pitch[s]), _TOE) for s in feet}

    # ---- pelvis: forward progression, bob, sway, yaw
    t_start = _STAND_START - 0.05
    knots = [t_start] + list(t_strike[: steps - 1]) + [t_strike[-1] + _SETTLE]
    xs = [0.0] + [0.5 * (x_print[k] + x_print[k - 1]) for k in range(1, steps)] + [x_print[-1]]
    knots_a, xs_a = np.array(knots), np.array(xs) + _PELVIS_X
    px = _hermite(t, knots_a, xs_a, _catmull_rom_slopes(knots_a, xs_a))

    mid_swing = t_strike - 0.5 * _SWING_TIME
    walking = (_smoothstep((t - t_start) / 0.4)
               * (1 - _smoothstep((t - t_strike[-1]) / (_SETTLE + 0.15))))
    sway = np.zeros_like(t)
    bob = np.zeros_like(t)
    alt = np.zeros_like(t)  # +1 around right heel strikes, -1 around left ones
    for k in range(steps):
        sway += -side[k] * _cos2_window(t, mid_swing[k], _STEP_TIME)
        bob += _cos2_window(t, mid_swing[k], 0.5 * _STEP_TIME)
        alt += -side[k] * _cos2_window(t, t_strike[k], _STEP_TIME)
    py = _PELVIS_SWAY * float(jitter(0.1)) * sway
    pz = pelvis_z - _PELVIS_DROP * walking + _PELVIS_BOB * bob
    pelvis = np.stack([px, py, pz], axis=-1)
    yaw = _PELVIS_YAW * alt
    rot_pelvis = _rot_z(yaw)
    forward = _apply(rot_pelvis, np.array([1.0, 0.0, 0.0]))

    # ---- legs (IK: knee bends forward)
    hip, knee = {}, {}
    for s in feet:
        hip[s] = pelvis + _apply(rot_pelvis, _HIP * np.array([1.0, s, 1.0]))
        knee[s] = _two_link(hip[s], ankle[s], _THIGH, _SHANK, forward, "leg")

    # ---- trunk and head
    lean = _TRUNK_LEAN * walking
    rot_lean = _rot_y(lean)
    up = _apply(rot_lean, np.array([0.0, 0.0, 1.0]))
    spine = pelvis + _SPINE * up
    chest = spine + _CHEST * up
    rot_thorax = _rot_z(-0.4 * yaw) @ rot_lean
    neck = chest + _apply(rot_thorax, np.array([0.0, 0.0, _NECK]))
    head = neck + _apply(_rot_y(0.3 * lean), np.array([0.0, 0.0, _HEAD]))

    # ---- arms: rest/swing pose (forward kinematics) blended with the clap pose, then IK
    clap_w = _smoothstep((t - t_raise) / _RAISE_TIME) * (1 - _smoothstep((t - t_clap_end)
                                                                         / _LOWER_TIME))
    phase = np.clip((t - t_clap) / _CLAP_PERIOD, 0.0, _N_CLAPS)
    gap_min, gap_open = _CLAP_GAP_MIN_M / scale, _CLAP_GAP_OPEN_M / scale
    gap = gap_open - (gap_open - gap_min) * np.sin(np.pi * phase) ** 2
    clap_centre = _CLAP_CENTRE + (np.array([0.01, 0.01, 0.01]) / scale
                                  * (np.asarray(jitter(1.0, 3)) - 1.0))
    arm_amp = _ARM_SWING * float(jitter(0.1))
    shoulder, elbow, wrist, hand = {}, {}, {}, {}
    for s in feet:
        mirror = np.array([1.0, s, 1.0])
        shoulder[s] = chest + _apply(rot_thorax, _SHOULDER * mirror)
        flex = 0.05 + s * arm_amp * alt * walking  # left arm forward at right heel strike
        abduct = s * 0.12
        hang = np.array([0.0, np.sin(abduct), -np.cos(abduct)])
        upper = _apply(rot_thorax @ _rot_y(-flex), hang)
        fore = _apply(rot_thorax @ _rot_y(-(flex + 0.25 + 0.6 * np.maximum(flex, 0.0) ** 1.5)),
                      hang)
        rest_wrist = shoulder[s] + _UPPER_ARM * upper + _FOREARM * fore
        rest_dir = fore
        offset = np.broadcast_to(clap_centre, (n_frames, 3)).copy()
        offset[:, 1] += s * 0.5 * gap
        clap_hand = chest + _apply(rot_thorax, offset)
        clap_dir = _apply(rot_thorax, _unit(np.array([0.55, -s * 0.15, 0.82])))
        clap_wrist = clap_hand - _HAND * clap_dir
        cw = clap_w[:, None]
        target = (1 - cw) * rest_wrist + cw * clap_wrist
        hand_dir = _unit((1 - cw) * rest_dir + cw * clap_dir)
        hint = _apply(rot_thorax, (1 - cw) * np.array([-1.0, 0.3 * s, 0.0])
                      + cw * np.array([-0.4, 1.0 * s, -0.6]))
        wrist[s] = target
        elbow[s] = _two_link(shoulder[s], target, _UPPER_ARM, _FOREARM, hint, "arm")
        hand[s] = wrist[s] + _HAND * hand_dir

    joints = {
        "pelvis": pelvis, "hip_l": hip[1.0], "hip_r": hip[-1.0], "knee_l": knee[1.0],
        "knee_r": knee[-1.0], "ankle_l": ankle[1.0], "ankle_r": ankle[-1.0], "toe_l": toe[1.0],
        "toe_r": toe[-1.0], "spine": spine, "chest": chest, "neck": neck, "head": head,
        "shoulder_l": shoulder[1.0], "shoulder_r": shoulder[-1.0], "elbow_l": elbow[1.0],
        "elbow_r": elbow[-1.0], "wrist_l": wrist[1.0], "wrist_r": wrist[-1.0],
        "hand_l": hand[1.0], "hand_r": hand[-1.0],
    }
    positions = np.stack([joints[name] for name in STANDARD_MARKERS], axis=1) * scale

    meta = {
        "units": "m",
        "up_axis": "+Z",
        "forward_axis": "+X",
        "synthetic": True,
        "generator": "imesh.io.synthetic.synthetic_walk_clap",
        "steps": steps,
        "seed": seed,
        "height_m": float(height_m),
        "step_length_m": float(np.mean(step_len) * scale),
        "forward_progress_m": float(x_print[-1] * scale),
        "heel_strike_s": [float(x) for x in t_strike],
        "clap_s": [float(t_clap + (i + 0.5) * _CLAP_PERIOD) for i in range(_N_CLAPS)],
        "phases_s": {
            "stand": (0.0, _STAND_START),
            "walk": (_STAND_START, float(t_walk_end)),
            "clap": (float(t_raise), float(t_rest)),
            "stand_end": (float(t_rest), float(duration)),
        },
    }
    return MarkerMotion(positions_m=positions, fps=float(fps), names=STANDARD_MARKERS,
                        valid=np.ones(positions.shape[:2], dtype=bool), bones=STANDARD_BONES,
                        source="synthetic:walk_clap", meta=meta)

"""Human motion in the sagittal plane: projection, link scaling and inverse kinematics (sec. IV-B).

The standard markers (hip, knee, ankle, toe per side, hips and neck for the torso) are projected
onto the sagittal plane of the walk (horizontal axis = the pelvis's net direction of travel, the
vertical axis = world z). A 2D human model with the paper's seven links is scaled from the
marker distances (median over frames) and fitted to the projected markers in every frame by
Gauss-Newton inverse kinematics (all frames at once), which gives the absolute link angles
(LINKS order, the robot's convention: 0 upright / foot flat, positive = top of the link
forward, foot toe-down).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from ..core.motion import MarkerMotion
from ..errors import InvalidMotionError
from ..morph.adapt import prepare_markers
from .chain import LINKS, rot

log = logging.getLogger(__name__)

#: Projected points of the 2D human model, in fitting order.
POINTS: tuple[str, ...] = ("hip", "knee_l", "ankle_l", "toe_l", "knee_r", "ankle_r", "toe_r",
                           "neck")


@dataclass(frozen=True, eq=False)
class SagittalCapture:
    """A human clip in the sagittal plane.

    Attributes:
        source: the clip.
        fps: frame rate [1/s].
        forward: (2,) unit horizontal direction of travel (world x, y).
        markers: name (:data:`POINTS`) -> (T, 2) projected marker positions (s forward, z up)
            [m].
        lengths: human link lengths [m]: thigh, shank, foot (ankle -> toe), torso (hips -> neck),
            per side where it applies (``thigh_l`` ...).
        angles: (T, 7) link angles from inverse kinematics [rad] (LINKS order).
        hip: (T, 2) fitted hip centre [m].
        ik_rms_m: RMS distance between fitted model points and projected markers [m].
        out_of_plane_rms_m: RMS lateral distance of the leg markers from the sagittal plane
            through the pelvis path, i.e. what the projection discards [m].
        foot_reference_rad: the ankle -> toe line's angle below the horizontal when the foot
            is flat [rad] (median over the low-toe frames, mean of both sides).
        links: the link order of ``angles`` (:data:`LINKS`).
    """

    source: str
    fps: float
    forward: np.ndarray
    markers: dict[str, np.ndarray]
    lengths: dict[str, float]
    angles: np.ndarray
    hip: np.ndarray
    ik_rms_m: float
    out_of_plane_rms_m: float
    foot_reference_rad: float
    links: tuple[str, ...] = LINKS

    @property
    def n_frames(self) -> int:
        return int(self.angles.shape[0])

    def model_points(self, angles: np.ndarray | None = None,
                     hip: np.ndarray | None = None) -> dict:
        """Points of the 2D human model for link angles (default: the fitted ones)."""
        return _human_fk(self.angles if angles is None else angles,
                         self.hip if hip is None else hip, self.lengths,
                         self.foot_reference_rad)


def _human_fk(phi: np.ndarray, hip: np.ndarray, L: dict, foot_ref: float) -> dict:
    """2D human model points. Thigh/shank point down in the zero pose, torso up, foot along
    ``foot_ref`` (angle below the horizontal of the ankle -> toe line when the foot is flat)."""
    down = np.array([0.0, -1.0])
    up = np.array([0.0, 1.0])
    foot = np.array([np.cos(foot_ref), -np.sin(foot_ref)])
    out = {"hip": hip}
    for side, (f, s, t) in (("l", (0, 1, 2)), ("r", (6, 5, 4))):
        knee = hip + L[f"thigh_{side}"] * rot(phi[:, t], down)
        ankle = knee + L[f"shank_{side}"] * rot(phi[:, s], down)
        toe = ankle + L[f"foot_{side}"] * rot(phi[:, f], foot)
        out[f"knee_{side}"], out[f"ankle_{side}"], out[f"toe_{side}"] = knee, ankle, toe
    out["neck"] = hip + L["torso"] * rot(phi[:, 3], up)
    return out


def _seg_angle_down(d: np.ndarray) -> np.ndarray:
    """Angle phi with R(phi) (0, -1) parallel to d (T, 2)."""
    return np.arctan2(-d[:, 0], -d[:, 1])


def sagittal_capture(motion: MarkerMotion, iterations: int = 8) -> SagittalCapture:
    """Project a human clip onto its sagittal plane and fit the 2D seven-link model.

    Args:
        motion: any loaded clip (mapped to the standard markers, gaps filled).
        iterations: Gauss-Newton iterations of the inverse kinematics.

    Raises:
        InvalidMotionError: the pelvis does not travel (no direction of travel to define the
            sagittal plane) or the clip is shorter than a second.
    """
    std = prepare_markers(motion)
    P = std.positions_m
    idx = {n: i for i, n in enumerate(std.names)}
    if std.n_frames < std.fps:
        raise InvalidMotionError(f"{motion.source}: {std.n_frames} frames is shorter than 1 s; "
                                 "a periodic motion needs at least one full cycle")
    pel = P[:, idx["pelvis"], :2]
    travel = pel[-1] - pel[0]
    dist = float(np.linalg.norm(travel))
    if dist < 0.3:
        # walking in place: the horizontal axis the pelvis moves along most
        w, V = np.linalg.eigh(np.cov((pel - pel.mean(0)).T))
        travel = V[:, -1]
        log.warning("%s: pelvis travels only %.2f m: sagittal axis from its main direction of "
                    "motion", motion.source, dist)
    fwd = travel / np.linalg.norm(travel)
    lat = np.array([-fwd[1], fwd[0]])
    origin = P[0, idx["pelvis"]]

    def proj(name: str) -> np.ndarray:
        p = P[:, idx[name]] - origin
        return np.stack([p[:, :2] @ fwd, P[:, idx[name], 2]], axis=1)

    hip_mid3 = 0.5 * (P[:, idx["hip_l"]] + P[:, idx["hip_r"]])
    hip = np.stack([(hip_mid3 - origin)[:, :2] @ fwd, hip_mid3[:, 2]], axis=1)
    markers = {"hip": hip, "neck": proj("neck")}
    for s in "lr":
        for n in ("knee", "ankle", "toe"):
            markers[f"{n}_{s}"] = proj(f"{n}_{s}")
    # what the projection discards: lateral distance of the leg markers from the pelvis plane
    pel_lat = (P[:, idx["pelvis"], :2] - origin[:2]) @ lat
    legs = [f"{n}_{s}" for s in "lr" for n in ("hip", "knee", "ankle", "toe")]
    lat_dev = np.array([(P[:, idx[n], :2] - origin[:2]) @ lat - pel_lat for n in legs])
    lat_dev -= np.median(lat_dev, axis=1, keepdims=True)
    out_of_plane = float(np.sqrt(np.mean(lat_dev ** 2)))

    def dist3(a: str, b: str) -> float:
        return float(np.median(np.linalg.norm(P[:, idx[a]] - P[:, idx[b]], axis=1)))

    L = {"torso": float(np.median(np.linalg.norm(P[:, idx["neck"]] - hip_mid3, axis=1)))}
    for s in "lr":
        L[f"thigh_{s}"] = dist3(f"hip_{s}", f"knee_{s}")
        L[f"shank_{s}"] = dist3(f"knee_{s}", f"ankle_{s}")
        L[f"foot_{s}"] = dist3(f"ankle_{s}", f"toe_{s}")

    # foot reference: the ankle -> toe line's angle below horizontal when the foot is flat
    # (frames where the toe is within 1 cm of its lowest height and barely moving)
    refs = []
    for s in "lr":
        d = markers[f"toe_{s}"] - markers[f"ankle_{s}"]
        ang = np.arctan2(-d[:, 1], d[:, 0])
        low = markers[f"toe_{s}"][:, 1] < markers[f"toe_{s}"][:, 1].min() + 0.01
        refs.append(np.median(ang[low]) if low.any() else np.median(ang))
    foot_ref = float(np.mean(refs))

    # initial angles from the segment directions
    T = std.n_frames
    phi = np.zeros((T, 7))
    for side, (f, sh, t) in (("l", (0, 1, 2)), ("r", (6, 5, 4))):
        phi[:, t] = _seg_angle_down(markers[f"knee_{side}"] - hip)
        phi[:, sh] = _seg_angle_down(markers[f"ankle_{side}"] - markers[f"knee_{side}"])
        d = markers[f"toe_{side}"] - markers[f"ankle_{side}"]
        phi[:, f] = -np.arctan2(d[:, 1], d[:, 0]) - foot_ref
    dn = markers["neck"] - hip
    phi[:, 3] = np.arctan2(dn[:, 0], dn[:, 1])
    x = np.concatenate([hip, phi], axis=1)              # (T, 9) unknowns per frame
    target = np.concatenate([markers[n] for n in POINTS], axis=1)  # (T, 16)

    def residual(xv: np.ndarray) -> np.ndarray:
        pts = _human_fk(xv[:, 2:], xv[:, :2], L, foot_ref)
        return np.concatenate([pts[n] for n in POINTS], axis=1) - target

    eps = 1e-6
    for _ in range(iterations):
        r = residual(x)
        J = np.empty((T, r.shape[1], 9))
        for k in range(9):
            xp = x.copy()
            xp[:, k] += eps
            J[:, :, k] = (residual(xp) - r) / eps
        H = np.einsum("tik,tij->tkj", J, J) + 1e-9 * np.eye(9)
        g = np.einsum("tik,ti->tk", J, r)
        x = x - np.linalg.solve(H, g[..., None])[..., 0]
    r = residual(x).reshape(T, -1, 2)
    ik_rms = float(np.sqrt(np.mean(np.sum(r ** 2, axis=2))))
    log.info("%s: sagittal IK RMS %.1f mm over %d frames (out-of-plane RMS %.1f mm)",
             motion.source, 1e3 * ik_rms, T, 1e3 * out_of_plane)
    return SagittalCapture(source=motion.source, fps=std.fps, forward=fwd, markers=markers,
                           lengths=L, angles=x[:, 2:], hip=x[:, :2], ik_rms_m=ik_rms,
                           out_of_plane_rms_m=out_of_plane,
                           foot_reference_rad=foot_ref, links=LINKS)

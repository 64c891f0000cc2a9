"""The 7-link sagittal chain of a biped (Okada & Miyazaki sec. IV-A), without pinocchio.

A :class:`PlanarChain` holds what the motion-reduction method needs of a robot: the mass, centre
of mass and rotational inertia of the seven sagittal links (left foot, left shank, left thigh,
torso, right thigh, right shank, right foot; in the paper's order theta_0 .. theta_6), the joint
axes between them, the foot contact geometry (toe pad from the ball to the toe tip, heel roller)
and the joint limits. Everything is given in the *zero pose* (every link angle 0: upright, legs
straight, soles flat) in world coordinates (x forward, z up); the lateral coordinate is dropped.

Link angles ``phi``: absolute pitch of each link about +y (the paper's theta_i in absolute
coordinates), 0 in the zero pose; positive pitch turns the top of a link forward, a thigh or
shank backward at its lower end, a foot toe-down. A link point ``p0`` (zero pose) of link k is at
``O_k + R(phi_k) (p0 - o_k)`` where ``o_k`` is the link's joint towards the base and

    R(phi) (x, z) = (x cos phi + z sin phi, -x sin phi + z cos phi)   (pinocchio's RY).

Relative joint angles (the robot's joints, URDF order hip, knee, ankle per side):
``q_joint = sign * (phi_child - phi_parent)`` with the torso the parent of the thighs.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

#: The seven links in the paper's order (theta_0 .. theta_6).
LINKS: tuple[str, ...] = ("foot_l", "shank_l", "thigh_l", "torso", "thigh_r", "shank_r", "foot_r")
#: The six actuated joints (URDF order): hip, knee, ankle of the left then the right leg.
JOINTS: tuple[str, ...] = ("hip_l", "knee_l", "ankle_l", "hip_r", "knee_r", "ankle_r")
#: (parent link, child link) index of each joint in LINKS.
JOINT_LINKS: tuple[tuple[int, int], ...] = ((3, 2), (2, 1), (1, 0), (3, 4), (4, 5), (5, 6))
#: Link indices of the optimized (non-foot) angles theta_1 .. theta_5.
MID: tuple[int, ...] = (1, 2, 3, 4, 5)
FEET: tuple[int, int] = (0, 6)
#: Link order of the chain rooted at the base foot: base side 0 (left) or 1 (right).
BASE_ORDER: tuple[tuple[int, ...], tuple[int, ...]] = ((0, 1, 2, 3, 4, 5, 6), (6, 5, 4, 3, 2, 1, 0))

GRAVITY = 9.81


def rot(phi: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """R(phi) applied to (..., 2) vectors (x, z); ``phi`` broadcasts against ``vec[..., 0]``."""
    c, s = np.cos(phi), np.sin(phi)
    x, z = vec[..., 0], vec[..., 1]
    return np.stack([x * c + z * s, -x * s + z * c], axis=-1)


def joint_matrix() -> np.ndarray:
    """(6, 7) A with ``phi_child - phi_parent = A @ phi`` for the six joints (before sign)."""
    A = np.zeros((6, 7))
    for j, (p, c) in enumerate(JOINT_LINKS):
        A[j, c] += 1.0
        A[j, p] -= 1.0
    return A


@dataclass(frozen=True, eq=False)
class PlanarChain:
    """Mass and geometry of a biped's sagittal 7-link chain (see the module docstring).

    Attributes:
        name: robot name.
        mass: (7,) [kg] link masses (LINKS order); a link may lump several rigid bodies.
        com: (7, 2) [m] centres of mass (x, z) in the zero pose.
        inertia: (7, 3, 3) [kg m^2] rotational inertia about the centre of mass, world axes,
            zero pose (only the yy entry acts in planar motion).
        joint_xz: (6, 2) [m] joint axis points (JOINTS order) in the zero pose.
        joint_sign: (6,) +1 or -1: robot joint angle = sign * (phi_child - phi_parent).
        joint_names: (6,) the robot's names of the six joints (JOINTS order).
        ball: (2, 2) [m] rear end of the toe pad (the base foot's pivot), left and right foot.
        tip: (2, 2) [m] front end of the toe pad (toe tip).
        roller: (2, 2) [m] heel roller centre (or heel edge, radius 0).
        roller_radius: (2,) [m].
        q_lower, q_upper: (6,) [rad] joint limits (robot joint angles).
        effort: (6,) [Nm] torque limits.
        velocity: (6,) [rad/s] velocity limits.
        source: where the numbers come from (URDF path, robot name).
        meta: free-form provenance (e.g. which bodies were lumped into which link).
    """

    name: str
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    joint_xz: np.ndarray
    joint_sign: np.ndarray
    joint_names: tuple[str, ...]
    ball: np.ndarray
    tip: np.ndarray
    roller: np.ndarray
    roller_radius: np.ndarray
    q_lower: np.ndarray
    q_upper: np.ndarray
    effort: np.ndarray
    velocity: np.ndarray
    source: str = ""
    meta: dict = field(default_factory=dict)

    # --- derived geometry ---------------------------------------------------------------------

    @property
    def total_mass(self) -> float:
        return float(np.sum(self.mass))

    @property
    def ground_z(self) -> float:
        """Height of the sole line (ball) in the zero pose [m]."""
        return float(self.ball[:, 1].mean())

    @property
    def pad_angle(self) -> np.ndarray:
        """(2,) [rad] toe-pad angle above the sole line: the foot pitch of toe line contact."""
        d = self.tip - self.ball
        return np.arctan2(d[:, 1], d[:, 0])

    @property
    def pad_length(self) -> np.ndarray:
        """(2,) [m] toe-pad length (ball to tip)."""
        return np.linalg.norm(self.tip - self.ball, axis=1)

    @property
    def height(self) -> float:
        """Zero-pose height from the sole line to the highest point known (hip + torso extent)."""
        return float(self.meta.get("height_m", np.nan))

    def joint_limits_violated(self, q_joint: np.ndarray, tol: float = 1e-9) -> np.ndarray:
        """(..., 6) bool: joint angles outside [q_lower, q_upper]."""
        return (q_joint < self.q_lower - tol) | (q_joint > self.q_upper + tol)

    # --- angles -------------------------------------------------------------------------------

    def joint_angles(self, phi: np.ndarray) -> np.ndarray:
        """(..., 6) robot joint angles [rad] from (..., 7) link angles."""
        return self.joint_sign * (np.asarray(phi) @ joint_matrix().T)

    def link_angles(self, q_joint: np.ndarray, torso: np.ndarray) -> np.ndarray:
        """(..., 7) link angles from (..., 6) joint angles and the torso pitch (...,)."""
        q = np.asarray(q_joint) * self.joint_sign
        torso = np.asarray(torso)
        phi = np.empty(q.shape[:-1] + (7,))
        phi[..., 3] = torso
        phi[..., 2] = torso + q[..., 0]
        phi[..., 1] = phi[..., 2] + q[..., 1]
        phi[..., 0] = phi[..., 1] + q[..., 2]
        phi[..., 4] = torso + q[..., 3]
        phi[..., 5] = phi[..., 4] + q[..., 4]
        phi[..., 6] = phi[..., 5] + q[..., 5]
        return phi

    # --- kinematics (vectorized over frames) --------------------------------------------------

    def _segments(self, base: int) -> tuple[np.ndarray, tuple[int, ...]]:
        """Zero-pose vectors between consecutive chain points from the base ball to the moving
        roller, (7, 2); vector k turns with chain link k; and the chain's link order."""
        m = 1 - base
        s = (0, 3) if base == 0 else (3, 0)  # joint index offset of (base, moving) leg
        hip_b, knee_b, ankle_b = (self.joint_xz[s[0] + k] for k in range(3))
        hip_m, knee_m, ankle_m = (self.joint_xz[s[1] + k] for k in range(3))
        pts = np.array([self.ball[base], ankle_b, knee_b, hip_b, hip_m, knee_m, ankle_m,
                        self.roller[m]])
        return np.diff(pts, axis=0), BASE_ORDER[base]

    def _by_base(self, base: np.ndarray | int, n_frames: int
                 ) -> Iterator[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
        """Per base side b present in ``base`` (broadcast to ``n_frames``): (b, its frames,
        :meth:`_segments` of b, the chain's link order as an index array)."""
        base = np.broadcast_to(np.asarray(base, dtype=int), (n_frames,))
        for b in (0, 1):
            sel = np.flatnonzero(base == b)
            if sel.size:
                seg, order = self._segments(b)
                yield b, sel, seg, np.asarray(order)

    def chain_points(self, phi: np.ndarray, base: np.ndarray | int,
                     pivot: np.ndarray | None = None) -> np.ndarray:
        """(T, 8, 2) world (x, z) of base ball, ankle_b, knee_b, hip_b, hip_m, knee_m, ankle_m,
        moving roller centre, with the base ball at ``pivot`` (T, 2) (default (0, 0))."""
        phi = np.atleast_2d(phi)
        T = phi.shape[0]
        base = np.broadcast_to(np.asarray(base, dtype=int), (T,))
        out = np.zeros((T, 8, 2))
        for b in (0, 1):
            sel = base == b
            if not sel.any():
                continue
            seg, order = self._segments(b)
            steps = rot(phi[sel][:, list(order)], seg[None])   # (t, 7, 2)
            out[sel, 1:] = np.cumsum(steps, axis=1)
        if pivot is not None:
            out = out + np.asarray(pivot)[:, None, :]
        return out

    def closure(self, phi: np.ndarray, base: np.ndarray | int) -> tuple[np.ndarray, np.ndarray]:
        """The closed-loop condition (eq. 30): y_m, the height of the moving foot's roller
        contact point above the ground on which the base ball stands, and its gradient.

        Returns:
            y_m: (T,) [m].
            dy_dphi: (T, 7) [m/rad] derivative w.r.t. the link angles (LINKS order).
        """
        phi = np.atleast_2d(phi)
        T = phi.shape[0]
        y = np.zeros(T)
        dy = np.zeros((T, 7))
        for b, sel, seg, order in self._by_base(base, T):
            v = rot(phi[sel][:, order], seg[None])      # (t, 7, 2)
            y[sel] = v[..., 1].sum(axis=1) - self.roller_radius[1 - b]
            dy[np.ix_(sel, order)] = -v[..., 0]          # dz/dphi of each segment
        return y, dy

    def step_length(self, phi: np.ndarray, base: np.ndarray | int
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Horizontal distance from the base ball to the moving foot's ball [m] (the step the
        robot takes when the moving foot becomes the base) and its gradient (T, 7)."""
        phi = np.atleast_2d(phi)
        T = phi.shape[0]
        d = np.zeros(T)
        dd = np.zeros((T, 7))
        for b, sel, seg, order in self._by_base(base, T):
            m = 1 - b
            seg = seg.copy()
            seg[6] = self.ball[m] - self.joint_xz[3 * m + 2]      # ankle_m -> ball_m
            w = rot(phi[sel][:, order], seg[None])
            d[sel] = w[..., 0].sum(axis=1)
            dd[np.ix_(sel, order)] = w[..., 1]
        return d, dd

    def slip_velocity(self, phi: np.ndarray, phid: np.ndarray, base: np.ndarray | int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Horizontal velocity of the moving roller centre relative to the base ball.

        At a switch of the base foot it must vanish: the sliding foot stops to become the
        fixed base (otherwise the robot's velocity in the world would jump).

        Returns:
            v: (T,) [m/s]; dv_dphi, dv_dphid: (T, 7) derivatives (LINKS order).
        """
        phi, phid = np.atleast_2d(phi), np.atleast_2d(phid)
        T = phi.shape[0]
        v = np.zeros(T)
        dq = np.zeros((T, 7))
        dv = np.zeros((T, 7))
        for _, sel, seg, o in self._by_base(base, T):
            w = rot(phi[sel][:, o], seg[None])               # (t, 7, 2)
            rate = phid[sel][:, o]
            v[sel] = np.sum(w[..., 1] * rate, axis=1)
            dv[np.ix_(sel, o)] = w[..., 1]
            dq[np.ix_(sel, o)] = -w[..., 0] * rate
        return v, dq, dv

    def points_world(self, phi: np.ndarray, base: np.ndarray, ball_x: np.ndarray) -> dict:
        """World (x, z) of every joint and contact point per frame for plots and export.

        Args:
            phi: (T, 7) link angles.
            base: (T,) base side per frame.
            ball_x: (T,) x of the base ball per frame (its z is 0, on the ground).

        Returns:
            dict name -> (T, 2): hip, knee_l, ankle_l, knee_r, ankle_r, ball_l, tip_l, roller_l,
            ball_r, tip_r, roller_r, head (top of the torso) and com.
        """
        phi = np.atleast_2d(phi)
        T = phi.shape[0]
        pts = self.chain_points(phi, base, np.stack([ball_x, np.zeros(T)], axis=1))
        out: dict[str, np.ndarray] = {}
        names_b = ("ball", "ankle", "knee", "hip")
        for b in (0, 1):
            sel = base == b
            if not sel.any():
                continue
            sides = ("l", "r") if b == 0 else ("r", "l")
            p = pts[sel]
            for k, n in enumerate(names_b):
                out.setdefault(f"{n}_{sides[0]}", np.full((T, 2), np.nan))[sel] = p[:, k]
            for k, n in zip((4, 5, 6), ("hip", "knee", "ankle"), strict=True):
                out.setdefault(f"{n}_{sides[1]}", np.full((T, 2), np.nan))[sel] = p[:, k]
        for side, si in (("l", 0), ("r", 1)):
            ank = out[f"ankle_{side}"]
            f = phi[:, FEET[si]]
            a0 = self.joint_xz[3 * si + 2]
            out[f"ball_{side}"] = ank + rot(f, self.ball[si] - a0)
            out[f"tip_{side}"] = ank + rot(f, self.tip[si] - a0)
            out[f"roller_{side}"] = ank + rot(f, self.roller[si] - a0)
        top = self.meta.get("head_xz")
        if top is not None:
            out["head"] = out["hip_l"] + rot(phi[:, 3], np.asarray(top) - self.joint_xz[0])
        out["com"] = self.com_world(phi, out)
        return out

    def com_world(self, phi: np.ndarray, pts: dict) -> np.ndarray:
        """(T, 2) whole-body centre of mass from the joint points of :meth:`points_world`."""
        ref = {0: "ankle_l", 1: "knee_l", 2: "hip_l", 3: "hip_l", 4: "hip_r", 5: "knee_r",
               6: "ankle_r"}
        ref0 = {0: self.joint_xz[2], 1: self.joint_xz[1], 2: self.joint_xz[0],
                3: self.joint_xz[0], 4: self.joint_xz[3], 5: self.joint_xz[4],
                6: self.joint_xz[5]}
        c = np.zeros((phi.shape[0], 2))
        for k in range(7):
            c += self.mass[k] * (pts[ref[k]] + rot(phi[:, k], self.com[k] - ref0[k]))
        return c / self.total_mass

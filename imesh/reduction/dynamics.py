"""Dynamics of the sagittal chain with its ground contacts (eqs 3-5, 32).

This module

- builds a :class:`~imesh.reduction.chain.PlanarChain` from a URDF (the project's planar biped)
  or from a loaded 3D robot (JVRC-1, G1: the bodies between the sagittal hip, knee and ankle
  pitch joints, named in the robot's ``robot.toml`` ``[sagittal]``, are lumped, every other
  joint locked), and
- evaluates the constrained forward dynamics of eq. (5) and its derivatives for every frame.

The rigid-body dynamics (lumping a model's bodies, the mass matrix, RNEA and its derivatives)
are pinocchio's, behind :mod:`imesh.robot.planar`; this module only combines their numbers.

Model per frame (Okada & Miyazaki sec. IV-C/D). The chain is rooted at the *base* foot's ball
(rear end of its toe pad) by a planar root (x, z translation, pitch about the ball) and runs
base foot -> base shank -> base thigh -> torso -> moving thigh -> moving shank -> moving foot.
Generalized coordinates ``q = [x, z, q_0 .. q_6]`` with ``q_0`` the base foot's pitch and
``q_k = phi_k - phi_{k-1}`` along the chain. Constraints (rows of J, multipliers lambda):

- ball fixed on the ground: x and z rows (lambda = ground force fx, fz on the base foot);
- toe line contact, case (i): the base foot's pitch held (lambda = ground moment about the ball,
  which with fz gives the two vertical forces at the ball and the toe tip); in case (ii) the foot
  turns freely about the ball (point contact, an unactuated joint);
- closed loop (eq. 30): the moving foot's roller centre stays at its height (vertical row only:
  a free roller carries no horizontal force; lambda = its vertical ground force).

``M a + h = B u + J^T lambda``, ``J a + gamma = 0`` is solved for (a, lambda) in one KKT system
per frame, batched over frames. Derivatives of (a, lambda) w.r.t. q, v and u come from
differentiating the KKT system: pinocchio's RNEA derivatives with the roller force as an external
force, and the closed-form derivatives of the roller's vertical acceleration.
"""

from __future__ import annotations

import logging
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from ..robot.config import ROBOTS_DIR
from ..robot.planar import (
    ChainError,
    RootedChain,
    lump_robot,
    lump_urdf,
    pitch_quaternion,
    robot_energies,
)
from .chain import BASE_ORDER, JOINT_LINKS, JOINTS, LINKS, PlanarChain, rot

log = logging.getLogger(__name__)

#: The project's planar biped (robots/planar_biped).
PLANAR_BIPED_URDF = ROBOTS_DIR / "planar_biped" / "planar_biped.urdf"

#: The link each joint (JOINTS order) carries: the child of its (parent, child) in JOINT_LINKS.
CHILD_LINKS: tuple[int, ...] = tuple(child for _, child in JOINT_LINKS)
#: The link that takes the bodies above the hips (the torso).
TORSO = LINKS.index("torso")

N_CONSTRAINTS = 4  # ball x, ball z, base foot pitch (case i), roller z


# ----------------------------------------------------------------------------------------------
# building chains


@cache
def _planar_biped_cached(path: str, mtime: float) -> PlanarChain:
    sides = "lr"
    lump = lump_urdf(path, JOINTS, CHILD_LINKS, LINKS, TORSO,
                     [f"{kind}_{s}" for kind in ("toe", "toe_tip", "roller") for s in sides])
    links = lump.links
    ball = np.array([lump.frames[f"toe_{s}"] for s in sides])
    tip = np.array([lump.frames[f"toe_tip_{s}"] for s in sides])
    roller = np.array([lump.frames[f"roller_{s}"] for s in sides])
    radii: list[float] = []
    root = ET.parse(path).getroot()
    for s in sides:
        link = root.find(f"./link[@name='roller_{s}']")
        sphere = None if link is None else link.find("./collision/geometry/sphere")
        radius = None if sphere is None else sphere.get("radius")
        if radius is None:
            raise ChainError(f"{path}: link roller_{s} has no collision sphere with a radius")
        radii.append(float(radius))
    ground = ball[:, 1].mean()
    shift = np.array([0.0, ground])
    torso = root.find("./link[@name='torso']/visual/geometry/box")
    size = None if torso is None else torso.get("size")
    if torso is not None and size is None:
        raise ChainError(f"{path}: the torso's visual box has no size")
    top = 0.27 if size is None else float(size.split()[2])
    head = links.joint_xz[0] + np.array([0.0, top]) - shift
    return PlanarChain(
        name="planar_biped", mass=links.mass, com=links.com - shift,
        inertia=links.inertia, joint_xz=links.joint_xz - shift, joint_sign=links.joint_sign,
        joint_names=JOINTS, ball=ball - shift, tip=tip - shift, roller=roller - shift,
        roller_radius=np.array(radii), q_lower=lump.q_lower, q_upper=lump.q_upper,
        effort=lump.effort, velocity=lump.velocity,
        source=path, meta={"head_xz": head, "height_m": float(head[1]),
                           "groups": links.groups})


def planar_biped_chain(urdf: str | Path | None = None) -> PlanarChain:
    """The project's planar biped (robots/planar_biped/planar_biped.urdf) as a PlanarChain."""
    path = Path(urdf) if urdf is not None else PLANAR_BIPED_URDF
    if not path.is_file():
        raise ChainError(f"planar biped URDF not found: {path}")
    return _planar_biped_cached(str(path.resolve()), path.stat().st_mtime)


def chain_from_robot(robot, joint_names: tuple[str, ...] | None = None) -> PlanarChain:
    """The sagittal 7-link chain of a 3D humanoid (an :class:`imesh.robot.Robot`).

    Every joint except the six sagittal hip, knee and ankle pitch joints is locked (legs at 0,
    the rest at the robot's nominal pose) and the bodies between them are lumped; the sagittal
    dynamics of the locked 3D model equal those of the chain (only the yy inertia acts).
    Contacts: the sole rectangle's rear edge is the pad's rear end (the base foot's pivot), its
    front edge the toe tip (toe angle 0: the base foot stands flat), and the rear edge slides
    as the moving foot's contact (a heel "roller" of radius 0).

    Args:
        robot: a loaded robot (``imesh.robot.load_robot``).
        joint_names: the robot's names of (hip_l, knee_l, ankle_l, hip_r, knee_r, ankle_r)
            pitch joints; default: its ``robot.toml``'s ``[sagittal] joints``.
    """
    names = joint_names or robot.config.sagittal_joints
    if not names:
        raise ChainError(f"no sagittal joint names known for robot {robot.name!r}: pass "
                         f"joint_names (hip, knee, ankle pitch of left then right leg)")
    lump = lump_robot(robot, tuple(names), JOINTS, CHILD_LINKS, LINKS, TORSO)
    links = lump.links
    ball, tip = lump.soles[:, 0], lump.soles[:, 1]
    ground = ball[:, 1].mean()
    shift = np.array([0.0, ground])
    lower = robot.q_lower[lump.joint_q]
    upper = robot.q_upper[lump.joint_q]
    effort = robot.effort_max[lump.joint_v]
    velocity = robot.v_max[lump.joint_v]
    head = np.array([links.joint_xz[0, 0], lump.top_z + 0.12 - ground])
    return PlanarChain(
        name=robot.name, mass=links.mass, com=links.com - shift, inertia=links.inertia,
        joint_xz=links.joint_xz - shift, joint_sign=links.joint_sign, joint_names=tuple(names),
        ball=ball - shift, tip=tip - shift, roller=ball - shift, roller_radius=np.zeros(2),
        q_lower=lower, q_upper=upper, effort=effort, velocity=velocity,
        source=str(robot.urdf), meta={"head_xz": head, "height_m": float(head[1]),
                                      "groups": links.groups, "q0": lump.q0,
                                      "root_xz": lump.root_xz - shift,
                                      "joint_q": lump.joint_q})


def robot_configuration(robot, chain: PlanarChain, phi: np.ndarray, base: int) -> np.ndarray:
    """The 3D robot's configuration (pinocchio free-flyer q) of chain link angles (7,), with
    the base foot's ball at the origin: the sagittal joints from the link angles, every other
    joint locked as in :func:`chain_from_robot`. Used to check that the lumped chain has the
    3D robot's sagittal dynamics."""
    phi = np.asarray(phi, float)
    q = np.array(chain.meta["q0"], float).copy()
    hip = chain.chain_points(phi[None], base)[0, 3 if base == 0 else 4]   # hip_l point
    root = hip + rot(phi[3], chain.meta["root_xz"] - chain.joint_xz[0])
    q[0], q[1], q[2] = root[0], 0.0, root[1]          # the ground at z = 0
    q[3:7] = pitch_quaternion(phi[3])
    qj = chain.joint_angles(phi)
    for k, index in enumerate(chain.meta["joint_q"]):
        q[7 + index] = qj[k]
    return q


def energies(robot, chain: PlanarChain, phi: np.ndarray, phid: np.ndarray, base: int,
             eps: float = 1e-7) -> dict:
    """Kinetic and potential energy of the chain (rooted model) and of the 3D robot at the same
    motion (for tests: equal kinetic energy and equal potential-energy differences mean equal
    sagittal dynamics)."""
    dyn = ChainDynamics(chain)
    r = dyn.rooted[base]
    o = list(BASE_ORDER[base])
    qc = dyn.configuration(phi, base)
    vc = np.concatenate([[0.0, 0.0], dyn.D @ np.asarray(phid)[o]])
    ke_c, pe_c = r.chain.energies(qc, vc)
    q1 = robot_configuration(robot, chain, phi, base)
    q2 = robot_configuration(robot, chain, np.asarray(phi) + eps * np.asarray(phid), base)
    ke_r, pe_r = robot_energies(robot, q1, q2, eps)
    return {"kinetic_chain": float(ke_c), "kinetic_robot": float(ke_r),
            "potential_chain": float(pe_c), "potential_robot": float(pe_r)}


# ----------------------------------------------------------------------------------------------
# rooted models and the constrained dynamics


def difference_matrix() -> np.ndarray:
    """(7, 7) D with q_rot = D phi_chain (q_0 = phi_0, q_k = phi_k - phi_{k-1})."""
    return np.eye(7) - np.eye(7, k=-1)


@dataclass(frozen=True, eq=False)
class _Rooted:
    chain: RootedChain     # the chain rooted at the base foot's ball (pinocchio)
    B: np.ndarray          # (9, 6) generalized force of the robot joint torques
    order: tuple[int, ...]
    roller_local: np.ndarray  # (3,) roller centre in the moving ankle joint frame
    seg: np.ndarray        # (7, 2) zero-pose segment vectors ball -> roller along the chain


def _build_rooted(chain: PlanarChain, base: int) -> _Rooted:
    """The chain rooted at the ``base`` foot's ball: joint points and links along the chain,
    and B, the joint torques' generalized force (a joint passed from child to parent turns the
    other way)."""
    order = BASE_ORDER[base]
    B = np.zeros((9, 6))
    points, names = [], []
    for k, link in enumerate(order):
        if k == 0:
            point, name = chain.ball[base], "pivot"
        else:
            pair = {order[k - 1], link}
            j = next(i for i, (p, c) in enumerate(JOINT_LINKS) if {p, c} == pair)
            point, name = chain.joint_xz[j], JOINTS[j]
            reversed_ = JOINT_LINKS[j][1] != link
            B[2 + k, j] = -chain.joint_sign[j] if reversed_ else chain.joint_sign[j]
        points.append(point)
        names.append(name)
    links = list(order)
    rooted = RootedChain(chain.ball[base], points, names, chain.mass[links], chain.com[links],
                         chain.inertia[links])
    moving = 1 - base
    r = chain.roller[moving] - chain.joint_xz[3 * moving + 2]
    seg, _ = chain._segments(base)
    return _Rooted(chain=rooted, B=B, order=order, roller_local=np.array([r[0], 0.0, r[1]]),
                   seg=seg)


@dataclass(frozen=True, eq=False)
class DynamicsResult:
    """Constrained forward dynamics of every frame (eq. 5) and, optionally, derivatives.

    Link-angle quantities are in LINKS order (paper's theta_0..6); forces per frame refer to the
    frame's base and moving foot.

    Attributes:
        acc: (T, 7) [rad/s^2] link angular accelerations produced by the torques.
        lam: (T, 4) multipliers: ground force on the base ball fx, fz [N], ground moment about
            the ball [Nm] (0 in case ii), vertical force on the moving roller [N].
        grf: (T, 3) [N] vertical ground forces: base ball, base toe tip (0 in case ii), moving
            roller (the paper's f_y0, f_y02, f_y6 / f_y62 depending on which foot is the base).
        grf_active: (T, 3) bool: which of the three are contacts in that frame.
        dacc_dphi, dacc_dphid: (T, 7, 7) derivatives of ``acc`` w.r.t. link angles and rates.
        dacc_du: (T, 7, 6) derivatives w.r.t. the joint torques (JOINTS order).
        dgrf_dphi, dgrf_dphid: (T, 3, 7); dgrf_du: (T, 3, 6).
        dlam_dphi, dlam_dphid: (T, 4, 7); dlam_du: (T, 4, 6): derivatives of ``lam``.
    """

    acc: np.ndarray
    lam: np.ndarray
    grf: np.ndarray
    grf_active: np.ndarray
    dacc_dphi: np.ndarray | None = None
    dacc_dphid: np.ndarray | None = None
    dacc_du: np.ndarray | None = None
    dgrf_dphi: np.ndarray | None = None
    dgrf_dphid: np.ndarray | None = None
    dgrf_du: np.ndarray | None = None
    dlam_dphi: np.ndarray | None = None
    dlam_dphid: np.ndarray | None = None
    dlam_du: np.ndarray | None = None


class ChainDynamics:
    """Forward/inverse dynamics of a PlanarChain standing on either foot (rooted models,
    :class:`imesh.robot.planar.RootedChain`).

    Args:
        chain: the sagittal chain.
    """

    def __init__(self, chain: PlanarChain):
        self.chain = chain
        self.rooted = [_build_rooted(chain, b) for b in (0, 1)]
        self.D = difference_matrix()
        self.C = np.linalg.inv(self.D)  # lower-triangular ones
        self.pad_length = chain.pad_length

    # --- helpers --------------------------------------------------------------------------

    def configuration(self, phi: np.ndarray, base: int) -> np.ndarray:
        """(9,) q of the rooted model for link angles (7,) (LINKS order)."""
        return np.concatenate([[0.0, 0.0], self.D @ np.asarray(phi)[list(BASE_ORDER[base])]])

    def _roller_terms(self, phi_o, phid_o, phidd_o, seg):
        """Closed-form roller-height terms along the chain for (T, 7) chain-ordered angles.

        Returns J (T, 7) = dz/dphi, gamma (T,) = sum d2z/dphi2 phid^2, and the derivatives of
        the vertical acceleration alpha = J phidd + gamma w.r.t. phi and phid (T, 7).
        """
        v = rot(phi_o, seg[None])                 # (T, 7, 2)
        J = -v[..., 0]
        gamma = -(v[..., 1] * phid_o ** 2).sum(axis=1)
        dalpha_dphi = -v[..., 1] * phidd_o + v[..., 0] * phid_o ** 2
        dalpha_dphid = -2.0 * v[..., 1] * phid_o
        return J, gamma, dalpha_dphi, dalpha_dphid

    # --- forward dynamics -------------------------------------------------------------------

    def forward(self, phi: np.ndarray, phid: np.ndarray, torque: np.ndarray, base: np.ndarray,
                case: np.ndarray, derivatives: bool = True) -> DynamicsResult:
        """Constrained forward dynamics (eq. 5) of every frame, with derivatives.

        Args:
            phi, phid: (T, 7) link angles [rad] and rates [rad/s] (LINKS order).
            torque: (T, 6) joint torques [Nm] (JOINTS order, robot sign convention).
            base: (T,) 0 when the left foot is the base foot, 1 for the right.
            case: (T,) 1 = toe line contact (base foot pitch held), 2 = toe point contact.
            derivatives: also return the derivatives w.r.t. phi, phid, torque.
        """
        phi, phid, torque = (np.atleast_2d(np.asarray(x, float)) for x in (phi, phid, torque))
        T = phi.shape[0]
        base = np.broadcast_to(np.asarray(base, int), (T,))
        case = np.broadcast_to(np.asarray(case, int), (T,))
        nv, nc = 9, N_CONSTRAINTS
        K = np.zeros((T, nv + nc, nv + nc))
        rhs = np.zeros((T, nv + nc))
        phi_o = np.empty_like(phi)
        phid_o = np.empty_like(phid)
        for b in (0, 1):
            sel = base == b
            phi_o[sel] = phi[sel][:, list(BASE_ORDER[b])]
            phid_o[sel] = phid[sel][:, list(BASE_ORDER[b])]
        q_rot = phi_o @ self.D.T
        v_rot = phid_o @ self.D.T
        Jz = np.zeros((T, 7))
        gamma = np.zeros(T)
        for b in (0, 1):
            sel = base == b
            if sel.any():
                Jz[sel], gamma[sel], _, _ = self._roller_terms(phi_o[sel], phid_o[sel],
                                                               np.zeros_like(phid_o[sel]),
                                                               self.rooted[b].seg)
        Jq = Jz @ self.C                           # (T, 7) d z_roller / d q_rot
        for t in range(T):
            r = self.rooted[base[t]]
            q = np.concatenate([[0.0, 0.0], q_rot[t]])
            v = np.concatenate([[0.0, 0.0], v_rot[t]])
            M = r.chain.mass_matrix(q)
            h = r.chain.nonlinear_effects(q, v)
            K[t, :nv, :nv] = M
            rhs[t, :nv] = r.B @ torque[t] - h
        # constraint rows: ball x, ball z, base pitch (case 1), roller z
        rows = np.zeros((T, nc, nv))
        rows[:, 0, 0] = 1.0
        rows[:, 1, 1] = 1.0
        line = case == 1
        rows[line, 2, 2] = 1.0
        rows[:, 3, 1] = 1.0
        rows[:, 3, 2:] = Jq
        K[:, nv:, :nv] = rows
        K[:, :nv, nv:] = -np.transpose(rows, (0, 2, 1))
        K[~line, nv + 2, nv + 2] = -1.0            # case 2: the pitch multiplier is 0
        rhs[:, nv + 3] = -gamma
        sol = np.linalg.solve(K, rhs[..., None])[..., 0]
        a_rot = sol[:, 2:nv]
        lam = sol[:, nv:]
        acc_o = a_rot @ self.C.T
        acc = np.empty_like(acc_o)
        for b in (0, 1):
            sel = np.flatnonzero(base == b)
            acc[np.ix_(sel, np.asarray(BASE_ORDER[b]))] = acc_o[sel]
        grf, active, G = self._grf(lam, base, line)
        if not derivatives:
            return DynamicsResult(acc=acc, lam=lam, grf=grf, grf_active=active)

        # derivative right-hand sides: columns q_rot (7), v_rot (7), u (6). The roller force is
        # vertical in the world, so its generalized force J^T lambda is differentiated here in
        # closed form (pinocchio's fext would turn with the body).
        R = np.zeros((T, nv + nc, 20))
        for t in range(T):
            r = self.rooted[base[t]]
            q = np.concatenate([[0.0, 0.0], q_rot[t]])
            v = np.concatenate([[0.0, 0.0], v_rot[t]])
            dtau_dq, dtau_dv = r.chain.rnea_derivatives(q, v, sol[t, :nv])
            R[t, :nv, :7] = -dtau_dq[:, 2:]
            R[t, :nv, 7:14] = -dtau_dv[:, 2:]
            R[t, :nv, 14:] = r.B
        for b in (0, 1):
            sel = base == b
            if sel.any():
                seg = self.rooted[b].seg
                _, _, da_dphi, da_dphid = self._roller_terms(phi_o[sel], phid_o[sel],
                                                             acc_o[sel], seg)
                R[sel, nv + 3, :7] = -(da_dphi @ self.C)
                R[sel, nv + 3, 7:14] = -(da_dphid @ self.C)
                # d(J^T lambda)/dq_rot = C^T diag(dJ/dphi) C lambda, dJ_k/dphi_k = -(R d_k)_z
                dJ = -rot(phi_o[sel], seg[None])[..., 1] * lam[sel, 3:4]      # (t, 7)
                R[sel, 2:nv, :7] += np.einsum("ji,tj,jk->tik", self.C, dJ, self.C)
        X = np.linalg.solve(K, R)                  # (T, 16, 20)
        da = X[:, 2:nv]                            # d a_rot
        dl = X[:, nv:]                             # d lambda
        # to link angles: acc_o = C a_rot; q_rot = D phi_o; phi_o = P phi
        dacc_o_dq = np.einsum("ij,tjk->tik", self.C, da[..., :7]) @ self.D
        dacc_o_dv = np.einsum("ij,tjk->tik", self.C, da[..., 7:14]) @ self.D
        dacc_o_du = np.einsum("ij,tjk->tik", self.C, da[..., 14:])
        dl_dq = dl[..., :7] @ self.D
        dl_dv = dl[..., 7:14] @ self.D
        dl_du = dl[..., 14:]
        dacc_dphi = np.zeros((T, 7, 7))
        dacc_dphid = np.zeros((T, 7, 7))
        dacc_du = np.zeros((T, 7, 6))
        dl_dphi = np.zeros((T, 4, 7))
        dl_dphid = np.zeros((T, 4, 7))
        for b in (0, 1):
            sel = np.flatnonzero(base == b)
            if not sel.size:
                continue
            # index arrays, not lists or ranges: numpy's stub of ix_ takes one kind for all
            o = np.asarray(BASE_ORDER[b])
            dacc_dphi[np.ix_(sel, o, o)] = dacc_o_dq[sel]
            dacc_dphid[np.ix_(sel, o, o)] = dacc_o_dv[sel]
            dacc_du[np.ix_(sel, o, np.arange(6))] = dacc_o_du[sel]
            dl_dphi[np.ix_(sel, np.arange(4), o)] = dl_dq[sel]
            dl_dphid[np.ix_(sel, np.arange(4), o)] = dl_dv[sel]
        return DynamicsResult(
            acc=acc, lam=lam, grf=grf, grf_active=active, dacc_dphi=dacc_dphi,
            dacc_dphid=dacc_dphid, dacc_du=dacc_du, dgrf_dphi=G @ dl_dphi,
            dgrf_dphid=G @ dl_dphid, dgrf_du=G @ dl_du, dlam_dphi=dl_dphi,
            dlam_dphid=dl_dphid, dlam_du=dl_du)

    def _grf(self, lam: np.ndarray, base: np.ndarray, line: np.ndarray):
        """Vertical forces (ball, tip, roller) = G @ lambda per frame, and which are active."""
        T = lam.shape[0]
        G = np.zeros((T, 3, 4))
        lp = self.pad_length[base]
        G[:, 0, 1] = 1.0                           # ball: fz ...
        G[line, 0, 2] = 1.0 / lp[line]             # ... minus the tip's share (f_tip = -M/l)
        G[line, 1, 2] = -1.0 / lp[line]
        G[:, 2, 3] = 1.0
        grf = np.einsum("tij,tj->ti", G, lam)
        active = np.ones((T, 3), bool)
        active[~line, 1] = False
        return grf, active, G

    # --- inverse dynamics -------------------------------------------------------------------

    def inverse(self, phi: np.ndarray, phid: np.ndarray, phidd: np.ndarray, base: np.ndarray,
                case: np.ndarray, torque_ref: np.ndarray | None = None) -> tuple[np.ndarray,
                                                                                  np.ndarray]:
        """Joint torques and contact multipliers realizing given accelerations (RNEA).

        ``B u + J^T lambda = RNEA(q, v, a)`` per frame, solved in the least-squares sense; in
        case (i) one torque combination only shifts load between the feet (6 torques, 5 degrees
        of freedom): the solution closest to ``torque_ref`` (default 0) is taken.

        Returns:
            torque (T, 6) [Nm] and lambda (T, 4) as in :class:`DynamicsResult`.
        """
        phi, phid, phidd = (np.atleast_2d(np.asarray(x, float)) for x in (phi, phid, phidd))
        T = phi.shape[0]
        base = np.broadcast_to(np.asarray(base, int), (T,))
        case = np.broadcast_to(np.asarray(case, int), (T,))
        ref = np.zeros((T, 6)) if torque_ref is None else np.asarray(torque_ref, float)
        torque = np.zeros((T, 6))
        lam = np.zeros((T, 4))
        for t in range(T):
            b = base[t]
            r = self.rooted[b]
            o = list(BASE_ORDER[b])
            q = np.concatenate([[0.0, 0.0], self.D @ phi[t, o]])
            v = np.concatenate([[0.0, 0.0], self.D @ phid[t, o]])
            a = np.concatenate([[0.0, 0.0], self.D @ phidd[t, o]])
            tau = r.chain.rnea(q, v, a)
            Jz, _, _, _ = self._roller_terms(phi[t, o][None], phid[t, o][None],
                                             phidd[t, o][None], r.seg)
            rows = np.zeros((4, 9))
            rows[0, 0] = rows[1, 1] = rows[3, 1] = 1.0
            if case[t] == 1:
                rows[2, 2] = 1.0
            rows[3, 2:] = Jz[0] @ self.C
            if case[t] != 1:
                rows[2, 2] = 0.0
            A = np.concatenate([r.B, rows.T], axis=1)        # (9, 10)
            U_, S_, Vt = np.linalg.svd(A)
            rank = int(np.sum(S_ > 1e-9 * S_[0]))
            x = Vt[:rank].T @ ((U_[:, :rank].T @ tau) / S_[:rank])
            N = Vt[rank:].T                                   # null space (10, k)
            if N.shape[1]:
                Nu = N[:6]
                z = np.linalg.lstsq(Nu, ref[t] - x[:6], rcond=None)[0]
                x = x + N @ z
            torque[t], lam[t] = x[:6], x[6:]
        return torque, lam

    def grf_from_lambda(self, lam: np.ndarray, base: np.ndarray, case: np.ndarray):
        """Vertical forces (ball, tip, roller) and their active mask from multipliers."""
        base = np.asarray(base, int)
        grf, active, _ = self._grf(np.asarray(lam, float), base, np.asarray(case) == 1)
        return grf, active

"""Props in the whole-body solve: no robot link inside a prop (docs/terrain.md).

A prop is a convex polytope given by its outward face planes ``(K, 4)`` rows ``(n, d)``, inside
where ``n . p <= d`` (:func:`imesh.scene.prop_planes`). Its signed distance function is
``phi(p) = max_k (n_k . p - d_k)``: exact inside (minus the depth to the nearest face) and
above a face, a lower bound near edges and corners (so a row on it keeps a link at least as far
out as asked).

The robot's proxies against the props:

* the capsules of every body except the feet (:class:`imesh.robot.capsules.model.CapsuleModel`):
  the distance of a capsule (segment ``a + s (b - a)``, radius r) is
  ``min_{s in [0, 1]} phi(a + s (b - a)) - r``; ``phi`` along the segment is the upper envelope
  of K lines in s (convex, piecewise linear), so its minimum is at s = 0, s = 1 or where two
  lines cross: all ``K (K - 1) / 2 + 2`` candidates are evaluated (exact, vectorized);
* the feet's ground points (sole corners and the bottom of their proxies, the points the floor
  rows keep above z = 0; the G1's foot capsule reaches 30 mm below its sole, so it would hold a
  sole landing on a box top 35 mm above it): ``phi(p)``. A support foot's points are not
  checked in its support frames: its sole rows hold it on its footprint (on the prop's top).

At every SQP iterate the samples closer than the activation distance become rows
``d + n^T J_p dq_t + s_t >= margin`` (``J_p`` the point's Jacobian, ``n`` the face normal of
the maximizing plane), elastic with the frame's self-collision slack ``s_t`` (one per frame,
priced as an exact L1 penalty); the merit charges the frame's largest shortfall of either kind,
so the line search re-checks the exact distances after each step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .collision import CollisionLinearization


def pad_planes(planes: list[np.ndarray]) -> np.ndarray:
    """(P, K, 4) the props' face planes, each padded to the largest count K by repeating its
    first plane (which changes no maximum)."""
    K = max(len(p) for p in planes)
    return np.stack([np.concatenate([p, np.repeat(p[:1], K - len(p), axis=0)]) for p in planes])


def segment_distances(a: np.ndarray, b: np.ndarray, planes: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least ``phi`` along segments against convex props (see the module docstring).

    Args:
        a, b: (N, 3) segment ends [m].
        planes: (N, K, 4) the prop of each segment.

    Returns:
        (phi (N,) [m] the least signed distance of a point of the segment, s (N,) in [0, 1]
        where it is reached, normal (N, 3) the gradient of phi with respect to a translation
        of the segment: the outward normal of the maximizing face there, or where two faces'
        lines cross at the minimum, their normals weighted by the other's slope).
    """
    n, d = planes[..., :3], planes[..., 3]
    la = np.einsum("nka,na->nk", n, a) - d  # (N, K) each line at s = 0
    lb = np.einsum("nka,na->nk", n, b) - d  # and at s = 1
    slope = lb - la
    i, j = np.triu_indices(planes.shape[1], 1)
    den = slope[:, i] - slope[:, j]
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = np.where(np.abs(den) > 1e-12, (la[:, j] - la[:, i]) / den, 0.0)
    s = np.concatenate([np.zeros((len(a), 1)), np.ones((len(a), 1)), np.clip(cross, 0, 1)],
                       axis=1)  # (N, S) candidates
    val = la[:, None, :] + s[..., None] * slope[:, None, :]  # (N, S, K)
    phi = val.max(axis=2)
    best = np.argmin(phi, axis=1)
    rows = np.arange(len(a))
    face = np.argmax(val[rows, best], axis=1)
    normal = n[rows, face]
    # a minimum where two faces' lines cross inside the segment moves along it with the
    # segment: the distance's gradient is the weighted normal
    # (slope_i n_j - slope_j n_i) / (slope_i - slope_j), weights in [0, 1]
    c = best - 2
    at = np.flatnonzero((c >= 0) & (s[rows, best] > 0) & (s[rows, best] < 1))
    if len(at):
        fi, fj = i[c[at]], j[c[at]]
        si, sj = slope[at, fi], slope[at, fj]
        top = phi[at, best[at]]
        tied = (np.abs(val[at, best[at], fi] - top) < 1e-12) & \
            (np.abs(val[at, best[at], fj] - top) < 1e-12) & (si * sj < 0)
        at, fi, fj, si, sj = at[tied], fi[tied], fj[tied], si[tied], sj[tied]
        normal[at] = ((si[:, None] * n[at, fj] - sj[:, None] * n[at, fi])
                      / (si - sj)[:, None])
    return phi[rows, best], s[rows, best], normal


@dataclass(frozen=True, eq=False)
class PropLinearization:
    """The prop samples of one iterate (as :class:`~imesh.solve.collision.CollisionLinearization`).

    Attributes:
        frames: (R,) frame of each active sample (closer than the activation distance).
        props: (R,) prop of each sample; proxies: (R,) capsule index, or C + foot point index.
        distance: (R,) [m] signed distance of each sample.
        rows: (R, nv) its gradient with respect to the tangent update of its frame.
        min_distance: (T,) [m] smallest signed distance of any checked sample per frame.
        depth_by_prop: (P,) [m] deepest penetration of each prop over all frames (>= 0).
    """

    frames: np.ndarray
    props: np.ndarray
    proxies: np.ndarray
    distance: np.ndarray
    rows: np.ndarray
    min_distance: np.ndarray
    depth_by_prop: np.ndarray


def linearize_props(planes: np.ndarray, seg_world: np.ndarray, radius: np.ndarray,
                    seg_origin: np.ndarray, seg_jacobians: np.ndarray, capsule_skip: np.ndarray,
                    points: np.ndarray, point_origin: np.ndarray, point_jacobians: np.ndarray,
                    point_skip: np.ndarray, activation: float,
                    point_owner: np.ndarray | None = None,
                    point_radius: np.ndarray | None = None) -> PropLinearization:
    """Exact distances of every proxy to every prop at every frame, and the rows of those
    within ``activation`` [m].

    Args:
        planes: (P, K, 4) the props (:func:`pad_planes`).
        seg_world: (T, C, 2, 3) capsule segments in the world; radius: (C,) [m].
        seg_origin: (T, C, 3) origin of each capsule's frame; seg_jacobians: (T, C, 6, nv) its
            world-aligned Jacobian (linear, angular).
        capsule_skip: (T, C) bool samples not checked.
        points: (T, Q, 3) point proxies (the feet's ground points, the evaluator's proxy
            points); point_origin: (T, Q, 3) the origin of each one's frame; point_jacobians:
            (T, Q, 6, nv) that frame's Jacobian, or (T, F, 6, nv) with ``point_owner`` (Q,) the
            frame of each point; point_skip: (T, Q) bool; point_radius: (Q,) [m] subtracted from
            a point's distance (sphere proxies; None: 0).
    """
    T, C = seg_world.shape[:2]
    P, nv = len(planes), seg_jacobians.shape[-1]
    # capsules x props, all frames
    a = np.broadcast_to(seg_world[:, :, None, 0], (T, C, P, 3)).reshape(-1, 3)
    b = np.broadcast_to(seg_world[:, :, None, 1], (T, C, P, 3)).reshape(-1, 3)
    pl = np.broadcast_to(planes, (T, C) + planes.shape).reshape(-1, *planes.shape[1:])
    phi, s, normal = segment_distances(a, b, pl)
    d_cap = (phi.reshape(T, C, P) - radius[None, :, None])
    d_cap[capsule_skip] = np.inf
    # foot points x props
    vals = np.einsum("tqa,pka->tqpk", points, planes[..., :3]) - planes[..., 3]
    d_pt = vals.max(axis=-1)  # (T, Q, P)
    if point_radius is not None:
        d_pt = d_pt - point_radius[None, :, None]
    d_pt[point_skip] = np.inf
    face_pt = np.argmax(vals, axis=-1)
    dist = np.concatenate([d_cap, d_pt], axis=1)  # (T, C + Q, P)
    tt, xx, pp = np.nonzero(dist < activation)
    cap = xx < C
    rows = np.zeros((len(tt), nv))
    # capsule rows: n . (J_o + J_w x (p - o)) at the segment's nearest point p
    k = np.flatnonzero(cap)
    if len(k):
        flat = (tt[k] * C + xx[k]) * P + pp[k]
        n = normal[flat]
        p = a[flat] + s[flat, None] * (b[flat] - a[flat])
        J = seg_jacobians[tt[k], xx[k]]
        lever = np.cross(p - seg_origin[tt[k], xx[k]], n)
        rows[k] = np.einsum("ra,ran->rn", n, J[:, :3]) + np.einsum("ra,ran->rn", lever, J[:, 3:])
    k = np.flatnonzero(~cap)
    if len(k):
        qq = xx[k] - C
        n = planes[pp[k], face_pt[tt[k], qq, pp[k]], :3]
        J = point_jacobians[tt[k], qq if point_owner is None else point_owner[qq]]
        lever = np.cross(points[tt[k], qq] - point_origin[tt[k], qq], n)
        rows[k] = np.einsum("ra,ran->rn", n, J[:, :3]) + np.einsum("ra,ran->rn", lever, J[:, 3:])
    finite = np.where(np.isfinite(dist), dist, np.inf)
    depth = np.maximum(-finite.min(axis=(0, 1), initial=np.inf), 0.0) if P else np.zeros(0)
    return PropLinearization(frames=tt, props=pp, proxies=xx, distance=dist[tt, xx, pp],
                             rows=rows, min_distance=finite.min(axis=(1, 2), initial=np.inf),
                             depth_by_prop=depth)


def shared_violation(collision: CollisionLinearization | None, props: PropLinearization | None,
                     margin: float, obstacles=None, held: np.ndarray | None = None) -> float:
    """Sum over frames of the largest shortfall below ``margin`` [m] of a self-collision, a
    prop or a moving-obstacle distance (:mod:`imesh.solve.obstacles`), or of a held point's
    distance from its anchor (``held`` (T,), :func:`imesh.solve.touches.touch_violation`):
    what the frame's shared slack would have to cover."""
    lows = [x.min_distance for x in (collision, props, obstacles) if x is not None]
    short = (np.maximum(margin - np.minimum.reduce(lows), 0.0) if lows
             else np.zeros(0 if held is None else len(held)))
    if held is not None:
        short = np.maximum(short, held)
    return float(np.sum(short))

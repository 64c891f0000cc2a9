"""Plots (PNG) of adaptation results. Imports matplotlib lazily; never imported by solvers."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..contacts.phases import SIDES
from ..errors import ImeshError
from ..io.atomic import atomic_path
from ..mesh.bones import bone_lengths
from ..metrics.derivatives import motion_derivatives
from ..metrics.dynamics import ground_wrench, reference_dynamics
from ..metrics.polygon import support_polygons
from ..metrics.soles import sole_tracks
from ..metrics.support import motion_support
from ..metrics.zmp import desired_zmp, zmp_trajectory
from .pyplot import pyplot


def plot_adaptation(result, path: str | os.PathLike) -> None:
    """Bone lengths (source, target, adapted) and the closest hand distance over time.

    Args:
        result: an :class:`imesh.morph.adapt.AdaptResult`.
        path: PNG file to write (atomically).
    """
    plt = pyplot()
    src, ad, nv = result.source, result.adapted, result.naive
    t = np.arange(src.n_frames) / src.fps
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ls, la = bone_lengths(src.positions_m, src.bones), bone_lengths(ad.positions_m, ad.bones)
    order = np.argsort(ls.mean(axis=0))
    axes[0].plot(ls.mean(axis=0)[order], "o-", label="source")
    axes[0].plot(la.mean(axis=0)[order], "s--", label="adapted (mesh)")
    axes[0].set_xticks(range(len(order)))
    axes[0].set_xticklabels([src.names[src.bones[b, 1]] for b in order], rotation=90,
                            fontsize=7)
    axes[0].set_ylabel("bone length [m]")
    axes[0].legend()
    try:
        hl, hr = src.index("hand_l"), src.index("hand_r")
    except ImeshError:
        hl, hr = 0, src.n_markers - 1
    for motion, label in ((src, "source"), (ad, "mesh"), (nv, "naive scaling")):
        d = np.linalg.norm(motion.positions_m[:, hl] - motion.positions_m[:, hr], axis=1)
        axes[1].plot(t, d, label=label)
    axes[1].set_xlabel("time [s]")
    axes[1].set_ylabel(f"{src.names[hl]} - {src.names[hr]} distance [m]")
    axes[1].legend()
    fig.suptitle(f"interaction-mesh adaptation of {src.source}")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def plot_wholebody(robot, motion, path: str | os.PathLike, title: str = "") -> None:
    """The balance evidence of a written robot motion, as the evaluator sees it: the multibody
    ZMP against the support polygon's extent (x and y over time), the lowest point of each sole
    (support frames shaded), and the largest joint torque of each frame against the effort
    limits (inverse dynamics, sole wrenches least-norm).

    Args:
        robot: the robot; motion: its RobotMotion (e.g. read back from the written file).
        path: PNG file to write (atomically).
        title: figure title.
    """
    plt = pyplot()
    q, fps = motion.q, motion.fps
    t = np.arange(len(q)) / fps
    soles = sole_tracks(robot, q, fps)
    support = motion_support(soles, motion.contact_modes).support
    v, a = motion_derivatives(q, fps)
    zmp = zmp_trajectory(robot, q, fps)
    want = desired_zmp(soles, support)
    polys = support_polygons(soles, support)
    lo = np.array([p.min(axis=0) if p is not None else [np.nan, np.nan] for p in polys])
    hi = np.array([p.max(axis=0) if p is not None else [np.nan, np.nan] for p in polys])
    com, dh, _ = robot.centroidal_trajectory(q, v, fps)
    dyn = reference_dynamics(robot, q, v, a, support, ground_wrench(q, com, dh, robot.mass))
    fig, axes = plt.subplots(4, 1, figsize=(10, 11), sharex=True)
    for k, axis in enumerate("xy"):
        ax = axes[k]
        ax.fill_between(t, lo[:, k], hi[:, k], color="0.85", label="support polygon extent")
        ax.plot(t, want[:, k], "g--", lw=1, label="desired ZMP")
        ax.plot(t, zmp[:, k], "b", lw=1.2, label="multibody ZMP")
        ax.set_ylabel(f"{axis} [m]")
        ax.legend(loc="upper right", fontsize=8)
    ax = axes[2]
    for k, side in enumerate(SIDES):
        low = 1e3 * soles.lowest(side)
        ax.plot(t, low, label=f"{side} sole lowest corner")
        ax.fill_between(t, 0, np.where(support[:, k], low.max(), np.nan), alpha=0.1)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_ylabel("height [mm]")
    ax.legend(loc="upper right", fontsize=8)
    ax = axes[3]
    ax.plot(t, dyn.torque_ratios, "r", label="max |torque| / effort limit")
    ax.axhline(1.0, color="k", ls="--", lw=0.8, label="effort limit")
    ax.set_ylabel("torque ratio")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)
    if not os.path.getsize(path):
        raise ImeshError(f"plot {path} is empty")


def plot_keypoints(gen, path: str | os.PathLike) -> Path:
    """Front and side views of a generated robot (imesh.robot.generate.GeneratedConfig) in its
    nominal pose with the chosen key points (PNG)."""
    plt = pyplot()
    path = Path(path)
    fig, axes = plt.subplots(1, 2, figsize=(8, 6))
    pts = np.array(list(gen.keypoints_nominal_m.values()))
    for ax, (i, label) in zip(axes, ((1, "y (front view)"), (0, "x (side view)")), strict=True):
        for a, b in gen.segments_nominal_m:
            ax.plot([a[i], b[i]], [a[2], b[2]], color="0.6", lw=1.5)
        ax.scatter(pts[:, i], pts[:, 2], color="tab:red", s=14, zorder=3)
        for mk, p in gen.keypoints_nominal_m.items():
            if i == 1 or not mk.endswith("_r"):
                ax.annotate(mk, (p[i], p[2]), fontsize=6, xytext=(3, 2),
                            textcoords="offset points")
        ax.set_aspect("equal")
        ax.set_xlabel(f"{label} [m]")
        ax.set_ylabel("z [m]")
    fig.suptitle(f"{gen.name}: key points in the nominal pose")
    fig.tight_layout()
    tmp = path.with_name(path.stem + ".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return path

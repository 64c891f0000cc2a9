"""The paper's figures for an arm imitation (PNG, matplotlib with the Agg backend, imported
lazily; never imported by the solvers).

- Fig. 3: the three hand points over time, actor (solid, scaled onto the robot) and robot
  (dashed), x / y / z in mm.
- Fig. 4: every arm joint over time (solid) with its time-varying upper (dashed) and lower
  (dotted) bounds from the position and velocity limits (eqs 9, 13); the thin band is the box
  with the acceleration bounds (eq. 14) as well.

Both figure functions take ``(arm_result, fps, path, title="")``: an
:class:`imesh.arms.ArmResult`, its frame rate [1/s], the PNG file (written atomically) and a
title (default: one naming the arm and its error).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from .pyplot import pyplot

_POINTS = ("wrist", "hand", "thumb")
_COLORS = ("tab:red", "tab:green", "tab:blue")


def _save(fig, path: str | os.PathLike, plt) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=80)
    plt.close(fig)


def plot_hand_points(arm_result, fps: float, path: str | os.PathLike, title: str = "") -> None:
    """Fig. 3 of the paper for one arm: the hand points of actor and robot (arguments: see
    the module docstring)."""
    plt = pyplot()
    target = 1e3 * arm_result.targets.hand_m
    robot = 1e3 * arm_result.robot_points_m[:, :3]
    t = np.arange(len(target)) / fps
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    for c, (ax, axis) in enumerate(zip(axes, "xyz", strict=True)):
        for k, (name, color) in enumerate(zip(_POINTS, _COLORS, strict=True)):
            ax.plot(t, target[:, k, c], "-", color=color, lw=1.2, label=f"{name} (actor)")
            ax.plot(t, robot[:, k, c], "--", color=color, lw=1.2, label=f"{name} (robot)")
        ax.set_ylabel(f"{axis} [mm]")
        ax.grid(alpha=0.3)
    axes[0].legend(ncol=3, fontsize=7, loc="best")
    axes[-1].set_xlabel("time [s]")
    s = arm_result.summary()
    fig.suptitle(title or f"hand points, {arm_result.side} arm: RMS {s['hand_rms_mm']:.1f} mm",
                 fontsize=10)
    fig.tight_layout()
    _save(fig, path, plt)


def plot_joint_bounds(arm_result, fps: float, path: str | os.PathLike, title: str = "") -> None:
    """Fig. 4 of the paper for one arm: joints with their time-varying bounds (arguments: see
    the module docstring)."""
    plt = pyplot()
    theta = np.degrees(arm_result.theta)
    lo, hi = np.degrees(arm_result.posvel_lo), np.degrees(arm_result.posvel_hi)
    blo, bhi = np.degrees(arm_result.box_lo), np.degrees(arm_result.box_hi)
    for b in (lo, hi, blo, bhi):  # frame 0 has only the position limits: not drawn
        b[0] = np.nan
    t = np.arange(len(theta)) / fps
    n = theta.shape[1]
    cols = 2
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(9, 1.9 * rows + 0.6), sharex=True)
    axes = np.atleast_1d(axes).reshape(-1)
    for j in range(n):
        ax = axes[j]
        ax.fill_between(t, blo[:, j], bhi[:, j], color="0.8", lw=0, label="with acceleration")
        ax.plot(t, hi[:, j], "--", color="tab:red", lw=0.9, label="upper (pos., vel.)")
        ax.plot(t, lo[:, j], ":", color="tab:blue", lw=1.1, label="lower (pos., vel.)")
        ax.plot(t, theta[:, j], "-", color="k", lw=1.0, label="joint")
        ax.set_title(f"{j + 1}: {arm_result.arm.joints[j]}", fontsize=8)
        ax.set_ylabel("[deg]", fontsize=8)
        ax.tick_params(labelsize=7)
        pad = 0.15 * max(np.ptp(theta[:, j]), 5.0)
        ax.set_ylim(theta[:, j].min() - pad, theta[:, j].max() + pad)
    for ax in axes[n:]:
        ax.set_visible(False)
    axes[0].legend(fontsize=6, loc="best")
    for ax in axes[max(0, n - cols):n]:
        ax.set_xlabel("time [s]", fontsize=8)
    fig.suptitle(title or f"{arm_result.side} arm joints and their bounds (eqs 9, 13, 14)",
                 fontsize=10)
    fig.tight_layout()
    _save(fig, path, plt)


def write_plots(result, directory: str | os.PathLike, prefix: str = "") -> list[Path]:
    """Fig. 3 and Fig. 4 of every solved arm of an :class:`imesh.arms.ArmsResult`.

    Returns:
        The PNG files written: ``<prefix>fig3_hand_points_<side>.png`` and
        ``<prefix>fig4_joint_bounds_<side>.png`` in ``directory`` (created).
    """
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    files = []
    fps = result.motion.fps
    for side, arm in result.arms.items():
        name = f"{result.motion.robot} {side} arm, {Path(result.source).name or 'clip'}"
        f3 = out / f"{prefix}fig3_hand_points_{side}.png"
        plot_hand_points(arm, fps, f3, title=f"{name}: hand points, actor (solid) vs robot "
                         f"(dashed), RMS {arm.hand_rms_mm:.1f} mm")
        f4 = out / f"{prefix}fig4_joint_bounds_{side}.png"
        plot_joint_bounds(arm, fps, f4, title=f"{name}: joints and their bounds")
        files += [f3, f4]
    return files

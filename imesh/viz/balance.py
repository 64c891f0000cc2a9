"""Plots of the balance loop (matplotlib, PNG; imported only by the CLI and the docs).

- ``zmp_<robot>.png``: ZMP x and y over time, before and after balancing, against the desired
  ZMP and the extent of the support polygon (shaded) in each frame;
- ``waist_<robot>.png``: the horizontal waist correction and the CoM before/after.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from .pyplot import pyplot


def _save(plt, fig, path: Path) -> str:
    """Lay out, write atomically, close; the path written."""
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    return str(path)


def plot_balance(result, folder: str | os.PathLike, name: str = "robot") -> list[str]:
    """Write the two balance plots of a :class:`imesh.balance.BalanceResult` into ``folder``.

    Returns:
        The paths written.
    """
    plt = pyplot()
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    t = np.arange(len(result.zmp_m)) / result.fps
    lo = np.full((len(t), 2), np.nan)
    hi = np.full((len(t), 2), np.nan)
    for i, poly in enumerate(result.polygon_xy):
        if poly is not None and len(poly):
            lo[i], hi[i] = poly.min(axis=0), poly.max(axis=0)
    paths = []
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    for k, (ax, axis) in enumerate(zip(axes, "xy", strict=True)):
        ax.fill_between(t, lo[:, k], hi[:, k], color="0.85", label="support polygon extent")
        ax.plot(t, result.desired_m[:, k], "k--", lw=1, label="desired ZMP")
        ax.plot(t, result.zmp_before_m[:, k], color="tab:red", lw=0.8, alpha=0.7,
                label="ZMP before")
        ax.plot(t, result.zmp_m[:, k], color="tab:blue", lw=1.0, label="ZMP after")
        pad = 0.3
        ax.set_ylim(np.nanmin(lo[:, k]) - pad, np.nanmax(hi[:, k]) + pad)
        ax.set_ylabel(f"{axis} [m]")
    b, a = result.before, result.after
    axes[0].set_title(f"{name}: ZMP error {b.zmp_error_mm:.0f} -> {a.zmp_error_mm:.0f} mm, "
                      f"inside {100 * b.zmp_inside_fraction:.0f} -> "
                      f"{100 * a.zmp_inside_fraction:.0f} % ({len(result.iterations) - 1} "
                      "iterations)")
    axes[0].legend(loc="upper left", fontsize=8, ncol=2)
    axes[1].set_xlabel("time [s]")
    paths.append(_save(plt, fig, out / f"zmp_{name}.png"))

    fig, axes = plt.subplots(2, 1, figsize=(9, 5), sharex=True)
    for k, (ax, axis) in enumerate(zip(axes, "xy", strict=True)):
        ax.plot(t, 1e3 * result.waist_shift_m[:, k], color="tab:green", label="waist correction")
        ax.plot(t, 1e3 * (result.com_m[:, k] - result.com_before_m[:, k]), color="tab:purple",
                label="CoM change")
        ax.set_ylabel(f"{axis} [mm]")
    axes[0].legend(loc="upper left", fontsize=8)
    axes[0].set_title(f"{name}: waist correction and the CoM change")
    axes[1].set_xlabel("time [s]")
    paths.append(_save(plt, fig, out / f"waist_{name}.png"))
    return paths

"""Figure of one DART run (matplotlib, imported lazily; never imported by the solvers)."""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

from ..io.atomic import atomic_path
from .pyplot import pyplot


def plot_physics(result, path: str | os.PathLike) -> None:
    """Write a 4-panel figure of a :class:`~imesh.physics.PhysicsResult`: joint error, base
    height, torque ratio, ZMP (contact vs planned), to ``path`` (format from the suffix).

    Args:
        result: the PhysicsResult.
        path: output image, e.g. ``run.png``.
    """
    plt = pyplot()
    with warnings.catch_warnings():  # rows after a fall are all NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        _plot(result, path, plt)


def _plot(result, path, plt) -> None:
    t = result.times_s
    fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    title = (f"{result.robot}: {'FELL - ' + result.fall_reason if result.fell else 'did not fall'}"
             f" | tracking RMS {result.tracking_rms_rad:.3f} rad | torque ratio "
             f"{result.torque_ratio_max:.2f} | RTF {result.real_time_factor:.2f}")
    fig.suptitle(title, fontsize=9)
    err = np.abs(result.joint_error_rad)
    ax[0].plot(t, np.sqrt(np.nanmean(result.joint_error_rad ** 2, axis=1)), label="RMS")
    ax[0].plot(t, np.nanmax(err, axis=1) if err.size else t * np.nan, label="max", alpha=0.7)
    ax[0].set_ylabel("joint error [rad]")
    ax[0].legend(fontsize=8)
    ax[1].plot(t, result.q_reference[:, 2], "--", label="reference")
    ax[1].plot(t, result.q[:, 2], label="simulated")
    ax[1].set_ylabel("base height [m]")
    ax[1].legend(fontsize=8)
    ax[2].plot(t, result.torque_ratio)
    ax[2].axhline(1.0, color="r", lw=0.8)
    ax[2].set_ylabel("max |torque| / limit")
    for k, axis in enumerate("xy"):
        ax[3].plot(t, result.zmp_planned_m[:, k], "--", label=f"planned {axis}")
        ax[3].plot(t, result.zmp_contact_m[:, k], label=f"contact {axis}")
    both = np.concatenate([result.zmp_planned_m.ravel(), result.zmp_contact_m.ravel()])
    both = both[np.isfinite(both)]
    if both.size:  # ZMP outliers (tiny vertical acceleration + g) must not squash the plot
        lo, hi = np.percentile(both, [2, 98])
        pad = max(0.1, 0.2 * (hi - lo))
        ax[3].set_ylim(lo - pad, hi + pad)
    ax[3].set_ylabel("ZMP [m]")
    ax[3].set_xlabel("time [s]")
    ax[3].legend(fontsize=8, ncol=2)
    if result.fell:
        for a in ax:
            a.axvline(result.survived_s, color="k", lw=0.8, ls=":")
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=110)
    plt.close(fig)

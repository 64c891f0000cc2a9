"""Plots (PNG) of adaptation results. Imports matplotlib lazily; never imported by solvers."""

from __future__ import annotations

import os

import numpy as np

from .errors import ImeshError
from .export import atomic_path


def _pyplot():
    try:
        import matplotlib
    except ImportError as exc:
        raise ImportError("plots need matplotlib: pip install matplotlib") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_adaptation(result, path: str | os.PathLike) -> None:
    """Bone lengths (source, target, adapted) and the closest hand distance over time.

    Args:
        result: an :class:`imesh.adapt.AdaptResult`.
        path: PNG file to write (atomically).
    """
    from .mesh.bones import bone_lengths

    plt = _pyplot()
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

"""Figures of a motion-reduction result, after the paper's Figs 4-9 (matplotlib, Agg)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..reduction.chain import JOINTS
from .pyplot import pyplot

LEFT, RIGHT = "tab:blue", "tab:red"


def _time(result) -> np.ndarray:
    return np.arange(result.n) * result.dt


def plot_joints(result, path) -> None:
    """Fig. 6: hip, knee, ankle angles and torques of both legs; robot bold, human dashed,
    limits dotted."""
    plt = pyplot()
    t = _time(result)
    ch = result.chain
    q = result.joint_angles()
    qh = ch.joint_angles(result.cyclic.angles)
    u = result.optimization.torque
    fig, axes = plt.subplots(2, 3, figsize=(12, 6), sharex=True)
    for j in range(3):
        ax = axes[0, j]
        for side, col in ((0, LEFT), (1, RIGHT)):
            k = 3 * side + j
            ax.plot(t, np.degrees(q[:, k]), color=col, lw=2.0,
                    label=f"robot {'left' if side == 0 else 'right'}")
            ax.plot(t, np.degrees(qh[:, k]), color=col, lw=1.0, ls="--",
                    label=f"human {'left' if side == 0 else 'right'}")
        for lim in (ch.q_lower[j], ch.q_upper[j]):
            ax.axhline(np.degrees(lim), color="k", ls=":", lw=1)
        ax.set_title(f"{JOINTS[j].split('_')[0]} angle [deg]")
        ax = axes[1, j]
        for side, col in ((0, LEFT), (1, RIGHT)):
            ax.plot(t, u[:, 3 * side + j], color=col, lw=2.0)
        for lim in (-ch.effort[j], ch.effort[j]):
            ax.axhline(lim, color="k", ls=":", lw=1)
        ax.set_title(f"{JOINTS[j].split('_')[0]} torque [Nm]")
        ax.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=7, loc="best")
    fig.suptitle(f"{result.robot}: joint angles and torques (robot bold, human dashed, "
                 f"limits dotted)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_closure(result, path) -> None:
    """Fig. 8: the closed-loop index y_m (initial and final)."""
    plt = pyplot()
    t = _time(result)
    o = result.optimization
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.6))
    axes[0].plot(t, 1e3 * o.initial.y, color="gray", label="initial (human motion)")
    axes[0].plot(t, 1e3 * o.final.y, color="k", lw=2, label="optimized")
    axes[0].set_ylabel("y_m [mm]")
    axes[0].legend(fontsize=8)
    axes[1].plot(t, 1e3 * o.final.y, color="k", lw=2)
    axes[1].axhline(1.0, color="r", ls=":", lw=1)
    axes[1].axhline(-1.0, color="r", ls=":", lw=1)
    axes[1].set_ylabel("y_m [mm] (optimized; +-1 mm dotted)")
    for ax in axes:
        ax.set_xlabel("time [s]")
        _shade_base(ax, result)
    fig.suptitle("closed-loop condition: height of the moving foot's roller contact")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _shade_base(ax, result) -> None:
    t = _time(result)
    s = result.schedule
    ax.fill_between(t, 0, 1, where=s.base == 1, transform=ax.get_xaxis_transform(),
                    color=RIGHT, alpha=0.06, lw=0)
    ax.fill_between(t, 0, 1, where=s.case == 2, transform=ax.get_xaxis_transform(),
                    color="k", alpha=0.05, lw=0)


def grf_per_foot(result) -> dict:
    """Vertical ground forces per physical foot: name -> (n,) [N], NaN where not a contact.
    ``f_y0`` / ``f_y02`` (left foot: ball or roller / toe tip), ``f_y6`` / ``f_y62`` (right)."""
    d = result.optimization.final.dyn
    s = result.schedule
    n = result.n
    out = {k: np.full(n, np.nan) for k in ("f_y0", "f_y02", "f_y6", "f_y62")}
    for k in range(n):
        b = s.base[k]
        first, second = ("f_y0", "f_y02") if b == 0 else ("f_y6", "f_y62")
        mov = "f_y6" if b == 0 else "f_y0"
        out[first][k] = d.grf[k, 0]
        if d.grf_active[k, 1]:
            out[second][k] = d.grf[k, 1]
        out[mov][k] = d.grf[k, 2]
    return out


def plot_grf(result, path) -> None:
    """Fig. 9: vertical ground forces of both feet (solid: ball or roller, dashed: toe tip)."""
    plt = pyplot()
    t = _time(result)
    f = grf_per_foot(result)
    fig, ax = plt.subplots(figsize=(9, 3.8))
    ax.plot(t, f["f_y0"], color=LEFT, lw=2, label="left: ball (base) / roller (moving)")
    ax.plot(t, f["f_y02"], color=LEFT, lw=1.5, ls="--", label="left: toe tip")
    ax.plot(t, f["f_y6"], color=RIGHT, lw=2, label="right: ball (base) / roller (moving)")
    ax.plot(t, f["f_y62"], color=RIGHT, lw=1.5, ls="--", label="right: toe tip")
    ax.axhline(0, color="k", lw=0.8)
    _shade_base(ax, result)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("vertical ground force [N]")
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(f"ground forces (min {np.nanmin(np.stack(list(f.values()))):.1f} N; "
                 "shaded: right foot base, grey: toe point contact)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_convergence(history_by_label: dict, path, title: str = "") -> None:
    """J_m and J_r per iteration (and time) for one or several runs."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    for label, hist in history_by_label.items():
        it = [h.iteration if hasattr(h, "iteration") else h["iteration"] for h in hist]
        jm = [h.J_m if hasattr(h, "J_m") else h["J_m"] for h in hist]
        jr = [h.J_r if hasattr(h, "J_r") else h["J_r"] for h in hist]
        axes[0].semilogy(it, jm, label=label)
        axes[1].semilogy(it, jr, label=label)
    axes[0].set_ylabel("J_m [(rad/s^2)^2]")
    axes[1].set_ylabel("J_r")
    for ax in axes:
        ax.set_xlabel("iteration (stage I + II)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title or "evaluation terms per iteration")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_sequence(result, path, which: str = "final", every: int | None = None) -> None:
    """Figs 4/7: stick figures over one cycle (left leg blue, right red, torso black)."""
    plt = pyplot()
    o = result.optimization
    phi = {"final": o.phi, "initial": o.initial.phi}[which]
    ch = result.chain
    pts = ch.points_world(phi, result.schedule.base, result.ball_x)
    n = result.n
    every = every or max(1, n // 16)
    xs = np.concatenate([v[:, 0] for v in pts.values()])
    zs = np.concatenate([v[:, 1] for v in pts.values()])
    aspect = (np.nanmax(xs) - np.nanmin(xs) + 0.1) / (np.nanmax(zs) - np.nanmin(zs) + 0.1)
    fig, ax = plt.subplots(figsize=(min(14.0, 1.0 + 3.6 * aspect), 3.8))
    for k in range(0, n, every):
        a = 0.25 + 0.75 * k / n
        for side, col in (("l", LEFT), ("r", RIGHT)):
            chain_pts = np.array([pts["hip_l"][k], pts[f"knee_{side}"][k],
                                  pts[f"ankle_{side}"][k], pts[f"roller_{side}"][k],
                                  pts[f"ball_{side}"][k], pts[f"tip_{side}"][k],
                                  pts[f"ankle_{side}"][k]])
            ax.plot(chain_pts[:, 0], chain_pts[:, 1], color=col, alpha=a, lw=1.2)
        if "head" in pts:
            ax.plot([pts["hip_l"][k, 0], pts["head"][k, 0]],
                    [pts["hip_l"][k, 1], pts["head"][k, 1]], color="k", lw=2.5, alpha=a)
        ax.plot(*pts["com"][k], "o", color="k", ms=2, alpha=a)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title(f"{result.robot}: {which} motion over one cycle")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_dart(report, result, path) -> None:
    """DART run: joint angles against the references, and the torso pitch."""
    plt = pyplot()
    s = report.samples
    if not len(s.get("t", [])):
        return
    fig, axes = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
    for j in range(6):
        col = LEFT if j < 3 else RIGHT
        axes[0].plot(s["t"], np.degrees(s["q"][:, j]), color=col, lw=1.2,
                     alpha=0.5 + 0.15 * (j % 3))
        axes[0].plot(s["t"], np.degrees(s["q_ref"][:, j]), color="k", lw=0.6, ls=":")
    axes[0].set_ylabel("joint angles [deg] (DART; reference dotted)")
    period = result.cyclic.period_s
    ref = np.interp(s["t"] % period, np.arange(result.n + 1) * result.dt,
                    np.concatenate([result.optimization.phi[:, 3],
                                    result.optimization.phi[:1, 3]]))
    axes[1].plot(s["t"], np.degrees(s["torso"][:, 2]), color="k", label="torso pitch (DART)")
    axes[1].plot(s["t"], np.degrees(ref), color="k", ls=":", label="designed")
    axes[1].set_ylabel("torso pitch [deg]")
    axes[1].set_xlabel("time [s]")
    axes[1].legend(fontsize=8)
    fig.suptitle(f"DART, feed-forward torques + PD: {'FELL' if report.fell else 'walked'} "
                 f"{report.survived_s:.2f} s, tracking RMS {report.tracking_rms_rad:.3f} rad")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_all(result, folder) -> list[str]:
    """Write every figure of a result into ``folder``; returns the paths."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, fn in (("joints_torques.png", plot_joints), ("closure_ym.png", plot_closure),
                     ("ground_forces.png", plot_grf)):
        fn(result, folder / name)
        paths.append(str(folder / name))
    plot_sequence(result, folder / "sequence_final.png", "final")
    plot_sequence(result, folder / "sequence_initial.png", "initial")
    plot_convergence({f"r = {result.optimization.config.subspace.rank or 'full'}":
                      result.optimization.history}, folder / "convergence.png")
    paths += [str(folder / n) for n in ("sequence_final.png", "sequence_initial.png",
                                         "convergence.png")]
    return [os.fspath(p) for p in paths]

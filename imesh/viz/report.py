"""The HTML report of a robot motion (``imesh retarget/evaluate --report``, ``imesh demo``).

One self-contained file: the evaluator's metrics table with pass/fail against the gates of
:mod:`imesh.evaluate.verify`, figures computed from the motion file as written (ZMP inside the
support polygon, sole heights and skid, joints against their position and velocity limits as in Kim
2005 Fig. 4, torques against effort limits, marker errors per body part), and the 3D viewer
embedded. Each metrics row carries its exact value (``data-metric``/``data-value``), the number
``imesh evaluate --json`` writes for the same file. When the metrics carry a DART check
(``imesh evaluate --physics``, ``imesh demo``) the page states its verdict in one line (fell or
stood, key-point tracking error, base drift, torque ratio) and, given the
:class:`~imesh.physics.PhysicsResult`, adds its figure; the embedded viewer then shows the
simulated robot beside the reference. The report of a pair (:func:`write_pair_report`, ``imesh
retarget --partner --report``) holds the pair's figures, both robots' tables and figures, and
the viewer with both robots; a motion's props (``OUT.scene.npz``) are drawn in the viewer.
"""

from __future__ import annotations

import base64
import html
import io
import json
import logging
import os
import re
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..contacts.phases import SIDES
from ..evaluate.motion_files import load_motion_file
from ..evaluate.scoreboard import evaluate_motion
from ..evaluate.table import _fmt as fmt
from ..evaluate.table import _note, physics_line
from ..evaluate.verify import Gates, failed_gates
from ..io.atomic import atomic_path
from ..metrics.derivatives import motion_derivatives
from ..metrics.dynamics import ground_wrench, reference_dynamics
from ..metrics.markers import keypoint_motion
from ..metrics.polygon import support_polygons
from ..metrics.soles import sole_tracks
from ..metrics.support import motion_support
from ..metrics.zmp import zmp_report, zmp_trajectory
from .html import viewer_html
from .physics import plot_physics
from .pyplot import pyplot
from .scene import SceneRobot, build_robots_scene, build_scene

log = logging.getLogger(__name__)

#: Body parts of the standard markers, for the marker-error figure.
BODY_PARTS: dict[str, tuple[str, ...]] = {
    "legs": ("hip_l", "hip_r", "knee_l", "knee_r", "ankle_l", "ankle_r", "toe_l", "toe_r"),
    "torso": ("pelvis", "spine", "chest", "neck"),
    "head": ("head",),
    "arms": ("shoulder_l", "shoulder_r", "elbow_l", "elbow_r", "wrist_l", "wrist_r", "hand_l",
             "hand_r"),
}




def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    pyplot().close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


# ----------------------------------------------------------------------------------------------
# figures (each returns a base64 PNG)


def figure_zmp(t: np.ndarray, zmp, polygons, support: np.ndarray) -> str:
    """Top view of the ZMP path and the support polygons, and ZMP x/y against the polygon's
    extent over time.

    Args:
        t: (T,) float [s] frame times.
        zmp: a :class:`imesh.metrics.zmp.ZmpReport`.
        polygons: per frame the (K, 2) support polygon or None.
        support: (T, 2) bool feet in support.
    """
    plt = pyplot()
    fig = plt.figure(figsize=(12, 4.2))
    ax = fig.add_subplot(1, 2, 1)
    step = max(1, len(t) // 40)
    for k in range(0, len(t), step):
        p = polygons[k]
        if p is not None:
            q = np.vstack([p, p[:1]])
            ax.plot(q[:, 0], q[:, 1], color="tab:green", lw=0.6, alpha=0.5)
    ax.plot(zmp.desired_m[:, 0], zmp.desired_m[:, 1], color="tab:blue", lw=1.2,
            label="desired ZMP")
    ax.plot(zmp.zmp_m[:, 0], zmp.zmp_m[:, 1], color="tab:red", lw=1.2, label="ZMP (multibody)")
    out = zmp.support_frames & ~zmp.inside
    if out.any():
        ax.scatter(zmp.zmp_m[out, 0], zmp.zmp_m[out, 1], s=12, color="k", zorder=5,
                   label=f"outside ({int(out.sum())} frames)")
    ax.plot([], [], color="tab:green", lw=0.6, label="support polygons")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title("ZMP path over the support polygons (top view)")
    ax.legend(fontsize=8, loc="best")
    for i, axis in enumerate("xy"):
        ax = fig.add_subplot(2, 2, 2 + 2 * i)
        lo = np.array([p[:, i].min() if p is not None else np.nan for p in polygons])
        hi = np.array([p[:, i].max() if p is not None else np.nan for p in polygons])
        ax.fill_between(t, lo, hi, color="tab:green", alpha=0.25, lw=0, label="support polygon")
        ax.plot(t, zmp.desired_m[:, i], color="tab:blue", lw=1, label="desired")
        ax.plot(t, zmp.zmp_m[:, i], color="tab:red", lw=1, label="ZMP")
        ax.set_ylabel(f"{axis} [m]")
        if i == 0:
            ax.set_title("ZMP and the support polygon's extent over time")
            ax.legend(fontsize=7, ncol=3, loc="best")
        else:
            ax.set_xlabel("time [s]")
    return _png(fig)


def figure_soles(t: np.ndarray, soles, support: np.ndarray) -> str:
    """Lowest sole corner height and the sole's horizontal motion per frame, per foot, with the
    support phases shaded."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(12, 4.6), sharex=True)
    for k, side in enumerate(SIDES):
        low = soles.lowest(side) * 1e3
        step = np.zeros(len(t))
        step[1:] = np.linalg.norm(np.diff(soles.centers[side][:, :2], axis=0), axis=1) * 1e3
        skid = np.where(np.r_[False, support[1:, k] & support[:-1, k]], step, np.nan)
        for ax in axes[:, k]:
            ax.fill_between(t, 0, 1, where=support[:, k], color="0.85", lw=0,
                            transform=ax.get_xaxis_transform(), label="support")
        axes[0, k].plot(t, low, color="tab:purple", lw=1)
        axes[0, k].axhline(0, color="k", lw=0.6)
        axes[0, k].set_title(f"{side} foot")
        axes[0, k].set_ylabel("lowest sole corner [mm]")
        axes[1, k].plot(t, step, color="0.5", lw=0.8, label="sole centre motion")
        axes[1, k].plot(t, skid, color="tab:red", lw=1.2, label="skid (in support)")
        axes[1, k].set_ylabel("horizontal motion [mm/frame]")
        axes[1, k].set_xlabel("time [s]")
        axes[1, k].legend(fontsize=7, loc="upper right")
    return _png(fig)


def figure_joints(t: np.ndarray, robot, q: np.ndarray, fps: float, n_worst: int = 8) -> str:
    """Joints against their limits (Kim 2005 Fig. 4): the ``n_worst`` joints closest to a
    position limit with their limits, and every joint's |velocity| / limit over time."""
    plt = pyplot()
    qj = q[:, 7:]
    lo, hi = robot.q_lower, robot.q_upper
    closeness = np.maximum((qj - lo) / (hi - lo), (hi - qj) / (hi - lo)).max(axis=0)
    vel = np.zeros_like(qj)
    vel[1:] = np.abs(np.diff(qj, axis=0)) * fps / robot.v_max
    order = np.argsort(-np.maximum(closeness - 0.5, vel.max(axis=0) - 0.5))[:n_worst]
    cols = 4
    rows = int(np.ceil(len(order) / cols))
    fig = plt.figure(figsize=(12, 2.3 * rows + 3.2))
    gs = fig.add_gridspec(rows + 1, cols, height_ratios=[1.0] * rows + [1.4])
    for i, j in enumerate(order):
        ax = fig.add_subplot(gs[i // cols, i % cols])
        ax.plot(t, np.degrees(qj[:, j]), color="tab:blue", lw=1)
        for lim in (lo[j], hi[j]):
            ax.axhline(np.degrees(lim), color="tab:red", lw=1, ls="--")
        span = np.degrees(hi[j] - lo[j])
        ax.set_ylim(np.degrees(lo[j]) - 0.08 * span, np.degrees(hi[j]) + 0.08 * span)
        ax.set_title(f"{robot.joint_names[j]} (max |v| {vel[:, j].max():.2f} of limit)",
                     fontsize=8)
        ax.tick_params(labelsize=7)
        if i % cols == 0:
            ax.set_ylabel("angle [deg]", fontsize=8)
    ax = fig.add_subplot(gs[rows, :])
    im = ax.imshow(vel.T, aspect="auto", origin="lower", cmap="magma", vmin=0, vmax=1,
                   extent=(t[0], t[-1], -0.5, qj.shape[1] - 0.5), interpolation="nearest")
    ax.set_yticks(range(qj.shape[1]))
    ax.set_yticklabels(robot.joint_names, fontsize=5)
    ax.set_xlabel("time [s]")
    ax.set_title("|joint velocity| / velocity limit (1 = at the limit)", fontsize=9)
    fig.colorbar(im, ax=ax, fraction=0.02)
    fig.tight_layout()
    return _png(fig)


def figure_torques(t: np.ndarray, dyn) -> str:
    """The largest joint torque / effort limit and the friction demand of every frame
    (:func:`imesh.metrics.dynamics.reference_dynamics`)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.2))
    axes[0].plot(t, dyn.torque_ratios, color="tab:orange", lw=1.2)
    axes[0].axhline(1.0, color="tab:red", ls="--", lw=1, label="effort limit")
    axes[0].set_title(f"largest |torque| / effort limit per frame (max {dyn.torque_ratio:.2f}, "
                      f"{dyn.torque_joint})", fontsize=9)
    axes[0].set_xlabel("time [s]")
    axes[0].legend(fontsize=8)
    fr = np.where(np.isfinite(dyn.friction_ratios), dyn.friction_ratios, np.nan)
    axes[1].plot(t, fr, color="tab:brown", lw=1.2)
    axes[1].axhline(1.0, color="tab:red", ls="--", lw=1, label="friction cone (mu 0.7)")
    axes[1].set_title("tangential / (mu x normal) sole force per frame", fontsize=9)
    axes[1].set_xlabel("time [s]")
    axes[1].legend(fontsize=8)
    return _png(fig)


def figure_markers(t: np.ndarray, keypoints, markers) -> str:
    """RMS distance of the robot's key points from the adapted markers, per marker (grouped by
    body part) and per body part over time."""
    plt = pyplot()
    names = [n for n in keypoints.names if n in markers.names]
    kp = keypoints.subset(names).positions_m
    mk = markers.subset(names).positions_m
    n = min(len(kp), len(mk))
    err = np.linalg.norm(kp[:n] - mk[:n], axis=2) * 1e3  # (T, M) mm
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.6), gridspec_kw={"width_ratios": [1.3, 1]})
    colors = dict(zip(BODY_PARTS, ("tab:green", "tab:blue", "tab:purple", "tab:orange"),
                      strict=True))
    x = 0
    for part, members in BODY_PARTS.items():
        idx = [names.index(m) for m in members if m in names]
        if not idx:
            continue
        rms = np.sqrt(np.mean(err[:, idx] ** 2, axis=0))
        axes[0].bar(np.arange(x, x + len(idx)), rms, color=colors[part], label=part)
        axes[0].set_xticks(list(axes[0].get_xticks()))
        x += len(idx)
        axes[1].plot(t[:n], np.sqrt(np.mean(err[:, idx] ** 2, axis=1)), color=colors[part],
                     lw=1.1, label=part)
    order = [m for ms in BODY_PARTS.values() for m in ms if m in names]
    axes[0].set_xticks(range(len(order)))
    axes[0].set_xticklabels(order, rotation=60, fontsize=7)
    axes[0].set_ylabel("RMS error [mm]")
    axes[0].set_title("key point vs adapted marker, per marker", fontsize=9)
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel("time [s]")
    axes[1].set_ylabel("RMS error [mm]")
    axes[1].set_title("per body part over time", fontsize=9)
    axes[1].legend(fontsize=8)
    return _png(fig)


def figure_physics(result) -> str:
    """The DART run's figure (:func:`imesh.viz.physics.plot_physics`) as base64 PNG."""
    with tempfile.TemporaryDirectory(prefix="imesh-report-") as tmp:
        path = Path(tmp) / "physics.png"
        plot_physics(result, path)
        return base64.b64encode(path.read_bytes()).decode("ascii")


# ----------------------------------------------------------------------------------------------
# the page


def _fmt(value) -> str:
    return fmt(value)


def metrics_rows(metrics: Mapping[str, dict], balanced: bool = True) -> list[dict]:
    """Rows of the report's table: name, value, unit, gate, status (pass/fail/-), note."""
    gates = Gates()
    gate_text = {"limit_violation_frames": f"<= {gates.limit_violation_frames}",
                 "ground_penetration_mm": f"<= {gates.ground_penetration_mm}",
                 "marker_rms_mm": f"<= {gates.marker_rms_mm}"}
    if balanced:
        gate_text["zmp_inside_fraction"] = f">= {gates.zmp_inside_fraction}"
    failed = failed_gates(dict(metrics), gates, balanced=balanced)
    rows = []
    for name, entry in metrics.items():
        value = entry.get("value")
        gate = gate_text.get(name, "")
        status = "" if not gate or value is None else ("fail" if name in failed else "pass")
        rows.append({"name": name, "value": value, "text": _fmt(value),
                     "unit": entry.get("unit", ""), "gate": gate, "status": status,
                     "note": _note(name, entry)})
    return rows


def _table(rows: list[dict], table: str = "") -> str:
    """The metrics table; ``table`` (a pair's "a", "b", "pair") tags its rows
    (``data-table``, :func:`table_values`)."""
    tag = f' data-table="{html.escape(table)}"' if table else ""
    out = ['<table class="metrics"><thead><tr><th>metric</th><th>value</th><th>unit</th>'
           '<th>gate</th><th>result</th><th>note</th></tr></thead><tbody>']
    for r in rows:
        out.append(
            f'<tr data-metric="{html.escape(r["name"])}" '
            f'data-value="{html.escape(json.dumps(r["value"]))}"{tag} class="{r["status"]}">'
            f'<td>{html.escape(r["name"])}</td><td class="num">{html.escape(r["text"])}</td>'
            f'<td>{html.escape(r["unit"])}</td><td>{html.escape(r["gate"])}</td>'
            f'<td>{r["status"]}</td><td>{html.escape(str(r["note"]))}</td></tr>')
    out.append("</tbody></table>")
    return "\n".join(out)


STYLE = """
body { font: 14px/1.45 system-ui, sans-serif; max-width: 1240px; margin: 0 auto; padding: 16px;
       color: #222; }
h1 { font-size: 22px; } h2 { font-size: 17px; margin-top: 28px; border-bottom: 1px solid #ddd; }
h3 { font-size: 15px; margin-top: 20px; }
table.metrics { border-collapse: collapse; font-size: 13px; }
table.metrics td, table.metrics th { border-bottom: 1px solid #e4e4e4; padding: 3px 10px;
       text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.pass td:nth-child(5) { color: #127a2e; font-weight: 600; }
tr.fail td:nth-child(5), tr.fail td:first-child { color: #c00; font-weight: 600; }
.verdict { font-size: 16px; font-weight: 600; padding: 6px 10px; display: inline-block;
           border-radius: 4px; }
.verdict.ok { background: #dff3e4; color: #12632a; } .verdict.bad { background: #fbe1e1;
           color: #a00; }
img { max-width: 100%; } iframe { width: 100%; height: 640px; border: 1px solid #ccc; }
.meta td { padding: 1px 12px 1px 0; }
"""

#: Captions of the report's figures.
CAPTIONS = {
    "zmp": "ZMP inside the support polygon",
    "soles": "Sole heights and skid per foot",
    "joints": "Joints against their position and velocity limits",
    "torques": "Torques against effort limits, and friction",
    "markers": "Marker errors per body part",
    "physics": "DART check: joint error, base height, torque ratio, ZMP (contact vs planned)",
}


def robot_section(*, robot, motion_path: str | os.PathLike, metrics: Mapping[str, dict],
                  figures: Mapping[str, str], balanced: bool = True, table: str = "",
                  level: int = 2, command: str = "") -> str:
    """One robot's part of a report: the verdict against the gates, the DART verdict, the
    metrics table and the figures.

    Args:
        robot, motion_path, metrics, figures, balanced: see :func:`report_html`.
        table: the tag of the table's rows (a pair's "a" or "b"; "" for one robot).
        level: the heading level of the section's parts (2; 3 inside a pair's robot).
        command: the command that writes these numbers (default: ``imesh evaluate FILE --robot
            NAME [--physics] --json``).
    """
    rows = metrics_rows(metrics, balanced)
    failed = [r["name"] for r in rows if r["status"] == "fail"]
    # physics_fell is not a gate of the table (the retarget gates on it with --physics), but a
    # green "passes" beside a fall would mislead
    fell = (metrics.get("physics_fell") or {}).get("value") is True
    if failed:
        verdict = f'<span class="verdict bad">fails: {html.escape(", ".join(failed))}</span>'
    elif fell:
        verdict = ('<span class="verdict bad">passes every gate of the retarget; fell in the '
                   'DART check</span>')
    else:
        verdict = '<span class="verdict ok">passes every gate</span>'
    h = f"h{level}"
    figs = "\n".join(f'<{h}>{html.escape(CAPTIONS.get(k, k))}</{h}>'
                     f'<img alt="{html.escape(k)}" src="data:image/png;base64,{v}">'
                     for k, v in figures.items())
    command = command or (f"imesh evaluate {Path(motion_path).name} --robot {robot.name}"
                          f"{' --physics' if _has_physics(metrics) else ''} --json")
    return (f'<{h}>Metrics</{h}><p>{verdict}</p>{_physics_verdict(metrics)}<p>The numbers '
            f'<code>{html.escape(command)}</code> writes for this file; gates of '
            f'<code>imesh.evaluate.verify.Gates</code>.</p>{_table(rows, table)}{figs}')


def _page(title: str, facts: Mapping[str, str], body: str, viewer_page: str | None) -> str:
    """The report page: title, facts, ``body`` and the embedded viewer."""
    meta = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(str(v))}</td></tr>"
                   for k, v in facts.items())
    view = ""
    if viewer_page is not None:
        view = ('<h2>3D view</h2><p>Drag to orbit, right-drag to pan, wheel to zoom; space '
                'plays.</p><iframe title="3D view" srcdoc="'
                + html.escape(viewer_page, quote=True) + '"></iframe>')
    return (f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>'
            f'{html.escape(title)}</title><link rel="icon" href="data:,"><style>{STYLE}</style>'
            f'</head><body><h1>{html.escape(title)}</h1><table class="meta">{meta}</table>'
            f'{body}{view}</body></html>')


def report_html(*, robot, motion_path: str | os.PathLike, metrics: Mapping[str, dict],
                figures: Mapping[str, str], viewer_page: str | None, facts: Mapping[str, str],
                balanced: bool = True) -> str:
    """The report page of one robot motion from its parts (see :func:`write_report`)."""
    title = f"imesh report: {Path(motion_path).name} ({robot.name})"
    return _page(title, facts, robot_section(robot=robot, motion_path=motion_path,
                                             metrics=metrics, figures=figures,
                                             balanced=balanced), viewer_page)


def _has_physics(metrics: Mapping[str, dict]) -> bool:
    return metrics.get("physics_fell", {}).get("value") is not None


def _physics_verdict(metrics: Mapping[str, dict]) -> str:
    """The DART check's verdict line (:func:`imesh.evaluate.table.physics_line`), or ""."""
    line = physics_line(metrics)
    if not line:
        return ""
    fell = metrics["physics_fell"]["value"]
    return (f'<p id="physics-verdict" class="verdict {"bad" if fell else "ok"}">'
            f'{html.escape(line)}</p>')


def motion_figures(robot, motion, physics=None) -> dict[str, str]:
    """The report's figures of one robot motion (base64 PNGs, keys of :data:`CAPTIONS`): ZMP,
    soles, joints, torques (with support), markers (with adapted markers), and the DART run's
    with ``physics``."""
    q, fps = motion.q, motion.fps
    t = np.arange(motion.n_frames) / fps
    soles = sole_tracks(robot, q, fps)
    support = motion_support(soles, motion.contact_modes).support
    v, a = motion_derivatives(q, fps)
    zmp = zmp_report(zmp_trajectory(robot, q, fps), soles, support)
    figures = {"zmp": figure_zmp(t, zmp, support_polygons(soles, support), support),
               "soles": figure_soles(t, soles, support),
               "joints": figure_joints(t, robot, q, fps)}
    if support.any():
        com, dh, _ = robot.centroidal_trajectory(q, v, fps)
        figures["torques"] = figure_torques(t, reference_dynamics(
            robot, q, v, a, support, ground_wrench(q, com, dh, robot.mass)))
    adapted = motion.adapted
    if adapted is not None:
        figures["markers"] = figure_markers(t, keypoint_motion(robot, q, fps), adapted)
    if physics is not None:
        figures["physics"] = figure_physics(physics)
    return figures


def write_report(path: str | os.PathLike, robot, motion_path: str | os.PathLike, *,
                 metrics: Mapping[str, dict] | None = None, source=None,
                 facts: Mapping[str, str] | None = None, viewer: bool = True,
                 scene: dict | None = None, balanced: bool = True,
                 fps: float | None = None, physics=None, collisions=None,
                 props=None) -> Path:
    """Write the HTML report of a written robot motion file.

    Everything is computed from the file as written (:func:`imesh.evaluate.load_motion_file`).

    Args:
        path: the ``.html`` file to write (atomically).
        robot: the :class:`imesh.robot.Robot` of the motion.
        motion_path: the robot motion file (``.npz`` with its adapted markers, or ``.csv``).
        metrics: the evaluator's report of that file (:func:`imesh.evaluate.evaluate_motion`);
            None: computed here.
        source: the human clip, drawn in the embedded viewer.
        facts: extra lines for the header (name -> text).
        viewer: embed the 3D viewer.
        scene: the viewer's scene of this file (:func:`imesh.viz.scene.build_scene`), if
            already built.
        balanced: judge the ZMP gate (False for ``--balance none`` motions).
        fps: frame rate of motion files that store none.
        physics: the :class:`~imesh.physics.PhysicsResult` of this file's DART check: its
            figures in the table and the verdict line (when ``metrics`` is None, else those of
            ``metrics``), its figure, and the simulated robot in the viewer (unless ``scene``
            is given).
        collisions: the file's :func:`~imesh.metrics.collision.check_self_collisions` result,
            if already computed (used for ``metrics`` and ``scene`` when they are computed here).
        props: the motion's props (a robot-world :class:`imesh.scene.Scene`, ``OUT.scene.npz``),
            drawn in the embedded viewer (unless ``scene`` is given).

    Returns:
        the path written.
    """
    motion = load_motion_file(motion_path, robot, fps=fps)
    if metrics is None:
        metrics = evaluate_motion(robot, motion, physics_result=physics, collisions=collisions)
    figures = motion_figures(robot, motion, physics)
    page = None
    if viewer:
        if scene is None:
            scene = build_scene(robot, motion, source=source, physics=physics,
                                collisions=collisions, props=props,
                                title=f"{Path(motion_path).name} ({robot.name})")
        page = viewer_html(scene)
    info = {"motion": str(motion_path), "robot": robot.name,
            "frames": f"{motion.n_frames} at {motion.fps:g} fps "
                      f"({motion.n_frames / motion.fps:.2f} s)"}
    if props is not None:
        info["props"] = f"{len(props.props)} ({', '.join(props.names)})"
    info.update(facts or {})
    with atomic_path(path) as tmp:
        tmp.write_text(report_html(robot=robot, motion_path=motion_path, metrics=metrics,
                                   figures=figures, viewer_page=page, facts=info,
                                   balanced=balanced), encoding="utf-8")
    log.info("wrote the report %s", path)
    return Path(path)


#: Units and notes of a pair's figures (:meth:`imesh.partners.evaluate.PairMetrics.summary`).
PAIR_UNITS = {"inter_close_pair_error": "height fraction", "inter_close_pairs": "samples",
              "robot_penetration_mm": "mm", "penetration_frames": "frames",
              "hold_frames": "samples", "hold_error_max_mm": "mm", "hold_error_mean_mm": "mm",
              "hold_within_30mm": "fraction", "deepest": "frame, capsules"}


def pair_rows(pair_metrics: Mapping[str, Any]) -> list[dict]:
    """Rows of a pair's table (no gates: the pair's figures are measured, not gated)."""
    return [{"name": k, "value": v, "unit": PAIR_UNITS.get(k, ""), "gate": "", "status": "",
             "note": "", "text": "none" if v is None else (
                 _fmt(v) if not isinstance(v, list) else ", ".join(map(str, v)))}
            for k, v in pair_metrics.items()]


def write_pair_report(path: str | os.PathLike, robots: Sequence, motion_paths: Sequence, *,
                      metrics: Sequence[Mapping[str, dict]], pair_metrics: Mapping[str, Any],
                      scene: dict | None = None, facts: Mapping[str, str] | None = None,
                      keys: Sequence[str] = ("a", "b"), manifest: str = "") -> Path:
    """Write the HTML report of a pair (``imesh retarget A --partner B --report R.html``):
    the pair's figures, then per robot the metrics table with its gates and the figures of
    its file as written, and the embedded viewer with both robots.

    Args:
        path: the ``.html`` file to write (atomically).
        robots: the two robots (:class:`imesh.robot.Robot`).
        motion_paths: their motion files (``OUT.npz``, ``OUT.partner.npz``).
        metrics: each robot's evaluator report (``OUT.pair.json``'s ``metrics``).
        pair_metrics: the pair's figures (``OUT.pair.json``'s ``pair_metrics``).
        scene: the viewer's scene of the pair (:func:`imesh.viz.scene.build_robots_scene`);
            None: built here from the two files (without the human sources and the pair's
            per-frame distance).
        facts: extra lines for the header (name -> text).
        keys: the robots' names in the pair (the manifest's "a", "b"): the tags of their
            tables' rows (:func:`table_values`).
        manifest: the pair's manifest (``OUT.pair.json``), named in the page.

    Returns:
        the path written.
    """
    motions = [load_motion_file(p, r) for r, p in zip(robots, motion_paths, strict=True)]
    if scene is None:
        scene = build_robots_scene(
            [SceneRobot(r, m, label=f"{k} {r.name}") for r, m, k in
             zip(robots, motions, keys, strict=True)],
            title=" + ".join(f"{Path(p).name} ({r.name})"
                             for r, p in zip(robots, motion_paths, strict=True)))
    body = ['<h2>The pair</h2><p>Measured, not gated (docs/partners.md): the relations between '
            'the people kept by the robots, the robots\' penetration into each other, the held '
            'hands\' distance against the source\'s.'
            + (f' The numbers of <code>{html.escape(Path(manifest).name)}</code>'
               if manifest else "") + '.</p>' + _table(pair_rows(pair_metrics), "pair")]
    for key, robot, mpath, motion, m in zip(keys, robots, motion_paths, motions, metrics,
                                             strict=True):
        body.append(f"<h2>Robot {html.escape(key)}: {html.escape(robot.name)} "
                    f"({html.escape(Path(mpath).name)})</h2>")
        command = "" if not manifest else (  # the pair's evaluation: its "metrics" -> key
            f"imesh evaluate {Path(motion_paths[0]).name} --pair {Path(manifest).name} --json "
            f"(robot {key})")
        body.append(robot_section(robot=robot, motion_path=mpath, metrics=m,
                                  figures=motion_figures(robot, motion), table=key, level=3,
                                  command=command))
    T, fps = motions[0].n_frames, motions[0].fps
    info = {"motions": ", ".join(f"{k}: {p} ({r.name})" for k, p, r in
                                 zip(keys, motion_paths, robots, strict=True)),
            "frames": f"{T} at {fps:g} fps ({T / fps:.2f} s)"}
    if manifest:
        info["pair"] = str(manifest)
    info.update(facts or {})
    title = "imesh report: " + " + ".join(f"{Path(p).name} ({r.name})" for r, p in
                                          zip(robots, motion_paths, strict=True))
    with atomic_path(path) as tmp:
        tmp.write_text(_page(title, info, "".join(body), viewer_html(scene)), encoding="utf-8")
    log.info("wrote the pair's report %s", path)
    return Path(path)


def table_values(report_path: str | os.PathLike, table: str = "") -> dict:
    """``{metric: value}`` read back from a report's table (``data-value`` of each row); in a
    pair's report ``table`` picks the table: "a", "b" or "pair"."""
    text = Path(report_path).read_text(encoding="utf-8")
    return {m: json.loads(html.unescape(v))
            for m, v, t in re.findall(r'data-metric="([^"]+)" data-value="([^"]*)"'
                                      r'(?: data-table="([^"]*)")?', text) if t == table}

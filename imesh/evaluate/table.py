"""The plain-text table of an evaluator report (:func:`imesh.evaluate.scoreboard.evaluate_motion`):
what ``imesh evaluate``, ``imesh retarget`` and ``imesh demo`` print; the HTML report
(:mod:`imesh.viz.report`) formats its cells with the same :func:`_fmt` and :func:`_note`."""

from __future__ import annotations

from collections.abc import Mapping


def _fmt(value) -> str:
    """A metric value as the table shows it: n/a, yes/no, or 0 to 4 decimals by magnitude."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if abs(value) >= 100:
        return f"{value:.0f}"
    if abs(value) >= 1:
        return f"{value:.2f}"
    return f"{value:.4f}" if value else "0"


def _note(name: str, entry: dict) -> str:
    """The note column of a metric: why it is n/a, or its most telling detail."""
    if entry.get("value") is None:
        return entry.get("reason", "")
    if name == "self_collision_frames":
        text = ""
        if entry.get("worst_pairs"):
            p = entry["worst_pairs"][0]
            text = f"worst {p['pair'][0]}-{p['pair'][1]} {p['max_depth_mm']} mm; "
        if entry.get("capsule_frames") is not None:
            text += (f"capsules {entry['capsule_frames']} frames, deepest "
                     f"{entry['capsule_deepest_mm']} mm")
        return text.strip("; ")
    if name == "ground_penetration_mm":
        text = f"worst link {entry.get('worst_link')}" if entry.get("worst_link") else ""
        if entry.get("floating_frames"):
            text += f"; floating {entry['floating_frames']} frames"
        return text.strip("; ")
    if name == "foot_skid_mm_per_frame":
        return f"{100 * entry['fraction_over_10mm']:.1f} % of support frames > 10 mm"
    if name == "limit_violation_frames":
        return f"position {entry['position']}, velocity {entry['velocity']}"
    if name == "marker_rms_mm":
        worst, when = worst_markers(entry), worst_window(entry)
        return (f"vs {entry['reference']}" + (f"; worst {worst}" if worst else "")
                + (f"; worst half second: {when}" if when else ""))
    if name == "physics_fell":
        text = entry.get("fall_reason") or f"real-time factor {entry['real_time_factor']:.2f}"
        if entry.get("props"):
            text += (f"; props in the world: {', '.join(entry['props'])}, hands/knees carried "
                     f"up to {entry.get('link_contact_force_max_n', 0.0):.0f} N")
        return text
    if name == "seconds_per_frame":
        return ", ".join(f"{k} {v:.4f}" for k, v in entry.get("stages", {}).items())
    return ""


def worst_markers(entry: Mapping, count: int = 5) -> str:
    """The ``count`` key points farthest from their markers in a ``marker_rms_mm`` entry, as
    "head 159 mm, neck 151 mm, ..." ("" when the entry has no per-marker figures)."""
    by_marker = entry.get("by_marker_mm") or {}
    worst = sorted(by_marker.items(), key=lambda kv: -kv[1])[:count]
    return ", ".join(f"{k} {v:.0f} mm" for k, v in worst)


def worst_window(entry: Mapping) -> str:
    """The window of a ``marker_rms_mm`` entry farthest from its markers, as "frames 58-72
    (1.93-2.43 s; the clip's 0.93-1.43 s), 421 mm RMS": the motion's frames and seconds, its
    lead-in included, then the clip's own seconds when the motion's provenance names its
    lead-in (negative: in the lead-in); "" when the entry has no window."""
    w = entry.get("worst_window")
    if not w:
        return ""
    (a, b), (t0, t1) = w["frames"], w["seconds"]
    clip = w.get("clip_seconds")
    when = f"{t0:.2f}-{t1:.2f} s" + (f"; the clip's {clip[0]:.2f}-{clip[1]:.2f} s" if clip else "")
    return f"frames {a}-{b - 1} ({when}), {w['rms_mm']:.0f} mm RMS"


def format_table(report: Mapping[str, dict]) -> str:
    """A plain-text table of a report (metric, value, unit, note)."""
    rows = [(name, _fmt(e["value"]), e["unit"], _note(name, e)) for name, e in report.items()]
    w = [max(len(r[k]) for r in rows) for k in range(3)]
    return "\n".join(f"{a:<{w[0]}}  {b:>{w[1]}}  {c:<{w[2]}}  {d}".rstrip() for a, b, c, d in rows)


def physics_line(report: Mapping[str, dict]) -> str:
    """One line of the DART check's verdict from a report's physics entries
    (:func:`imesh.evaluate.scoreboard.physics_entries`): fell or stood with the time, key-point
    tracking error RMS/max, base drift and torque ratio; "" when the check did not run."""
    fell = report.get("physics_fell", {})
    if fell.get("value") is None:
        return ""
    survived = report["physics_survived_s"]
    duration = survived.get("duration_s")
    of = f" of {duration:.1f} s" if duration is not None else ""
    verdict = (f"FELL at {survived['value']:.1f} s{of} ({fell.get('fall_reason')})"
               if fell["value"] else f"stood through the {survived['value']:.1f} s")

    def mm(key: str) -> str:
        return "n/a" if fell.get(key) is None else f"{fell[key]:.0f}"

    drift = fell.get("base_drift_m")
    ratio = report["torque_ratio_max"]["value"]
    worst = (f" ({fell['keypoint_worst']} at {fell['keypoint_worst_s']:.2f} s)"
             if fell.get("keypoint_worst") and fell.get("keypoint_worst_s") is not None else "")
    slip = (f"; slip {mm('slip_mm')} mm ({fell['slip_side']} sole at {fell['slip_s']:.2f} s)"
            if fell.get("slip_side") and fell.get("slip_s") is not None else "")
    props = (f"; with the props ({', '.join(fell['props'])}), hands/knees carrying up to "
             f"{fell.get('link_contact_force_max_n', 0.0):.0f} N") if fell.get("props") else ""
    return (f"physics check ({fell.get('controller')}): {verdict}{props}; key points "
            f"{mm('keypoint_rms_mm')} mm RMS, {mm('keypoint_max_mm')} mm max{worst}{slip}; "
            f"base drift {'n/a' if drift is None else f'{1e3 * drift:.0f} mm'}; torque ratio "
            f"{_fmt(ratio)} (docs/checking.md)")

"""Verification of a robot motion before it is written: the evaluator's report against gates.

The retarget command scores the motion it is about to write with
:func:`imesh.evaluate.evaluate_motion` (the numbers ``imesh evaluate`` prints for the written
file) and writes it only when every gate holds; otherwise it exits with status 3 and writes
nothing, unless ``--force`` (written, and the report says which gates failed).
"""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import VerificationError
from .scoreboard import evaluate_motion, metric_values
from .table import worst_markers, worst_window


@dataclass(frozen=True)
class Gates:
    """Pass/fail limits on the evaluator's metrics.

    Attributes:
        limit_violation_frames: most frames with a joint outside its position, velocity or
            acceleration limits.
        ground_penetration_mm: deepest collision shape below the ground [mm].
        marker_rms_mm: largest RMS distance of the key points from the adapted markers [mm].
        zmp_inside_fraction: smallest fraction of support frames with the multibody ZMP inside
            the support polygon (balanced motions only).

    ``physics_fell`` is a gate whenever the DART check ran (``--physics``): the motion passes
    only if the robot did not fall.
    """

    limit_violation_frames: int = 0
    ground_penetration_mm: float = 10.0
    marker_rms_mm: float = 100.0
    zmp_inside_fraction: float = 0.95


def failed_gates(report: dict, gates: Gates | None = None, balanced: bool = True) -> dict:
    """metric -> (value, gate text) of every gate the evaluator's ``report`` fails (metrics that
    could not be computed are not judged)."""
    gates = gates or Gates()
    m = metric_values(report)
    out = {}
    checks = [("limit_violation_frames", "<=", gates.limit_violation_frames),
              ("ground_penetration_mm", "<=", gates.ground_penetration_mm),
              ("marker_rms_mm", "<=", gates.marker_rms_mm)]
    if balanced:
        checks.append(("zmp_inside_fraction", ">=", gates.zmp_inside_fraction))
    if m.get("physics_fell") is True:
        out["physics_fell"] = (True, "== False (the robot fell in the DART check)")
    for name, op, limit in checks:
        value = m.get(name)
        if value is None:
            continue
        ok = value <= limit if op == "<=" else value >= limit
        if not ok:
            gate = f"{op} {limit}"
            if name == "marker_rms_mm":  # where and when
                where, when = worst_markers(report[name]), worst_window(report[name])
                gate += (f"; worst key points: {where}" if where else "") + \
                    (f"; worst half second: {when}" if when else "")
            out[name] = (value, gate)
    return out


def verify_motion(robot, motion, *, adapted=None, seconds=None, name: str,
                  balanced: bool = True, force: bool = False, source=None,
                  physics=None, scene=None) -> tuple[dict, dict]:
    """Score a robot motion as it will be written and check it against the gates (what
    ``imesh retarget`` and ``imesh batch`` do before writing).

    Args:
        robot: the Robot.
        motion: the RobotMotion about to be written.
        adapted: the adapted markers it was fitted to (for ``marker_rms_mm``), or None.
        seconds: the pipeline's stage timings (for ``seconds_per_frame``), or None.
        name: the clip, for the message.
        balanced: whether the balance gates apply (not with ``balance="none"``).
        force: return the failed gates instead of raising (``--force``: written anyway, the
            report says which gates failed).
        source: the human clip (MarkerMotion or file) the motion was made from, for
            ``close_pair_error`` on the clip's frames (the motion's provenance says which), or
            None.
        physics: a :class:`imesh.physics.PhysicsConfig` to run the DART check with and gate
            on (``physics_fell``), or None (no physics check).
        scene: the motion's props in the robot's world, in the DART check's world.

    Returns:
        (the evaluator's report (:func:`~imesh.evaluate.scoreboard.evaluate_motion`), the failed
        gates: metric -> (value, gate text), empty when all hold).

    Raises:
        VerificationError: a gate fails and not ``force`` (lists every failed gate).
    """
    metrics = evaluate_motion(robot, motion, source=source, adapted=adapted, seconds=seconds,
                              physics=physics is not None, physics_config=physics, scene=scene)
    failed = failed_gates(metrics, balanced=balanced)
    if failed and not force:
        raise VerificationError(f"retargeted motion of {name} for {robot.name}", failed)
    return metrics, failed

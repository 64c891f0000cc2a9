"""The evaluator: every metric of DESIGN.md for a written robot motion, and the gates that decide
whether a retarget writes it.

- :func:`~imesh.evaluate.scoreboard.evaluate_motion`: metric name -> value and unit (keys
  :data:`~imesh.evaluate.scoreboard.METRIC_NAMES`; ``metric_values`` flattens it);
- :func:`~imesh.evaluate.motion_files.load_motion_file` reads a motion as written (.npz, CSV),
  :func:`~imesh.evaluate.motion_files.arranged_source` the human source arranged for a robot;
- :func:`~imesh.evaluate.table.format_table`: the report as a plain-text table;
- :func:`~imesh.evaluate.verify.failed_gates`: which gates of a robot a report fails.

``imesh evaluate`` (:mod:`imesh.cli.evaluate`) prints the same report.
"""

from ..core.lazy import lazy_exports

_LAZY = {
    **dict.fromkeys(("METRIC_NAMES", "EVAL_BLOCK_FRAMES", "evaluate_motion", "metric_values"),
                    ".scoreboard"),
    **dict.fromkeys(("arranged_source", "load_motion_file"), ".motion_files"),
    "format_table": ".table",
    **dict.fromkeys(("Gates", "failed_gates"), ".verify"),
}
__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals())

__all__ = sorted(_LAZY)

"""Progress of a retarget job: the library reports, the command line draws one bar.

The library never draws: :func:`imesh.pipeline.retarget.retarget` and the whole-body solve call a
``progress`` callback with a :class:`StageProgress` (stage, units done of the stage's total,
frames). :class:`JobBar` (the CLI layer) turns those into one tqdm bar over every stage of the
job, loading and writing included, counted in output frames with an ETA: each stage's share of
the bar is its estimated cost (:data:`STAGE_COST_S`, measured in docs/speed.md), so the bar
moves at about the speed of the wall clock and tqdm's ETA means something.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass

from tqdm import tqdm

#: Estimated cost of each stage: (fixed seconds, seconds per working frame) on the G1 walk
#: (benchmarks/speed.py, docs/speed.md); only their ratios matter (the bar's shares).
STAGE_COST_S: dict[str, tuple[float, float]] = {
    "load": (0.5, 0.0),
    "prepare": (0.3, 1e-3),
    "morph": (0.0, 1.5e-3),
    "fit": (0.0, 1.5e-3),
    "plan": (0.0, 5e-4),
    "wholebody": (0.0, 0.1),
    "verify": (0.0, 1.5e-3),
    "write": (0.0, 1e-4),
    "viewer": (0.5, 1e-3),
    "report": (1.0, 5e-3),
}

#: How the bar names each stage.
STAGE_LABELS = {"load": "load", "prepare": "prepare", "morph": "morph", "fit": "fit",
                "plan": "plan", "wholebody": "whole-body solve", "verify": "verify",
                "write": "write", "physics": "DART check", "viewer": "viewer page",
                "report": "report"}


@dataclass(frozen=True)
class StageProgress:
    """One progress report of a stage.

    Attributes:
        stage: a key of :data:`STAGE_COST_S` ("prepare", "morph", "fit", "plan",
            "wholebody", ...).
        done: units of the stage done (morph steps, SQP iterations, solved frames).
        total: units of the stage in all (an upper bound: an SQP may converge earlier).
        frames: frames the stage works on.
        detail: a short text for the bar ("iteration 3", "window 2/7").
    """

    stage: str
    done: int
    total: int
    frames: int
    detail: str = ""


ProgressCallback = Callable[[StageProgress], None]


def notify(progress: ProgressCallback | None, stage: str, done: int, total: int, frames: int,
           detail: str = "") -> None:
    """Call ``progress`` (if any) with a :class:`StageProgress`."""
    if progress is not None:
        progress(StageProgress(stage, done, total, frames, detail))


class JobBar:
    """One tqdm bar over the stages of a job, in frames, with an ETA (nothing when quiet).

    Use it as the library's progress callback; the stages the caller runs itself (loading,
    verifying, writing) are announced with :meth:`stage` and closed with :meth:`finish`.

    Args:
        quiet: draw nothing.
        desc: the job ("retarget walk.bvh to g1").
        frames: output frames of the job (the bar's total).
        stages: the stages in order, each a key of ``costs``.
        costs: (fixed s, s per frame) per stage (default :data:`STAGE_COST_S`).
    """

    def __init__(self, quiet: bool, desc: str, frames: int, stages: list[str],
                 costs: dict[str, tuple[float, float]] | None = None):
        costs = costs or STAGE_COST_S
        cost = [costs.get(s, (0.0, 0.0)) for s in stages]
        weights = [a + b * frames for a, b in cost]
        total_w = sum(weights) or 1.0
        self.frames = max(int(frames), 1)
        self.desc = desc
        self.stages = list(stages)
        self.start: dict[str, float] = {}
        self.share: dict[str, float] = {}
        acc = 0.0
        for s, w in zip(stages, weights, strict=True):
            self.start[s] = acc / total_w
            self.share[s] = w / total_w
            acc += w
        self.position = 0.0
        self.bar = None
        if not quiet:
            self.bar = tqdm(total=self.frames, desc=desc, unit="frame", file=sys.stderr,
                            dynamic_ncols=True,
                            bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total} "
                                       "frames [{elapsed}<{remaining}]")

    def stage(self, name: str, frames: int | None = None, detail: str = "") -> None:
        """Announce the start of a stage the caller runs itself."""
        self(StageProgress(name, 0, 1, frames if frames is not None else self.frames, detail))

    def __call__(self, event: StageProgress) -> None:
        if event.stage not in self.start:
            return
        frac = min(max(event.done / event.total, 0.0), 1.0) if event.total else 1.0
        target = self.frames * (self.start[event.stage] + self.share[event.stage] * frac)
        if self.bar is not None:
            label = STAGE_LABELS.get(event.stage, event.stage)
            text = f"{self.desc}: {label} ({event.frames} frames"
            text += f", {event.detail})" if event.detail else ")"
            self.bar.set_description_str(text, refresh=False)
            if target > self.position:
                self.bar.update(target - self.position)
            else:
                self.bar.refresh()
        self.position = max(self.position, target)

    def finish(self) -> None:
        """Fill the bar (the last stage is done) and close it."""
        if self.bar is not None:
            if self.frames > self.position:
                self.bar.update(self.frames - self.position)
            self.bar.close()
        self.position = self.frames

    def close(self) -> None:
        """Close without filling (an error stopped the job)."""
        if self.bar is not None:
            self.bar.close()


def retarget_bar(quiet: bool, desc: str, motion, config, extra: tuple[str, ...] = ()):
    """The job's one progress bar (:class:`imesh.core.progress.JobBar`) over loading the robot, the
    retarget's stages, verifying and writing (then ``extra`` stages), in output frames."""
    fps = config.fps or motion.fps
    n_work = int(round(motion.n_frames / motion.fps * fps))
    stages = ["load", "prepare", "morph", "fit"]
    if config.balance == "wholebody":
        n_work += 2 * int(round(config.lead_s * fps))
        stages += ["plan", "wholebody"]
    return JobBar(quiet, desc, n_work, [*stages, "verify", "write", *extra])

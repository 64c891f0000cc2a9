"""Writing results: atomic files (temp file + rename), so a failure never leaves partial output."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .errors import OptionError
from .motion import MarkerMotion


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success."""
    final = Path(path)
    if final.parent and not final.parent.exists():
        final.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{final.name}.", suffix=final.suffix or ".tmp",
                               dir=final.parent if str(final.parent) else ".")
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.replace(tmp_path, final)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def write_json(path: str | os.PathLike, data: dict) -> None:
    """Write ``data`` as indented JSON, atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(_jsonable(data), indent=2, allow_nan=True) + "\n")


def save_marker_motion(path: str | os.PathLike, motion: MarkerMotion) -> None:
    """Save markers as .npz (keys: positions_m (T, M, 3), valid (T, M), names (M,), bones (B, 2),
    fps) or .csv (header: frame, time_s, then ``name.x name.y name.z`` per marker), atomically."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez_compressed(fh, positions_m=motion.positions_m, valid=motion.valid,
                                names=np.array(motion.names), bones=motion.bones,
                                fps=np.float64(motion.fps), source=np.str_(motion.source))
    elif suffix == ".csv":
        header = ["frame", "time_s"] + [f"{n}.{c}" for n in motion.names for c in "xyz"]
        t = np.arange(motion.n_frames)
        table = np.column_stack([t, t / motion.fps,
                                 motion.positions_m.reshape(motion.n_frames, -1)])
        with atomic_path(path) as tmp:
            np.savetxt(tmp, table, delimiter=",", header=",".join(header), comments="",
                       fmt="%.9g")
    else:
        raise OptionError("output file extension", suffix or path.name, [".npz", ".csv"])


def load_marker_motion(path: str | os.PathLike) -> MarkerMotion:
    """Read a marker .npz written by :func:`save_marker_motion`."""
    with np.load(path, allow_pickle=False) as data:
        return MarkerMotion(positions_m=data["positions_m"], fps=float(data["fps"]),
                            names=tuple(str(n) for n in data["names"]), valid=data["valid"],
                            bones=data["bones"], source=str(data["source"]))

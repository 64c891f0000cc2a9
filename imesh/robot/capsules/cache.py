"""Fitted capsules on disk: the fit takes 1-6 s per robot, so its result is kept in imesh's
cache folder, keyed by a hash of exactly what it is computed from."""

from __future__ import annotations

import hashlib
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ...core.cache import CACHE_ENV, cache_root
from .fit import FIT_VERSION, MAX_CAPSULES, SPLIT_GAIN, SPLIT_MAX_EDGE_M, SPLIT_RADIUS
from .model import Capsule


def capsule_cache_dir() -> Path | None:
    """The folder of fitted capsules: ``capsules/`` in imesh's cache folder
    (:func:`imesh.core.cache.cache_root`); None (no cache) when ``$IMESH_CACHE_DIR`` is set
    empty."""
    env = os.environ.get(CACHE_ENV)
    if env is not None and not env.strip():
        return None
    return cache_root() / "capsules"


def fit_key(inputs: Sequence[tuple[str, np.ndarray, np.ndarray | None]],
            split_excess: float | None) -> str:
    """The cache key of a fit: a hash of the fit's settings and of every body's name, (N, 3)
    points [m] and (F, 3, 3) triangles (or None), in order."""
    h = hashlib.sha256(repr((FIT_VERSION, MAX_CAPSULES, SPLIT_GAIN, SPLIT_RADIUS,
                             SPLIT_MAX_EDGE_M, split_excess)).encode())
    for body, pts, tris in inputs:
        h.update(body.encode() + b"\0")
        h.update(np.ascontiguousarray(pts, dtype=np.float64).tobytes())
        h.update(b"\0" if tris is None else
                 np.ascontiguousarray(tris, dtype=np.float64).tobytes())
    return h.hexdigest()[:32]


def write_capsules(path: Path, capsules: Sequence[Capsule]) -> None:
    """Write atomically (a temporary file in the same folder, then a rename), so concurrent
    processes never read a partial file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.stem, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            np.savez(fh, name=np.array([c.name for c in capsules]),
                     body=np.array([c.body for c in capsules]),
                     frame=np.array([c.frame for c in capsules]),
                     a=np.array([c.a for c in capsules]).reshape(-1, 3),
                     b=np.array([c.b for c in capsules]).reshape(-1, 3),
                     radius=np.array([c.radius for c in capsules], dtype=float))
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def read_capsules(path: Path) -> list[Capsule]:
    """The capsules :func:`write_capsules` wrote to ``path``.

    Raises:
        OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile: a missing or damaged file.
    """
    with np.load(path, allow_pickle=False) as z:
        return [Capsule(name=str(n), body=str(b), frame=str(f), a=a.copy(), b=e.copy(),
                        radius=float(r))
                for n, b, f, a, e, r in zip(z["name"], z["body"], z["frame"], z["a"], z["b"],
                                            z["radius"], strict=True)]

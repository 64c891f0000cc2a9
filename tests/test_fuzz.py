"""Fuzzing every reader with mutants of the real clips (benchmarks/fuzz.py runs 10,000 per format):
a few hundred per format with a fixed seed, and nothing but ImeshError may come out."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import fuzz  # noqa: E402

MUTANTS = 300


@pytest.fixture(scope="module", autouse=True)
def quiet():
    import logging
    import warnings

    logging.disable(logging.CRITICAL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield
    logging.disable(logging.NOTSET)


@pytest.mark.parametrize("fmt", fuzz.FORMATS)
def test_mutants_raise_only_imesh_errors(fmt, tmp_path, mocap):
    mocap("MANIFEST.md")  # fails clearly when IMESH_DATA is missing
    seed_list = [fuzz._Seed(s) for s in fuzz.seeds(fmt, frames=60)]
    outcomes = [fuzz.run_mutant(fmt, seed_list, 2024, k, tmp_path) for k in range(MUTANTS)]
    other = [o.detail for o in outcomes if o.result == "other"]
    assert other == []
    counts = {r: sum(o.result == r for o in outcomes) for r in ("loaded", "imesh")}
    assert counts["imesh"] > MUTANTS // 3  # the mutations do break files
    assert counts["loaded"] + counts["imesh"] == MUTANTS
    assert max(o.seconds for o in outcomes) < 5.0


def test_seeds_load_unchanged(tmp_path, mocap):
    """The cut seeds are valid files: they load (so every error above comes from a mutation)."""
    mocap("MANIFEST.md")
    for fmt in fuzz.FORMATS:
        for seed in fuzz.seeds(fmt, frames=60):
            folder = tmp_path / fmt.replace("/", "_")
            folder.mkdir()
            for name, data in seed.items():
                (folder / name).write_bytes(data)
            motion = fuzz.load(fmt, folder)
            assert motion.n_frames in ((340, 675) if fmt == "c3d" else (60,))  # c3d: whole
            for name in seed:
                (folder / name).unlink()
            folder.rmdir()

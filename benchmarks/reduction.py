"""What the PCA motion reduction buys: reduced dimension r = 2, 3, 5 and full (no reduction).

For each r the same motion-design problem (planar biped, a real walking cycle) is solved by the
Levenberg-Marquardt stage (I) (the default) and by the paper's gradient stage (I) (steepest
descent, Jacobi-scaled, Armijo steps); both alternate with stage (II). Printed per run:
iterations and seconds until the acceptance targets first hold (J_m <= J_m(initial)/100,
|y_m| <= 1 mm, every vertical ground force > 0, no angle or torque limit violated), and the
final E = J_r + J_m, J_m, |y_m|, minimum ground force, wall time and how far the motion moved
from the human one (RMS change of the five optimized link angles, "change").

With five optimized angles, r = 5 is an orthogonal change of coordinates of the full problem
(no reduction of the search space); "full" skips the SVD altogether.

    python benchmarks/reduction.py                       # cmu_02_01_walk.bvh, both methods
    python benchmarks/reduction.py --clip cmu_07_05.amc --methods gauss-newton
    python benchmarks/reduction.py --json results.json --plot convergence.png
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def data_path(name: str) -> Path:
    root = Path(os.environ.get("IMESH_DATA", ROOT.parent / "shared" / "data"))
    path = root / "mocap" / name
    if not path.is_file():
        sys.exit(f"clip {path} not found: set IMESH_DATA to the shared data folder")
    return path


def reached(history, J_m0: float) -> tuple[int | None, float | None]:
    """First iteration (and its time) at which the acceptance targets hold."""
    for h in history:
        if (h.J_m <= J_m0 / 100 and h.closure_max_mm <= 1.0 and h.min_grf_N > 0
                and h.angle_violations == 0 and h.torque_violations == 0):
            return h.iteration, h.seconds
    return None, None


def run(clip: str, rank, method: str, iterations: int, robot: str,
        harmonics: int | None = 15) -> dict:
    from imesh.io import load_motion
    from imesh.reduction import ReductionConfig, SolverConfig, SubspaceConfig, reduce_motion

    motion = load_motion(data_path(clip))
    t0 = time.perf_counter()
    config = ReductionConfig(subspace=SubspaceConfig(rank=rank, harmonics=harmonics),
                             solver=SolverConfig(method=method, max_iterations=iterations))
    res = reduce_motion(motion, robot, config)
    total = time.perf_counter() - t0
    o = res.optimization
    it, sec = reached(o.history, o.initial.J_m)
    rep = res.report()
    return {
        "clip": clip, "robot": robot, "rank": "full" if rank is None else rank,
        "method": method, "iterations": rep["iterations"], "target_iteration": it,
        "target_seconds": sec, "E_final": rep["E_final"], "J_m_initial": rep["J_m_initial"],
        "J_m_final": rep["J_m_final"], "J_r_final": rep["J_r_final"],
        "closure_mm": rep["closure_error_mm"], "min_grf_N": rep["min_vertical_grf_N"],
        "violations": rep["angle_violations"] + rep["torque_violations"],
        "pca_explained": rep["pca_explained"], "optimization_s": o.seconds, "total_s": total,
        "change_deg": rep["change_from_human_rms_deg"], "harmonics": harmonics,
        "history": [(h.iteration, h.seconds, h.J_m, h.J_r) for h in o.history],
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clip", default="cmu_02_01_walk.bvh")
    ap.add_argument("--robot", default="planar_biped")
    ap.add_argument("--ranks", nargs="+", default=["2", "3", "5", "full"])
    ap.add_argument("--methods", nargs="+", default=["gauss-newton", "gradient"])
    ap.add_argument("--iterations", type=int, default=200,
                    help="iterations of the Levenberg-Marquardt runs (default 200)")
    ap.add_argument("--gradient-iterations", type=int, default=300,
                    help="iterations of the gradient runs (default 300)")
    ap.add_argument("--harmonics", default="15",
                    help="harmonics of the optimized trajectories, or 'free' (every sample "
                         "a parameter, as in the paper) (default 15)")
    ap.add_argument("--json", help="write all results (with histories) here")
    ap.add_argument("--plot", help="write the convergence figure (J_m per iteration) here")
    args = ap.parse_args(argv)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "2")
    rows = []
    harmonics = None if args.harmonics == "free" else int(args.harmonics)
    print(f"{args.clip} on {args.robot}, trajectories: "
          f"{'free samples' if harmonics is None else f'{harmonics} harmonics'}")
    print(f"{'method':<13} {'r':>4} {'it':>4} {'to target':>14} {'E final':>10} "
          f"{'J_m final':>10} {'J_m ratio':>9} {'|y_m| mm':>8} {'min grf N':>9} "
          f"{'viol':>4} {'time s':>7} {'PCA var':>7} {'change':>7}")
    for method in args.methods:
        its = args.iterations if method == "gauss-newton" else args.gradient_iterations
        for r in args.ranks:
            rank = None if r == "full" else int(r)
            row = run(args.clip, rank, method, its, args.robot, harmonics)
            rows.append(row)
            tgt = ("not reached" if row["target_iteration"] is None else
                   f"{row['target_iteration']} / {row['target_seconds']:.1f} s")
            var = "-" if row["pca_explained"] is None else f"{row['pca_explained']:.5f}"
            print(f"{method:<13} {row['rank']!s:>4} {row['iterations']:>4} {tgt:>14} "
                  f"{row['E_final']:>10.4g} {row['J_m_final']:>10.4g} "
                  f"{row['J_m_initial'] / row['J_m_final']:>9.0f} {row['closure_mm']:>8.3f} "
                  f"{row['min_grf_N']:>9.2f} {row['violations']:>4} "
                  f"{row['optimization_s']:>7.1f} {var:>7} {row['change_deg']:>6.1f}d",
                  flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(12, 4))
        for row in rows:
            h = np.array(row["history"])
            ls = "-" if row["method"] == "gauss-newton" else "--"
            label = f"{row['method']} r={row['rank']}"
            axes[0].semilogy(h[:, 0], h[:, 2], ls, label=label)
            axes[1].semilogy(h[:, 1], h[:, 2], ls, label=label)
        for ax, xl in zip(axes, ("iteration", "seconds"), strict=True):
            ax.axhline(rows[0]["J_m_initial"] / 100, color="k", ls=":", lw=1)
            ax.set_xlabel(xl)
            ax.set_ylabel("J_m")
            ax.grid(True, which="both", alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.suptitle(f"J_m per iteration and over time ({args.clip}, {args.robot}); "
                     "dotted: J_m(initial)/100")
        fig.tight_layout()
        fig.savefig(args.plot, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())

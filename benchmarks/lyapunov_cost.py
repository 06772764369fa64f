"""Cost of one lambda_1: Stefanski (synchronisation) vs Benettin (two trajectories).

Runs both estimators on the reference systems of ``analysis.lyapunov.reference_systems``
with the same RK4 step and the same measuring length, after a warm-up call that
compiles the numba kernel for each right-hand side (compile time is reported
separately, it is paid once per rhs per process).  Prints a Markdown table with
wall time, CPU time, right-hand-side evaluations and the Stefanski/Benettin
ratios.  The beam-specific rows will be added when the beam model exists.

Usage::

    .venv/bin/python benchmarks/lyapunov_cost.py               # all systems
    .venv/bin/python benchmarks/lyapunov_cost.py lorenz rossler --repeat 3
    .venv/bin/python benchmarks/lyapunov_cost.py --threads 1    # single thread

CPU time is process time (all threads), so with ``--threads 2`` the Stefanski
wall time can be below its CPU time.  On a shared machine trust the CPU time and
the evaluation counts more than the wall time.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analysis.lyapunov import benettin_lle, stefanski_lle
from analysis.lyapunov.reference_systems import REFERENCE_SYSTEMS


def _timed(fn, repeat: int):
    """Best-of-``repeat`` wall time, its CPU time, and the last result."""
    best = (float("inf"), float("inf"), None)
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        res = fn()
        w, c = time.perf_counter() - w0, time.process_time() - c0
        if w < best[0]:
            best = (w, c, res)
    return best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("systems", nargs="*", default=list(REFERENCE_SYSTEMS),
                    help=f"subset of {list(REFERENCE_SYSTEMS)}")
    ap.add_argument("--repeat", type=int, default=1, help="best of N runs (default 1)")
    ap.add_argument("--threads", type=int, default=None,
                    help="threads for the Stefanski batch (default min(2, cpus))")
    args = ap.parse_args(argv)

    rows = []
    for name in args.systems:
        s = REFERENCE_SYSTEMS[name]
        kw = dict(dt=s.dt, t_transient=s.t_transient, t_measure=s.t_measure)
        # warm-up: compile the kernel for this rhs (short run)
        c0 = time.perf_counter()
        benettin_lle(s.rhs, s.x0, s.params, dt=s.dt, t_transient=0.0, t_measure=200 * s.dt)
        t_compile = time.perf_counter() - c0
        ws, cs, rs = _timed(lambda: stefanski_lle(s.rhs, s.x0, s.params, n_threads=args.threads, **kw),
                            args.repeat)
        wb, cb, rb = _timed(lambda: benettin_lle(s.rhs, s.x0, s.params, **kw), args.repeat)
        rows.append((name, s.reference, rs.value, rb.value, rb.extras["stderr"], ws, cs, rs.n_rhs_evals,
                     len(rs.rounds), wb, cb, rb.n_rhs_evals, t_compile, s.t_measure / s.dt))

    print("| system | reference | Stefanski | Benettin (+-se) | steps/test | rounds | "
          "Stef wall s | Stef CPU s | Stef rhs evals | Ben wall s | Ben CPU s | Ben rhs evals | "
          "wall ratio | CPU ratio | evals ratio | compile s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for (name, ref, vs, vb, se, ws, cs, es, nr, wb, cb, eb, tc, nsteps) in rows:
        ref_s = "-" if ref is None else f"{ref:.4g}"
        print(f"| {name} | {ref_s} | {vs:.4f} | {vb:.4f} +- {se:.4f} | {nsteps:.0f} | {nr} | "
              f"{ws:.2f} | {cs:.2f} | {es:.3g} | {wb:.3f} | {cb:.3f} | {eb:.3g} | "
              f"{ws / wb:.1f} | {cs / cb:.1f} | {es / eb:.1f} | {tc:.2f} |")
    tot = np.array([[r[5], r[6], r[7], r[9], r[10], r[11]] for r in rows]).sum(axis=0)
    print(f"\nTotal: Stefanski {tot[0]:.2f} s wall / {tot[1]:.2f} s CPU / {tot[2]:.3g} evals; "
          f"Benettin {tot[3]:.2f} s wall / {tot[4]:.2f} s CPU / {tot[5]:.3g} evals; "
          f"ratios wall {tot[0] / tot[3]:.1f}, CPU {tot[1] / tot[4]:.1f}, evals {tot[2] / tot[5]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

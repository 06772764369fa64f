"""``expo``'s output grid: what 4 to 128 steps per forcing period cost and change.

    .venv/bin/python benchmarks/expo_grid.py            (about 30 s, one thread)

``expo`` is exact between located switches; its steps set only the output grid (Poincare
samples at period ends and the divergence test at step ends; since results version 18 its
stick statistics are tallied per interval, not at the step ends) and the longest spacing of its
event checks (``span / event_checks``).  Every step end starts a new
interval (the rate bounds, the event functions and the state are set up again), so the grid
is a cost; since results version 14 the checks' bounds follow the free modes' decay
(``beamsim.kernels.expo._decayed_rates``), so a step end no longer renews a loose bound.
Prints two tables (docs/performance.md and docs/model.md record them):

1. **Against a converged RK4 reference** (three modes, with and without the interface
   dashpot): the largest relative Poincare-state error over a few periods from rest, RK4 at
   step factors 0.125 / 0.0625 (their own difference printed: the reference is converged when
   it is far below the rest).  ``mu_s = mu_k``: with ``mu_s = 0.45 > mu_k`` (at ``Omega = 1.5``) RK4 at
   those two steps ended 0.3 of the state apart after the same 5 periods, so no trajectory
   there is a reference.
2. **The default grid** (every ``--every``-th point of ``config/grid.yaml``'s default map,
   100 periods after ``--transient``): time, event checks and switches per period per grid,
   the Poincare samples' distance to the 128-step grid (per point, relative to its largest
   state) and the largest difference of the stick fractions from the 128-step grid's.  A
   trajectory that differs between grids by far more than the event location's error is one
   that amplifies last-bit differences (a chaotic record, or a slow transient); it differs as
   much between 64 and 128 as between 4 and 128.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import yaml

import beamsim  # noqa: F401  (first: pins BLAS threads before numpy loads)
from analysis.pipeline.config import Numerics
from analysis.pipeline.grid import expand_grid
from beamsim.pattern_store import PatternStore
from beamsim.simulate import simulate, simulate_batch

ROOT = Path(__file__).resolve().parents[1]
GRIDS = (4, 8, 16, 32, 64, 128)


def rel(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / np.abs(b).max())


def against_rk4() -> None:
    print("1. expo against converged RK4 (n_modes 3, Omega 1.2, f0_rel 3, mu_s = mu_k = 0.3, "
          "2 + 3 periods from rest)")
    print(f"{'model':>28} {'RK4 h/8 vs h/16':>16} " + " ".join(f"{g:>9}" for g in GRIDS))
    for name, kw in (("interface dashpot 0.0939", dict(interface_viscosity=0.0939)),
                     ("undamped", dict(interface_viscosity=0.0))):
        base = dict(n_modes=3, Omega=1.2, f0_rel=3.0, mu_s=0.3, mu_k=0.3, n_transient=2,
                    n_record=3, **kw)
        fine, finer = (simulate(step_factor=sf, **base).poincare_state for sf in (0.125, 0.0625))
        errs = [rel(simulate(method="expo", steps_per_period=g, **base).poincare_state, finer)
                for g in GRIDS]
        print(f"{name:>28} {rel(fine, finer):>16.1e} " + " ".join(f"{e:>9.1e}" for e in errs))


def default_grid(every: int, n_transient: int) -> None:
    cfg = yaml.safe_load((ROOT / "config/config.yaml").read_text())
    grid = yaml.safe_load((ROOT / "config/grid.yaml").read_text())["grids"]["default"]
    pts = [p.params for p in expand_grid("default", grid, cfg["model"], Numerics().result_dict())]
    sel = pts[every // 2::every]
    kw = dict(n_transient=n_transient, n_record=100, method="expo", n_threads=1)
    store = PatternStore()
    simulate_batch(sel, pattern_store=store, steps_per_period=GRIDS[0], **kw)  # decompositions
    n_per = n_transient + 100
    runs = {}
    print(f"\n2. default grid: {len(sel)} points, {n_per} periods from rest, one thread, "
          "decompositions cached")
    print(f"{'grid':>5} {'time [s]':>9} {'checks/period':>14} {'switches/period':>16} "
          f"{'median dist to 128':>19} {'points > 1e-6':>14} {'> 1e-3':>7} {'stick fraction':>15}")
    for g in GRIDS:
        t0 = time.perf_counter()
        b = simulate_batch(sel, pattern_store=store, steps_per_period=g, **kw)
        runs[g] = (time.perf_counter() - t0, b.results)
    ref = [r.poincare_state for r in runs[GRIDS[-1]][1]]
    ref_stick = np.array([r.stick_fraction for r in runs[GRIDS[-1]][1]])
    for g in GRIDS:
        wall, res = runs[g]
        d = np.array([rel(r.poincare_state, x) for r, x in zip(res, ref)])
        checks = sum(r.n_checks for r in res) / len(res) / n_per
        events = sum(r.n_events for r in res) / len(res) / n_per
        stick = np.abs(np.array([r.stick_fraction for r in res]) - ref_stick).max()
        print(f"{g:>5} {wall:>9.2f} {checks:>14.0f} {events:>16.1f} {np.median(d):>19.1e} "
              f"{int((d > 1e-6).sum()):>14} {int((d > 1e-3).sum()):>7} {stick:>15.1e}")
    t4, t16 = runs[4][0], runs[16][0]
    print(f"time_ratio_16_over_4={t16 / t4:.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--every", type=int, default=16, help="every n-th point of the default grid")
    ap.add_argument("--transient", type=int, default=40, help="periods before the 100 recorded")
    args = ap.parse_args()
    against_rk4()
    default_grid(args.every, args.transient)


if __name__ == "__main__":
    main()

"""The rigid stick as the limit of the penalty (Jenkins) interface: trajectories, cost, and what
the limit does to the largest Lyapunov exponent.

    .venv/bin/python benchmarks/rigid_stick_limit.py            (about 5 minutes, 2 threads)

Prints three tables (docs/model.md section 6 and docs/lyapunov.md record them):

1. **Trajectories**: Poincare states of the penalty model at ``k_t`` = 1e2, 1e3, 1e4 against the
   rigid stick (same ``omega`` and ``f0``; two modes, 3 periods from rest), for ``mu_s = mu_k``
   and for ``mu_s = 1.5 mu_k``; the rigid run's own step error (step factors 0.25 / 0.125).
2. **Cost**: one RK4 run of 20 periods per law at the default grid's chaotic-band point
   (``Omega = 1.85``, ``f0_rel = 2``, ``mu_s / mu_k = 0.45 / 0.3``), step factor 1.
3. **Benettin's exponent against the initial separation** ``e0`` at that point (60 periods
   after 100 of transient, renormalised every period): a well-defined exponent does not depend
   on ``e0``; one that grows as ``e0`` shrinks (about ``log(1/e0)``) measures jumps of the
   separation, i.e. a flow that is not Lipschitz there.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import beamsim  # noqa: F401  (first: pins BLAS threads before numpy loads)
from analysis.lyapunov.beam import attractor_scale, beam_benettin, response_scale
from beamsim.simulate import prepare_point, simulate, simulate_batch

BAND = dict(n_modes=2, Omega=1.85, f0_rel=2.0, mu_s=0.45, mu_k=0.3, interface_viscosity=0.0939)


def rel(a, b) -> float:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max() / np.abs(b).max())


def trajectories() -> None:
    print("1. penalty -> rigid stick (two modes, Omega = 1.5, f0_rel = 3 of the rigid f_cr, 3 periods)")
    print(f"{'mu_s/mu_k':>10} {'rigid step err':>15} {'k_t':>8} {'coords':>9} {'velocities':>11}")
    for mus in (0.3, 0.45):
        kw = dict(n_modes=2, mu_s=mus, mu_k=0.3, interface_viscosity=0.0939)
        pr = prepare_point(law="rigid-stick", Omega=1.5, f0_rel=3.0, **kw)
        base = dict(kw, omega=pr.omega, f0=pr.f0, n_transient=0, n_record=3, method="rk4")
        ref = np.asarray(simulate(law="rigid-stick", step_factor=0.25, **base).poincare_state)
        fine = np.asarray(simulate(law="rigid-stick", step_factor=0.125, **base).poincare_state)
        n = pr.model.n
        for kt in (1e2, 1e3, 1e4):
            pen = np.asarray(simulate(law="stick-slip", k_t=kt, step_factor=0.5, **base).poincare_state)
            print(f"{mus / 0.3:>10.2f} {rel(ref, fine):>15.1e} {kt:>8.0e} "
                  f"{rel(pen[:, :n], ref[:, :n]):>9.1e} {rel(pen[:, n:], ref[:, n:]):>11.1e}")


def cost() -> None:
    print("\n2. one RK4 run, 20 periods, step factor 1, band point (best of 2)")
    print(f"{'law':>22} {'steps/period':>13} {'switches':>9} {'time':>8}")
    for law, kw in (("stick-slip k_t=10", dict(law="stick-slip")),
                    ("stick-slip k_t=1000", dict(law="stick-slip", k_t=1000.0)),
                    ("rigid-stick", dict(law="rigid-stick"))):
        best = math.inf
        for _ in range(2):
            t = time.perf_counter()
            r = simulate(n_transient=0, n_record=20, method="rk4", step_factor=1.0, **BAND, **kw)
            best = min(best, time.perf_counter() - t)
        print(f"{law:>22} {r.steps_per_period:>13} {r.n_events:>9} {best:>7.2f}s")


def exponents(threads: int) -> None:
    e0s = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9)
    print("\n3. Benettin lambda_1 T (per forcing period, 60 periods) against e0, band point")
    print(f"{'law':>22} " + " ".join(f"{e:>7.0e}" for e in e0s) + f" {'time':>7}")
    for law, kw in (("stick-slip k_t=10", dict(law="stick-slip")),
                    ("stick-slip k_t=100", dict(law="stick-slip", k_t=100.0)),
                    ("stick-slip k_t=1000", dict(law="stick-slip", k_t=1000.0)),
                    ("rigid-stick", dict(law="rigid-stick")),
                    ("rigid-stick mu_s=mu_k", dict(law="rigid-stick", mu_s=0.3))):
        t = time.perf_counter()
        P = dict(BAND, **kw)
        pp = prepare_point(**P)
        r = simulate_batch([P], n_transient=100, n_record=20, method="rk4", step_factor=1.0,
                           n_threads=threads)[0]
        scale = attractor_scale(r.poincare_state, response_scale(pp), pp.omega)[None]
        T = 2 * math.pi / pp.omega
        vals = [beam_benettin([pp], r.final_state[None], scale, n_periods=60, e0=e0,
                              n_threads=threads)[0].value * T for e0 in e0s]
        print(f"{law:>22} " + " ".join(f"{v:>7.3f}" for v in vals)
              + f" {time.perf_counter() - t:>6.0f}s", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", choices=("trajectories", "cost", "exponents"), default=None)
    args = ap.parse_args()
    if args.only in (None, "trajectories"):
        trajectories()
    if args.only in (None, "cost"):
        cost()
    if args.only in (None, "exponents"):
        exponents(args.threads)


if __name__ == "__main__":
    main()

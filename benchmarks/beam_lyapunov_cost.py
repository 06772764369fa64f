"""Cost of one lambda_1 per beam grid point: Stefanski vs Benettin (and the reference run).

For a few points of the default grid's region (one-mode model, mu_s / mu_k = 1.5) and two
three-mode points (weakly and strongly chaotic) the reference trajectory is integrated
(``n_transient + n_record`` periods, pipeline numerics), then from its final state, each timed
separately after a warm-up call that compiles the kernels:

* Benettin: one free copy renormalised every period over ``n_periods`` (what the pipeline
  reports as ``lle_benettin``);
* Stefanski as the pipeline runs it (``d = 0`` tested alone first; ladder and multisection
  only if the free pair's rate exceeds the resolution);
* Stefanski with the full generic search forced (``d = 0`` plus the ladder, then multisection
  rounds of 8 couplings): the cost at a chaotic point, where the shortcut does not apply.

Prints a Markdown table with wall times (2 threads unless ``--threads``) and the ratios to
Benettin.  Usage::

    .venv/bin/python benchmarks/beam_lyapunov_cost.py [--threads 2] [--n-periods 30]
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analysis.lyapunov.beam import attractor_scale, beam_benettin, beam_lle, response_scale
from beamsim.simulate import prepare_point, simulate_batch

BASE = dict(mu_s=0.45, mu_k=0.3, n_modes=1, interface_damping=0.5)   # the pipeline's model
POINTS = [
    ("stuck (torus), N=1", dict(BASE, Omega=2.5, f0_rel=0.8)),
    ("period-1 slip, N=1", dict(BASE, Omega=1.5, f0_rel=2.64)),
    ("period-m slip, N=1", dict(BASE, Omega=5.0, f0_rel=1.05)),
    ("quasi-periodic slip, N=1", dict(BASE, Omega=4.0, f0_rel=1.3)),
    ("weakly chaotic, N=3", dict(BASE, n_modes=3, Omega=1.5, f0_rel=2.64)),
    ("chaotic, N=3, mu_s/mu_k=3", dict(BASE, n_modes=3, mu_s=0.9, Omega=1.5, f0_rel=2.2)),
]


def _wall(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--n-periods", type=int, default=30)
    ap.add_argument("--n-transient", type=int, default=100)
    ap.add_argument("--n-record", type=int, default=128)
    args = ap.parse_args(argv)
    kw = dict(n_periods=args.n_periods, n_threads=args.threads)

    # warm-up (compilation)
    p0 = POINTS[1][1]
    r0 = simulate_batch([p0], n_transient=0, n_record=2, method="rk4", step_factor=1.0)[0]
    pp0 = prepare_point(**p0)
    sc0 = attractor_scale(r0.poincare_state, response_scale(pp0), pp0.omega)[None]
    beam_lle([pp0], r0.final_state[None], sc0, n_periods=2, n_threads=args.threads)
    beam_benettin([pp0], r0.final_state[None], sc0, n_periods=2, n_threads=args.threads)

    print(f"| point | reference run s ({args.n_transient}+{args.n_record} periods) | Benettin s | "
          f"Stefanski (pipeline) s | ratio | Stefanski (full search) s | ratio | "
          f"lambda_1 T Stefanski / Benettin | verdict |")
    print("|---|---|---|---|---|---|---|---|---|")
    tot = np.zeros(4)
    for name, p in POINTS:
        t_ref, res = _wall(lambda: simulate_batch([p], n_transient=args.n_transient,
                                                  n_record=args.n_record, method="rk4",
                                                  step_factor=1.0, n_threads=args.threads)[0])
        pp = prepare_point(**p)
        x = res.final_state[None]
        sc = attractor_scale(res.poincare_state, response_scale(pp), pp.omega)[None]
        T = 2 * math.pi / pp.omega
        t_b, ben = _wall(lambda: beam_benettin([pp], x, sc, **kw)[0])
        t_s, st = _wall(lambda: beam_lle([pp], x, sc, with_benettin=False, **kw)[0].stefanski)
        t_f, full = _wall(lambda: beam_lle([pp], x, sc, with_benettin=False, zero_first=False,
                                           **kw)[0].stefanski)
        tot += (t_ref, t_b, t_s, t_f)
        print(f"| {name} | {t_ref:.2f} | {t_b:.2f} | {t_s:.2f} | {t_s / t_b:.1f} | {t_f:.2f} | "
              f"{t_f / t_b:.1f} | {st.value * T:.4f} / {ben.value * T:.4f} | {st.verdict[:48]} |")
    print(f"\nTotal: reference {tot[0]:.1f} s, Benettin {tot[1]:.1f} s, Stefanski (pipeline) "
          f"{tot[2]:.1f} s (x{tot[2] / tot[1]:.1f}), Stefanski (full search) {tot[3]:.1f} s "
          f"(x{tot[3] / tot[1]:.1f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""How long must the Benettin record be, and how long its blocks, for the label's exponent?

Runs the reference (expo, the pipeline's transient and record) at ``--points`` random points
of the default grid, then the renormalised free copy of the Lyapunov stage for ``--periods``
periods, and evaluates block plans on the same records (docs/lyapunov.md, section 10): for each
plan the verdict counts (positive / non-positive / undetermined), the periods spent (the
adaptive extension), and for every point that is not a plain "non-positive" its rate over the
whole record (the reference) beside each plan's verdict.

    .venv/bin/python benchmarks/lle_block_plans.py            # 40 points, 225 periods, ~7 min
    .venv/bin/python benchmarks/lle_block_plans.py --points 10 --periods 125
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import yaml

from analysis.lyapunov.beam import attractor_scale, initial_offset, response_scale
from analysis.lyapunov.block_statistics import BOUNDARIES, UNDETERMINED, BlockPlan
from analysis.pipeline.config import Numerics
from analysis.pipeline.plan import build_plan
from beamsim.coupled_copies import run_copies
from beamsim.simulate import prepare_point, simulate_batch

ROOT = Path(__file__).resolve().parents[1]
#: (block, burn_in, min_blocks) of the plans compared; max_blocks fills ``--periods``
PLANS = ((25, 25, 3), (10, 5, 2), (5, 5, 4))


def verdict_of(plan: BlockPlan, record: np.ndarray, period: float) -> tuple[str, int]:
    """Verdict and periods used by the adaptive rule on a precomputed record."""
    st = plan.sequential(record, period)
    return st.verdict, st.burn_in + st.n_periods


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=40)
    ap.add_argument("--periods", type=int, default=225)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--boundary", default="obrien-fleming", choices=BOUNDARIES,
                    help="sequential boundary of the looks (docs/lyapunov.md section 10; the "
                         "table there was measured with every look at 95 %%: none)")
    a = ap.parse_args()

    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    cfg["grid_file"] = str(ROOT / "config" / "grid.yaml")
    plan = build_plan(cfg, ROOT / "workflow" / "schemas")
    nm: Numerics = plan.numerics
    pts = plan.points["default"]
    pick = sorted(np.random.default_rng(a.seed).choice(len(pts), a.points, replace=False))
    params = [pts[i].params for i in pick]
    t0 = time.perf_counter()
    res = simulate_batch(params, n_transient=nm.n_transient, n_record=nm.n_record, method="expo",
                         n_threads=a.threads).results
    t_sim = time.perf_counter() - t0
    pp = [prepare_point(**p) for p in params]
    starts = np.stack([r.final_state for r in res])
    scales = np.stack([attractor_scale(r.poincare_state, response_scale(q), q.omega)
                       for r, q in zip(res, pp)])
    offs = np.stack([initial_offset(q, s, 1e-6, 0)[None] for q, s in zip(pp, scales)])
    t0 = time.perf_counter()
    le = run_copies(pp, starts, offs, np.zeros((len(pp), 1)), 1 / scales,
                    renorm_period=np.ones((len(pp), 1), np.bool_), n_periods=a.periods, e0=1e-6,
                    band=(1e-2, 1e2), step_factor=nm.lyapunov.step_factor, n_threads=a.threads)[:, 0]
    t_lle = time.perf_counter() - t0
    periods = np.array([2 * np.pi / q.omega for q in pp])
    print(f"{a.points} points: reference runs {t_sim:.1f} s, free copy over {a.periods} periods "
          f"{t_lle:.1f} s ({a.threads * t_lle / a.points / a.periods * 1e3:.1f} core-ms per "
          f"point-period, {a.threads} threads)")
    plans = [BlockPlan(block=b, burn_in=bi, min_blocks=mb, max_blocks=(a.periods - bi) // b,
                       boundary=a.boundary)
             for b, bi, mb in PLANS if bi + mb * b <= a.periods]
    results = {}
    for pl in plans:
        out = [verdict_of(pl, r, T) for r, T in zip(le, periods)]
        results[pl] = out
        counts = {v: sum(o[0] == v for o in out) for v in ("positive", "non-positive", UNDETERMINED)}
        spent = sum(o[1] for o in out)
        print(f"blocks {pl.block:>2} burn-in {pl.burn_in:>2} min {pl.min_blocks}: {counts}, "
              f"{spent} point-periods ({spent / (25 * a.points):.1f} x a 25-period window each)")
    burn = 25
    print(f"\npoints not plainly non-positive (reference: rate per period over periods {burn}-{a.periods}):")
    for k in range(a.points):
        verdicts = [results[pl][k] for pl in plans]
        if all(v == "non-positive" for v, _ in verdicts):
            continue
        ref = (le[k, a.periods] - le[k, burn]) / (a.periods - burn)
        desc = ", ".join(f"b{pl.block}: {v} @ {n}" for pl, (v, n) in zip(plans, verdicts))
        print(f"  Omega {params[k]['Omega']:.3f} f0_rel {params[k]['f0_rel']:.3f}: "
              f"lambda_1 T = {ref:+.3f}; {desc}")


if __name__ == "__main__":
    main()

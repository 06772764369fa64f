"""Error rates, power and length of the long record's sequential test per boundary.

The label's exponent is decided by looks after ``min_blocks .. max_blocks`` blocks of one
Benettin record (``analysis.lyapunov.block_statistics.BlockPlan.sequential``), each look's
interval at the level of the group-sequential boundary ``numerics.lyapunov.boundary``
(docs/lyapunov.md, section 10).  This runs the shipped plan with each boundary on synthetic
records -- a rate ``lambda_1 T`` per forcing period plus independent per-period noise, i.e.
independent normal block rates, the case the boundaries are calibrated for -- and prints, per
true rate and noise: the verdicts (positive / non-positive / undetermined, in %), the mean
periods run, and how often the interval the record stopped at holds the true rate.

    .venv/bin/python benchmarks/lle_sequential_boundaries.py            # 1000 records, seconds
    .venv/bin/python benchmarks/lle_sequential_boundaries.py --records 200
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from analysis.lyapunov.block_statistics import (  # noqa: E402
    BOUNDARIES,
    NON_POSITIVE,
    POSITIVE,
    UNDETERMINED,
    BlockPlan,
)

T = 2.0 * np.pi
#: (true lambda_1 T per period, per-period noise): a torus with noisy and quiet blocks, the
#: margin, weak and strong chaos, a contracting record
CASES = ((0.0, 1.0), (0.0, 0.3), (0.05, 1.0), (0.1, 0.6), (0.15, 0.6), (0.3, 1.0), (-0.05, 0.3))


def record(lam_T: float, n: int, noise: float, seed: int) -> np.ndarray:
    """``ln eps`` at the period ends ``0 .. n`` of a separation growing at ``lam_T`` per period
    with independent per-period fluctuations of size ``noise``."""
    steps = lam_T + noise * np.random.default_rng(seed).standard_normal(n)
    return np.concatenate([[np.log(1e-6)], np.log(1e-6) + np.cumsum(steps)])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--records", type=int, default=1000, help="records per case and boundary")
    a = ap.parse_args()
    print("lambda_1 T, noise | " + " | ".join(BOUNDARIES)
          + "  (positive / non-positive / undetermined %, mean periods, stopping interval holds %)")
    for lam, noise in CASES:
        row = []
        for boundary in BOUNDARIES:
            plan = BlockPlan(boundary=boundary)
            stats = [plan.sequential(record(lam, plan.max_periods, noise, seed), T)
                     for seed in range(a.records)]
            share = {v: 100.0 * np.mean([s.verdict == v for s in stats])
                     for v in (POSITIVE, NON_POSITIVE, UNDETERMINED)}
            periods = np.mean([s.burn_in + s.n_periods for s in stats])
            holds = 100.0 * np.mean([s.per_period[2] <= lam <= s.per_period[3] for s in stats])
            row.append(f"{share[POSITIVE]:.1f} / {share[NON_POSITIVE]:.1f} / {share[UNDETERMINED]:.1f}"
                       f", {periods:.0f}, {holds:.1f}")
        print(f"{lam:g}, {noise:g} | " + " | ".join(row), flush=True)


if __name__ == "__main__":
    main()

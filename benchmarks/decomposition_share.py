"""How much of an ``expo`` start-up trajectory is stick-pattern decompositions.

The benchmark's start-up case (``benchmarks/simulate.py``: three modes, ``f0 = 3 f_cr``,
``Omega = 1.5``, 2 + 4 periods, ``expo`` at 16 output steps per period) runs with a fresh
:class:`beamsim.pattern_store.PatternStore`, so every stick pattern it visits is decomposed,
and then again with the store the first run filled, so none is.  The two runs are the same
trajectory (checked to the bit), so their time difference is the decompositions' cost.  For
scale, LAPACK's ``dgeev`` (:func:`beamsim.kernels.real_eig.real_eig`) and ``np.linalg.eig`` plus
the eigenvector inverse are timed on a random matrix of the patterns' size.

    .venv/bin/python benchmarks/decomposition_share.py      # seconds

Results: docs/performance.md, "Where the time goes".
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from beamsim.kernels.real_eig import real_eig
from beamsim.pattern_store import PatternStore
from beamsim.simulate import prepare_point, simulate_batch

sys.path.insert(0, str(Path(__file__).resolve().parent))
# benchmarks/simulate.py: its start-up case and its best-of timing
from simulate import CASES, timed  # noqa: E402

POINT = CASES["start-up"]["point"]
RUN = dict(n_transient=2, n_record=4, method="expo", steps_per_period=16, n_threads=1)
ROUNDS = 7


def main() -> None:
    simulate_batch([POINT], **RUN)  # compile or load the kernels
    cold, warm = [], []
    for _ in range(ROUNDS):  # interleaved
        store = PatternStore()
        t = time.perf_counter()
        first = simulate_batch([POINT], pattern_store=store, **RUN).results[0]
        cold.append(time.perf_counter() - t)
        t = time.perf_counter()
        again = simulate_batch([POINT], pattern_store=store, **RUN).results[0]
        warm.append(time.perf_counter() - t)
    same = (np.array_equal(first.final_state, again.final_state)
            and np.array_equal(first.poincare_state, again.poincare_state))
    share = (min(cold) - min(warm)) / min(cold)
    print(f"expo start-up: {1e3 * min(cold):.1f} ms with {first.n_patterns} decompositions, "
          f"{1e3 * min(warm):.1f} ms with {again.n_patterns} (same trajectory: {same}); "
          f"decompositions {100 * share:.0f} %, "
          f"{1e3 * (min(cold) - min(warm)) / max(first.n_patterns, 1):.2f} ms each")
    n = 2 * prepare_point(**POINT).model.n  # the first-order matrix of the start-up model
    a = np.random.default_rng(0).standard_normal((n, n))
    real_eig(a)
    print(f"random {n} x {n}: real_eig (dgeev) {1e3 * timed(lambda: real_eig(a), 200)[1]:.3f} ms, "
          f"np.linalg.eig + inverse {1e3 * timed(lambda: np.linalg.inv(np.linalg.eig(a)[1]), 200)[1]:.3f} ms")


if __name__ == "__main__":
    main()

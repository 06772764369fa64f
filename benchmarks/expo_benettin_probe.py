"""Probe: can the Lyapunov stage's long Benettin record run on ``expo`` instead of RK4?

The Lyapunov stage (RK4 drive and free copy at step factor 0.5) is two thirds of a map's time
(docs/performance.md), and ``expo`` integrates a period about 10x faster.  This probe runs the
Benettin pair on ``expo`` -- drive and copy one period at a time through the public API, the
copy renormalised to ``e0`` at every period end after adopting the drive's stick/slip state with
the drive's elastic strain (the rule of ``beamsim.kernels.copies.adopt_modes``) -- on points of
the default grid, and compares the mean log growth per period with the RK4 pipeline's
``lambda_1 T`` at step factors 0.5 and 0.25.

Run:  .venv/bin/python benchmarks/expo_benettin_probe.py [--points N] [--periods P]

It simulates its points first (the pipeline's simulate stage, 2 threads) and runs the RK4
Lyapunov stage at both steps for the comparison, so it takes several minutes.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analysis.lyapunov.beam import attractor_scale, response_scale
from analysis.pipeline.config import as_numerics
from analysis.pipeline.grid import expand_grid, point_id
from analysis.pipeline.stages import lyapunov_points, poincare_array, simulate_points
from beamsim.simulate import prepare_point, simulate


def expo_benettin(params: dict, start: np.ndarray, scale: np.ndarray, n_burn: int, n_periods: int,
                  e0: float = 1e-6, seed: int = 0) -> tuple[float, float]:
    """Mean and standard error (over 25-period blocks) of the log growth per period of an
    ``expo`` Benettin pair from ``start`` (a final state: q, v, z, stick/slip modes)."""
    pp = prepare_point(**params)
    n, nq = pp.model.n, pp.model.n_quad
    S = pp.model.S
    x = start.copy()
    d = np.random.default_rng(seed).normal(size=2 * n)
    d *= e0 / math.sqrt(np.mean(d ** 2))
    y = x.copy()
    y[:2 * n] += d * scale
    inv = 1.0 / scale
    logs = []

    def state(v):
        return dict(q0=v[:n], v0=v[n:2 * n], z0=v[2 * n:2 * n + nq], mode0=v[2 * n + nq:])

    for k in range(n_burn + n_periods):
        rx = simulate(method="expo", n_transient=0, n_record=1, **params, **state(x))
        ry = simulate(method="expo", n_transient=0, n_record=1, **params, **state(y))
        x, y = rx.final_state.copy(), ry.final_state.copy()
        # the drive's stick/slip state with its elastic strain (copies.adopt_modes)
        mx, my = x[2 * n + nq:], y[2 * n + nq:]
        for j in np.nonzero(mx != my)[0]:
            y[2 * n + j] = S[j] @ y[:n] - (S[j] @ x[:n] - x[2 * n + j])
            y[2 * n + nq + j] = mx[j]
        err = math.sqrt(np.mean(((y[:2 * n] - x[:2 * n]) * inv) ** 2))
        if k >= n_burn:
            logs.append(math.log(err / e0))
        fac = e0 / err
        y[:2 * n + nq] = x[:2 * n + nq] + fac * (y[:2 * n + nq] - x[:2 * n + nq])
    blocks = np.array(logs).reshape(-1, 25).mean(axis=1)
    return float(blocks.mean()), float(blocks.std(ddof=1) / math.sqrt(len(blocks)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=100, help="every k-th point of the default grid "
                    "is taken so that about this many remain")
    ap.add_argument("--periods", type=int, default=100, help="measured periods (multiple of 25)")
    args = ap.parse_args(argv)
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    grid = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())["grids"]["default"]
    nm = as_numerics(cfg["numerics"])
    allp = expand_grid("default", grid, cfg["model"], nm.result_dict())
    step = max(1, len(allp) // args.points)
    pts = [{"point_id": point_id(p.params, nm.result_dict()), "params": p.params} for p in allp[::step]]
    with tempfile.TemporaryDirectory() as store:
        sim = simulate_points(pts, nm, store, threads=2)
        lya = {}
        for sf in (0.5, 0.25):
            c = dict(cfg["numerics"])
            c["lyapunov"] = dict(c["lyapunov"], step_factor=sf)
            lya[sf] = lyapunov_points(pts, sim, as_numerics(c), f"{store}/sf{sf}", threads=2)
    sim = sim.set_index("point_id")
    T = 2 * math.pi / sim["omega"]
    lam = {sf: (t.set_index("point_id")["lle_mean"] * T) for sf, t in lya.items()}
    # the points where the RK4 record measured a positive exponent, and as many others
    measured = lam[0.5].dropna()
    pos = measured[measured > 0.05].index.tolist()
    rest = [p for p in measured.index if p not in pos][:len(pos)]
    print(f"{len(pos)} points with lambda_1 T > 0.05 at step factor 0.5, {len(rest)} others")
    print("Omega   f0_rel   RK4 0.5   RK4 0.25   expo (se)          expo s / point")
    for pid in pos + rest:
        r = sim.loc[pid]
        params = next(p["params"] for p in pts if p["point_id"] == pid)
        pp = prepare_point(**params)
        scale = attractor_scale(poincare_array(r["poincare_state"]), response_scale(pp), pp.omega)
        t0 = time.perf_counter()
        m, se = expo_benettin(params, np.asarray(r["final_state"], float), scale, 25, args.periods)
        dt = time.perf_counter() - t0
        print(f"{params['Omega']:6.3f} {params['f0_rel']:7.3f} {lam[0.5][pid]:9.3f} "
              f"{lam[0.25][pid]:9.3f}   {m:7.3f} ({se:.3f})   {dt:8.1f}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The Lyapunov stage's free copy on ``expo`` against the RK4 pair: same exponents, how much faster?

The label's exponent is the block statistics of a renormalised two-trajectory (Benettin)
record (docs/lyapunov.md, section 10).  Until results version 8 drive and copy ran on RK4 at
step factor 0.5; ``numerics.lyapunov.method: auto`` (the default) runs them on ``expo``
(:mod:`beamsim.kernels.expo_copies`: each trajectory exact between its own located switches)
with the separation ``expo_e0 = 1e-4``.  This script measures, on the pipeline's own stages:

1. **the stage**: every k-th point of the default grid (``--points``, default 100) through the
   simulate stage once, then the Lyapunov stage twice -- free copy on RK4 (``method: rk4``,
   ``e0 = 1e-6``, the stage of results version 8) and on ``expo`` -- with the stage times, side by side
   in one process, and per point the exponent ``lambda_1 T``, its interval and verdict, and the
   label from the classifier; ``--rk4-quarter`` adds the RK4 pair at step factor 0.25 (the
   reference of the RK4 pair's own step convergence);
2. **the separation** (``--e0-points``, default 4): why ``1e-4``: the mean log growth per period
   (125 periods, the last 100) of the ``expo`` pair at ``e0`` = 1e-6 ... 1e-3 against the RK4
   pair at 1e-6 and 1e-4, at the first measured points of part 1 and the two period-1 points of the
   band where ``expo`` at 1e-6 failed up to results version 21 (there ``expo``'s rounding
   opened about 1e-6 of the attractor in a period; near the slip onset far more:
   docs/lyapunov.md sections 12 and 16; version 22 removed its source, section 17);
3. **the grazing cell** (skip with ``--no-grazing``): the two attractors of the multistability
   test's cell (``Omega = 1.378``, ``f0_rel = 0.858``, below the slip onset), where the way a
   copy takes the drive's stick/slip state decides the exponent: ``expo`` with the adoption
   window (half the RK4 step of step factors 0.5, 0.25, 0.125) and on its output grid against
   the RK4 pair at those three steps.

Run:  .venv/bin/python benchmarks/expo_lyapunov.py [--points N] [--e0-points K] [--rk4-quarter]
      [--no-grazing]

About 8 minutes with the defaults on 2 cores (numba kernels compiled).  The last line is
``lyapunov_stage_speedup=<x>`` (RK4 stage time / expo stage time).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from analysis.lyapunov.beam import attractor_scale, initial_offset, response_scale  # noqa: E402
from analysis.pipeline.config import as_numerics  # noqa: E402
from analysis.pipeline.grid import expand_grid, point_id  # noqa: E402
from analysis.pipeline.stages import (  # noqa: E402
    classify_points,
    lle_resolution,
    lyapunov_points,
    simulate_points,
)
from beamsim.coupled_copies import EXPO_COPY_STEPS_PER_PERIOD, run_copies  # noqa: E402
from beamsim.simulate import prepare_point, simulate_batch  # noqa: E402

#: period-1 points of the band where the expo pair at e0 = 1e-6 reads +0.55 and +0.71
FLOOR_POINTS = ({"Omega": 1.378, "f0_rel": 1.396}, {"Omega": 1.378, "f0_rel": 1.843})


def stage(points, sim, nm, store, threads):
    t0 = time.perf_counter()
    lya = lyapunov_points(points, sim, nm, store, threads=threads)
    return lya, time.perf_counter() - t0


def record_study(title, starts, variants, threads, periods=125):
    """Mean and standard error (4 blocks of 25 after 25 periods) of the log growth per period
    of free copies from ``starts`` (``(prepared, final state, scale)`` triples), one column per
    variant ``(name, method, e0, run_copies keywords)``."""
    pps = [s[0] for s in starts]
    xs = np.stack([s[1] for s in starts])
    sc = np.stack([s[2] for s in starts])
    P = len(pps)
    rows = {}
    for name, method, e0, kw in variants:
        off = np.stack([initial_offset(pp, s, e0)[None] for pp, s in zip(pps, sc)])
        t0 = time.perf_counter()
        le = run_copies(pps, xs, off, np.zeros((P, 1)), 1 / sc, n_periods=periods, e0=e0,
                        band=(1e-2, 1e2), renorm_period=np.ones((P, 1), np.bool_), method=method,
                        n_threads=threads, **kw)[:, 0]
        blocks = np.diff(le[:, 25::25], axis=1) / 25
        rows[name] = (blocks.mean(axis=1), blocks.std(axis=1, ddof=1) / math.sqrt(blocks.shape[1]),
                      time.perf_counter() - t0)
    print(f"\n{title}: lambda_1 T, mean (standard error) of 4 blocks of 25 periods after 25")
    for k, (m, se, t) in rows.items():
        print(f"{k:>26s} " + "  ".join(f"{m[i]:+7.3f} ({se[i]:.3f})" for i in range(P)) + f"   {t:6.1f} s")


def _settled(params_list, threads):
    res = simulate_batch(params_list, n_transient=600, n_record=64, method="expo", n_threads=threads)
    pps = [prepare_point(**p) for p in params_list]
    return [(pp, r.final_state, attractor_scale(r.poincare_state, response_scale(pp), pp.omega))
            for r, pp in zip(res, pps)]


def e0_study(params_list, threads):
    """The separation: expo at 1e-6 ... 1e-3 against the RK4 pair at 1e-6 and 1e-4."""
    print("\npoints: " + ", ".join(f"({p['Omega']:.3f}, {p['f0_rel']:.3f})" for p in params_list))
    record_study("separation study", _settled(params_list, threads),
                 [(f"expo {e0:g}", "expo", e0, {}) for e0 in (1e-6, 1e-5, 1e-4, 1e-3)]
                 + [("RK4 1e-6", "rk4", 1e-6, {"step_factor": 0.5}),
                    ("RK4 1e-4", "rk4", 1e-4, {"step_factor": 0.5})], threads)


def grazing_study(threads):
    """The two attractors of the multistability test's cell (below the slip onset, where the
    tractions graze their limits): the adoption of the drive's stick/slip state by window
    (half the RK4 step of ``step_factor``) and by grid against the RK4 pair at three steps."""
    from analysis.multistability import perturbed_starts
    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import simulate_runs

    cell = dict(n_modes=2, mu_s=0.45, mu_k=0.3, p=1e-4, k_t=10.0, damping=0.0,
                interface_damping=0.5, law="stick-slip", alpha1=0.005, alpha2=0.005, beta=0.4,
                bc="clamped-free", Omega=1.37828978659, f0_rel=0.857634334011)
    starts = [{}] + perturbed_starts(cell, 3, seed=0, amplitude=0.3)
    pts = [{"point_id": f"s{k}", "params": dict(cell) | dict(s)} for k, s in enumerate(starts)]
    sims = simulate_runs([pts[0], pts[2]], Numerics(), threads)  # one start per attractor
    pp = prepare_point(**cell)
    settled = [(pp, np.asarray(r["final_state"], float),
                attractor_scale(np.asarray(r["poincare_state"], float), response_scale(pp), pp.omega))
               for r in sims]
    print("\ngrazing cell Omega = 1.378, f0_rel = 0.858 (tests/analysis/test_multistability.py): "
          "the attractor from rest, and the other")
    record_study("grazing cell", settled,
                 [(f"expo window, step factor {sf}", "expo", 1e-4, {"step_factor": sf})
                  for sf in (0.5, 0.25, 0.125)]
                 + [(f"expo grid (every T / {EXPO_COPY_STEPS_PER_PERIOD})", "expo", 1e-4,
                     {"adoption": "grid"})]
                 + [(f"RK4 step factor {sf}", "rk4", 1e-6, {"step_factor": sf})
                    for sf in (0.5, 0.25, 0.125)], threads)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=100, help="about this many points of the default "
                    "grid (every k-th)")
    ap.add_argument("--e0-points", type=int, default=4, help="points of the separation study "
                    "(0: skip it)")
    ap.add_argument("--rk4-quarter", action="store_true", help="also the RK4 pair at step factor 0.25")
    ap.add_argument("--no-grazing", action="store_true", help="skip the grazing cell's study")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args(argv)
    warnings.filterwarnings("ignore", module="nolds")  # its short-series notes, one per point
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    grid = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())["grids"]["default"]
    nm = as_numerics(cfg["numerics"])
    variants = {"RK4": replace(nm, lyapunov=replace(nm.lyapunov, method="rk4")),
                "expo": replace(nm, lyapunov=replace(nm.lyapunov, method="expo"))}
    if args.rk4_quarter:
        variants["RK4/2"] = replace(nm, lyapunov=replace(nm.lyapunov, method="rk4", step_factor=0.25))
    allp = expand_grid("default", grid, cfg["model"], nm.result_dict())
    step = max(1, len(allp) // args.points)
    pts = [{"point_id": point_id(p.params, nm.result_dict()), "params": p.params} for p in allp[::step]]
    print(f"{len(pts)} points (every {step}th of the default grid), {args.threads} threads")
    with tempfile.TemporaryDirectory() as store:
        t0 = time.perf_counter()
        sim = simulate_points(pts, nm, store, threads=args.threads)
        print(f"simulate stage: {time.perf_counter() - t0:.1f} s", flush=True)
        out, times = {}, {}
        for name, v in variants.items():
            # same point ids for every variant: a store per variant
            lya, times[name] = stage(pts, sim, v, f"{store}/{name.replace('/', '_')}", args.threads)
            out[name] = (lya.set_index("point_id"),
                         classify_points(sim, lya, lle_threshold=lle_resolution(v)).set_index("point_id"))
            print(f"Lyapunov stage, free copy on {name}: {times[name]:.1f} s", flush=True)
    simi = sim.set_index("point_id")
    ids = [p["point_id"] for p in pts]
    T = 2 * math.pi / simi.loc[ids, "omega"]
    measured = [i for i in ids if np.isfinite(out["RK4"][0].loc[i, "lle_se"])]
    print(f"\n{len(measured)} points with a long record (the others: periodic, linear or "
          "unsettled records, exempt)")
    hdr = "  ".join(f"{k + ' lambda_1 T [interval]':>30s} {'label':>14s}" for k in variants)
    print(f"Omega   f0_rel  {hdr}")
    for i in measured:
        cells = []
        for k in variants:
            ly, cl = out[k][0].loc[i], out[k][1].loc[i]
            lab = cl["label"] + (f"-{int(cl['period'])}" if cl["label"] == "periodic" else "")
            cells.append(f"{ly['lle_mean'] * T[i]:+7.3f} [{ly['lle_lo'] * T[i]:+.3f}, "
                         f"{ly['lle_hi'] * T[i]:+.3f}] {lab:>14s}")
        p = next(q["params"] for q in pts if q["point_id"] == i)
        print(f"{p['Omega']:6.3f} {p['f0_rel']:7.3f}  " + "  ".join(cells))
    ref = out["RK4"]
    for k in variants:
        if k == "RK4":
            continue
        same_v = sum(out[k][0].loc[i, "lle_verdict"] == ref[0].loc[i, "lle_verdict"] for i in measured)
        same_l = sum(out[k][1].loc[i, "label"] == ref[1].loc[i, "label"]
                     and (out[k][1].loc[i, "label"] != "periodic"
                          or out[k][1].loc[i, "period"] == ref[1].loc[i, "period"]) for i in ids)
        d = np.array([(out[k][0].loc[i, "lle_mean"] - ref[0].loc[i, "lle_mean"]) * T[i] for i in measured])
        print(f"\n{k} vs RK4: exponent verdicts {same_v}/{len(measured)} the same, labels "
              f"{same_l}/{len(ids)} the same; |delta lambda_1 T| median {np.median(np.abs(d)):.4f}, "
              f"90 % {np.quantile(np.abs(d), 0.9):.4f}, max {np.abs(d).max():.4f}")
    if args.e0_points > 0:
        first = [next(q["params"] for q in pts if q["point_id"] == i) for i in measured[:args.e0_points]]
        base = {k: v for k, v in first[0].items() if k not in ("Omega", "f0_rel")} if first else {}
        if not first:
            base = {k: v for k, v in pts[0]["params"].items() if k not in ("Omega", "f0_rel")}
        e0_study(first + [dict(base, **fp) for fp in FLOOR_POINTS], args.threads)
    if not args.no_grazing:
        grazing_study(args.threads)
    print(f"\nlyapunov_stage_speedup={times['RK4'] / times['expo']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

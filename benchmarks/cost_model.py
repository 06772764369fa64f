"""Measure the pipeline's cost per forcing period (the coefficients of analysis.pipeline.cost).

The cost of a point depends on its regime (``expo`` crosses a stuck interval in one exact step
but locates every switch of a slipping one; the Lyapunov stage's Stefanski search ends early on
a contracting attractor and runs its full ladder on a chaotic one), so the coefficients are
measured on the workload the pipeline ships: 8 points drawn (seed 0) from the default grid of
``config/grid.yaml`` (its friction and axes; the mode count varied), run through the pipeline's
stage functions (:func:`analysis.pipeline.stages.simulate_points`, :func:`lyapunov_points`) as
one batch on one thread with the default numerics, after a warm-up that compiles the kernels.
The coefficient is ``seconds / sum(periods / Omega)`` over the batch, with the nominal periods
(``n_transient + n_record``, the Stefanski window ``n_periods``), so it carries the sample's
adaptive transients, continuation checks and long records; the cost model adds expected shares
of those on top, and this (not the periods actually run, tried on 2026-11-25: the estimate of
the default run fell to 19 min against 39 min measured) keeps the estimate near the measured
default run (docs/reliability.md).  The Lyapunov stage is measured with its free copy on
``expo`` and on RK4.  RK4 costs the same per
step whatever the regime, so its coefficient comes from a short run (40 periods) of the same
points.  Also measured: the store's bytes per point (the disk-space check before a run).

Usage::

    .venv/bin/python benchmarks/cost_model.py            # measure and print (minutes)
    .venv/bin/python benchmarks/cost_model.py --write    # ... and update the cost model
    .venv/bin/python benchmarks/cost_model.py --laws     # RK4's steps by friction law (seconds)
"""

from __future__ import annotations

import argparse
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

from analysis.pipeline.config import Numerics
from analysis.pipeline.cost import COST_MODEL_FILE
from analysis.pipeline.grid import expand_grid, point_id
from analysis.pipeline.stages import compile_kernels, lyapunov_points, simulate_points

N_POINTS = 8


def sample_points(n_modes: int) -> list[dict]:
    """``N_POINTS`` points of the shipped default grid (seed 0), with ``n_modes`` modes."""
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    grid = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())["grids"]["default"]
    points = expand_grid("default", grid, cfg["model"], Numerics().result_dict())
    pick = np.random.default_rng(0).choice(len(points), N_POINTS, replace=False)
    return [dict(points[i].params, n_modes=n_modes) for i in sorted(pick)]


def _bytes(folder: str) -> int:
    return sum(f.stat().st_size for f in Path(folder).rglob("*") if f.is_file())


def run_batch(n_modes: int, nm: Numerics, lyapunov: bool) -> dict:
    """Seconds of each stage for the sample (an empty store), the nominal periods over
    ``Omega`` (``sim_periods``: ``n_transient + n_record``; ``lyapunov_periods``, per free
    copy's integrator: the Stefanski window ``n_periods``), store bytes."""
    params = sample_points(n_modes)
    pts = [{"point_id": point_id(p, nm.result_dict()), "params": p} for p in params]
    out = {}
    with tempfile.TemporaryDirectory() as store:
        t0 = time.perf_counter()
        sim = simulate_points(pts, nm, store)
        out["simulate"] = time.perf_counter() - t0
        inv_omega = float((1.0 / sim["Omega"]).sum())
        out["sim_periods"] = (nm.n_transient + nm.n_record) * inv_omega
        if lyapunov:
            out["lyapunov"], out["lyapunov_periods"] = {}, {}
            for free in ("expo", "rk4"):
                v = replace(nm, lyapunov=replace(nm.lyapunov, method=free))
                t0 = time.perf_counter()
                lyapunov_points(pts, sim, v, f"{store}/{free}")
                out["lyapunov"][free] = time.perf_counter() - t0
                out["lyapunov_periods"][free] = nm.lyapunov.n_periods * inv_omega
        out["bytes_per_point"] = (_bytes(store) - _bytes(f"{store}/rk4")) / len(pts) if lyapunov \
            else _bytes(store) / len(pts)
    return out


#: the laws of :func:`rk4_by_law` at Fig 13's middle point (docs/pipeline.md, "The velocity band
#: of the regularised laws"): the paper runs' model, three modes
LAW_POINT = {"n_modes": 3, "Omega": 1.5, "f0_rel": 1.3333, "mu_s": 0.3, "mu_k": 0.3, "p": 1e-4,
             "interface_damping": 0.5}
LAWS = {"stick-slip": {}, "stribeck": {"law": "stribeck", "F_s": 3e-5, "F_c": 1.5e-5, "v_s": 4e-4},
        "full-slip": {"law": "full-slip"}}


def rk4_by_law(periods: int = 20) -> None:
    """RK4's steps per period and cost per step by friction law at one point (step factor 1,
    one thread), beside :func:`analysis.pipeline.cost.rk4_stiffness`, which scales the RK4
    coefficients by the steps (docs/reliability.md, "RK4's step follows the point's
    stiffness")."""
    from analysis.pipeline.cost import rk4_stiffness
    from beamsim.simulate import simulate_batch

    print("| law | steps per period | us per step | rk4_stiffness |")
    print("|---|---|---|---|")
    for name, extra in LAWS.items():
        p = LAW_POINT | extra
        simulate_batch([p], n_transient=0, n_record=1, method="rk4", step_factor=1.0, n_threads=1)
        t0 = time.perf_counter()
        r = simulate_batch([p], n_transient=0, n_record=periods, method="rk4", step_factor=1.0,
                           n_threads=1)[0]
        us = 1e6 * (time.perf_counter() - t0) / (periods * r.steps_per_period)
        print(f"| {name} | {r.steps_per_period} | {us:.2f} | {rk4_stiffness(p):.2f} |", flush=True)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", type=int, nargs="*", default=[1, 2, 3])
    ap.add_argument("--write", action="store_true", help=f"update {COST_MODEL_FILE.name}")
    ap.add_argument("--laws", action="store_true",
                    help="only RK4's steps and cost per step by friction law (seconds)")
    args = ap.parse_args(argv)
    warnings.filterwarnings("ignore", category=RuntimeWarning, module="nolds")  # short series
    if args.laws:
        rk4_by_law()
        return 0

    for stage in ("simulate", "lyapunov"):
        compile_kernels(stage, methods=("expo", "rk4"))
    model: dict = {"simulate": {"expo": {}, "rk4": {}}, "lyapunov": {"expo": {}, "rk4": {}},
                   "bytes_per_point": {}}
    print("| stage | method | n_modes | sum of periods / Omega | seconds (8 points) "
          "| c [s per period at Omega = 1] |")
    print("|---|---|---|---|---|---|")
    for n_modes in args.modes:
        default = Numerics(method="expo")
        # a fixed-length RK4 run: no adaptive transient, no continuation check (both need the
        # classifier's 128 samples)
        short = Numerics(method="rk4", n_transient=10, n_record=30, n_transient_max=10,
                         continuation_check=False)
        for nm, lyap in ((default, True), (short, False)):
            secs = run_batch(n_modes, nm, lyap)
            c = secs["simulate"] / secs["sim_periods"]
            model["simulate"][nm.method][n_modes] = round(c, 6)
            print(f"| simulate | {nm.method} | {n_modes} | {secs['sim_periods']:.0f} "
                  f"| {secs['simulate']:.1f} | {c:.5f} |", flush=True)
            if lyap:
                model["bytes_per_point"][n_modes] = int(secs["bytes_per_point"])
                # the free copy on expo (the default, auto) and on RK4, same simulated records
                for free, t in secs["lyapunov"].items():
                    c = t / secs["lyapunov_periods"][free]
                    model["lyapunov"][free][n_modes] = round(c, 6)
                    print(f"| lyapunov | {free} free copy | {n_modes} "
                          f"| {secs['lyapunov_periods'][free]:.0f} | {t:.1f} | {c:.5f} |", flush=True)
    print(yaml.safe_dump(model, sort_keys=True))
    if args.write:
        header = ("# Seconds per forcing period and point at Omega = 1, one thread, compiled kernels\n"
                  "# (analysis.pipeline.cost).  Written by benchmarks/cost_model.py --write; do not\n"
                  "# edit by hand.  Per nominal period (simulate: n_transient + n_record; lyapunov:\n"
                  "# n_periods, by the free copy's integrator, rk4 at step 0.5);\n"
                  "# bytes_per_point: the store's records of one point (both stages).\n")
        COST_MODEL_FILE.write_text(header + yaml.safe_dump(model, sort_keys=True))
        print(f"wrote {COST_MODEL_FILE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""What the switches of an ``expo`` run are: every element's stick/slip changes, logged.

``expo`` counts its switches (``SimResult.n_events``) but does not say what they are.  This script
runs a copy of :func:`beamsim.kernels.expo.run_point`'s loop (the same kernels: pattern lookup,
projection, ``_interval``, the Zeno guard) that also logs, after every interval that ends on a
switch, each element whose mode changed, and prints per point: switches per forcing period,
per element, and the median stick and slip phase (time between an element's consecutive
switches, in forcing periods) over the recorded periods.  The stick statistics of the kernel
are not tallied (not needed here); the trajectory is the kernel's.

    .venv/bin/python benchmarks/switch_log.py                     # the default grid's model
    .venv/bin/python benchmarks/switch_log.py --set k_t=30        # another stick stiffness
    .venv/bin/python benchmarks/switch_log.py --set interface_viscosity=0   # no dashpot

Results: docs/performance.md, "Probes on the rocketlake host" ("What the switches are").
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path

import numpy as np
import yaml
from numba import njit

import beamsim.simulate as bs
from beamsim.kernels import common, expo
from beamsim.kernels.bundles import point_at, schedule_at
from beamsim.pattern_store import cache_slots, model_keys

#: default-grid cells (``Omega``, ``f0_rel``): two slipping periodic cells, a locked one
CELLS = ((4.451505, 1.301893), (1.37829, 1.214404), (2.246431, 1.132794))
ROOT = Path(__file__).resolve().parents[1]


@functools.cache
def _grid_points() -> tuple:
    """The default grid's points as the pipeline makes them
    (:func:`analysis.pipeline.grid.expand_grid`)."""
    from analysis.pipeline.config import as_numerics
    from analysis.pipeline.grid import expand_grid

    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    grid = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())["grids"]["default"]
    return tuple(expand_grid("default", grid, config["model"], as_numerics(config["numerics"])))


def grid_point(omega: float, f0_rel: float) -> dict:
    """The parameters of the default grid's point nearest (``Omega``, ``f0_rel``):
    ``config/config.yaml``'s model with the grid's fixed values, the interface dashpot among
    them (a point without it has none)."""
    def distance(p) -> float:
        return abs(p.params["Omega"] - omega) + abs(p.params["f0_rel"] - f0_rel)

    return dict(min(_grid_points(), key=distance).params)


@njit
def _run_logged(stk, steps, n_sub, models, out, cache, p, logbuf):
    """``expo.run_point`` of point ``p`` with every mode change logged into ``logbuf`` rows
    ``(t, element, old mode, new mode)``; returns ``(switches logged, Zeno-guard windows)``."""
    pt = point_at(stk, p, False)
    sched = schedule_at(steps, p)
    x, tally, _ = common.start_point(p, stk.x0[p], pt, sched, out)
    expo.use_model(cache, models[p])
    wk = expo.new_scratch(pt, n_sub, np.zeros(expo.N_COUNTERS, np.int64))
    window = expo.zeno_window(pt.om)
    slot = np.int64(-1)
    t0 = 0.0
    nlog = 0
    zeno = 0
    prev = x.mode.copy()
    for step in range((sched.n_trans + sched.n_rec) * sched.n_per):
        t_end = (step + 1) * sched.h
        guard = 0
        t_win = t0
        while True:
            if slot < 0:
                slot = expo._pattern_slot(cache, wk, x, pt)
                expo.project(cache, slot, wk, x, pt)
            t0, switched = expo._interval(t0, t_end, slot, cache, wk, x, pt, tally)
            if not switched:
                break
            for j in range(x.mode.shape[0]):
                if x.mode[j] != prev[j]:
                    if nlog < logbuf.shape[0]:
                        logbuf[nlog, 0] = t0
                        logbuf[nlog, 1] = j
                        logbuf[nlog, 2] = prev[j]
                        logbuf[nlog, 3] = x.mode[j]
                    nlog += 1
                    prev[j] = x.mode[j]
            t_win, guard = expo.zeno_count(t0, t_win, guard, window)
            slot = -1
            if guard > expo.zeno_limit(x.z.shape[0]):  # as expo._step: accept, resume later
                zeno += 1
                t0 = min(t_win + window, t_end)
                if t0 >= t_end:
                    break
                t_win = t0
                guard = 0
        if common.end_of_step(p, step + 1, t_end, x, tally.ecum, pt, sched, out):
            break
    return nlog, zeno


def switch_log(point: dict, n_transient: int, n_record: int, steps_per_period: int = 16,
               max_rows: int = 4_000_000):
    """The prepared point and its switch log over the whole run (rows ``(t, element, old mode,
    new mode)``), and the number of Zeno-guard windows."""
    prepared = [bs.prepare_point(**point)]
    n, nq = prepared[0].model.n, prepared[0].model.n_quad
    stk = bs.stack_points(prepared, 1e6)
    sched = bs._schedule(prepared, "expo", steps_per_period, 0.5, 0, n_transient, n_record, stk.divl)
    out = bs._outputs(1, n, nq, n_record, 1, False)
    cache = expo.new_cache(n, nq, cache_slots(2048, n))
    logbuf = np.zeros((max_rows, 4))
    m, zeno = _run_logged(stk, sched, 4, model_keys(stk), out, cache, 0, logbuf)
    if m > max_rows:
        raise RuntimeError(f"{m} switches: more than the log's {max_rows} rows")
    return prepared[0], logbuf[:m], zeno


def summary(pp, log: np.ndarray, n_transient: int, n_record: int) -> dict:
    """Switches per forcing period (all, per element) and the median stick and slip phase (in
    forcing periods) over the recorded periods."""
    period = 2 * np.pi / pp.omega
    rec = log[log[:, 0] > n_transient * period]
    stick, slip = [], []
    for j in range(pp.model.n_quad):
        e = rec[rec[:, 1] == j]
        for a, b in zip(e[:-1], e[1:]):
            (stick if a[3] == 0 else slip).append((b[0] - a[0]) / period)
    return {"per_period": len(rec) / n_record,
            "per_element": [int(np.sum(rec[:, 1] == j)) / n_record for j in range(pp.model.n_quad)],
            "stick_median": float(np.median(stick)) if stick else float("nan"),
            "slip_median": float(np.median(slip)) if slip else float("nan")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--transient", type=int, default=200)
    ap.add_argument("--record", type=int, default=64)
    ap.add_argument("--set", nargs="*", default=[], help="point parameters KEY=VALUE (floats)")
    args = ap.parse_args()
    over = {k: float(v) for k, v in (kv.split("=", 1) for kv in args.set)}
    for omega, f0_rel in CELLS:
        point = grid_point(omega, f0_rel) | over
        pp, log, zeno = switch_log(point, args.transient, args.record)
        s = summary(pp, log, args.transient, args.record)
        print(f"Omega {omega:.3f}, f0_rel {f0_rel:.3f} {over or ''}: {s['per_period']:.0f} switches per "
              f"period, per element {[round(v) for v in s['per_element']]}; median stick phase "
              f"{s['stick_median']:.2e} T, slip phase {s['slip_median']:.2e} T; Zeno-guard windows {zeno}",
              flush=True)


if __name__ == "__main__":
    main()

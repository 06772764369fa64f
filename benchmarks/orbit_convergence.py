"""Do the map's regular orbits converge in the mode count, the stick stiffness and the
interface points?

The convergence evidence's ``modes + 1`` and ``k_t x 3`` rows say whether a cell's *label*
holds under one refinement (docs/pipeline.md); this measures how far the *orbit* moves along a
ladder of values of one knob, at the cells where there is an orbit to compare: period-1 cells
of a finished map that slip in their record, whose label every grid neighbour shares
(``neighbours_same == n_neighbours``: docs/pipeline.md "Neighbour support") and whose map run
settled within ``--max-settle`` transient periods.  Stuck cells are left out: their motion is
the linear forced response of the bonded beam plus its undamped free vibration.

Each cell runs from rest at every value of ``--knob`` (``n_modes``: 2 ... 7 by default;
``k_t``: 10 ... 1000; ``n_quad``, the interface points, which otherwise follow the mode count:
8 ... 32) at the map's *physical* load and frequency (the row's ``f0`` and
``omega``: ``f_cr`` and ``omega_1`` change with either knob, so fixed ``f0_rel`` and ``Omega``
would be other physical points), every other parameter the map's, on ``expo`` (exact between
switches, so a stiffer stick costs switches, not steps) for ``--transient`` periods, then
``--record`` periods recorded, the last one sampled 64 times.  Against the last value it
prints, per cell and value:

* ``wave``: the largest difference of the tip deflection ``w`` over the last period, relative
  to its peak-to-peak amplitude (the whole waveform, phase included);
* ``amp``: the relative difference of that amplitude;
* ``diss``: of the friction dissipation per forcing period (the record's mean);
* ``stick``: the fraction of the interface stuck over the record (``stick_fraction``: quadrature-
  weighted, time-averaged; absolute difference);
* ``spread``: the spread of ``w`` over the record's Poincare samples relative to the
  amplitude (near 0: the run is on a period-1 orbit too).

and a summary over the cells (median and largest).

    .venv/bin/python benchmarks/orbit_convergence.py --table results/regimes/default.parquet
    .venv/bin/python benchmarks/orbit_convergence.py --table ... --knob k_t --cells 16
    .venv/bin/python benchmarks/orbit_convergence.py --table ... --knob n_modes --values 3 4 6
    .venv/bin/python benchmarks/orbit_convergence.py --table ... --knob n_modes --set n_quad=28

Results: docs/pipeline.md, "The regular orbits under more modes and a stiffer stick".
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import pandas as pd
import yaml

from beamsim.simulate import simulate_batch

SAMPLES = 64  # dense samples of the last recorded period


def regular_cells(table: pd.DataFrame, n: int, seed: int, max_settle: int) -> pd.DataFrame:
    """``n`` period-1 cells (seeded draw, sorted by frequency and load) that slip in their
    record, whose label every grid neighbour shares and whose map run settled within
    ``max_settle`` transient periods."""
    ok = ((table["label"] == "periodic") & (table["period"] == 1) & (table["stick_fraction"] < 1.0)
          & (table["n_neighbours"] > 0) & (table["neighbours_same"] == table["n_neighbours"])
          & (table["n_transient_used"] <= max_settle))
    cells = table[ok]
    if len(cells) == 0:
        raise SystemExit("no slipping period-1 cell whose label every neighbour shares in the table")
    cells = cells.sample(min(n, len(cells)), random_state=seed)
    return cells.sort_values(["Omega", "f0_rel"])


#: the knobs and their default ladders (the reference last)
KNOBS = {"n_modes": (2, 3, 4, 5, 6, 7), "k_t": (10.0, 30.0, 100.0, 300.0, 1000.0),
         "n_quad": (8, 12, 16, 24, 32)}


def run_cells(cells: pd.DataFrame, knob: str, values: list, transient: int, record: int,
              threads: int, fixed: dict | None = None) -> list[list[dict]]:
    """Per cell, per value of ``knob`` (one batch per value: a batch has one model size), at
    the map rows' physical load and frequency, with the parameters ``fixed`` set at every
    value."""
    out: list[list[dict]] = [[] for _ in range(len(cells))]
    for value in values:
        t0 = time.perf_counter()
        pts = [{k: v for k, v in json.loads(row["params_json"]).items() if k not in ("f0_rel", "Omega")}
               | (fixed or {}) | {knob: value, "f0": float(row["f0"]), "omega": float(row["omega"])}
               for _, row in cells.iterrows()]
        res = simulate_batch(pts, n_transient=transient, n_record=record, method="expo",
                             dense_per_period=SAMPLES, n_threads=threads)
        for i, r in enumerate(res):
            w = np.asarray(r.dense)[-(SAMPLES + 1):, 0]  # tip deflection over the last period
            amp = float(np.ptp(w))
            out[i].append({"value": value, "w": w, "amp": amp, "diss": float(np.mean(r.diss_per_cycle)),
                           "stick": float(r.stick_fraction),
                           "spread": float(np.ptp(np.asarray(r.poincare_tip)[:, 0])) / amp,
                           "f_cr": float(r.f_cr), "diverged": bool(r.diverged)})
        print(f"  {knob} = {value:g}: {time.perf_counter() - t0:.0f} s", flush=True)
    return out


def compare(rows: list[dict]) -> list[dict]:
    """Each value against the last (``diss`` NaN where the reference run no longer slips)."""
    ref = rows[-1]
    return [{"value": r["value"], "wave": float(np.abs(r["w"] - ref["w"]).max()) / ref["amp"],
             "amp": r["amp"] / ref["amp"] - 1.0,
             "diss": r["diss"] / ref["diss"] - 1.0 if ref["diss"] > 0 else np.nan,
             "stick": r["stick"] - ref["stick"], "spread": r["spread"]} for r in rows]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--table", default="results/regimes/default.parquet", help="a finished map")
    ap.add_argument("--cells", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--knob", choices=sorted(KNOBS), default="n_modes")
    ap.add_argument("--values", type=float, nargs="+", default=None,
                    help="the ladder, the reference last (default: the knob's, see KNOBS)")
    ap.add_argument("--max-settle", type=int, default=1000,
                    help="only cells whose map run settled within this many transient periods")
    ap.add_argument("--transient", type=int, default=None,
                    help="transient periods (default: the cells' largest settling time + 400)")
    ap.add_argument("--record", type=int, default=32)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a model parameter fixed at every value (repeatable), e.g. n_quad=28")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    fixed = {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in args.set)}
    values = sorted(set(args.values or KNOBS[args.knob]))
    if args.knob in ("n_modes", "n_quad"):
        values = [int(v) for v in values]
    name = args.knob
    table = pd.read_parquet(args.table)
    cells = regular_cells(table, args.cells, args.seed, args.max_settle)
    transient = args.transient or int(cells["n_transient_used"].max()) + 400
    print(f"{len(cells)} slipping period-1 cells whose neighbours share the label "
          f"(map: {int((table['label'] == 'periodic').sum())} periodic of {len(table)}); "
          f"{name} = {values} against {values[-1]:g}{', with ' + str(fixed) if fixed else ''}, "
          f"{transient} + {args.record} periods from rest "
          f"(the map's runs settled after {int(cells['n_transient_used'].min())}-"
          f"{int(cells['n_transient_used'].max())})")
    allrows = []
    runs = run_cells(cells, name, values, transient, args.record, args.threads, fixed)
    for (_, row), rows in zip(cells.iterrows(), runs):
        print(f"Omega {row['Omega']:.3f}, f0_rel {row['f0_rel']:.3f} (map: stick "
              f"{row['stick_fraction']:.2f}; f_cr at {name} = {values[0]:g}..{values[-1]:g}: "
              f"{rows[0]['f_cr']:.4g}..{rows[-1]['f_cr']:.4g})")
        if any(r["diverged"] for r in rows):
            print(f"  diverged at {name} =", [r["value"] for r in rows if r["diverged"]])
            continue
        for c in compare(rows):
            print(f"  {name}={c['value']:g}: wave {c['wave']:.4f}  amp {c['amp']:+.4f}  "
                  f"diss {c['diss']:+.4f}  stick {c['stick']:+.3f}  spread {c['spread']:.1e}")
            allrows.append(c)
    df = pd.DataFrame(allrows)
    print(f"summary over the cells, against {name} = {values[-1]:g} (median / largest of |value|):")
    for v, g in df[df["value"] < values[-1]].groupby("value"):
        parts = [f"{k} {g[k].abs().median():.4f} / {g[k].abs().max():.4f}"
                 for k in ("wave", "amp", "diss", "stick")]
        settled = int((g["spread"] <= 1e-2).sum())
        print(f"  {name}={v:g}: " + ", ".join(parts) + f"; spread <= 1e-2 at {settled}/{len(g)}")


if __name__ == "__main__":
    main()

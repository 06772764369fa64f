"""``expo``'s noise floor: the separation sweep at a grazing cell, and the floor over a finished map.

Part 1 (``--sweep``): at the default map's period-1 cell ``Omega`` 1.25, ``f0_rel`` 1.057 (from
rest through its table's 1424-period transient), four free copies (seeds 0-3) renormalised
every period (and within it when they leave ``[1e-2, 1e2] e0``, ``beam_lle``'s band), on the
``expo`` pair and on the RK4 pair (step factor 0.5), at separations
``1e-3`` ... ``1e-7``: their growth per forcing period (after 10 of 60 periods).  A record that
measures a fixed noise ``N`` grows by ``ln(N / e0)``; a dynamical exponent does not depend on
``e0``.  Also the cell's floor (:func:`analysis.lyapunov.noise_floor.expo_noise_floor`).  Up to
results version 21 the ``expo`` pair's growth rose by ``ln 10`` per decade of ``e0`` here
(section 16); since version 22, whose ``expo`` forms the interface tractions' modal load per
stick pattern (section 17), it does not.

Part 2 (default): the floor at every cell of a finished map, from the end states its Lyapunov
stage started from (the simulate chunks): quartiles, the cells above ``expo_floor * expo_e0``
by label, and, for those, the integrator the table's exponent columns came from and whether a
period-test cell's window or Stefanski value exceeds the margin.

    .venv/bin/python benchmarks/noise_floor.py --sweep      # about 1 minute
    .venv/bin/python benchmarks/noise_floor.py              # results/regimes/default, seconds

Needs ``snakemake -c2 regimes`` first for part 2; reads ``config/config.yaml``'s numerics.
Results: docs/lyapunov.md, sections 16 and 17.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.lyapunov.beam import attractor_scale, initial_offset, response_scale
from analysis.lyapunov.noise_floor import expo_noise_floor
from analysis.pipeline.config import as_numerics
from analysis.pipeline.stages import poincare_array, reference_run, register_cached_modes
from beamsim.coupled_copies import run_copies
from beamsim.simulate import prepare_point

ROOT = Path(__file__).resolve().parents[1]
GRAZING = dict(n_modes=3, mu_s=0.45, mu_k=0.3, interface_viscosity=0.0939, Omega=1.25,
               f0_rel=1.05666829058)
GRAZING_TRANSIENT = 1424


def sweep() -> None:
    """Part 1: growth per period against the separation, both pairs, at the grazing cell."""
    r = reference_run(GRAZING, as_numerics({}), n_transient=GRAZING_TRANSIENT, n_record=256)
    pp = prepare_point(**GRAZING)
    scale = attractor_scale(r.poincare_state, response_scale(pp), pp.omega)
    print(f"floor at the grazing cell: {expo_noise_floor([pp], r.final_state[None], scale[None])[0]:.2e}")
    for method in ("expo", "rk4"):
        for e0 in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7):
            offs = np.stack([initial_offset(pp, scale, e0, seed) for seed in range(4)])[None]
            t0 = time.perf_counter()
            le = run_copies([pp], r.final_state[None], offs, np.zeros((1, 4)), 1.0 / scale[None],
                            n_periods=60, e0=e0, renorm_period=np.ones((1, 4), np.bool_), method=method,
                            step_factor=0.5, band=(1e-2, 1e2))
            g = np.diff(le[0], axis=1)[:, 10:].mean(axis=1)
            print(f"{method:4s} e0 = {e0:.0e}: growth per period {g.min():+.3f} to {g.max():+.3f} "
                  f"(copies: {np.round(g, 3)}), {time.perf_counter() - t0:.1f} s", flush=True)


def over_map(run: Path, grid: str, config: Path) -> None:
    """Part 2: the floor at every cell of a finished map."""
    register_cached_modes(sorted(str(p) for p in run.glob("modes/*/*.parquet")))
    chunks = sorted(run.glob(f"regimes/{grid}/chunks/*.simulate.parquet"))
    sim = pd.concat([pd.read_parquet(p) for p in chunks]).set_index("point_id")
    table = pd.read_parquet(run / "regimes" / f"{grid}.parquet")
    lopt = as_numerics(yaml.safe_load(config.read_text())["numerics"]).lyapunov
    pps = [prepare_point(**json.loads(p)) for p in table["params_json"]]
    starts = np.stack([np.asarray(sim.loc[pid, "final_state"], dtype=float) for pid in table["point_id"]])
    records = [poincare_array(sim.loc[pid, "poincare_state"]) for pid in table["point_id"]]
    scales = np.stack([attractor_scale(x, response_scale(pp), pp.omega) for x, pp in zip(records, pps)])
    t0 = time.perf_counter()
    floors = np.empty(len(pps))
    for key in sorted({(pp.model.n, pp.model.n_quad) for pp in pps}):  # one call per model size
        idx = [i for i, pp in enumerate(pps) if (pp.model.n, pp.model.n_quad) == key]
        floors[idx] = expo_noise_floor([pps[i] for i in idx], starts[idx], scales[idx])
    print(f"{len(pps)} cells in {time.perf_counter() - t0:.1f} s")
    q = np.quantile(floors, [0.25, 0.5, 0.75])
    print(f"floor quartiles {q[0]:.1e} {q[1]:.1e} {q[2]:.1e}, largest {floors.max():.1e}")
    guard = (lopt.expo_floor or math.inf) * lopt.expo_e0
    T = 2 * np.pi / table["omega"]
    window = np.maximum(table["lle_benettin"], table["lle_stefanski"]) * T
    t = table.assign(floor=floors, exempt=table["lle_verdict"].str.startswith("not measured: periodic"),
                     window_T=window)
    above = t[t["floor"] > guard]
    print(f"above the guard {guard:.0e}: {len(above)} cells {above['label'].value_counts().to_dict()}")
    print("integrator of their exponent columns:", above["lle_free_copy"].value_counts().to_dict())
    print("period-test cells with a window or Stefanski value above the margin:",
          int((t["exempt"] & (t["window_T"] > lopt.margin)).sum()))
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print(above[["Omega", "f0_rel", "label", "floor", "window_T", "lle_free_copy"]]
              .sort_values("floor", ascending=False).to_string(index=False))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sweep", action="store_true", help="part 1 instead of part 2")
    ap.add_argument("--run", default=str(ROOT / "results"), help="results directory of a finished run")
    ap.add_argument("--grid", default="default")
    ap.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    a = ap.parse_args()
    if a.sweep:
        sweep()
    else:
        over_map(Path(a.run), a.grid, Path(a.config))


if __name__ == "__main__":
    main()

"""The RK4 pair's second opinion on a finished map: where does the ``expo`` pair's verdict hold?

The label's exponent is the block statistics of a long renormalised two-trajectory record
(docs/lyapunov.md, section 10), run on the ``expo`` pair; ``numerics.lyapunov.confirm`` has the
RK4 pair measure it again where the ``expo`` interval is not at or below the margin (section
15).  This script takes a finished regime table and its simulate chunks (the end states the
Lyapunov stage started from) and runs the RK4 pair's long record alone
(:func:`analysis.lyapunov.beam.rk4_long_record`, the pipeline's plan, ``e0 = 1e-6``) at each
``--step-factors`` (default 0.5, the pipeline's, and 0.25) on:

* ``periodic``: the period test's periodic cells (no long record in the table, it exempts
  them) whose 25-period window or Stefanski value exceeds the margin -- a periodic label beside
  a positive exponent -- and, for them, the ``expo`` pair's long record too (``beam_lle`` as the
  stage called it before the noise-floor guard: no ``floor_ratio``);
* ``measured``: every cell with a long record whose interval (the table's, from whichever pair
  decided it) is not at or below the margin, or with ``--all-measured`` every cell with a long
  record.

It prints per cell ``lambda_1 T`` with its interval and verdict from each pair, whether the
Poincare record says chaos on its own (:func:`analysis.regimes.poincare_says_chaotic`, the
default rule's test), the cross-table of verdicts, and the RK4 pair's cost per period.

    .venv/bin/python benchmarks/second_opinion.py                 # results/regimes/default
    .venv/bin/python benchmarks/second_opinion.py --step-factors 0.5 --all-measured

About 14 minutes for the default map on one core (50 cells at 0.5 and 0.25; 2026-11-28, a
map without the noise-floor guard).  Needs ``snakemake -c2 regimes`` first; reads
``config/config.yaml``'s numerics.  On a map with the guard (``expo_floor``, the default since
the same day) the ``periodic`` group is empty, because the guarded cells' columns are the RK4
pair's: run the map with ``numerics.lyapunov.expo_floor: null`` to repeat section 15's check.
Results: docs/lyapunov.md, sections 15 and 16.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.lyapunov.beam import attractor_scale, beam_lle, response_scale, rk4_long_record
from analysis.pipeline.config import as_numerics
from analysis.pipeline.stages import poincare_array, register_cached_modes
from analysis.regimes import poincare_says_chaotic
from beamsim.simulate import prepare_point

ROOT = Path(__file__).resolve().parents[1]


def per_period(st, T: float) -> dict:
    """``lambda_1 T``, its interval, the periods measured and the verdict of statistics ``st``."""
    return {"mean": st.mean * T, "lo": st.lo * T, "hi": st.hi * T, "n": st.n_periods, "verdict": st.verdict}


def cells(table: pd.DataFrame, margin: float, all_measured: bool) -> pd.DataFrame:
    """The cells to measure, with their group (``periodic`` or ``measured``)."""
    T = 2 * np.pi / table["omega"]
    measured = table["lle_blocks"].apply(len) > 0
    exempt = table["lle_verdict"].str.startswith("not measured: periodic")
    window = np.maximum(table["lle_benettin"], table["lle_stefanski"]) * T
    periodic = table[exempt & (window > margin)].assign(group="periodic")
    pick = measured if all_measured else measured & ~(table["lle_hi"] * T <= margin)
    return pd.concat([table[pick].assign(group="measured"), periodic])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run", default=str(ROOT / "results"), help="results directory of a finished run")
    ap.add_argument("--grid", default="default")
    ap.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    ap.add_argument("--step-factors", default="0.5,0.25")
    ap.add_argument("--all-measured", action="store_true")
    a = ap.parse_args()
    run = Path(a.run)
    register_cached_modes(sorted(str(p) for p in run.glob("modes/*/*.parquet")))
    chunks = sorted(run.glob(f"regimes/{a.grid}/chunks/*.simulate.parquet"))
    sim = pd.concat([pd.read_parquet(p) for p in chunks]).set_index("point_id")
    table = pd.read_parquet(run / "regimes" / f"{a.grid}.parquet")
    nm = as_numerics(yaml.safe_load(Path(a.config).read_text())["numerics"])
    lopt = nm.lyapunov
    plan = lopt.block_plan()
    todo = cells(table, plan.margin, a.all_measured)
    rows, cost = [], {}
    for _, r in todo.iterrows():
        pp = prepare_point(**json.loads(r["params_json"]))
        x = poincare_array(sim.loc[r["point_id"], "poincare_state"])
        start = np.asarray(sim.loc[r["point_id"], "final_state"], dtype=float)[None]
        scale = attractor_scale(x, response_scale(pp), pp.omega)[None]
        T = 2 * np.pi / pp.omega
        row = {"group": r["group"], "Omega": r["Omega"], "f0_rel": r["f0_rel"], "label": r["label"],
               "chaos_like": poincare_says_chaotic(x), "free_copy": r["lle_free_copy"]}
        if r["group"] == "periodic":
            st = beam_lle([pp], start, scale, n_periods=lopt.n_periods, step_factor=lopt.step_factor,
                          plan=plan, free_method="expo", free_e0=lopt.expo_e0, ladder_method="expo",
                          n_threads=1)[0]
            row |= {f"expo_{k}": v for k, v in per_period(st.statistics, T).items()}
        else:
            row |= {"table_mean": r["lle_mean"] * T, "table_lo": r["lle_lo"] * T, "table_hi": r["lle_hi"] * T}
        for sf in (float(v) for v in a.step_factors.split(",")):
            t0 = time.perf_counter()
            st = rk4_long_record([pp], start, scale, plan=plan, step_factor=sf, n_threads=1)[0]
            c = cost.setdefault(sf, [0.0, 0])
            c[0] += time.perf_counter() - t0
            c[1] += st.n_periods + st.burn_in
            row |= {f"rk4_{sf}_{k}": v for k, v in per_period(st, T).items()}
        rows.append(row)
        print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in row.items()}, flush=True)
    out = pd.DataFrame(rows)
    show = ("display.width", 250, "display.max_rows", 500, "display.float_format", "{:.3f}".format)
    with pd.option_context(*show):
        print(out.to_string(index=False))
    sfs = sorted(cost, reverse=True)
    for g, d in out.groupby("group"):
        left = d["expo_verdict"] if g == "periodic" else d["table_hi"].le(plan.margin).map(
            {True: "non-positive", False: "not non-positive"})
        print(f"\n{g}: {len(d)} cells; verdicts (rows: {'expo pair' if g == 'periodic' else 'table'}; "
              f"columns: RK4 pair at step factor {sfs[0]})")
        print(pd.crosstab(left, d[f"rk4_{sfs[0]}_verdict"]).to_string())
    if len(sfs) > 1:
        print(f"\nRK4 verdicts at {sfs[0]} against {sfs[1]} (all cells):")
        print(pd.crosstab(out[f"rk4_{sfs[0]}_verdict"], out[f"rk4_{sfs[1]}_verdict"]).to_string())
    for sf, (sec, n) in cost.items():
        print(f"RK4 pair at step factor {sf}: {n} periods in {sec:.1f} s, {sec / max(n, 1):.4f} s per period")


if __name__ == "__main__":
    main()

"""Do the stuck records of a finished map stay stuck, and does their free vibration decay?

The classify stage labels a record in which every interface element stays stuck by its
attractor, the forced response (periodic-1), when the stuck beam's exact exponent is negative
(docs/classification.md, rule 3).  That rests on the elements staying stuck while the free
vibration decays.  This script takes every stuck record of a map (``lle_verdict`` the linear
verdict), continues it from its end state for ``--periods`` forcing periods on the pipeline's
reference integrator, recording every period, and reports per cell:

* the stick fraction over the whole continuation (1: no element slipped);
* the spread of the Poincare samples of the generalised coordinates (largest distance from
  their mean, relative to the largest coordinate) over the first and the last ``--window``
  periods: the free vibration's amplitude, which must not grow;
* the map's ``stuck_bound`` (results version 20, ``beamsim.shakedown``): below 1 the record is
  proven never to slip again, so a slip in the continuation would refute the bound.

    .venv/bin/python benchmarks/stuck_records.py                 # results/regimes/default.parquet
    .venv/bin/python benchmarks/stuck_records.py --periods 4000 --cells 40

About 1 s per cell and 1000 periods on one core (stuck records are cheap: no switches).
"""

from __future__ import annotations

import argparse
import glob
import json
import tempfile
import time

import numpy as np
import pandas as pd
import yaml

from analysis.continuation import state_params
from analysis.pipeline.config import Numerics
from analysis.pipeline.grid import point_id
from analysis.pipeline.stages import LINEAR_VERDICT, poincare_array, register_cached_modes, simulate_points
from analysis.pipeline.store import PointStore
from beamsim.point import prepare_point


def spread(x: np.ndarray, n: int) -> float:
    """Largest distance of the coordinate samples ``x[:, :n]`` from their mean, over the
    largest coordinate's magnitude."""
    q = x[:, :n]
    return float(np.max(np.linalg.norm(q - q.mean(axis=0), axis=1)) / np.max(np.abs(q)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", default="results/regimes/default.parquet")
    ap.add_argument("--config", default="config/config.yaml")
    ap.add_argument("--periods", type=int, default=2000)
    ap.add_argument("--window", type=int, default=256)
    ap.add_argument("--cells", type=int, default=0, help="at most this many stuck cells (0: all)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()

    cfg = yaml.safe_load(open(args.config))
    nm = Numerics.from_dict(cfg["numerics"] | {"n_transient": 0, "n_transient_max": 0,
                                                "n_record": args.periods, "continuation_check": False})
    register_cached_modes(sorted(glob.glob("results/modes/*/modes.parquet")))
    table = pd.read_parquet(args.table)
    stuck = table[table["lle_verdict"] == LINEAR_VERDICT]
    if args.cells:
        stuck = stuck.iloc[:: max(1, len(stuck) // args.cells)][: args.cells]
    sims = PointStore("results/store", "simulate")  # the map's own runs (their end states)
    pts, rows = [], []
    for _, r in stuck.iterrows():
        params = json.loads(r["params_json"])
        rec = sims.load(r["point_id"])
        model = prepare_point(**params).model
        state = state_params(np.asarray(rec["final_state"], dtype=float), model.n, model.n_quad)
        cont = params | {k: np.asarray(v, dtype=float).tolist() for k, v in state.items()}
        pts.append({"point_id": point_id(cont, nm), "params": cont})
        rows.append({"Omega": r["Omega"], "f0_rel": r["f0_rel"], "n": model.n, "label": r["label"],
                     "efold_periods": -1.0 / (r["lle_mean"] * 2.0 * np.pi / r["omega"]),
                     "stuck_bound": r.get("stuck_bound", np.nan)})
    print(f"{len(pts)} stuck records of {args.table}, continued {args.periods} periods")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        sim = simulate_points(pts, nm, tmp, threads=args.threads)
    out = pd.DataFrame(rows)
    out["stick_fraction"] = sim["stick_fraction"].to_numpy()
    firsts, lasts = [], []
    for (_, s), n in zip(sim.iterrows(), out["n"]):
        x = poincare_array(s["poincare_state"])
        firsts.append(spread(x[: args.window], n))
        lasts.append(spread(x[-args.window:], n))
    out["spread_first"], out["spread_last"] = firsts, lasts
    out["ratio"] = out["spread_last"] / out["spread_first"]
    print(f"{time.perf_counter() - t0:.0f} s")
    print(out.drop(columns="n").round(6).to_string(index=False))
    ratio = out["ratio"]
    print(f"stayed stuck: {int((out['stick_fraction'] >= 1.0).sum())} of {len(out)}; spread last / first "
          f"window: median {ratio.median():.4f}, range {ratio.min():.4f}-{ratio.max():.4f}")
    # the map's proof (results version 20, beamsim.shakedown): below 1, no element can slip again
    proven = out["stuck_bound"] < 1.0
    slipped = out["stick_fraction"] < 1.0
    print(f"bound below 1: {int(proven.sum())} (of them slipped in the continuation: "
          f"{int((proven & slipped).sum())}, which would refute the bound); bound at or above 1: "
          f"{int((out['stuck_bound'] >= 1.0).sum())} (slipped: {int((~proven & slipped).sum())}); "
          f"no bound: {int(out['stuck_bound'].isna().sum())}")


if __name__ == "__main__":
    main()

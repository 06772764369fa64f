"""Do a map's labels survive a long run?  Each cell's stored end state run on by thousands of periods.

The map labels a cell from a record that starts after the adaptive transient (at most
``numerics.n_transient_max`` periods) and passed the transient tests and the continuation check
(docs/classification.md).  A creep too slow for those tests -- the mean deflection, i.e. the slip
locked into the stuck elements, changing by a few percent of the spread per record
(docs/classification.md, "Record length: what the conflicts are") -- passes them.  This runs
each selected cell on from the end state the map run stored (``results/store``; the forcing's
phase is kept: every run ends on a period boundary) for ``--periods`` forcing periods on the
table's integrator (``method``: ``expo``, or RK4 where the map's run met the Zeno guard) and
step, then through the pipeline's own stages from there
(:func:`analysis.continuation.continue_from`: the adaptive transient, the continuation check,
the Lyapunov record and the classifier, with the run's numerics).  It reports, per cell, the
map's label and the label after the long run, whether the long run ended with every element
stuck (``stuck_end``: no friction work in its last ``TAIL`` periods), the creep of the
mean tip deflection over the long run (the change of the Poincare samples' mean from its first
``BLOCK`` periods to its last, over the tip's amplitude: half the range of a dense history of
``DENSE`` samples per period over ``TAIL`` more periods from the long run's end, a run of its
own, since a dense history sets the integrator's steps) and whether the creep had stopped
(the last two blocks' means within ``1e-3`` of that amplitude); and per map label, how many
labels held.

Cells: every cell of the ``--all`` labels (default chaotic, quasi-periodic, unsettled), and
``--sample`` cells (seed 0) of every other label; or, with ``--min-period m``, every periodic cell
of period ``m`` or more (no other cell).

    .venv/bin/python benchmarks/long_runs.py --run <a finished run's working directory>
    .venv/bin/python benchmarks/long_runs.py --run ... --periods 4000 --sample 10

Needs a finished run (``snakemake -c2 regimes``) with its store.  On two threads (znver3) the
default map's 95 cells took 6.5 min of long runs at 8000 periods and 3 min more to classify
them.  Results:
docs/pipeline.md, "Long runs from the map's end states".
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.continuation import continue_from
from analysis.pipeline.config import as_numerics
from analysis.pipeline.convergence import label_text
from analysis.pipeline.stages import lle_resolution
from analysis.pipeline.store import PointStore
from beamsim.simulate import prepare_point, simulate_batch, state_params

BLOCK = 1000  # periods per block of the creep measure
BATCH = 16  # cells per simulate_batch call (each keeps its whole Poincare record)
TAIL = 100  # periods at the end of the long run that say whether it still slips, and its amplitude
DENSE = 8  # dense samples per period (the amplitude)


def select(table: pd.DataFrame, every: list[str], sample: int, seed: int = 0) -> pd.DataFrame:
    """Every cell of the labels ``every``, ``sample`` cells (seeded, in grid order) of the others."""
    rng = np.random.default_rng(seed)
    keep = []
    for label in sorted(table["label"].unique()):
        ix = table.index[table["label"] == label].to_numpy()
        if label not in every and len(ix) > sample:
            ix = np.sort(rng.choice(ix, sample, replace=False))
        keep.extend(ix.tolist())
    return table.loc[sorted(keep)]


def long_runs(cells: pd.DataFrame, store: PointStore, numerics, periods: int, threads: int) -> list[dict]:
    """Run each cell on from its stored end state by ``periods``: its creep and end state (a
    cell without a stored end state is left out)."""
    jobs = []
    for i, row in cells.iterrows():
        rec = store.find(row["point_id"])
        if rec is None:
            continue
        params = json.loads(row["params_json"])
        model = prepare_point(**params).model
        jobs.append((i, row, params, model, state_params(params, rec["final_state"], model.n)))
    out = []
    for method in sorted({row["method"] for _, row, *_ in jobs}):
        mine = [j for j in jobs if j[1]["method"] == method]
        for k in range(0, len(mine), BATCH):
            part = mine[k:k + BATCH]
            kw = dict(method=method, step_factor=numerics.step_factor, n_threads=threads)
            b = simulate_batch([j[4] for j in part], n_transient=0, n_record=periods, **kw)
            # the tip's amplitude: TAIL more periods with a dense history (a run of its own: a
            # dense history sets the integrator's steps, and the long run is on the map's)
            ends = [j[4] if res.diverged else state_params(j[2], res.final_state, j[3].n)
                    for j, res in zip(part, b.results)]
            dense = simulate_batch(ends, n_transient=0, n_record=TAIL, dense_per_period=DENSE, **kw)
            for (i, row, params, model, _), res, tail in zip(part, b.results, dense.results):
                w = res.poincare_tip[1:, 0]
                amp = float(np.ptp(tail.dense[:, 0])) / 2
                means = w[: periods // BLOCK * BLOCK].reshape(-1, BLOCK).mean(axis=1)
                out.append({"index": i, "params": params, "model": model, "state": res.final_state,
                            "diverged": res.diverged, "drift": float(means[-1] - means[0]) / amp,
                            "stopped": bool(abs(means[-1] - means[-2]) <= 1e-3 * amp),
                            "stuck_end": bool(np.all(res.diss_per_cycle[-TAIL:] == 0.0))})
    return sorted(out, key=lambda r: r["index"])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--run", required=True, help="working directory of a finished run")
    ap.add_argument("--grid", default="default")
    ap.add_argument("--periods", type=int, default=8000, help=f"long run, >= {2 * BLOCK}")
    ap.add_argument("--all", nargs="+", default=["chaotic", "quasi-periodic", "unsettled"])
    ap.add_argument("--sample", type=int, default=20, help="cells of every other label")
    ap.add_argument("--min-period", type=int, default=0,
                    help="instead of --all and --sample: every periodic cell of period >= this")
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    if a.periods < 2 * BLOCK:
        ap.error(f"--periods must be >= {2 * BLOCK}")
    run = Path(a.run)
    numerics = as_numerics(yaml.safe_load((run / "config" / "config.yaml").read_text())["numerics"])
    table = pd.read_parquet(run / "results" / "regimes" / f"{a.grid}.parquet")
    cells = (table[(table["label"] == "periodic") & (table["period"] >= a.min_period)] if a.min_period
             else select(table, a.all, a.sample))
    store = PointStore(run / "results" / "store", "simulate")
    t0 = time.perf_counter()
    runs = long_runs(cells, store, numerics, a.periods, a.threads)
    t_run = time.perf_counter() - t0
    rows = []
    for r in runs:
        row = table.loc[r["index"]]
        after = {"label": "diverged", "period": pd.NA}
        if not r["diverged"]:
            after = continue_from(r["state"], r["model"], [r["params"]], numerics,
                                  lle_threshold=lle_resolution(numerics), threads=a.threads)
        T = 2.0 * np.pi / row["omega"]
        rows.append({"Omega": row["Omega"], "f0_rel": row["f0_rel"],
                     "map": label_text(row["label"], row["period"]),
                     "lle_T": row["lle_mean"] * T, "lock_ratio": row["lock_ratio"],
                     "after": label_text(after["label"], after["period"]),
                     "after_lle_T": after.get("lle_mean", np.nan) * T,
                     "stuck_end": r["stuck_end"], "drift": r["drift"], "stopped": r["stopped"],
                     "conflict": "CONFLICT" in str(row["reason"])})
    out = pd.DataFrame(rows)
    show = ("display.width", 200, "display.max_rows", 500, "display.float_format", "{:.3g}".format)
    with pd.option_context(*show):
        print(out.to_string(index=False))
    print(f"\n{len(out)} cells, {a.periods} periods each: {t_run:.0f} s, classified after "
          f"{time.perf_counter() - t0 - t_run:.0f} s more; {len(cells) - len(out)} selected cells "
          "without an end state in the store (left out)")
    regime = out["map"].str.replace(r"-\d+$", "", regex=True)
    out["group"] = np.where(out["conflict"], "undetermined (CONFLICT)", regime)
    for name, g in out.groupby("group"):
        held = int((g["map"] == g["after"]).sum())
        moves = (g.loc[g["map"] != g["after"], "map"] + " -> " + g.loc[g["map"] != g["after"], "after"])
        print(f"{name}: {held}/{len(g)} held; stuck at the end {int(g['stuck_end'].sum())}; creep stopped "
              f"{int(g['stopped'].sum())}; |drift| median {g['drift'].abs().median():.3g}; moves: "
              + ", ".join(f"{k} {v}" for k, v in moves.value_counts().items()))


if __name__ == "__main__":
    main()

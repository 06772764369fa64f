"""What the map's conflicts are: their aperiodic records read again on longer records.

A cell is ``undetermined`` with a ``CONFLICT`` note when its exponent interval is at or below
the margin (no chaos) but its 256-sample Poincare record has a broadband spectrum and a 0-1
test near 1 (docs/classification.md, rule 2).  This script takes every such cell of a finished
regime table, and for comparison its quasi-periodic and chaotic cells, runs each one's
reference trajectory again from rest to where its kept record starts
(``n_transient_used``) and on for ``--periods`` periods (the pipeline's integrator, one
thread), and reports:

* the classifier's label on the first 256, 512 (the length of the continuation check's
  joined records), 1024 and ``--periods`` samples, with the table's exponent interval (does a
  longer record turn the spectrum into lines?);
* the drift of the mean tip deflection: the means of the record's 256-period blocks, their
  change from the first block to the last and their standard deviation, over the spread of
  the tip deflection (does the record stay stationary?).

The re-run is one continuous run where the pipeline chained several (adaptive transients, the
continuation check): the table's trajectory up to round-off, which a chaotic record amplifies.
The table's spectral growth and K (``growth_table``, ``K_table``) are printed beside the
re-run's first 256 samples' (``growth_256``, ``K_256``): where they differ, the longer record
is another stretch of the same attractor, not the table's record continued.

    .venv/bin/python benchmarks/conflict_records.py            # the default map, ~3 min
    .venv/bin/python benchmarks/conflict_records.py --table results/regimes/default.parquet --periods 1024

Needs the table of a finished run (``snakemake -c2 regimes``) and its numerics
(``config/config.yaml``).  Results: docs/classification.md, "Known limitations" ("Record
length: what the conflicts are").
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.pipeline.config import as_numerics
from analysis.pipeline.stages import reference_run
from analysis.regimes import classify

ROOT = Path(__file__).resolve().parents[1]
BLOCK = 256  # periods per block of the drift measure (the pipeline's record length)


def reread(row: pd.Series, numerics, periods: int) -> dict:
    """Labels of the longer records and the drift of the tip deflection's block means."""
    params = json.loads(row["params_json"])
    T = 2.0 * np.pi / row["omega"]
    lam, lo, hi = (row[k] * T for k in ("lle_mean", "lle_lo", "lle_hi"))
    known = not np.isnan([lam, lo, hi]).any()  # as the classify stage: no statistics, no interval
    r = reference_run(params, numerics, n_transient=int(row["n_transient_used"]), n_record=periods)
    out = {"Omega": row["Omega"], "f0_rel": row["f0_rel"], "label": row["label"], "lle_T": lam,
           "growth_table": row["spectral_growth"], "K_table": row["K"]}
    for n in sorted({BLOCK, 2 * BLOCK, 4 * BLOCK, periods}):  # periods >= 4 BLOCK (main)
        res = classify(r.poincare_state[:n + 1], lle_per_period=lam if known else None,
                       lle_interval=(lo, hi) if known else None, lle_threshold=numerics.lyapunov.margin)
        ind = dict(res.indicators)
        out[f"label_{n}"] = res.label + ("" if res.period is None else f"-{res.period}")
        out[f"growth_{n}"] = float(ind.get("spectral_growth", np.nan))
        out[f"K_{n}"] = float(ind.get("K", np.nan))
    w = r.poincare_tip[1:, 0]
    nb = periods // BLOCK
    means = w[:nb * BLOCK].reshape(nb, BLOCK).mean(axis=1) / np.ptp(w)
    out["drift"] = float(means[-1] - means[0])
    out["block_mean_sd"] = float(means.std())
    return out


def counts(column: pd.Series) -> str:
    """``"label n, label n, ..."`` of a column of labels, most frequent first."""
    return ", ".join(f"{k} {v}" for k, v in column.value_counts().items())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--table", default=str(ROOT / "results" / "regimes" / "default.parquet"))
    ap.add_argument("--config", default=str(ROOT / "config" / "config.yaml"))
    ap.add_argument("--periods", type=int, default=2048, help="record length (>= 1024)")
    a = ap.parse_args()
    if a.periods < 4 * BLOCK:
        ap.error(f"--periods must be >= {4 * BLOCK}")
    numerics = as_numerics(yaml.safe_load(Path(a.config).read_text())["numerics"])
    table = pd.read_parquet(a.table)
    conflict = (table["label"] == "undetermined") & table["reason"].str.contains("CONFLICT")
    groups = {"conflict": table[conflict], "quasi-periodic": table[table["label"] == "quasi-periodic"],
              "chaotic": table[table["label"] == "chaotic"]}
    t0 = time.perf_counter()
    rows = []
    for name, sub in groups.items():
        for _, row in sub.iterrows():
            rows.append({"group": name, **reread(row, numerics, a.periods)})
    out = pd.DataFrame(rows)
    show = ("display.width", 200, "display.max_rows", 500, "display.float_format", "{:.3g}".format)
    with pd.option_context(*show):
        print(out.to_string(index=False))
    print(f"\n{len(out)} cells, {a.periods} periods each, {time.perf_counter() - t0:.0f} s")
    for name, g in out.groupby("group", sort=False):
        drifting = int((g["drift"].abs() > 0.1).sum())
        print(f"{name}: {len(g)} cells; on {a.periods} samples {counts(g[f'label_{a.periods}'])}"
              + f"; on {2 * BLOCK}: {counts(g[f'label_{2 * BLOCK}'])}"
              + f"; on {4 * BLOCK}: {counts(g[f'label_{4 * BLOCK}'])}"
              + f"; mean tip deflection drifting by more than 0.1 of the spread: {drifting}"
              + f" (|drift| median {g['drift'].abs().median():.3g}, max {g['drift'].abs().max():.3g})")


if __name__ == "__main__":
    main()

"""Do the labels of a model variant converge in the interface stiffness and the mode count?

Takes the convergence sample of a finished map (``analysis.pipeline.convergence.sample_points``
on ``results/regimes/<grid>.parquet``: the same points the map's convergence step re-ran),
changes the model of every sampled point by a variant (e.g. ``--set damping=0.01`` for 1 %
modal damping of the structure), runs the variant's own map labels through the pipeline's
stages, then its refinements (default ``k_t`` and ``modes``), and prints how many labels hold
-- the evidence for choosing a model default (docs/pipeline.md, "Convergence evidence").

    .venv/bin/python benchmarks/interface_convergence.py --set damping=0.01
    .venv/bin/python benchmarks/interface_convergence.py --set damping=0.0 --refinements k_t

A few minutes per refinement on 2 cores (20 points); the runs go to a throw-away store.
"""

from __future__ import annotations

import argparse
import glob
import json
import tempfile
import time

import pandas as pd
import yaml

from analysis.pipeline.config import Numerics
from analysis.pipeline.convergence import (
    ConvergenceSettings,
    convergence_runs,
    convergence_summary,
    sample_points,
)
from analysis.pipeline.grid import point_id
from analysis.pipeline.stages import (
    classify_points,
    lle_resolution,
    lyapunov_points,
    register_cached_modes,
    simulate_points,
)
from analysis.pipeline.table import assemble_regime_table


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", default="results/regimes/default.parquet")
    ap.add_argument("--config", default="config/config.yaml")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="model override of the variant (repeatable), e.g. damping=0.01")
    ap.add_argument("--refinements", nargs="+", default=["k_t", "modes"])
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()

    cfg = yaml.safe_load(open(args.config))
    nm = Numerics.from_dict(cfg["numerics"])
    conv = ConvergenceSettings.from_dict(cfg.get("convergence"))
    register_cached_modes(sorted(glob.glob("results/modes/*/modes.parquet")))
    overrides = {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in args.set)}
    sample = sample_points(pd.read_parquet(args.table), conv.sample, conv.seed)
    axes = [a for a in ("Omega", "f0_rel") if a in sample.columns]
    print(f"variant {overrides or 'shipped model'}; {len(sample)} sampled points of {args.table}")

    with tempfile.TemporaryDirectory() as store:
        t0 = time.perf_counter()
        pts = []
        for k, (_, row) in enumerate(sample.iterrows()):
            params = json.loads(row["params_json"]) | overrides
            pts.append({"point_id": point_id(params, nm), "params": params, "index": [k]})
        sim = simulate_points(pts, nm, store, args.threads)
        lyap = lyapunov_points(pts, sim, nm, store, args.threads)
        table = assemble_regime_table(pts, sim, lyap, classify_points(sim, lyap, lle_resolution(nm)))
        print(f"variant map: {time.perf_counter() - t0:.0f} s; labels "
              f"{table['label'].value_counts().to_dict()}; changed against the shipped map: "
              f"{int((table['label'].to_numpy() != sample['label'].to_numpy()).sum())}/{len(table)}")
        runs = []
        every = ConvergenceSettings(sample=len(table), seed=conv.seed)
        for ref in args.refinements:
            t0 = time.perf_counter()
            runs.append(convergence_runs(table, ref, nm, every, store, axes=axes, threads=args.threads))
            print(f"{ref}: {time.perf_counter() - t0:.0f} s")
        summary = convergence_summary(pd.concat(runs, ignore_index=True))
        print(summary[["what", "n", "held", "contradicted", "flips"]].to_string(index=False))


if __name__ == "__main__":
    main()

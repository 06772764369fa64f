"""Snakemake script: the convergence table of one grid (every refinement's runs, in order)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.pipeline.convergence import convergence_summary, write_convergence_table

runs = pd.concat([pd.read_parquet(f) for f in snakemake.input.runs], ignore_index=True)
print(convergence_summary(runs).to_string(), file=sys.stderr)
write_convergence_table(runs, snakemake.output.table, grid_name=snakemake.wildcards.grid,
                        settings=snakemake.params.settings, config_hash=snakemake.params.config_hash)

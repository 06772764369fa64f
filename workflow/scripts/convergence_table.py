"""Snakemake script: the convergence table of one grid (every refinement's runs, in order)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.pipeline.convergence import (
    census_line,
    convergence_summary,
    summary_line,
    write_convergence_table,
)

runs = pd.concat([pd.read_parquet(f) for f in snakemake.input.runs], ignore_index=True)
summary = convergence_summary(runs)
print(summary.to_string(), file=sys.stderr)
print(summary_line(summary), file=sys.stderr)  # the maps' titles give its short form (title_line)
census = census_line(runs, snakemake.params.settings.get("census", []))
if census:  # every cell of the census labels, counted apart (convergence.census)
    print(census, file=sys.stderr)
write_convergence_table(runs, snakemake.output.table, grid_name=snakemake.wildcards.grid,
                        settings=snakemake.params.settings, config_hash=snakemake.params.config_hash)

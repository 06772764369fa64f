"""Snakemake script: one regime table per grid, with config hash and versions in its metadata."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.pipeline.stages import register_cached_modes
from analysis.pipeline.table import assemble_regime_table, write_regime_table


def read(files) -> pd.DataFrame:
    return pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)


inp = snakemake.input
register_cached_modes(inp.modes)  # the lock-up ratio of each point (beamsim.shakedown)
table = assemble_regime_table(snakemake.params.points, read(inp.simulate), read(inp.lyapunov),
                              read(inp.classified))
write_regime_table(table, snakemake.output.table, grid_name=snakemake.wildcards.grid,
                   grid=snakemake.params.grid, config=snakemake.params.config,
                   config_hash=snakemake.params.config_hash)

"""Snakemake script: one regime table per grid, with config hash and versions in its metadata."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

import pandas as pd  # noqa: E402

from analysis.regime_pipeline import assemble_regime_table, write_regime_table  # noqa: E402


def read(files) -> pd.DataFrame:
    return pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)


inp = snakemake.input  # noqa: F821
table = assemble_regime_table(snakemake.params.points, read(inp.simulate), read(inp.lyapunov),  # noqa: F821
                              read(inp.classified))
write_regime_table(table, snakemake.output.table, grid_name=snakemake.wildcards.grid,  # noqa: F821
                   grid=snakemake.params.grid, config=snakemake.params.config,  # noqa: F821
                   config_hash=snakemake.params.config_hash)  # noqa: F821

"""Snakemake script: phase portraits and Poincare maps of the points marked in grid.yaml."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

import pandas as pd  # noqa: E402

from analysis.regime_figures import nearest_rows, plot_portraits  # noqa: E402
from analysis.regime_pipeline import portrait_case, register_cached_modes  # noqa: E402

register_cached_modes(snakemake.input.modes)  # noqa: F821
table = pd.read_parquet(snakemake.input.table)  # noqa: F821
grid = snakemake.params.grid  # noqa: F821
cases = [portrait_case(row, list(grid["axes"]), snakemake.params.numerics)  # noqa: F821
         for row in nearest_rows(table, grid)]
plot_portraits(cases, snakemake.wildcards.grid, snakemake.output.figure,  # noqa: F821
               dpi=snakemake.params.dpi)  # noqa: F821

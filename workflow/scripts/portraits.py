"""Snakemake script: phase portraits and Poincare maps of the points marked in grid.yaml."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.figures.regimes import nearest_rows, plot_portraits
from analysis.pipeline.stages import portrait_case, register_cached_modes

register_cached_modes(snakemake.input.modes)
table = pd.read_parquet(snakemake.input.table)
grid = snakemake.params.grid
cases = [portrait_case(row, list(grid["axes"]), snakemake.params.numerics)
         for row in nearest_rows(table, grid)]
plot_portraits(cases, snakemake.wildcards.grid, snakemake.output.figure,
               dpi=snakemake.params.dpi)

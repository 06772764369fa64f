"""Snakemake script: regime map / bifurcation diagram and lambda_1 map of one grid."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

import pandas as pd  # noqa: E402

from analysis.regime_figures import plot_lle, plot_regimes  # noqa: E402
from analysis.regime_pipeline import lle_resolution  # noqa: E402

table = pd.read_parquet(snakemake.input.table)  # noqa: F821
grid, name, dpi = snakemake.params.grid, snakemake.wildcards.grid, snakemake.params.dpi  # noqa: F821
plot_regimes(table, name, grid, snakemake.output.regimes, dpi=dpi)  # noqa: F821
plot_lle(table, name, grid, snakemake.output.lle, dpi=dpi,  # noqa: F821
         resolution=lle_resolution(snakemake.params.numerics))  # noqa: F821

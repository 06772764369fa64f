"""Snakemake script: regime map / bifurcation diagram and lambda_1 map of one grid."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.figures.regimes import plot_lle, plot_regimes
from analysis.pipeline import cell_attractors
from analysis.pipeline.convergence import census_line, convergence_summary, title_line
from analysis.pipeline.stages import lle_resolution

table = pd.read_parquet(snakemake.input.table)
grid, name, dpi = snakemake.params.grid, snakemake.wildcards.grid, snakemake.params.dpi
runs = [pd.read_parquet(f) for f in snakemake.input.convergence]
# runs without a cell: no sample and no cell of the census labels (convergence.census)
unchecked = ("convergence.sample = 0, no cell of the census labels" if runs
             else snakemake.params.unchecked)
evidence = title_line(convergence_summary(runs[0]) if runs else None, unchecked)
census = census_line(runs[0], snakemake.params.census) if runs else ""
evidence += f"; {census}" if census else ""
attractors = pd.read_parquet(snakemake.input.attractors[0]) if snakemake.input.attractors else None
multistability = cell_attractors.summary_line(cell_attractors.cell_summary(attractors))
lifetimes = pd.read_parquet(snakemake.input.lifetimes[0]) if snakemake.input.lifetimes else None
plot_regimes(table, name, grid, snakemake.output.regimes, dpi=dpi, evidence=evidence + "; " + multistability,
             attractors=attractors, lifetimes=lifetimes)
plot_lle(table, name, grid, snakemake.output.lle, dpi=dpi,
         resolution=lle_resolution(snakemake.params.numerics), evidence=evidence)

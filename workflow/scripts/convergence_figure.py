"""Snakemake script: the convergence figure of one grid."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.figures.convergence import plot_convergence
from analysis.pipeline.convergence import convergence_summary

runs = pd.read_parquet(snakemake.input.table)
plot_convergence(runs, convergence_summary(runs), snakemake.wildcards.grid, snakemake.params.axes,
                 snakemake.output.figure, dpi=snakemake.params.dpi)

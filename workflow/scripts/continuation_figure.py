"""Snakemake script: bifurcation diagram (up and down sweeps) with lambda_1 curves of one line."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.figures.continuation import plot_continuation
from analysis.pipeline.stages import lle_resolution

plot_continuation(pd.read_parquet(snakemake.input.table), snakemake.params.axis, snakemake.params.line,
                  f"{snakemake.wildcards.grid}/{snakemake.wildcards.line}", snakemake.output.figure,
                  margin=lle_resolution(snakemake.params.numerics), dpi=snakemake.params.dpi)

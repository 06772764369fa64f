"""Snakemake script: re-run the stratified sample of one grid under one refinement."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

import pandas as pd

from analysis.pipeline.atomic import write_parquet
from analysis.pipeline.convergence import ConvergenceSettings, convergence_runs
from analysis.pipeline.stages import register_cached_modes

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
runs = convergence_runs(pd.read_parquet(snakemake.input.table), snakemake.wildcards.refinement,
                        snakemake.params.numerics, ConvergenceSettings.from_dict(snakemake.params.settings),
                        store_root=snakemake.params.store, axes=snakemake.params.axes,
                        threads=snakemake.threads)
write_parquet(runs, snakemake.output.table)

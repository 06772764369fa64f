"""Snakemake script: largest Lyapunov exponent of every point of one chunk (stage 2)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

import pandas as pd

from analysis.pipeline.atomic import write_parquet
from analysis.pipeline.stages import lyapunov_points, register_cached_modes

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
simulated = pd.read_parquet(snakemake.input.simulate)
table = lyapunov_points(snakemake.params.points, simulated, snakemake.params.numerics,
                        store_root=snakemake.params.store, threads=snakemake.threads)
write_parquet(table, snakemake.output.table)

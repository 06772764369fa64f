"""Snakemake script: integrate the points of one chunk (stage 1)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

from analysis.pipeline.atomic import write_parquet
from analysis.pipeline.stages import register_cached_modes, simulate_points

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
table = simulate_points(snakemake.params.points, snakemake.params.numerics,
                        store_root=snakemake.params.store, threads=snakemake.threads)
write_parquet(table, snakemake.output.table)

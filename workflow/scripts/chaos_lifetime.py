"""Snakemake script: the lifetimes of one grid's chaos below the lock-up limit (perturbed
copies of each cell's end state run until they lock)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

import pandas as pd

from analysis.pipeline.chaos_lifetime import (
                      LifetimeSettings,
                      chaos_lifetimes,
                      summary_line,
                      write_lifetime_table,
)
from analysis.pipeline.stages import register_cached_modes

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
simulated = pd.concat([pd.read_parquet(f, columns=["point_id", "final_state"])
                       for f in snakemake.input.simulate], ignore_index=True)
lifetimes = chaos_lifetimes(pd.read_parquet(snakemake.input.table), simulated, snakemake.params.numerics,
                            LifetimeSettings.from_dict(snakemake.params.settings), axes=snakemake.params.axes,
                            threads=snakemake.threads)
logging.info(summary_line(lifetimes))
write_lifetime_table(lifetimes, snakemake.output.table, grid_name=snakemake.wildcards.grid,
                     settings=snakemake.params.settings, config_hash=snakemake.params.config_hash)

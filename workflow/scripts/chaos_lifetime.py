"""Snakemake script: the lifetimes of one grid's chaos below the lock-up limit (perturbed
copies of each cell's end state run until they lock)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

import pandas as pd

from analysis.pipeline import chaos_lifetime
from analysis.pipeline.stages import register_cached_modes

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
simulated = pd.concat([pd.read_parquet(f, columns=["point_id", "final_state"])
                       for f in snakemake.input.simulate], ignore_index=True)
lifetimes = chaos_lifetime.chaos_lifetimes(
    pd.read_parquet(snakemake.input.table), simulated, snakemake.params.numerics,
    chaos_lifetime.LifetimeSettings.from_dict(snakemake.params.settings), axes=snakemake.params.axes,
    threads=snakemake.threads)
logging.info(chaos_lifetime.summary_line(lifetimes))
chaos_lifetime.write_lifetime_table(lifetimes, snakemake.output.table, grid_name=snakemake.wildcards.grid,
                                    settings=snakemake.params.settings,
                                    config_hash=snakemake.params.config_hash)

"""Snakemake script: the cells of one grid's map run again from other initial states, their
attractors grouped and labelled (multistability)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

import pandas as pd

from analysis.pipeline.cell_attractors import MultistabilitySettings, cell_attractors, write_attractor_table
from analysis.pipeline.stages import register_cached_modes

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
simulated = pd.concat([pd.read_parquet(f, columns=["point_id", "poincare_state", "poincare_tip",
                                                   "final_state", "diverged", "continuation_reason"])
                       for f in snakemake.input.simulate], ignore_index=True)
attractors = cell_attractors(pd.read_parquet(snakemake.input.table), simulated, snakemake.params.numerics,
                             MultistabilitySettings.from_dict(snakemake.params.settings),
                             store_root=snakemake.params.store, axes=snakemake.params.axes,
                             threads=snakemake.threads)
write_attractor_table(attractors, snakemake.output.table, grid_name=snakemake.wildcards.grid,
                      settings=snakemake.params.settings, config_hash=snakemake.params.config_hash)

"""Snakemake script: compute and cache the arch modes of one geometry."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging

from beamsim.mode_cache import parse_cache_key, write_modes
from beamsim.modes import arch_modes

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
geom = parse_cache_key(snakemake.wildcards.geometry)
logging.info("computing arch modes for %s", geom)
modes = arch_modes(geom["alpha"], geom["beta"], geom["n_modes"], geom["bc"])
logging.info("lam = %s", modes.lam)
logging.info("frequency ratios f_n/f_1 = %s", modes.frequency_ratios)
write_modes(modes, snakemake.output.table)

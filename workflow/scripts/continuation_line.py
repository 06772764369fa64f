"""Snakemake script: up- and down-sweep of one continuation line of a grid.

The table's metadata carries the line's own inputs (points, numerics, results version) and
their hash, not the whole config's: an edit elsewhere in the grid file does not rerun a line."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import hashlib
import logging

from analysis.continuation import continuation_sweeps
from analysis.pipeline.grid import canonical_json
from analysis.pipeline.stages import register_cached_modes
from analysis.pipeline.table import write_regime_table

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)
p = snakemake.params
table = continuation_sweeps(p.points, p.numerics, axis=p.axis, threads=snakemake.threads)
inputs = {"points": p.points, "numerics": p.numerics, "version": p.version}
inputs_hash = hashlib.sha256(canonical_json(inputs).encode()).hexdigest()[:16]
write_regime_table(table, snakemake.output.table,
                   grid_name=f"{snakemake.wildcards.grid}/lines/{snakemake.wildcards.line}", grid=p.line,
                   config=inputs, config_hash=inputs_hash)

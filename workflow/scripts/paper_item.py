"""Snakemake script: the runs of one paper item (analysis.paper.runs) -> measured table."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import logging
import warnings

import pandas as pd

from analysis.paper.measure import measure_runs
from analysis.paper.runs import item_runs, smallest_chaotic_ratio
from analysis.paper.tables import paper_config_hash, write_paper_table

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
# nolds' lag heuristics on short series (its module is loaded as _nolds_measures)
warnings.filterwarnings("ignore", module="_?nolds")
item = snakemake.wildcards.item
ratio = None
if snakemake.input.chaos:
    ratio, found = smallest_chaotic_ratio(pd.read_parquet(snakemake.input.chaos[0]))
    logging.info("smallest mu_s / mu_k with chaos: %g (%s)", ratio, "found" if found else "none chaotic")
runs = item_runs(item, snakemake.params.paper, snakemake.params.model, ratio)
fig = dict(snakemake.params.figures)
dense = {"samples_per_period": fig["samples_per_period"], "n_show": fig["n_show"]} if fig else {}
table = measure_runs(runs, snakemake.params.numerics, snakemake.params.store, threads=snakemake.threads,
                     **dense)
# the hash of what this table depends on (a rule parameter would rerun every item on any edit)
inputs = {"paper": snakemake.params.paper, "figures": fig}
write_paper_table(table, snakemake.output.table, item=item, paper=snakemake.params.paper,
                  model=snakemake.params.model, numerics=snakemake.params.numerics,
                  config_hash=paper_config_hash({"model": snakemake.params.model,
                                                 "numerics": snakemake.params.numerics}, inputs))

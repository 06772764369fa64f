"""Snakemake script: the verdict of every paper claim (analysis.paper.verdicts)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.paper.runs import paper_modes
from analysis.paper.tables import write_paper_table
from analysis.paper.verdicts import verdict_table
from analysis.pipeline.atomic import atomic_output
from analysis.pipeline.stages import lle_resolution

measured = {item: pd.read_parquet(path)
            for item, path in zip(snakemake.params.run_items, snakemake.input.tables)}
table = verdict_table(measured, modes=paper_modes(),
                      stribeck=snakemake.params.stribeck,
                      resolution=lle_resolution(snakemake.params.numerics))
write_paper_table(table, snakemake.output.table, paper=snakemake.params.paper,
                  stribeck=snakemake.params.stribeck, numerics=snakemake.params.numerics,
                  config_hash=snakemake.params.config_hash)
with atomic_output(snakemake.output.tsv) as tmp:
    table.to_csv(tmp, sep="\t", index=False)

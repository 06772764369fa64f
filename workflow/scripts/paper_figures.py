"""Snakemake script: the figures of one paper item (analysis.paper.drawing)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.paper.drawing import draw_item
from analysis.paper.runs import paper_modes
from analysis.pipeline.stages import lle_resolution

item = snakemake.params.item
measured = pd.read_parquet(snakemake.input.table[0]) if snakemake.input.table else None
draw_item(item, measured, list(snakemake.output), dpi=snakemake.params.dpi,
          resolution=lle_resolution(snakemake.params.numerics),
          modes=paper_modes() if item == "modes" else None,
          stribeck=snakemake.params.stribeck)

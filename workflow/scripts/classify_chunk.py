"""Snakemake script: classify the points of one chunk (stage 3)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

import pandas as pd

from analysis.pipeline.atomic import write_parquet
from analysis.pipeline.stages import classify_points, lle_resolution

table = classify_points(pd.read_parquet(snakemake.input.simulate),
                        pd.read_parquet(snakemake.input.lyapunov),
                        lle_threshold=lle_resolution(snakemake.params.numerics))
write_parquet(table, snakemake.output.table)

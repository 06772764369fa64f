"""Snakemake script: classify the points of one chunk (stage 3)."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

import pandas as pd  # noqa: E402

from analysis.regime_pipeline import classify_points, lle_resolution  # noqa: E402

table = classify_points(pd.read_parquet(snakemake.input.simulate),  # noqa: F821
                        pd.read_parquet(snakemake.input.lyapunov),  # noqa: F821
                        lle_threshold=lle_resolution(snakemake.params.numerics))  # noqa: F821
table.to_parquet(snakemake.output.table, index=False)  # noqa: F821

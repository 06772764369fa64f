"""Snakemake script: largest Lyapunov exponent of every point of one chunk (stage 2)."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

import logging  # noqa: E402

import pandas as pd  # noqa: E402

from analysis.regime_pipeline import lyapunov_points, register_cached_modes  # noqa: E402

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)  # noqa: F821
simulated = pd.read_parquet(snakemake.input.simulate)  # noqa: F821
table = lyapunov_points(snakemake.params.points, simulated, snakemake.params.numerics,  # noqa: F821
                        store_root="results/store", threads=snakemake.threads)  # noqa: F821
table.to_parquet(snakemake.output.table, index=False)  # noqa: F821

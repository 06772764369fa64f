"""Snakemake script: integrate the points of one chunk (stage 1)."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

import logging  # noqa: E402

from analysis.regime_pipeline import register_cached_modes, simulate_points  # noqa: E402

logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(asctime)s %(message)s")
register_cached_modes(snakemake.input.modes)  # noqa: F821
table = simulate_points(snakemake.params.points, snakemake.params.numerics,  # noqa: F821
                        store_root="results/store", threads=snakemake.threads)  # noqa: F821
table.to_parquet(snakemake.output.table, index=False)  # noqa: F821

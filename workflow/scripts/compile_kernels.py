"""Snakemake script: compile the numba kernels of one stage before its chunk jobs run."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

from pathlib import Path  # noqa: E402

from analysis.regime_pipeline import compile_kernels  # noqa: E402

wall = compile_kernels(snakemake.wildcards.stage, snakemake.params.methods,  # noqa: F821
                       threads=snakemake.threads)  # noqa: F821
print(f"{snakemake.wildcards.stage} kernels ready after {wall:.1f} s", file=sys.stderr)  # noqa: F821
Path(snakemake.output.stamp).write_text(f"{wall:.1f}\n")  # noqa: F821

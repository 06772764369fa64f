"""Snakemake script: compile the numba kernels of one stage before its chunk jobs run."""

import sys

sys.stderr = open(snakemake.log[0], "w")

from pathlib import Path

from analysis.pipeline.stages import compile_kernels

wall = compile_kernels(snakemake.wildcards.stage, snakemake.params.methods,
                       threads=snakemake.threads, rigid=snakemake.params.rigid)
print(f"{snakemake.wildcards.stage} kernels ready after {wall:.1f} s", file=sys.stderr)
Path(snakemake.output.stamp).write_text(f"{wall:.1f}\n")

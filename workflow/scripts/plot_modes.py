"""Snakemake script: characteristic-function and mode-shape figures (paper Figs 4 and 5)."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821 (snakemake is injected)

from analysis.mode_figures import plot_determinant, plot_mode_shapes  # noqa: E402
from beamsim.mode_cache import read_modes  # noqa: E402

modes = read_modes(snakemake.input.table)  # noqa: F821
plot_determinant(modes, snakemake.output.determinant)  # noqa: F821
plot_mode_shapes(modes, snakemake.output.shapes)  # noqa: F821

"""Snakemake script: characteristic-function and mode-shape figures (paper Figs 4 and 5)."""

import sys

sys.stderr = open(snakemake.log[0], "w")

from analysis.figures.modes import plot_determinant, plot_mode_shapes
from beamsim.mode_cache import read_modes

modes = read_modes(snakemake.input.table)
plot_determinant(modes, snakemake.output.determinant)
plot_mode_shapes(modes, snakemake.output.shapes)

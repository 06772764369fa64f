"""Figures: arch modes (:mod:`~analysis.figures.modes`) and regime maps, exponent maps and
phase portraits (:mod:`~analysis.figures.regimes`)."""

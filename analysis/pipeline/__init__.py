"""Glue of the regime pipeline (called by the thin Snakemake scripts in ``workflow/scripts``):

* :mod:`~analysis.pipeline.config` -- :class:`Numerics`, the typed numerical settings with their
  defaults;
* :mod:`~analysis.pipeline.validation` -- config and grid checks with one-line errors;
* :mod:`~analysis.pipeline.grid` -- grid expansion, point ids, chunks;
* :mod:`~analysis.pipeline.store` -- the content-addressed per-point store;
* :mod:`~analysis.pipeline.stages` -- one function per rule: simulate, lyapunov, classify,
  compile, portraits;
* :mod:`~analysis.pipeline.table` -- the regime table and its Parquet metadata.
"""

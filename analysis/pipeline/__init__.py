"""Glue of the regime pipeline (called by the thin Snakemake scripts in ``workflow/scripts``):

* :mod:`~analysis.pipeline.config` -- :class:`Numerics`, the typed numerical settings with their
  defaults;
* :mod:`~analysis.pipeline.validation` -- config and grid checks with one-line errors;
* :mod:`~analysis.pipeline.plan` -- the one parse-time pass: checks, expansion, chunks, hash;
* :mod:`~analysis.pipeline.cost` -- the run-cost estimate (new points, time, disk);
* :mod:`~analysis.pipeline.preflight` -- before the first job: long-run opt-in, results/ writable;
* :mod:`~analysis.pipeline.atomic` -- atomic file output;
* :mod:`~analysis.pipeline.grid` -- grid expansion, point ids, chunks;
* :mod:`~analysis.pipeline.store` -- the content-addressed per-point store;
* :mod:`~analysis.pipeline.stages` -- one function per rule: simulate, lyapunov, classify,
  compile, portraits;
* :mod:`~analysis.pipeline.table` -- the regime table and its Parquet metadata.
"""

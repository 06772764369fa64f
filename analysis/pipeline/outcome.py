"""The check after a run that Snakemake calls successful: every file the command asked for exists.

Snakemake 9.15 can end a run with exit code 0 without the requested files: an existing output
that later jobs read through ``ancient()`` -- the kernels' stamps ``results/kernels/<stage>.done``
-- and that is rerun is rerun alone, and the jobs downstream of it are dropped from the DAG.
Two causes rerun a stamp: a killed run left it marked incomplete (``--rerun-incomplete``,
``profiles/default/``; a minimal Snakefile shows the drop: ``tests/workflow/test_interrupted_runs.py``),
or its params changed because the grids need kernels of another integrator (the plan keeps
the Lyapunov stage's params the same for every stick-slip grid, :mod:`analysis.pipeline.plan`;
a config whose grids all use another law still changes them). The workflow's ``onsuccess``
calls :func:`check_targets_made`, so such a run fails in one line that says what to do (run
the same command again: the stamp is up to date then) instead of looking finished
(docs/reliability.md, "Interrupted runs resume to the same table").
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

from snakemake.exceptions import WorkflowError


def check_targets_made(targets: Iterable[str]) -> None:
    """Raise a one-line :class:`WorkflowError` naming the files of ``targets`` that do not exist
    (the workflow passes the target jobs' outputs and inputs: an aggregate target such as
    ``regimes`` has only inputs)."""
    missing = sorted({str(f) for f in targets if not Path(f).exists()})
    if missing:
        raise WorkflowError(
            f"the run ended without {', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''}: "
            f"Snakemake dropped the jobs that make it (a kernel stamp was rebuilt alone: after a "
            f"killed run, or for grids that need other kernels, docs/reliability.md); run the same "
            f"command again")

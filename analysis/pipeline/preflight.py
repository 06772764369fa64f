"""Checks of the environment before a run starts: time and disk.

``workflow/rules/common.smk`` logs the work still to do while the workflow is parsed (new
points per stage, the estimated time on the current cores, :mod:`analysis.pipeline.cost`), and
runs these checks in Snakemake's ``onstart`` (main process, a real run, the jobs known).  They
refuse -- one line, before any job, nothing under ``results/`` created or changed -- a run that

* is estimated to take longer than :data:`~analysis.pipeline.cost.LONG_RUN_SECONDS` without the
  opt-in ``--config allow_long=True``;
* cannot write into ``results/`` (a read-only mount, no permission);
* would not fit on the disk: the free space is below twice the estimated size of the new
  store records (the tables and figures need a fraction of it more).

A dry run (``snakemake -n``) only logs the estimate.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from snakemake.exceptions import WorkflowError

from analysis.pipeline.cost import LONG_RUN_SECONDS, Estimate

__all__ = ["check_results_dir", "check_run_length", "writable_base"]


def writable_base(results: str | Path) -> Path:
    """``results`` if it exists, else its nearest existing parent (where it would be created)."""
    where = Path(results).absolute()
    while not where.exists():
        where = where.parent
    return where


def _mb(n: float) -> str:
    return f"{n / 1e6:.1f} MB"


def check_results_dir(results: str | Path, need_bytes: float) -> None:
    """``results`` (or where it would be created) must take a new file and have room for about
    ``2 * need_bytes``; the probe file is removed at once."""
    where = writable_base(results)
    try:
        fd, probe = tempfile.mkstemp(prefix=".write-probe-", dir=where)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise WorkflowError(f"cannot run: {where} is not writable ({exc.strerror}); nothing was "
                            "started or changed") from None
    free = shutil.disk_usage(where).free
    if free < 2 * need_bytes:
        raise WorkflowError(f"cannot run: {where} has {_mb(free)} free, the new results need about "
                            f"{_mb(need_bytes)} (twice that is required); nothing was started or changed")


def check_run_length(estimate: Estimate, cores: int, allow_long: bool) -> None:
    """Refuse a run estimated over :data:`LONG_RUN_SECONDS` on ``cores`` unless ``allow_long``."""
    if estimate.wall_seconds(cores) > LONG_RUN_SECONDS and not allow_long:
        raise WorkflowError(
            f"long run: {estimate.summary(cores)}, over the {LONG_RUN_SECONDS // 3600} h that start "
            "without asking; start it with --config allow_long=True (or fewer points, more cores)")

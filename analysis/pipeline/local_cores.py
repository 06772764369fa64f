"""Hold Snakemake's local scheduler to ``--cores``.

Snakemake 9.10 and later (9.15 installed here; the same code in the upstream snapshot read for
this, commit 01a80b0; upstream issue snakemake/snakemake#3913) start jobs whose threads add up
to more than ``--cores``: when a single job is ready, ``JobScheduler.job_selector`` returns it
without booking its threads against the free cores, but books them back when it finishes, so
every job that ran alone adds its threads to the pool (what that did to the default run:
docs/reliability.md, "`-c2` means two cores").

:func:`hold_local_cores` books the lone job's resources as the scheduler does for any other
selection. It patches only when Snakemake's source has the faulty shortcut (read with
:mod:`inspect`), so a Snakemake that fixes it is left alone; ``tests/workflow/test_local_cores.py``
runs three two-thread jobs under ``-c2`` and checks that no two overlap.
"""

from __future__ import annotations

import inspect

__all__ = ["hold_local_cores", "has_lone_job_shortcut"]

#: the line of ``JobScheduler.job_selector`` that returns a lone job without booking it
_SHORTCUT = "if len(jobs) == 1:"


def has_lone_job_shortcut(scheduler_class) -> bool:
    """Whether ``scheduler_class.job_selector`` returns a lone ready job before booking
    resources (the shortcut followed by a ``return`` of the greedy selection)."""
    try:
        src = inspect.getsource(scheduler_class.job_selector)
    except (OSError, TypeError, AttributeError):
        return False
    _, sep, rest = src.partition(_SHORTCUT)
    return bool(sep) and rest.lstrip().startswith("return self.job_selector_greedy(")


def hold_local_cores() -> bool:
    """Patch Snakemake's ``JobScheduler`` so that a lone selected job's resources are booked
    (idempotent).  Returns whether the patch is in place."""
    try:
        from snakemake.scheduling.job_scheduler import JobScheduler
    except ImportError:  # another Snakemake layout: nothing known to fix
        return False
    if getattr(JobScheduler, "_beamsim_holds_cores", False):
        return True
    if not has_lone_job_shortcut(JobScheduler):
        return False
    init = JobScheduler.__init__

    def __init__(self, *args, **kwargs):
        init(self, *args, **kwargs)
        greedy = self.job_selector_greedy

        def select(jobs, remaining_jobs, resources, input_sizes):
            selected = greedy(jobs, remaining_jobs, resources, input_sizes)
            if len(jobs) == 1:  # the shortcut's call: book it (the other calls are booked after)
                self.update_available_resources(selected)
            return selected

        self.job_selector_greedy = select

    JobScheduler.__init__ = __init__
    JobScheduler._beamsim_holds_cores = True
    return True

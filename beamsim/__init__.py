"""beamsim: physics of curved two-layer beams with interlayer friction.

Modules: ``modes`` (in-plane arch modes).

The project parallelises over parameter points (threads running compiled kernels, Snakemake
jobs); the
linear algebra it does is on tiny matrices (6x6 to 100x100), where a multi-threaded BLAS
only adds overhead and, worse, changes the last bits of LAPACK's results (an eigen-
decomposition of ``expo`` split over two OpenBLAS threads rounds differently), which a
stick-slip or chaotic trajectory then grows into another trajectory.  Results must not depend
on the machine's thread settings, so every BLAS/LAPACK library of the process is pinned to
one thread when beamsim is imported: the environment variables for libraries loaded later
(``OPENBLAS_NUM_THREADS``, ``MKL_NUM_THREADS``, overriding any value: Snakemake sets them to a
job's thread count), and :func:`threadpoolctl.threadpool_limits` for those already loaded.
Parallelism comes from threads over points (:mod:`beamsim.kernels.thread_pool`), whose results
do not depend on their number.

numba's optimisation level defaults to 1 here (``NUMBA_OPT``, set only when the environment
does not set it, and only for a process that imports beamsim before numba): numba's default, 3,
spends more compile time on a fresh install for kernels that ran no faster and gave the same
bits where it was measured (docs/performance.md, "numba at optimisation level 1").  The
level is a compile-speed knob, not a result: a numba cache filled at another level is reused.
"""

import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ[_var] = "1"

from threadpoolctl import threadpool_limits as _threadpool_limits  # noqa: E402

_threadpool_limits(limits=1, user_api="blas")

_os.environ.setdefault("NUMBA_OPT", "1")

__version__ = "0.1.0"

"""beamsim: physics of curved two-layer beams with interlayer friction.

Modules: ``modes`` (in-plane arch modes).

The project parallelises over parameter points (numba threads, Snakemake jobs); the
linear algebra it does is on tiny matrices (6x6 to 20x20), where a multi-threaded BLAS
only adds overhead (measured: a 20x20 ``expm`` takes 26 us single-threaded and 16 ms with
OpenBLAS threads competing for 2 busy cores).  Unless the user set them, BLAS thread
counts are therefore pinned to 1 before numpy is first imported.
"""

import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.1.0"

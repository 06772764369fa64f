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

numba's on-disk cache (``cache=True``) lives in a folder of its own for each version of
beamsim's sources, ``<NUMBA_CACHE_DIR or beamsim/__pycache__/numba>/beamsim-<hash>`` (the hash:
every ``.py`` file of the package, names and contents).  numba invalidates a cached kernel when
its own source file changes, not when a callee in another file does, and it links callees into
their callers' machine code: after an edit of ``beamsim/kernels/expo.py`` the cached kernels of
``expo_copies.py`` still ran the old ``expo`` functions, so a run mixed two versions of the
code (found by the pattern-store sharing tests; docs/reliability.md, "Compiled kernels").  A
new folder per source version compiles everything again instead (once per version).
"""

import os as _os

for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ[_var] = "1"

from threadpoolctl import threadpool_limits as _threadpool_limits  # noqa: E402

_threadpool_limits(limits=1, user_api="blas")

_os.environ.setdefault("NUMBA_OPT", "1")


def _kernel_cache_dir() -> str | None:
    """numba's cache folder for these sources (module docstring), created; ``None`` where it
    cannot be created (numba's own choice then stands)."""
    import hashlib
    from pathlib import Path

    root = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        digest.update(path.relative_to(root).as_posix().encode() + b"\0")
        digest.update(path.read_bytes())
    tag = "beamsim-" + digest.hexdigest()[:16]
    base = Path(_os.environ.get("NUMBA_CACHE_DIR") or root / "__pycache__" / "numba").absolute()
    folder = base if base.name == tag else base / tag     # a child process inherits the folder
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        import warnings

        warnings.warn(f"beamsim: numba's cache folder {folder} cannot be created ({err}); numba's "
                      "own cache setting is used, whose kernels may keep callees of older "
                      "sources: set NUMBA_CACHE_DIR to a writable folder", RuntimeWarning, stacklevel=2)
        return None
    return str(folder)


_cache_dir = _kernel_cache_dir()
if _cache_dir is not None:
    _os.environ["NUMBA_CACHE_DIR"] = _cache_dir
    import sys as _sys

    if "numba" in _sys.modules:  # numba read its configuration before beamsim was imported
        _sys.modules["numba"].config.CACHE_DIR = _cache_dir

__version__ = "0.1.0"

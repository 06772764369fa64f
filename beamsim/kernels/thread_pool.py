"""Run a compiled per-item kernel over the items of a batch on a pool of threads.

The batch kernels of the integrators (:mod:`beamsim.kernels.rk4`, :mod:`~beamsim.kernels.expo`,
:mod:`~beamsim.kernels.newmark`, :mod:`~beamsim.kernels.copies`) integrate one item (a point, or
a point's share of Lyapunov copies) per call and release the GIL (``nogil=True``), so Python
threads run them side by side.  They were ``parallel=True`` kernels over ``prange`` before;
numba compiles such a loop into a module of its own that links and optimises the whole point
kernel a second time (measured: docs/performance.md, "Not done yet", compile time).

Every item writes only its own rows of the output arrays, so the results do not depend on the
number of threads or on which thread runs an item (bitwise).  Items are handed out one at a
time to whichever thread is free.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor


def run_items(kernel: Callable, args: tuple, items: Sequence[int], threads: int) -> None:
    """Call ``kernel(*args, i)`` for every ``i`` of ``items`` on ``threads`` threads (in the
    calling thread if ``threads`` is 1 or there is one item).  numba compiles the kernel, or
    loads it from its cache, on its first call under its compiler lock, so the first calls of
    several threads wait for one compilation.  An exception of any call is raised here after
    the pool has finished."""
    items = [int(i) for i in items]
    if threads <= 1 or len(items) <= 1:
        for i in items:
            kernel(*args, i)
        return
    with ThreadPoolExecutor(max_workers=min(threads, len(items))) as pool:
        for _ in pool.map(lambda i: kernel(*args, i), items):
            pass

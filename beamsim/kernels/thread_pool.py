"""Run a compiled per-item kernel over the items of a batch on a pool of threads.

The batch kernels of the integrators (:mod:`beamsim.kernels.rk4`, :mod:`~beamsim.kernels.expo`,
:mod:`~beamsim.kernels.newmark`, :mod:`~beamsim.kernels.copies`) integrate one item (a point, or
a point's share of Lyapunov copies) per call and release the GIL (``nogil=True``), so Python
threads run them side by side.  They were ``parallel=True`` kernels over ``prange`` before;
numba compiles such a loop into a module of its own that links and optimises the whole point
kernel a second time (measured: docs/performance.md, "Not done yet", compile time).

Every item writes only its own rows of the output arrays, so the results do not depend on the
number of threads or on which thread runs an item (bitwise).  Items are handed out one at a
time, in their order, to whichever thread is free.  A thread may carry state of its own from
item to item (``per_thread``: ``expo``'s pattern caches, :mod:`beamsim.pattern_store`), which
must then not change any result either.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor


def run_items(kernel: Callable, args: tuple, items: Sequence[int], threads: int,
              per_thread: Sequence | None = None) -> None:
    """Call ``kernel(*args, i)`` for every ``i`` of ``items`` on ``threads`` threads (in the
    calling thread if ``threads`` is 1 or there is one item); with ``per_thread`` (at least
    ``min(threads, len(items))`` entries) thread ``w`` calls ``kernel(*args, per_thread[w], i)``.
    numba compiles the kernel, or loads it from its cache, on its first call under its compiler
    lock, so the first calls of several threads wait for one compilation.  An exception of any
    call is raised here after the pool has finished."""
    items = [int(i) for i in items]
    workers = max(1, min(threads, len(items)))
    if per_thread is not None and len(per_thread) < workers:
        raise ValueError(f"per_thread has {len(per_thread)} entries for {workers} threads")

    def extra(w: int) -> tuple:
        return () if per_thread is None else (per_thread[w],)

    if workers == 1:
        for i in items:
            kernel(*args, *extra(0), i)
        return
    queue = iter(items)
    lock = threading.Lock()

    def work(w: int) -> None:
        while True:
            with lock:
                i = next(queue, None)
            if i is None:
                return
            kernel(*args, *extra(w), i)

    with ThreadPoolExecutor(max_workers=workers) as pool:
        futures = [pool.submit(work, w) for w in range(workers)]
    for f in futures:
        f.result()

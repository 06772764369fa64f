"""Stick-pattern decompositions of ``expo`` shared across the points of one model.

Between two stick/slip switches ``expo`` propagates the beam with the eigen-decomposition of
the current stick pattern's linear system (:mod:`beamsim.kernels.expo`).  A decomposition
depends on the model's matrices and the pattern only, so the points of a regime map that share
a model (every point of a grid over the load and the forcing frequency) visit largely the same
patterns, and a point's continuation runs revisit its own.  A :class:`PatternStore` keeps one
pattern cache per thread for the runs that are handed it (:func:`beamsim.simulate.simulate_batch`
``pattern_store=``), so a pattern decomposed for one point is found by the next point that
thread runs.

Results do not depend on it: a decomposition found in a cache is, to the bit, the one the point
would compute (the same LAPACK call on the same matrix), and the one input that differs between
points, the forcing frequency of the exact-resonance guard, is applied per point
(:func:`beamsim.kernels.expo.resonant`).  Only the counter ``SimResult.n_patterns`` (the
decompositions a run computed) depends on what the cache held.
"""

from __future__ import annotations

import hashlib
import threading
from contextlib import contextmanager

import numpy as np

from beamsim.kernels import expo
from beamsim.kernels.bundles import PointStack
from beamsim.kernels.thread_pool import run_items

__all__ = ["PatternStore", "model_keys", "cache_slots"]

#: bytes of decompositions a thread's cache may hold (its ``V``, ``V^-1`` and check ladders)
_CACHE_BYTES = 1e8

#: the inputs of a point that ``beamsim.kernels.expo._pattern`` reads (the full damping matrix
#: ``Cm``: expo books the interface dashpot in it)
_MODEL_INPUTS = ("Mm", "Km", "Cm", "damp", "S", "wq", "kt", "g", "Linv")


def cache_slots(requested: int, n: int) -> int:
    """Slots of a thread's cache for models of ``n`` coordinates: ``requested``, capped at about
    100 MB of decompositions, at least 2."""
    slot_bytes = (2 * (2 * n) + expo.LADDER_RUNGS) * (2 * n) * 16
    return max(2, min(int(requested), int(_CACHE_BYTES // slot_bytes)))


def model_keys(stk: PointStack) -> np.ndarray:
    """Key (int64) of each point's model: a 64-bit hash of every matrix a decomposition reads,
    bit for bit, so two points share a key exactly when their decompositions are the same."""
    keys = np.empty(stk.f0.shape[0], np.int64)
    for p in range(keys.shape[0]):
        h = hashlib.blake2b(digest_size=8)
        for name in _MODEL_INPUTS:
            a = np.ascontiguousarray(getattr(stk, name)[p])
            h.update(name.encode())
            h.update(str(a.shape).encode())
            h.update(a.tobytes())
        keys[p] = int.from_bytes(h.digest(), "little", signed=True)
    return keys


class PatternStore:
    """Pattern caches that outlive a batch: hand the same store to the runs whose points share
    models (the pipeline's reference runs of a stage and their continuations).

    Thread-safe: :meth:`caches` lends caches that no other run holds (allocating new ones as
    needed), so concurrent batches never share one.  Each cache has ``slots`` decompositions
    allocated (touched only when filled) and holds one model at a time (emptied when a point
    of another model uses it)."""

    def __init__(self) -> None:
        self._free: dict[tuple[int, int, int], list] = {}
        self._lock = threading.Lock()

    @contextmanager
    def caches(self, n: int, nq: int, slots: int, count: int):
        """``count`` caches for models of ``n`` coordinates and ``nq`` interface points, lent
        for the ``with`` block."""
        shape = (int(n), int(nq), int(slots))
        with self._lock:
            free = self._free.setdefault(shape, [])
            lent = [free.pop() for _ in range(min(count, len(free)))]
        lent += [expo.new_cache(*shape) for _ in range(count - len(lent))]
        try:
            yield lent
        finally:
            with self._lock:
                self._free.setdefault(shape, []).extend(lent)

    def run(self, kernel, args: tuple, models: np.ndarray, stk: PointStack, slots: int,
            threads: int) -> None:
        """:func:`beamsim.kernels.thread_pool.run_items` over the items ``0 .. len(models) - 1``
        (``models[i]``: item ``i``'s model key), each thread with a cache of ``slots`` lent by
        this store, the items of one model one after another (so that a thread's cache keeps
        its model)."""
        items = np.argsort(models, kind="stable")
        workers = max(1, min(threads, items.size))
        with self.caches(stk.Mm.shape[1], stk.S.shape[1], slots, workers) as caches:
            run_items(kernel, args, items, threads, per_thread=caches)

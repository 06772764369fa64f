"""A drive trajectory and free (uncoupled) copies of it, each propagated exactly between its
own located switches (``expo``, :mod:`beamsim.kernels.expo`): the two-trajectory (Benettin)
record of :mod:`beamsim.coupled_copies` without RK4's step.

Every row (0: the drive, ``1 .. M``: the copies) is an ``expo`` trajectory with its own
scratch; they share one pattern cache (a copy in the linear regime visits the drive's stick
patterns, whose decompositions are then computed once).  Each row locates its own switches
(the copies are not tied to the drive's event times), so a copy's separation from the drive
is that of two exact solutions of the piecewise-linear system up to the event-location
tolerance.  At every step end (``n_per`` steps per forcing period) the copies are measured,
rescaled and given the drive's stick/slip state exactly as the RK4 copies are
(:func:`beamsim.kernels.copies.error`, :func:`~beamsim.kernels.copies.rescale`,
:func:`~beamsim.kernels.copies.adopt_modes`); a copy that was moved is return-mapped
(:func:`beamsim.kernels.common.post_step`) and its modal state is projected afresh at the next
step.  The drive is never moved, so its trajectory does not depend on the copies.  Every
row's modal state is projected afresh from ``(q, v, z)`` at every period end, so a run
restarted from the end states (``final``) continues the drive exactly as one longer run does.

Stick-slip (Jenkins) law only; free copies only (a coupling ``d (x - y)`` would make a copy's
system non-autonomous in the drive's state, which the closed form does not cover).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from beamsim.kernels import common, expo
from beamsim.kernels.bundles import LEAF, State, Tally, point_at
from beamsim.kernels.copies import CopySchedule, CopySpec, adopt_modes, error, rescale
from beamsim.results import N_STATS


@njit(**LEAF)
def _measure(p, c0, step, rows, slots, spec, band, n_per, pt, tally, log_err):
    """After a step: each copy's scaled error, recorded (with the carried rescaling factors)
    at period ends; a copy outside the band (or flagged for period renormalisation at a period
    end) is moved back to ``e0``; a copy within ``10 e0`` adopts the drive's stick/slip state;
    a moved copy is return-mapped and its pattern looked up again (``slots[r] = -1``); a copy
    whose error is not finite is dropped (``+inf`` from then on).  ``rows``: ``(Q, V, Z, MODE,
    logacc, alive)``."""
    Q, V, Z, MODE, logacc, alive = rows
    x = State(Q[0], V[0], Z[0], MODE[0])
    period_end = (step + 1) % n_per == 0
    t = ((step % n_per) + 1) * (2.0 * math.pi / pt.om) / n_per
    for m in range(logacc.shape[0]):
        r = m + 1
        if not alive[r]:
            continue
        y = State(Q[r], V[r], Z[r], MODE[r])
        e = error(x.q, x.v, y.q, y.v, spec.inv_scale)
        if not math.isfinite(e):
            alive[r] = False
            for k in range((step + 1) // n_per, log_err.shape[2]):
                log_err[p, c0 + m, k] = np.inf
            continue
        if period_end:
            k = (step + 1) // n_per
            log_err[p, c0 + m, k] = (math.log(e) + logacc[m]) if e > 0.0 else -np.inf
        moved = False
        if e > 0.0 and (e > band.hi or e < band.lo or (period_end and spec.renorm_period[c0 + m])):
            logacc[m] += math.log(e / band.e0)
            rescale(band.e0 / e, x, y)
            e = band.e0
            moved = True
        if e <= 10.0 * band.e0 and adopt_modes(x, y, pt) > 0:
            moved = True
        if moved:
            common.post_step(t, y, pt, tally, False, True)
            slots[r] = -1


@njit(cache=True)
def expo_copies_task(p, c0, c1, pt, sch, x_start, spec, band, n_sub, cache_size, log_err,
                     final):
    """Integrate point ``p``'s drive with its free copies ``c0 .. c1 - 1`` for
    ``sch.n_periods`` periods of ``sch.n_per`` steps (the output grid of ``expo``: the copies
    are measured at step ends), writing ``ln eps`` at the period boundaries into
    ``log_err[p, c0:c1]`` (``nan``: the drive diverged; ``+inf``: the copy did) and the end
    states ``(q, v, z, mode)`` into ``final`` as :func:`beamsim.kernels.copies.copies_task`
    does.  ``n_sub``, ``cache_size``: ``expo``'s checks per step and pattern-cache slots."""
    n = pt.Mm.shape[0]
    nq = pt.S.shape[0]
    M = c1 - c0
    R = M + 1
    Q = np.empty((R, n))
    V = np.empty((R, n))
    Z = np.empty((R, nq))
    MODE = np.zeros((R, nq), np.int64)
    for r in range(R):
        for i in range(n):
            Q[r, i] = x_start[i] + (spec.offsets[c0 + r - 1, i] if r > 0 else 0.0)
            V[r, i] = x_start[n + i] + (spec.offsets[c0 + r - 1, n + i] if r > 0 else 0.0)
        for j in range(nq):
            Z[r, j] = x_start[2 * n + j] + (spec.offsets[c0 + r - 1, 2 * n + j] if r > 0 else 0.0)
            MODE[r, j] = int(x_start[2 * n + nq + j])
    logacc = np.zeros(M)
    alive = np.ones(R, np.bool_)
    rows = (Q, V, Z, MODE, logacc, alive)
    cache = expo.new_cache(pt, cache_size)
    cnt = np.zeros(4, np.int64)
    wks = [expo.new_scratch(pt, n_sub, cnt) for _ in range(R)]
    slots = np.full(R, -1, np.int64)
    tally = Tally(np.zeros(3), np.zeros(N_STATS))
    x = State(Q[0], V[0], Z[0], MODE[0])
    for m in range(M):
        e = error(x.q, x.v, Q[m + 1], V[m + 1], spec.inv_scale)
        log_err[p, c0 + m, 0] = math.log(e) if e > 0.0 else -np.inf
    h, n_per = sch.h, sch.n_per
    for step in range(sch.n_periods * n_per):
        # time within the forcing period (the forcing is T-periodic; a restart at t = 0 on a
        # period boundary then continues the same arithmetic)
        t0 = (step % n_per) * h
        t_end = (step % n_per + 1) * h
        for r in range(R):
            if not alive[r]:
                continue
            y = State(Q[r], V[r], Z[r], MODE[r])
            _, slots[r] = expo._step(t0, t_end, slots[r], cache, wks[r], y, pt, tally)
        if common.diverged(x.q, x.v, sch.div_limit):
            for m in range(M):
                for k in range(log_err.shape[2]):
                    log_err[p, c0 + m, k] = np.nan
            return
        _measure(p, c0, step, rows, slots, spec, band, n_per, pt, tally, log_err)
        if (step + 1) % n_per == 0:
            # every row starts a period from its state (q, v, z, mode), projected afresh, as a
            # run restarted from the end states does: a continued record is that of one run
            for r in range(R):
                slots[r] = -1
    for r in range(R):
        if r == 0 and c0 != 0:
            continue
        dst = final[p, 0] if r == 0 else final[p, c0 + r]
        for i in range(n):
            dst[i] = Q[r, i]
            dst[n + i] = V[r, i]
        for j in range(nq):
            dst[2 * n + j] = Z[r, j]
            dst[2 * n + nq + j] = MODE[r, j]


@njit(cache=True, nogil=True)
def run_task(tasks, stk, sch, x_start, spec, band, n_sub, cache_size, log_err, final, k):
    """Task ``k`` ``(point, first copy, end copy)`` of ``tasks`` (an item of
    :func:`beamsim.kernels.thread_pool.run_items`); bundles stacked over the points as in
    :func:`beamsim.kernels.copies.run_task`.  The point carries its full damping matrix (the
    interface dashpot included), as ``expo``'s reference runs do."""
    p = tasks[k, 0]
    expo_copies_task(p, tasks[k, 1], tasks[k, 2], point_at(stk, p, False),
                     CopySchedule(sch.h[p], sch.n_per[p], sch.n_periods, sch.div_limit[p]),
                     x_start[p], CopySpec(spec.offsets[p], spec.d[p], spec.renorm_period[p],
                                          spec.inv_scale[p]), band, n_sub, cache_size, log_err,
                     final)

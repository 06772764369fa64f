"""A drive trajectory and free (uncoupled) copies of it, each propagated exactly between its
own located switches (``expo``, :mod:`beamsim.kernels.expo`): the two-trajectory (Benettin)
record of :mod:`beamsim.coupled_copies` without RK4's step.

Every row (0: the drive, ``1 .. M``: the copies) is an ``expo`` trajectory with its own
scratch; all rows share the thread's pattern cache (one model: the point's), so a row whose
slot another row's decomposition has taken looks its pattern up again.  Each row locates its
own switches, so a copy's separation from the drive is that of two exact solutions of the
piecewise-linear system up to the event-location tolerance (the drive's: the rows call
``expo``'s own interval, check and refinement kernels, which numba compiles into this
module's cached kernels: a change there must come with a change here, or a warm on-disk cache
keeps the old code).  The drive is never moved, so its
trajectory does not depend on the copies.

**Stick/slip mismatches.**  An element's stick/slip state is memory: a copy can stay stuck
while its drive slides (section 7 of docs/lyapunov.md), and the RK4 copies take the drive's
state at every RK4 step end (:func:`beamsim.kernels.copies.adopt_modes`).  Here:

* ``tau_a > 0`` (the pipeline's): a mismatch of an element is adopted once it has lasted
  ``tau_a`` -- the copy is advanced to that instant (a split of its interval) and takes the
  drive's state and elastic strain there, evaluated from the drive's closed form over the
  output step (each drive interval of the step is logged: :data:`DriveLog`); a mismatch that
  the later switch of the other trajectory resolves within ``tau_a`` is left alone, so the
  switch-time difference (the saltation term) stays in the separation;
* ``tau_a <= 0``: the drive's state is adopted at every output step end, as the RK4 copies do
  at theirs (the first version; its exponent depends on the grid at grazing attractors).

At every output step end (``n_per`` per forcing period) the copies are measured and rescaled
as the RK4 copies are (:func:`beamsim.kernels.copies.error`,
:func:`~beamsim.kernels.copies.rescale`); a rescaled copy takes the drive's stick/slip state
at once (it is then within ``e0`` of the drive), a moved copy is return-mapped
(:func:`beamsim.kernels.common.post_step`) and projected afresh.  Every row's modal state is
projected afresh at every period end and the time runs within the period, so a run restarted
from the end states (``final``) continues the drive exactly as one longer run does.

**Coupled copies** (``d > 0``, the Stefanski ladder).  The coupling ``d (x - y)`` of
:mod:`beamsim.coupled_copies` is applied as its own flow at every output step end: the copy is
moved to ``x + e^{-d h} (y - x)`` on ``(q, v, z)`` (``h``: the output step), return-mapped and
projected afresh, keeping its own stick/slip state; between step ends it is a free ``expo``
trajectory.  While the copy and the drive are in the same stick pattern their difference obeys
``e' = (A_p - d) e`` (the load and the pattern's constant terms cancel) and ``d I`` commutes
with everything linear, so in the linearised dynamics, saltations at switches included, the
split is exact: ``e_d(t) = e^{-d t} e_0(t)`` at the step ends, as for the RK4 pair (tested).
What the split changes is the copy's separation *within* a step (up to ``e^{d h}`` larger), so
the nonlinear events that decide Stefanski's test against Benettin's -- a switch one trajectory
makes and the other does not -- see a slightly larger separation; the coupling's effect on a
mismatch window (at most ``tau_a``) is first order in ``d h``.

Stick-slip (Jenkins) law only.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from beamsim.kernels import common, expo
from beamsim.kernels.bundles import LEAF, State, Tally, point_at
from beamsim.kernels.copies import CopySchedule, CopySpec, adopt_modes, error, measure_copy, rescale
from beamsim.results import N_STATS

#: ``expo``'s checks per step, the adoption window ``tau_a`` (time units; ``<= 0``: adopt at
#: output step ends) and the key of the point's model (:func:`beamsim.kernels.expo.use_model`);
#: ``tau_a`` and ``model`` per point in :func:`run_task`'s stacked bundle
ExpoCopyOptions = namedtuple("ExpoCopyOptions", ("n_sub", "tau_a", "model"))

#: the outputs, indexed by the point: ``ln eps`` at the period boundaries ``(P, M, K + 1)``, end
#: states ``(P, M + 1, 2 n + 2 nq)`` and Zeno-guard counts ``(P, M + 1)`` (rows: 0 the drive,
#: ``1 + m`` copy ``m``)
ExpoCopyOutputs = namedtuple("ExpoCopyOutputs", ("log_err", "final", "zeno"))

#: the drive's intervals within one output step: start time, cache slot and its pattern key,
#: modal state and forcing at the start, stick/slip modes and slips at the start; ``count[0]``
#: intervals logged
DriveLog = namedtuple("DriveLog", ("t", "slot", "key", "zeta0", "beta", "mode", "z", "count"))

#: the copies' rows (0: the drive) and their bookkeeping: states, carried log rescaling
#: factors, live flags, cache slots and the pattern keys they held when taken, and the start
#: time of each element's stick/slip mismatch with the drive (``-1``: none)
Rows = namedtuple("Rows", ("Q", "V", "Z", "MODE", "logacc", "alive", "slots", "keys", "mstart"))


@njit(cache=True, inline="always")
def _row(rows, r):
    return State(rows.Q[r], rows.V[r], rows.Z[r], rows.MODE[r])


@njit(cache=True)
def _new_log(n2, nq, size):
    return DriveLog(np.zeros(size), np.zeros(size, np.int64), np.zeros(size, np.int64),
                    np.zeros((size, n2), np.complex128), np.zeros((size, n2), np.complex128),
                    np.zeros((size, nq), np.int64), np.zeros((size, nq)), np.zeros(1, np.int64))


@njit(cache=True)
def log_size(h, om, nq):
    """Intervals the drive's log must hold for an output step of length ``h`` without the Zeno
    guard firing: a new window begins at a switch at least a window after the last one began,
    so a step spans at most ``h / window + 1`` windows (one more here: ``h / window`` may round
    down), each with at most :func:`beamsim.kernels.expo.zeno_limit` switches, and the switch
    that fires the guard (one interval more than switches).  A full log ends the step as the
    guard does (never, by this count)."""
    return (int(h / expo.zeno_window(om)) + 2) * expo.zeno_limit(nq) + 2


@njit(**LEAF)
def _log_interval(log, k, t0, slot, key, wk, x):
    log.t[k] = t0
    log.slot[k] = slot
    log.key[k] = key
    for i in range(wk.zeta0.shape[0]):
        log.zeta0[k, i] = wk.zeta0[i]
        log.beta[k, i] = wk.beta[i]
    for j in range(x.mode.shape[0]):
        log.mode[k, j] = x.mode[j]
        log.z[k, j] = x.z[j]


@njit(cache=True)
def _drive_step(t0, t_end, slot, cache, wk, x, pt, tally, log):
    """:func:`beamsim.kernels.expo._step` of the drive (the same arithmetic), with every
    interval logged; returns the slot for the next step.  Its Zeno guard is ``_step``'s
    (:func:`beamsim.kernels.expo.zeno_count`, per window, not per output step), so it fires
    where the reference run's would; then the step ends there (counted: the point falls back
    to the RK4 pair), and the log (:func:`log_size`) holds every interval of a step before."""
    guard = 0
    window = expo.zeno_window(pt.om)
    t_win = t0
    k = 0
    while True:
        if slot < 0:
            slot = expo._pattern_slot(cache, wk, x, pt)
            expo.project(cache, slot, wk, x, pt)
        _log_interval(log, k, t0, slot, cache.keys[slot], wk, x)
        k += 1
        t0, switched = expo._interval(t0, t_end, slot, cache, wk, x, pt, tally)
        if not switched:
            break
        slot = -1
        t_win, guard = expo.zeno_count(t0, t_win, guard, window)
        if guard > expo.zeno_limit(x.z.shape[0]) or k == log.t.shape[0]:
            wk.cnt[expo._N_ZENO] += 1
            break
    log.count[0] = k
    return slot


@njit(cache=True, inline="always")
def _drive_interval(t, log):
    """Index of the drive's logged interval that holds time ``t`` (the last one starting at
    or before it: a switch at ``t`` belongs to the interval it starts)."""
    k = np.int64(0)  # int64 from the start: a literal 0 would have numba compile _drive_modes twice
    for i in range(1, log.count[0]):
        if log.t[i] <= t:
            k = i
    return k


@njit(cache=True)
def _drive_modes(k, cache, log, pt, wk):
    """The decomposition of the drive's logged interval ``k`` (recomputed if its cache slot has
    been reused since) and a scratch with its modal state and forcing at the interval's start."""
    slot = log.slot[k]
    if cache.keys[slot] == log.key[k]:
        lam = cache.lam[slot]
        guarded = expo.resonant(lam, pt.om)
        if guarded:
            lam = np.empty_like(lam)
            expo.shift_resonant(cache.lam[slot], pt.om, lam)
        md = expo.slot_modes(cache, slot, lam, guarded)
    else:
        for j in range(log.mode.shape[1]):
            wk.stuck[j] = log.mode[k, j] == 0 and not wk.free[j]
        lam, V, Vi, SVq, SVv, cg, gam, gS, nh, nc, wt = expo._pattern(wk.stuck, pt)
        c = np.ascontiguousarray
        lam = c(lam)
        expo.shift_resonant(lam, pt.om, lam)
        md = expo.Modes(lam, c(V), c(Vi), c(SVq), c(SVv), c(cg), c(gam), c(gS), nh, nc, c(wt),
                        expo.weighted_abs(SVq, wt), np.empty((0, lam.shape[0]), np.complex128))
    w = expo.ExpoWork(wk.free, wk.stuck, wk.xr, log.zeta0[k], wk.zeta, wk.ztmp, log.beta[k], wk.rv,
                      wk.r1, wk.r2, wk.zdot, wk.sbuf, wk.sdbuf, wk.fcur, wk.fprev, wk.rate, wk.cnt,
                      wk.n_sub, wk.glam, wk.gslot, wk.ca, wk.cb, wk.cc, wk.cd, wk.el,
                      wk.ratec, wk.mag, wk.ez, wk.et, wk.zbest)
    return md, w


@njit(cache=True)
def _drive_at(t, log, cache, pt, wk, q, v, strain):
    """The drive's ``(q, v)`` and every element's elastic strain ``s - z`` at time ``t`` of
    the logged output step (closed form of its interval; ``wk``: scratch)."""
    k = _drive_interval(t, log)
    md, w = _drive_modes(k, cache, log, pt, wk)
    expo._zeta_at(t - log.t[k], md, w, log.t[k], pt, wk.ztmp, wk.et)
    n = q.shape[0]
    for i in range(n):
        aq = 0.0
        av = 0.0
        for m in range(md.nh):
            aq += md.wt[m] * (md.V[i, m] * wk.ztmp[m]).real
            av += md.wt[m] * (md.V[n + i, m] * wk.ztmp[m]).real
        q[i] = aq
        v[i] = av
    for j in range(strain.shape[0]):
        if log.mode[k, j] != 0:
            strain[j] = log.mode[k, j] * pt.tau_k[j] / pt.kt
        else:
            s = 0.0
            for i in range(n):
                s += pt.S[j, i] * q[i]
            strain[j] = s - log.z[k, j]


@njit(**LEAF)
def _note_mismatches(r, t, rows, log):
    """Start or end the stick/slip mismatches of copy ``r`` against the drive's state at
    ``t``."""
    k = _drive_interval(t, log)
    for j in range(rows.MODE.shape[1]):
        if rows.MODE[r, j] != log.mode[k, j]:
            if rows.mstart[r, j] < 0.0:
                rows.mstart[r, j] = t
        else:
            rows.mstart[r, j] = -1.0


@njit(cache=True)
def _adopt_due(r, t, tau_a, rows, log, cache, pt, wk, spec, band, scratch):
    """Copy ``r`` at time ``t``: every mismatch that has lasted ``tau_a`` takes the drive's
    stick/slip state and elastic strain (while the copy is within ``10 e0`` of the drive; else
    it waits another ``tau_a``).  Returns True if the copy was changed."""
    due = False
    for j in range(rows.MODE.shape[1]):
        if rows.mstart[r, j] >= 0.0 and rows.mstart[r, j] + tau_a <= t:
            due = True
    if not due:
        return False
    q, v, strain = scratch
    _drive_at(t, log, cache, pt, wk, q, v, strain)
    y = _row(rows, r)
    if error(q, v, y.q, y.v, spec.inv_scale) > 10.0 * band.e0:
        for j in range(rows.MODE.shape[1]):
            if rows.mstart[r, j] >= 0.0 and rows.mstart[r, j] + tau_a <= t:
                rows.mstart[r, j] = t
        return False
    k = _drive_interval(t, log)
    for j in range(rows.MODE.shape[1]):
        if rows.mstart[r, j] >= 0.0 and rows.mstart[r, j] + tau_a <= t:
            s = 0.0
            for i in range(y.q.shape[0]):
                s += pt.S[j, i] * y.q[i]
            y.z[j] = s - strain[j]
            y.mode[j] = log.mode[k, j]
            rows.mstart[r, j] = -1.0
    return True


@njit(cache=True)
def _copy_step(r, t0, t1, rows, work, pt, tally, opts, spec, band):
    """Advance copy ``r`` over the output step ``[t0, t1]`` (the drive already is): its own
    switches, a split at every switch of the drive (its mismatches are noted there) and at
    every adoption that falls due (``opts.tau_a > 0``).  Returns True if the step was ended
    by the Zeno guard (more than ``10 nq + 10`` switches of the copy within
    :data:`beamsim.kernels.expo.ZENO_WINDOWS_PER_PERIOD`-th of a forcing period, the window of
    ``expo``'s own guard, whatever the output step).  ``work``: the drive's log, the two
    pattern cache, every row's scratch and three scratch vectors."""
    log, cache, wks, scratch = work
    wk = wks[r]
    y = _row(rows, r)
    tau_a = opts.tau_a
    guard = 0
    window = expo.zeno_window(pt.om)
    t_win = t0
    t = t0
    while t < t1:
        t_next = t1
        if tau_a > 0.0:
            for i in range(1, log.count[0]):
                if log.t[i] > t:
                    t_next = min(t_next, log.t[i])
                    break
            for j in range(rows.MODE.shape[1]):
                if rows.mstart[r, j] >= 0.0:
                    t_next = min(t_next, max(rows.mstart[r, j] + tau_a, t))
        if t_next > t:
            if rows.slots[r] < 0:
                rows.slots[r] = expo._pattern_slot(cache, wk, y, pt)
                rows.keys[r] = cache.keys[rows.slots[r]]
                expo.project(cache, rows.slots[r], wk, y, pt)
            elif cache.keys[rows.slots[r]] != rows.keys[r]:
                # another copy's decomposition took the slot (a full cache): the same pattern
                # decomposed again is the same to the bit, so the modal state stays valid
                rows.slots[r] = expo._pattern_slot(cache, wk, y, pt)
            t_reached, switched = expo._interval(t, t_next, rows.slots[r], cache, wk, y, pt, tally)
            if switched:
                rows.slots[r] = -1
                t_win, guard = expo.zeno_count(t_reached, t_win, guard, window)
                if guard > expo.zeno_limit(y.z.shape[0]):
                    # Zeno guard, as expo's: accept the state, resume on the grid (counted:
                    # the copy is then behind the drive in time, its error meaningless)
                    return True
                if tau_a > 0.0:
                    _note_mismatches(r, t_reached, rows, log)
                t = t_reached
                continue
            t = t_next
        if tau_a > 0.0:
            _note_mismatches(r, t, rows, log)
            if _adopt_due(r, t, tau_a, rows, log, cache, pt, wks[0], spec, band, scratch):
                common.post_step(t, y, pt, tally, False, True)
                rows.slots[r] = -1
                _note_mismatches(r, t, rows, log)
    return False


@njit(**LEAF)
def _measure(p, c0, step, rows, spec, band, n_per, pt, tally, log_err, grid_adoption):
    """After a step: a coupled copy (``d > 0``) is first moved to ``x + e^{-d h} (y - x)``
    (``h``: the output step; the coupling's flow, see the module docstring); then each copy's
    scaled error, recorded (with the carried rescaling factors) at period ends; a copy outside
    the band (or flagged for period renormalisation at a period end) is moved back to ``e0``
    and takes the drive's stick/slip state (with ``grid_adoption`` every copy within ``10 e0``
    does); a moved copy is return-mapped and its pattern looked up again; a copy whose error is
    not finite is dropped (``+inf`` from then on)."""
    x = _row(rows, 0)
    h = (2.0 * math.pi / pt.om) / n_per
    t = ((step % n_per) + 1) * (2.0 * math.pi / pt.om) / n_per  # as the free copies always had it
    for m in range(rows.logacc.shape[0]):
        r = m + 1
        if not rows.alive[r]:
            continue
        y = _row(rows, r)
        coupled = spec.d[c0 + m] > 0.0
        if coupled:
            rescale(math.exp(-spec.d[c0 + m] * h), x, y)  # not carried: the coupling is dynamics
        e, moved = measure_copy(p, c0, m, step, n_per, x, y, rows.logacc, spec, band, log_err)
        if not math.isfinite(e):
            rows.alive[r] = False
            continue
        if (moved or grid_adoption) and e <= 10.0 * band.e0 and adopt_modes(x, y, pt) > 0:
            moved = True
        if moved or coupled:
            common.post_step(t, y, pt, tally, False, True)
            rows.slots[r] = -1
            for j in range(rows.mstart.shape[1]):
                if y.mode[j] == x.mode[j]:
                    rows.mstart[r, j] = -1.0
                elif moved or rows.mstart[r, j] < 0.0:
                    rows.mstart[r, j] = t  # a mismatch from here (a contracted copy keeps its own)


@njit(cache=True)
def _new_rows(x_start, spec, c0, c1, n, nq):
    """Drive (row 0) at ``x_start``, copy ``m`` at ``x_start + offsets[c0 + m]`` with the
    drive's stick/slip state."""
    R = c1 - c0 + 1
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
    return Rows(Q, V, Z, MODE, np.zeros(R - 1), np.ones(R, np.bool_), np.full(R, -1, np.int64),
                np.full(R, -1, np.int64), np.full((R, nq), -1.0))


@njit(cache=True, nogil=True)
def run_task(tasks, stk, steps, starts, specs, band, options, out, cache, item):
    """Task ``item`` ``(p, c0, c1)`` of ``tasks`` (an item of
    :func:`beamsim.kernels.thread_pool.run_items` with the calling thread's pattern ``cache``;
    the schedule ``steps``, start states ``starts``, copy specs ``specs`` and options
    ``options`` (:data:`ExpoCopyOptions`; ``tau_a`` and ``model`` per point) stacked over the
    points as in :func:`beamsim.kernels.copies.run_task`): integrate point ``p``'s drive with
    its free copies ``c0 .. c1 - 1`` for ``steps.n_periods`` periods of the point's ``n_per``
    steps (the output grid of ``expo``: the copies are measured at step ends), writing ``ln
    eps`` at the period boundaries into ``log_err[p, c0:c1]`` (``nan``: the drive diverged; ``+inf``: the
    copy did) and the end states ``(q, v, z, mode)`` into ``final`` as
    :func:`beamsim.kernels.copies.copies_task` does, and into ``zeno[p, r]`` (rows as
    ``final``'s) the number of output steps that the Zeno guard ended (row 0, the drive: only
    by the task with ``c0 = 0``).  ``cache``: the pattern cache every row uses; ``out``:
    :data:`ExpoCopyOutputs`.  The point carries its full damping matrix (the interface dashpot
    included), as ``expo``'s reference runs do.  (One function, not a wrapper around a task
    kernel: numba optimises and generates the machine code of every callee again inside each
    caller, docs/performance.md, "Compilation".)"""
    p, c0, c1 = tasks[item, 0], tasks[item, 1], tasks[item, 2]
    pt = point_at(stk, p, False)
    sch = CopySchedule(steps.h[p], steps.n_per[p], steps.n_periods, steps.div_limit[p])
    spec = CopySpec(specs.offsets[p], specs.d[p], specs.renorm_period[p], specs.inv_scale[p])
    opts = ExpoCopyOptions(options.n_sub, options.tau_a[p], options.model[p])
    log_err, final, zeno = out
    n = pt.Mm.shape[0]
    nq = pt.S.shape[0]
    rows = _new_rows(starts[p], spec, c0, c1, n, nq)
    R = c1 - c0 + 1
    expo.use_model(cache, opts.model)
    cnts = (np.zeros(expo.N_COUNTERS, np.int64), np.zeros(expo.N_COUNTERS, np.int64))
    wks = [expo.new_scratch(pt, opts.n_sub, cnts[0] if r == 0 else cnts[1]) for r in range(R)]
    log = _new_log(2 * n, nq, log_size(sch.h, pt.om, nq))
    scratch = (np.empty(n), np.empty(n), np.empty(nq))
    work = (log, cache, wks, scratch)
    tally = Tally(np.zeros(3), np.zeros(N_STATS))
    x = _row(rows, 0)
    for m in range(R - 1):
        e = error(x.q, x.v, rows.Q[m + 1], rows.V[m + 1], spec.inv_scale)
        log_err[p, c0 + m, 0] = math.log(e) if e > 0.0 else -np.inf
    h, n_per = sch.h, sch.n_per
    for step in range(sch.n_periods * n_per):
        # time within the forcing period (the forcing is T-periodic; a restart at t = 0 on a
        # period boundary then continues the same arithmetic)
        t0 = (step % n_per) * h
        t1 = (step % n_per + 1) * h
        s0 = rows.slots[0]
        if s0 >= 0 and cache.keys[s0] != rows.keys[0]:
            # a copy's decomposition took the drive's slot: look the same pattern up again
            rows.slots[0] = expo._pattern_slot(cache, wks[0], x, pt)
        rows.slots[0] = _drive_step(t0, t1, rows.slots[0], cache, wks[0], x, pt, tally, log)
        if rows.slots[0] >= 0:
            rows.keys[0] = cache.keys[rows.slots[0]]
        if common.diverged(x.q, x.v, sch.div_limit):
            for m in range(R - 1):
                for k in range(log_err.shape[2]):
                    log_err[p, c0 + m, k] = np.nan
            if c0 == 0:
                zeno[p, 0] = cnts[0][expo._N_ZENO]
            return
        for r in range(1, R):
            if rows.alive[r] and _copy_step(r, t0, t1, rows, work, pt, tally, opts, spec, band):
                zeno[p, c0 + r] += 1
        _measure(p, c0, step, rows, spec, band, n_per, pt, tally, log_err, opts.tau_a <= 0.0)
        if (step + 1) % n_per == 0:
            # every row starts a period from its state (q, v, z, mode), projected afresh, as a
            # run restarted from the end states does: a continued record is that of one run
            for r in range(R):
                rows.slots[r] = -1
                if r > 0:
                    for j in range(nq):
                        if rows.mstart[r, j] >= 0.0:
                            rows.mstart[r, j] -= n_per * h
    if c0 == 0:
        zeno[p, 0] = cnts[0][expo._N_ZENO]
    for r in range(R):
        if r == 0 and c0 != 0:
            continue
        dst = final[p, 0] if r == 0 else final[p, c0 + r]
        for i in range(n):
            dst[i] = rows.Q[r, i]
            dst[n + i] = rows.V[r, i]
        for j in range(nq):
            dst[2 * n + j] = rows.Z[r, j]
            dst[2 * n + nq + j] = rows.MODE[r, j]



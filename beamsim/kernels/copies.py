"""A drive trajectory and perturbed / coupled copies of it, stepped together with the RK4
reference step (the method is described in :mod:`beamsim.coupled_copies`, the public entry).

Hot kernels are compiled with :data:`~beamsim.kernels.bundles.LEAF`'s floating-point flags.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from beamsim.kernels import common, rigid_stick, rk4
from beamsim.kernels.bundles import LEAF, State, Tally, point_at
from beamsim.results import N_STATS

#: a point's copies: initial offsets ``(M, 2 n + n_quad)``, couplings ``d`` ``(M,)``, which are
#: also renormalised at period ends, and the inverse attractor scale ``(2 n,)`` of the error
CopySpec = namedtuple("CopySpec", ("offsets", "d", "renorm_period", "inv_scale"))

#: rescaling target ``e0`` of the scaled error and the band ``[lo, hi]`` it is kept in
Band = namedtuple("Band", ("e0", "lo", "hi"))

#: step, steps per period, periods to integrate, divergence limit of the drive
CopySchedule = namedtuple("CopySchedule", ("h", "n_per", "n_periods", "div_limit"))

#: the rows (0: drive, 1..M: copies) of one task: states, step ends, stage states, couplings,
#: carried log rescaling factors and which copies are alive; ``shared``: the stage scratch
#: every row uses in turn (:data:`beamsim.kernels.rk4.Stages` with row 0's end/stage arrays)
CopyRows = namedtuple("CopyRows", ("Q", "V", "Z", "MODE", "QN", "VN", "ZN", "EN", "SQ", "SV",
                                   "SZ", "dd", "logacc", "alive", "shared"))


@njit(**LEAF)
def error(q, v, yq, yv, inv_scale):
    """Scaled RMS error of ``(yq, yv)`` from ``(q, v)`` over the ``2 n`` components."""
    n = q.shape[0]
    acc = 0.0
    for i in range(n):
        a = (yq[i] - q[i]) * inv_scale[i]
        b = (yv[i] - v[i]) * inv_scale[n + i]
        acc += a * a + b * b
    return math.sqrt(acc / (2 * n))


@njit(**LEAF)
def adopt_modes(x, y, pt):
    """Give a copy ``y`` the drive's (``x``) stick/slip state, element by element, together with
    the drive's elastic strain of that element: ``y_z = s_y - (s_x - z_x)``, so the element's
    traction equals the drive's (for a sliding drive element that is the kinetic traction).
    Without the strain a copy that broke away (``mu_s > mu_k``: ``z`` jumps by
    ``(mu_s - mu_k) p / k_t``) while the drive did not would keep a traction difference of
    ``(mu_s - mu_k) p`` when made to stick again: a finite jump of the separation that the
    linearised dynamics do not have.  Rigid stick: the drive's locked-in traction, and the
    copy's velocity projected onto its new stuck set's constraint.  Returns the number of
    changed elements."""
    S = pt.S
    changed = 0
    n = x.q.shape[0]
    for j in range(x.mode.shape[0]):
        if y.mode[j] == x.mode[j]:
            continue
        changed += 1
        if pt.law == rigid_stick.RIGID_STICK:
            # a rigid stick's strain is its residual-traction memory
            y.z[j] = x.z[j]
            y.mode[j] = x.mode[j]
            continue
        sx = 0.0
        sy = 0.0
        for k in range(n):
            sx += S[j, k] * x.q[k]
            sy += S[j, k] * y.q[k]
        y.z[j] = sy - (sx - x.z[j])
        y.mode[j] = x.mode[j]
    if changed:
        rk4.project_velocity(y.v, y.mode, pt)
    return changed


@njit(**LEAF)
def rescale(fac, x, y):
    """Move ``y`` along ``y - x`` to ``x + fac (y - x)`` on ``(q, v, z)``."""
    for i in range(x.q.shape[0]):
        y.q[i] = x.q[i] + fac * (y.q[i] - x.q[i])
        y.v[i] = x.v[i] + fac * (y.v[i] - x.v[i])
    for j in range(x.z.shape[0]):
        y.z[j] = x.z[j] + fac * (y.z[j] - x.z[j])


@njit(cache=True, inline="always")
def _row(rows, r):
    return State(rows.Q[r], rows.V[r], rows.Z[r], rows.MODE[r])


@njit(cache=True, inline="always")
def _row_stages(rows, r):
    sh = rows.shared
    return rk4.Stages(sh.kq, sh.kv, sh.kz, sh.ke, sh.tau, rows.QN[r], rows.VN[r], rows.ZN[r],
                      rows.EN[r], rows.SQ[r], rows.SV[r], rows.SZ[r], sh.g0)


@njit(cache=True)
def _new_rows(x_start, spec, c0, c1, n, nq):
    """Drive (row 0) at ``x_start``, copy ``m`` at ``x_start + offsets[c0 + m]`` with the
    drive's stick/slip state."""
    M = c1 - c0
    Q = np.empty((M + 1, n))
    V = np.empty((M + 1, n))
    Z = np.empty((M + 1, nq))
    MODE = np.zeros((M + 1, nq), np.int64)
    for i in range(n):
        Q[0, i] = x_start[i]
        V[0, i] = x_start[n + i]
    for j in range(nq):
        Z[0, j] = x_start[2 * n + j]
        MODE[0, j] = int(x_start[2 * n + nq + j])
    for m in range(M):
        for i in range(n):
            Q[m + 1, i] = Q[0, i] + spec.offsets[c0 + m, i]
            V[m + 1, i] = V[0, i] + spec.offsets[c0 + m, n + i]
        for j in range(nq):
            Z[m + 1, j] = Z[0, j] + spec.offsets[c0 + m, 2 * n + j]
            MODE[m + 1, j] = MODE[0, j]
    dd = np.zeros(M + 1)
    for m in range(M):
        dd[m + 1] = spec.d[c0 + m]
    QN = np.empty((M + 1, n))
    VN = np.empty((M + 1, n))
    ZN = np.empty((M + 1, nq))
    EN = np.empty((M + 1, 3))
    SQ = np.zeros((M + 1, 4, n))
    SV = np.zeros((M + 1, 4, n))
    SZ = np.zeros((M + 1, 4, nq))
    shared = rk4.Stages(np.zeros((4, n)), np.zeros((4, n)), np.zeros((4, nq)), np.zeros((4, 3)),
                        np.empty(nq), QN[0], VN[0], ZN[0], EN[0], SQ[0], SV[0], SZ[0],
                        np.zeros(nq))
    return CopyRows(Q, V, Z, MODE, QN, VN, ZN, EN, SQ, SV, SZ, dd, np.zeros(M),
                    np.ones(M + 1, np.bool_), shared)


@njit(**LEAF, inline="always")
def _drive_step(t, h, rows, pt, tally, seg):
    """The drive's step, exactly as the reference run steps it (its trajectory does not depend
    on the copies), its substeps recorded in ``seg``; returns their number."""
    x = _row(rows, 0)
    w = _row_stages(rows, 0)
    rk4.store_substep(seg, 0, x)
    if rk4.try_full_step(t, h, x, pt, tally.ecum, w, 0.0, w):
        seg.t[0] = t
        seg.t[1] = t + h
        return 1
    _, nseg = rk4.located_step(t, h, h, x, pt, tally, w, rk4.uncoupled(x, w), seg, True)
    return nseg


@njit(**LEAF, inline="always")
def _copy_step(r, t, h, nseg, rows, pt, tally, seg, cp):
    """Copy ``r`` follows the drive substep by substep, splitting further at its own switches;
    a coupled copy integrates each drive substep alongside (``cp``: scratch of the drive's
    substep) for its stages.  When the drive took one smooth step its stage states are at hand
    (row 0) and the copy first tries one smooth step too."""
    y = _row(rows, r)
    w = _row_stages(rows, r)
    d = rows.dd[r]
    if nseg == 1 and rk4.try_full_step(t, h, y, pt, tally.ecum, w, d, _row_stages(rows, 0)):
        return
    for k in range(nseg):
        ts = seg.t[k]
        hk = seg.t[k + 1] - ts
        if hk <= 1e-12 * h:
            continue
        if d != 0.0:
            for i in range(cp.xq.shape[0]):
                cp.xq[i] = seg.q[k, i]
                cp.xv[i] = seg.v[k, i]
            for j in range(cp.xz.shape[0]):
                cp.xz[j] = seg.z[k, j]
        ck = rk4.Coupling(d, cp.xq, cp.xv, cp.xz, seg.m[k], cp.xqn, cp.xvn, cp.xzn, cp.xsq,
                          cp.xsv, cp.xsz)
        rk4.located_step(ts, hk, h, y, pt, tally, w, ck, seg, False)


@njit(**LEAF)
def _step_rows(step, h, n_per, rows, pt, tally, seg, cp):
    """Step ``step`` of the drive and every live copy, then their return mappings."""
    t = (step % n_per) * h
    nseg = _drive_step(t, h, rows, pt, tally, seg)
    for r in range(1, rows.alive.shape[0]):
        if rows.alive[r]:
            _copy_step(r, t, h, nseg, rows, pt, tally, seg, cp)
    tn = (step + 1) * h
    for r in range(rows.alive.shape[0]):
        if rows.alive[r]:
            common.post_step(tn, _row(rows, r), pt, tally, False)


@njit(cache=True, inline="always")
def measure_copy(p, c0, m, step, n_per, x, y, logacc, spec, band, log_err):
    """Copy ``m`` (state ``y``) against the drive ``x`` after output step ``step``: its scaled
    error, recorded at period ends with the carried rescaling factors ``logacc[m]``; outside
    the band (or flagged for period renormalisation at a period end) it is moved back to
    ``e0``.  Returns ``(e, moved)``; a non-finite ``e`` has written ``+inf`` from this period
    on, and the caller drops the copy."""
    period_end = (step + 1) % n_per == 0
    e = error(x.q, x.v, y.q, y.v, spec.inv_scale)
    if not math.isfinite(e):
        for k in range((step + 1) // n_per, log_err.shape[2]):
            log_err[p, c0 + m, k] = np.inf
        return e, False
    if period_end:
        k = (step + 1) // n_per
        log_err[p, c0 + m, k] = (math.log(e) + logacc[m]) if e > 0.0 else -np.inf
    if e > 0.0 and (e > band.hi or e < band.lo or (period_end and spec.renorm_period[c0 + m])):
        logacc[m] += math.log(e / band.e0)
        rescale(band.e0 / e, x, y)
        return band.e0, True
    return e, False


@njit(**LEAF)
def _measure(p, c0, step, rows, spec, band, n_per, pt, log_err):
    """After a step: each copy measured (:func:`measure_copy`); a copy within ``10 e0`` adopts
    the drive's stick/slip state; a copy whose error is not finite is dropped."""
    x = _row(rows, 0)
    for m in range(rows.logacc.shape[0]):
        r = m + 1
        if not rows.alive[r]:
            continue
        y = _row(rows, r)
        e, _ = measure_copy(p, c0, m, step, n_per, x, y, rows.logacc, spec, band, log_err)
        if not math.isfinite(e):
            rows.alive[r] = False
            continue
        if e <= 10.0 * band.e0:
            adopt_modes(x, y, pt)


@njit(cache=True)
def copies_task(p, c0, c1, pt, sch, x_start, spec, band, log_err, final):
    """Integrate point ``p``'s drive with its copies ``c0 .. c1 - 1`` for ``sch.n_periods``
    periods, writing ``ln eps`` at the period boundaries into ``log_err[p, c0:c1]`` (``nan``:
    the drive diverged; ``+inf``: the copy did) and the end states ``(q, v, z, mode)`` of the
    drive (``final[p, 0]``, written by the task with ``c0 == 0``) and of the copies
    (``final[p, 1 + c0:1 + c1]``), from which a later call continues the run exactly."""
    n = pt.Aq.shape[0]
    nq = pt.S.shape[0]
    rows = _new_rows(x_start, spec, c0, c1, n, nq)
    # the copies start at offsets that need not respect a rigid stuck set's constraint
    for r in range(c1 - c0 + 1):
        rk4.project_velocity(rows.V[r], rows.MODE[r], pt)
    tally = Tally(np.zeros(3), np.zeros(N_STATS))
    x = _row(rows, 0)
    for m in range(c1 - c0):
        e = error(x.q, x.v, rows.Q[m + 1], rows.V[m + 1], spec.inv_scale)
        log_err[p, c0 + m, 0] = math.log(e) if e > 0.0 else -np.inf
    # the drive's substeps of the current step (split at its own switches only)
    seg = rk4.new_segments(rk4.MAX_SWITCHES_PER_STEP + 1, n, nq)
    # the drive's local state and stages inside a copy's located step (scratch; the drive's own
    # stage states must survive for the fast path of the next copy)
    cp = rk4.Coupling(0.0, np.empty(n), np.empty(n), np.empty(nq), np.zeros(nq, np.int64),
                      np.empty(n), np.empty(n), np.empty(nq), np.zeros((4, n)), np.zeros((4, n)),
                      np.zeros((4, nq)))
    h, n_per = sch.h, sch.n_per
    for step in range(sch.n_periods * n_per):
        _step_rows(step, h, n_per, rows, pt, tally, seg, cp)
        if common.diverged(x.q, x.v, sch.div_limit):
            for m in range(c1 - c0):
                for k in range(log_err.shape[2]):
                    log_err[p, c0 + m, k] = np.nan
            return
        _measure(p, c0, step, rows, spec, band, n_per, pt, log_err)
    for r in range(c1 - c0 + 1):
        if r == 0 and c0 != 0:
            continue
        dst = final[p, 0] if r == 0 else final[p, c0 + r]
        for i in range(n):
            dst[i] = rows.Q[r, i]
            dst[n + i] = rows.V[r, i]
        for j in range(nq):
            dst[2 * n + j] = rows.Z[r, j]
            dst[2 * n + nq + j] = rows.MODE[r, j]


@njit(cache=True, nogil=True)
def run_task(tasks, stk, sch, x_start, spec, band, log_err, final, k):
    """Task ``k`` ``(point, first copy, end copy)`` of ``tasks`` (an ``(T, 3)`` int array; an
    item of :func:`beamsim.kernels.thread_pool.run_items`); ``stk``, ``sch`` and ``spec``
    stacked over the points."""
    p = tasks[k, 0]
    copies_task(p, tasks[k, 1], tasks[k, 2], point_at(stk, p, True),
                CopySchedule(sch.h[p], sch.n_per[p], sch.n_periods, sch.div_limit[p]),
                x_start[p], CopySpec(spec.offsets[p], spec.d[p], spec.renorm_period[p],
                                     spec.inv_scale[p]), band, log_err, final)


@njit(cache=True, nogil=True)
def run_task_rigid(tasks, stk, sch, x_start, spec, band, log_err, final, k):
    """:func:`run_task` for a rigid-stick point (a kernel of its own: compiled only when
    used)."""
    p = tasks[k, 0]
    copies_task(p, tasks[k, 1], tasks[k, 2], rigid_stick.with_cache(point_at(stk, p, True)),
                CopySchedule(sch.h[p], sch.n_per[p], sch.n_periods, sch.div_limit[p]),
                x_start[p], CopySpec(spec.offsets[p], spec.d[p], spec.renorm_period[p],
                                     spec.inv_scale[p]), band, log_err, final)

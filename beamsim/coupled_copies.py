r"""A drive trajectory of the beam and perturbed copies of it, integrated together (RK4).

This is the integrator behind the beam's Lyapunov estimates (:mod:`analysis.beam_lyapunov`).
One *drive* ``x = (q, v, z)`` (generalised coordinates, velocities, Jenkins slips) with its
stick/slip state, started from a full restart state (``SimResult.final_state``), and ``M``
*copies* ``y_m`` started at ``x + offset_m``, each with its own stick/slip state, obey

.. math::  \dot x = f(t, x), \qquad \dot y_m = f(t, y_m) + d_m\,(x - y_m)

on every continuous state variable (``q``, ``v`` and ``z``): ``d_m = 0`` is a free copy
(two-trajectory / Benettin estimate), ``d_m > 0`` is the one-way coupling of the Stefanski
synchronisation method.  All of them use the RK4 reference scheme of
:mod:`beamsim.simulate` with the same step.  The drive is stepped exactly as the reference
run steps it (split only at its own stick/slip switches), so its trajectory does not depend on
the copies: every copy of a point, in whatever task or batch, follows the same drive.  A copy
follows the drive's substeps and splits them further at its own switches; a coupled copy
integrates the drive's substep alongside (from the drive's state at the substep start) and the
coupling enters every RK4 stage with the drive's stage state, so the coupled pair is
integrated as one system.  Each copy's Jenkins elements are return-mapped after every step
exactly as the drive's.

The scaled error of copy ``m`` is the RMS over the ``2 n`` components of ``(q, v)``:

.. math::  \varepsilon_m = \sqrt{\tfrac{1}{2n}\sum_i ((y_{m,i} - x_i)\,/\,s_i)^2}

(``s_i``: the attractor's size in component ``i``).  To keep the copies in the linear regime
and off the round-off floor, a copy whose error leaves ``[band_lo, band_hi]`` is moved back
along its current direction to ``e0`` (about the drive, on ``q``, ``v`` and ``z``), and the
factor is carried in the recorded ``ln eps`` (so the record is the error of the linearised,
unbounded dynamics).  Copies flagged ``renorm_period`` are moved back to ``e0`` at every
period end as well (the classic Benettin renormalisation).  ``ln eps`` is recorded at every
forcing period boundary.

The stick/slip state of a Jenkins element is memory (hysteresis), not a function of the
continuous state, so a copy can stay stuck inside the band ``mu_k p < |tau| < mu_s p`` while the
drive's element slides: a mismatch that no coupling of the continuous variables removes (the
error settles at ``~ s'/d``) and that a rescaling would make inconsistent.  A copy within
``10 e0`` of the drive (after any rescaling) therefore takes the drive's stick/slip state
(:func:`_adopt_modes`): in the linear regime the two switch within the same step, so this only
acts on persistent mismatches, moving the copy's switch by less than the time its own would
have taken (an error of the order of the separation).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import njit, prange

from beamsim.simulate import (MAX_SWITCHES_PER_STEP, _accept, _diverged, _first_event,
                              _located_step, _post_step, _rk4_incr, check_int, check_positive,
                              period_steps, stack_points)

__all__ = ["run_copies"]


@njit(cache=True)
def _error(q, v, yq, yv, inv_scale):
    n = q.shape[0]
    acc = 0.0
    for i in range(n):
        a = (yq[i] - q[i]) * inv_scale[i]
        b = (yv[i] - v[i]) * inv_scale[n + i]
        acc += a * a + b * b
    return math.sqrt(acc / (2 * n))


@njit(cache=True)
def _adopt_modes(q, z, mode, yq, yz, ymode, S):
    """Give a copy the drive's stick/slip state, element by element, together with the drive's
    elastic strain of that element: ``y_z = s_y - (s_x - z_x)``, so the element's traction
    equals the drive's (for a sliding drive element that is the kinetic traction).  Without
    the strain a copy that broke away (``mu_s > mu_k``: ``z`` jumps by ``(mu_s - mu_k) p / k_t``)
    while the drive did not would keep a traction difference of ``(mu_s - mu_k) p`` when made
    to stick again: a finite jump of the separation that the linearised dynamics do not have.
    Returns the number of changed elements."""
    changed = 0
    n = q.shape[0]
    for j in range(mode.shape[0]):
        if ymode[j] == mode[j]:
            continue
        changed += 1
        sx = 0.0
        sy = 0.0
        for k in range(n):
            sx += S[j, k] * q[k]
            sy += S[j, k] * yq[k]
        yz[j] = sy - (sx - z[j])
        ymode[j] = mode[j]
    return changed


@njit(cache=True)
def _rescale(fac, q, v, z, yq, yv, yz):
    for i in range(q.shape[0]):
        yq[i] = q[i] + fac * (yq[i] - q[i])
        yv[i] = v[i] + fac * (yv[i] - v[i])
    for j in range(z.shape[0]):
        yz[j] = z[j] + fac * (yz[j] - z[j])


@njit(cache=True)
def _copies_task(p, c0, c1, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0, om, tau_s, tau_k, fc, fs,
                 vs, kv, eps, damp, h, n_per, n_periods, x_start, offsets, d, renorm_period,
                 inv_scale, e0, band_lo, band_hi, div_limit, log_err):
    n = Aq.shape[0]
    nq = S.shape[0]
    M = c1 - c0
    # row 0: the drive, rows 1..M: the copies
    Q = np.empty((M + 1, n)); V = np.empty((M + 1, n)); Z = np.empty((M + 1, nq))
    MODE = np.zeros((M + 1, nq), np.int64)
    for i in range(n):
        Q[0, i] = x_start[i]
        V[0, i] = x_start[n + i]
    for j in range(nq):
        Z[0, j] = x_start[2 * n + j]
        MODE[0, j] = int(x_start[2 * n + nq + j])
    for m in range(M):
        for i in range(n):
            Q[m + 1, i] = Q[0, i] + offsets[c0 + m, i]
            V[m + 1, i] = V[0, i] + offsets[c0 + m, n + i]
        for j in range(nq):
            Z[m + 1, j] = Z[0, j] + offsets[c0 + m, 2 * n + j]
            MODE[m + 1, j] = MODE[0, j]
    dd = np.zeros(M + 1)
    for m in range(M):
        dd[m + 1] = d[c0 + m]
    logacc = np.zeros(M)
    alive = np.ones(M + 1, np.bool_)
    ecum = np.zeros(3)
    stats = np.zeros(6)
    tau = np.empty(nq)
    kq = np.zeros((4, n)); kvv = np.zeros((4, n)); kz = np.zeros((4, nq)); ke = np.zeros((4, 3))
    SQ = np.zeros((M + 1, 4, n)); SV = np.zeros((M + 1, 4, n)); SZ = np.zeros((M + 1, 4, nq))
    QN = np.empty((M + 1, n)); VN = np.empty((M + 1, n)); ZN = np.empty((M + 1, nq))
    EN = np.empty((M + 1, 3))
    for m in range(M):
        e = _error(Q[0], V[0], Q[m + 1], V[m + 1], inv_scale)
        log_err[p, c0 + m, 0] = math.log(e) if e > 0.0 else -np.inf
    adopt_below = 10.0 * e0
    # the drive's substeps of the current step (split at its own switches only)
    ns = MAX_SWITCHES_PER_STEP + 1
    seg_t = np.empty(ns + 1); seg_q = np.empty((ns, n)); seg_v = np.empty((ns, n))
    seg_z = np.empty((ns, nq)); seg_m = np.zeros((ns, nq), np.int64)
    # the drive's local state and stages inside a copy's located step (scratch; the drive's own
    # stage states SQ[0] must survive for the fast path of the next copy)
    xq = np.empty(n); xv = np.empty(n); xz = np.empty(nq)
    xqn = np.empty(n); xvn = np.empty(n); xzn = np.empty(nq)
    xsq = np.zeros((4, n)); xsv = np.zeros((4, n)); xsz = np.zeros((4, nq))
    for step in range(n_periods * n_per):
        t = (step % n_per) * h
        # the drive, exactly as the reference run steps it (its trajectory does not depend on
        # the copies); fast path: one RK4 step, redone with located switches only if it has one
        for i in range(n):
            seg_q[0, i] = Q[0, i]
            seg_v[0, i] = V[0, i]
        for j in range(nq):
            seg_z[0, j] = Z[0, j]
            seg_m[0, j] = MODE[0, j]
        _rk4_incr(t, h, Q[0], V[0], Z[0], MODE[0], law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0,
                  om, fc, fs, vs, kv, eps, damp, kq, kvv, kz, ke, tau, QN[0], VN[0], ZN[0], EN[0],
                  SQ[0], SV[0], SZ[0], 0.0, SQ[0], SV[0], SZ[0])
        th = 2.0
        if law == 0:
            th, _ = _first_event(Q[0], V[0], Z[0], MODE[0], QN[0], VN[0], ZN[0], S, kt, tau_s)
        if th >= 1.0:
            _accept(Q[0], V[0], Z[0], ecum, QN[0], VN[0], ZN[0], EN[0])
            nseg = 1
            seg_t[0] = t
            seg_t[1] = t + h
        else:
            _, nseg = _located_step(t, h, h, Q[0], V[0], Z[0], MODE[0], law, Aq, Av, Bt, gv, S,
                                    wq, kt, ct, Cm, g, f0, om, tau_s, tau_k, fc, fs, vs, kv, eps,
                                    damp, ecum, stats, kq, kvv, kz, ke, tau, QN[0], VN[0], ZN[0],
                                    EN[0], SQ[0], SV[0], SZ[0], 0.0, xq, xv, xz, MODE[0], QN[0],
                                    VN[0], ZN[0], SQ[0], SV[0], SZ[0], seg_t, seg_q, seg_v,
                                    seg_z, seg_m, True)
        # every copy follows the drive segment by segment (splitting further at its own
        # switches); a coupled copy integrates the drive's segment alongside for the stages
        for r in range(1, M + 1):
            if not alive[r]:
                continue
            if nseg == 1:
                # fast path: the drive's full step and its stage states (SQ[0]) are at hand
                _rk4_incr(t, h, Q[r], V[r], Z[r], MODE[r], law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm,
                          g, f0, om, fc, fs, vs, kv, eps, damp, kq, kvv, kz, ke, tau, QN[r], VN[r],
                          ZN[r], EN[r], SQ[r], SV[r], SZ[r], dd[r], SQ[0], SV[0], SZ[0])
                th = 2.0
                if law == 0:
                    th, _ = _first_event(Q[r], V[r], Z[r], MODE[r], QN[r], VN[r], ZN[r], S, kt,
                                         tau_s)
                if th >= 1.0:
                    _accept(Q[r], V[r], Z[r], ecum, QN[r], VN[r], ZN[r], EN[r])
                    continue
            for k in range(nseg):
                ts = seg_t[k]
                hk = seg_t[k + 1] - ts
                if hk <= 1e-12 * h:
                    continue
                if dd[r] != 0.0:
                    for i in range(n):
                        xq[i] = seg_q[k, i]
                        xv[i] = seg_v[k, i]
                    for j in range(nq):
                        xz[j] = seg_z[k, j]
                _located_step(ts, hk, h, Q[r], V[r], Z[r], MODE[r], law, Aq, Av, Bt, gv, S, wq, kt,
                              ct, Cm, g, f0, om, tau_s, tau_k, fc, fs, vs, kv, eps, damp, ecum,
                              stats, kq, kvv, kz, ke, tau, QN[r], VN[r], ZN[r], EN[r], SQ[r],
                              SV[r], SZ[r], dd[r], xq, xv, xz, seg_m[k], xqn, xvn, xzn, xsq,
                              xsv, xsz, seg_t, seg_q, seg_v, seg_z, seg_m, False)
        tn = (step + 1) * h
        for r in range(M + 1):
            if alive[r]:
                _post_step(tn, Q[r], V[r], Z[r], MODE[r], law, S, wq, kt, tau_s, tau_k, eps,
                           ecum, stats, False)
        if _diverged(Q[0], V[0], div_limit):
            for m in range(M):
                for k in range(log_err.shape[2]):
                    log_err[p, c0 + m, k] = np.nan
            return
        period_end = (step + 1) % n_per == 0
        for m in range(M):
            r = m + 1
            if not alive[r]:
                continue
            e = _error(Q[0], V[0], Q[r], V[r], inv_scale)
            if not math.isfinite(e):
                alive[r] = False
                for k in range((step + 1) // n_per, log_err.shape[2]):
                    log_err[p, c0 + m, k] = np.inf
                continue
            if period_end:
                k = (step + 1) // n_per
                log_err[p, c0 + m, k] = (math.log(e) + logacc[m]) if e > 0.0 else -np.inf
            if e > 0.0 and (e > band_hi or e < band_lo or (period_end and renorm_period[c0 + m])):
                logacc[m] += math.log(e / e0)
                _rescale(e0 / e, Q[0], V[0], Z[0], Q[r], V[r], Z[r])
                e = e0
            if e <= adopt_below:
                _adopt_modes(Q[0], Z[0], MODE[0], Q[r], Z[r], MODE[r], S)


@njit(cache=True, parallel=True)
def _run_tasks(task_p, task_c0, task_c1, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0, om, tau_s,
               tau_k, fc, fs, vs, kv, eps, damp, h, n_per, n_periods, x_start, offsets, d,
               renorm_period, inv_scale, e0, band_lo, band_hi, div_limit, log_err):
    for k in prange(task_p.shape[0]):
        p = task_p[k]
        _copies_task(p, task_c0[k], task_c1[k], law[p], Aq[p], Av[p], Bt[p], gv[p], S[p], wq[p],
                     kt[p], ct[p], Cm[p], g[p], f0[p], om[p], tau_s[p], tau_k[p], fc[p], fs[p], vs[p],
                     kv[p], eps[p], damp[p], h[p], n_per[p], n_periods, x_start[p], offsets[p],
                     d[p], renorm_period[p], inv_scale[p], e0, band_lo, band_hi, div_limit[p],
                     log_err)


def run_copies(prepared: list, x_start: np.ndarray, offsets: np.ndarray, d: np.ndarray,
               inv_scale: np.ndarray, *, n_periods: int, e0: float,
               renorm_period: np.ndarray | None = None, band: tuple[float, float] = (1e-4, 1e4),
               steps_per_period: int | None = None, step_factor: float = 0.5,
               n_threads: int | None = None, split: int | None = None,
               div_limit: float = 1e6) -> np.ndarray:
    """Integrate the drive and its copies for ``n_periods`` forcing periods (see the module
    docstring) and return ``ln eps`` of shape ``(P, M, n_periods + 1)`` at the period
    boundaries (``nan``: the drive diverged; ``+inf``: the copy did).

    prepared : ``P`` points (:func:`beamsim.simulate.prepare_point`, same ``n`` and ``n_quad``).
    x_start : ``(P, 2 n + 2 n_quad)`` drive restart states ``(q, v, z, mode)``
        (``SimResult.final_state``; the run restarts the forcing phase at ``t = 0``).
    offsets : ``(P, M, 2 n + n_quad)`` initial ``y_m - x`` on ``(q, v, z)``.
    d : ``(P, M)`` couplings (1 / time unit); ``0`` = free copy.
    inv_scale : ``(P, 2 n)`` inverse attractor size per component of ``(q, v)``.
    e0, band : rescaling target and band ``[e0 band[0], e0 band[1]]`` of the scaled error.
    renorm_period : ``(P, M)`` bool, copies also rescaled to ``e0`` at every period end.
    split : tasks per point (for threads), each integrating the drive with its share of the
        copies.  The drive does not depend on the copies, so results do not depend on
        ``split``, on which other copies run, or on the number of threads (bitwise).  Default:
        enough tasks to occupy the threads (``ceil(threads / P)``).
    """
    P = len(prepared)
    x_start = np.ascontiguousarray(x_start, dtype=float)
    offsets = np.ascontiguousarray(offsets, dtype=float)
    d = np.ascontiguousarray(d, dtype=float)
    inv_scale = np.ascontiguousarray(inv_scale, dtype=float)
    n_periods = check_int("n_periods", n_periods, 1)
    e0 = check_positive("e0", e0)
    if P == 0:
        raise ValueError("prepared must not be empty")
    n, nq = prepared[0].model.n, prepared[0].model.n_quad
    M = offsets.shape[1] if offsets.ndim == 3 else -1
    if offsets.shape != (P, M, 2 * n + nq) or d.shape != (P, M):
        raise ValueError(f"offsets must be (P, M, {2 * n + nq}) and d (P, M); got "
                         f"{offsets.shape} and {d.shape}")
    if x_start.shape != (P, 2 * n + 2 * nq) or inv_scale.shape != (P, 2 * n):
        raise ValueError("x_start must be (P, 2 n + 2 n_quad) and inv_scale (P, 2 n)")
    if not (np.all(np.isfinite(x_start)) and np.all(np.isfinite(offsets)) and np.all(d >= 0)):
        raise ValueError("x_start and offsets must be finite and d >= 0")
    if renorm_period is None:
        renorm_period = np.zeros((P, M), np.bool_)
    renorm_period = np.ascontiguousarray(renorm_period, dtype=np.bool_)
    k = stack_points(prepared, div_limit)
    h = np.empty(P)
    n_per = np.empty(P, np.int64)
    for i, pp in enumerate(prepared):
        n_per[i] = period_steps(pp, "rk4", steps_per_period, step_factor)
        h[i] = 2 * math.pi / pp.omega / n_per[i]
    threads = numba.get_num_threads() if n_threads is None else check_int("n_threads", n_threads, 1)
    split = -(-threads // P) if split is None else int(split)
    split = max(1, min(M, split))
    tp, t0, t1 = [], [], []
    for p in range(P):
        for chunk in np.array_split(np.arange(M), split):
            if chunk.size:
                tp.append(p); t0.append(int(chunk[0])); t1.append(int(chunk[-1]) + 1)
    log_err = np.full((P, M, n_periods + 1), np.nan)
    old = numba.get_num_threads()
    if n_threads is not None:
        numba.set_num_threads(threads)
    try:
        _run_tasks(np.array(tp, np.int64), np.array(t0, np.int64), np.array(t1, np.int64),
                   k.law, k.Aq, k.Av, k.Bt, k.gv, k.S, k.wq, k.kt, k.ct, k.Cs, k.g, k.f0, k.om,
                   k.tau_s, k.tau_k, k.fc, k.fs, k.vs, k.kv, k.eps, k.damp_s, h, n_per, n_periods, x_start,
                   offsets, d, renorm_period, inv_scale, e0, e0 * band[0], e0 * band[1],
                   k.divl, log_err)
    finally:
        if n_threads is not None:
            numba.set_num_threads(old)
    return log_err

"""Bookkeeping shared by every integrator (see the step contract in :mod:`beamsim.kernels`).

Units and equations: docs/model.md.  ``pt`` is a :data:`~beamsim.kernels.bundles.Point`,
``x`` a :data:`~beamsim.kernels.bundles.State`, ``tally`` a
:data:`~beamsim.kernels.bundles.Tally`, ``sched`` a :data:`~beamsim.kernels.bundles.Schedule`,
``out`` the batch's :data:`~beamsim.kernels.bundles.Outputs` and ``p`` the point's row in it.

Hot kernels are compiled with :data:`~beamsim.kernels.bundles.LEAF`'s floating-point flags.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from beamsim.friction import RIGID_STICK
from beamsim.kernels.bundles import LEAF, State, Tally
from beamsim.results import (
    FLAG_DIVERGED,
    FLAG_E_MECH0,
    FLAG_SLIPPED,
    FLAG_STICK_FRACTION,
    FLAG_STICK_FRACTION_ALL,
    FLAG_T_DIVERGED,
    FLAG_T_FIRST_SLIP,
    N_STATS,
    STAT_SLIPPED,
    STAT_STUCK_W_ALL,
    STAT_STUCK_W_RECORD,
    STAT_T_FIRST_SLIP,
    STAT_W_ALL,
    STAT_W_RECORD,
)


@njit(cache=True, inline="always")
def slip_and_rate(S, j, q, v):
    """Slip ``s_j = S_j.q`` and slip rate ``s_j' = S_j.v`` of Jenkins element ``j``."""
    s = 0.0
    sd = 0.0
    for k in range(q.shape[0]):
        s += S[j, k] * q[k]
        sd += S[j, k] * v[k]
    return s, sd


@njit(cache=True, inline="always")
def structural_acceleration(i, q, v, F, pt):
    """Row ``i`` of ``M^-1 (g F - K q - C_struct v)`` (everything but the interface)."""
    acc = pt.gv[i] * F
    for k in range(q.shape[0]):
        acc += pt.Aq[i, k] * q[k]
    if pt.damp:
        for k in range(q.shape[0]):
            acc += pt.Av[i, k] * v[k]
    return acc


@njit(cache=True, inline="always")
def damping_power(v, pt):
    """``v.C v``, the power of the damping matrix the integrator books (0 without damping)."""
    pd = 0.0
    if pt.damp:
        Cm = pt.Cm
        n = v.shape[0]
        for i in range(n):
            ci = 0.0
            for k in range(n):
                ci += Cm[i, k] * v[k]
            pd += v[i] * ci
    return pd


@njit(**LEAF)
def energy(q, v, z, pt):
    """Mechanical energy ``v.M v / 2 + q.K q / 2`` plus the elastic energy of the stuck-or-
    slipping Jenkins springs ``sum_j w_j k_t (s_j - z_j)^2 / 2`` (stick-slip law); returns
    ``(total, interface part)``."""
    n = q.shape[0]
    Mm, Km, S, wq, kt = pt.Mm, pt.Km, pt.S, pt.wq, pt.kt
    e = 0.0
    for i in range(n):
        mi = 0.0
        ki = 0.0
        for k in range(n):
            mi += Mm[i, k] * v[k]
            ki += Km[i, k] * q[k]
        e += 0.5 * (v[i] * mi + q[i] * ki)
    ei = 0.0
    if pt.law == 0:
        for j in range(z.shape[0]):
            s = 0.0
            for k in range(n):
                s += S[j, k] * q[k]
            ei += 0.5 * kt * wq[j] * (s - z[j]) ** 2
    return e + ei, ei


@njit(**LEAF)
def record(row, x, ecum, pt, out, p):
    """Poincare sample ``row`` of point ``p``: state, tip response, energy ledger."""
    q = x.q
    n = q.shape[0]
    for i in range(n):
        out.pc_state[p, row, i] = q[i]
        out.pc_state[p, row, n + i] = x.v[i]
    for r in range(4):
        acc = 0.0
        for k in range(n):
            acc += pt.tip[r, k] * q[k]
        out.pc_tip[p, row, r] = acc
    em, ei = energy(q, x.v, x.z, pt)
    out.pc_energy[p, row, 0] = ecum[0]
    out.pc_energy[p, row, 1] = ecum[1]
    out.pc_energy[p, row, 2] = ecum[2]
    out.pc_energy[p, row, 3] = em
    out.pc_energy[p, row, 4] = ei


@njit(**LEAF)
def dense_sample(row, q, v, tip, dense, p):
    """Dense-history sample ``row``: tip response, and ``(q, v)`` if the history is full."""
    n = q.shape[0]
    for r in range(4):
        acc = 0.0
        for k in range(n):
            acc += tip[r, k] * q[k]
        dense[p, row, r] = acc
    if dense.shape[2] > 4:
        for i in range(n):
            dense[p, row, 4 + i] = q[i]
            dense[p, row, 4 + n + i] = v[i]


@njit(cache=True, inline="always")
def start_slip(j, s, z, mode, kt, tau_k, wq, ecum):
    """Stuck element ``j`` (slip ``s``) starts sliding in the direction of its traction:
    ``z`` moves so that the traction is ``tau_k``; the released elastic energy is booked as
    friction dissipation ``ecum[1]``.  Shared by the return mapping and the located switches."""
    tr = kt * (s - z[j])
    m = 1 if tr > 0 else -1
    znew = s - m * tau_k[j] / kt
    ecum[1] += wq[j] * 0.5 * kt * ((s - z[j]) ** 2 - (s - znew) ** 2)
    z[j] = znew
    mode[j] = m


@njit(cache=True, inline="always")
def note_first_slip(stats, t):
    """Record ``t`` as the time of the first slip unless a slip was recorded before."""
    if stats[STAT_SLIPPED] == 0.0:
        stats[STAT_SLIPPED] = 1.0
        stats[STAT_T_FIRST_SLIP] = t


@njit(**LEAF)
def post_step(t, x, pt, tally, inrec, update=True):
    """Return mapping of the Jenkins elements after a step (``update``; the implicit
    integrators map inside their step and pass False) and the slip statistics: first slip,
    stuck and total quadrature weight (whole run, and the recorded periods if ``inrec``)."""
    q, v, z, mode = x.q, x.v, x.z, x.mode
    S, kt, tau_s, stats = pt.S, pt.kt, pt.tau_s, tally.stats
    nq = z.shape[0]
    stuck_w = 0.0
    tot_w = 0.0
    for j in range(nq):
        s, sd = slip_and_rate(S, j, q, v)
        stuck = False
        if pt.law == RIGID_STICK:
            # rigid stick (beamsim.kernels.rigid_stick): every switch is located; only points
            # without friction (zero pressure) are set sliding here
            if update and tau_s[j] <= 0.0:
                mode[j] = 1
            stuck = mode[j] == 0
            if mode[j] != 0:
                note_first_slip(stats, t)
        elif pt.law == 0 and not update:
            stuck = mode[j] == 0
            if mode[j] != 0:
                note_first_slip(stats, t)
        elif pt.law == 0:
            if tau_s[j] <= 0.0:
                # no stick possible (zero pressure): permanently sliding, zero traction
                mode[j] = 1
                z[j] = s
            elif mode[j] == 0:
                if abs(kt * (s - z[j])) > tau_s[j]:
                    start_slip(j, s, z, mode, kt, pt.tau_k, pt.wq, tally.ecum)
                else:
                    stuck = True
            else:
                if mode[j] * sd < 0.0:
                    mode[j] = 0
                    stuck = True
            if mode[j] != 0:
                note_first_slip(stats, t)
        else:
            if abs(sd) < pt.eps:
                stuck = True
            else:
                note_first_slip(stats, t)
        tot_w += pt.wq[j]
        if stuck:
            stuck_w += pt.wq[j]
    stats[STAT_STUCK_W_ALL] += stuck_w
    stats[STAT_W_ALL] += tot_w
    if inrec:
        stats[STAT_STUCK_W_RECORD] += stuck_w
        stats[STAT_W_RECORD] += tot_w


@njit(**LEAF)
def diverged(q, v, lim):
    """True if some ``|q_i|`` exceeds ``lim`` or some ``v_i`` is not finite."""
    for i in range(q.shape[0]):
        if not (abs(q[i]) <= lim) or not math.isfinite(v[i]):
            return True
    return False


@njit(**LEAF)
def end_of_step(p, k, t, x, ecum, pt, sched, out):
    """Bookkeeping after step ``k`` (time ``t``) of every integrator: divergence flag
    (returns True: stop this point), Poincare record at period ends, dense output."""
    if diverged(x.q, x.v, sched.div_limit):
        out.flags[p, FLAG_DIVERGED] = 1.0
        out.flags[p, FLAG_T_DIVERGED] = t
        return True
    if k % sched.n_per == 0:
        ip = k // sched.n_per - sched.n_trans
        if ip >= 0:
            record(ip, x, ecum, pt, out, p)
    if sched.dense_every > 0 and k % sched.dense_every == 0:
        dense_sample(k // sched.dense_every, x.q, x.v, pt.tip, out.dense, p)
    return False


@njit(**LEAF)
def final_flags(p, stats, out, x):
    """Slip indicators of a finished point (see :class:`beamsim.results.SimResult`) and its
    final state ``(q, v, z, mode)`` (the restart point of :mod:`beamsim.coupled_copies`)."""
    q, v, z, mode = x.q, x.v, x.z, x.mode
    final, flags = out.final, out.flags
    n = q.shape[0]
    nq = z.shape[0]
    for i in range(n):
        final[p, i] = q[i]
        final[p, n + i] = v[i]
    for j in range(nq):
        final[p, 2 * n + j] = z[j]
        final[p, 2 * n + nq + j] = mode[j]
    flags[p, FLAG_SLIPPED] = stats[STAT_SLIPPED]
    flags[p, FLAG_T_FIRST_SLIP] = stats[STAT_T_FIRST_SLIP] if stats[STAT_SLIPPED] > 0 else np.nan
    flags[p, FLAG_STICK_FRACTION] = (stats[STAT_STUCK_W_RECORD] / stats[STAT_W_RECORD]
                                     if stats[STAT_W_RECORD] > 0 else np.nan)
    flags[p, FLAG_STICK_FRACTION_ALL] = (stats[STAT_STUCK_W_ALL] / stats[STAT_W_ALL]
                                         if stats[STAT_W_ALL] > 0 else np.nan)


@njit(cache=True)
def state_from(x0, n, nq):
    """``(q, v, z, mode)`` copied out of a flat state ``x0 = (q, v, z[, mode])``."""
    q = x0[:n].copy()
    v = x0[n:2 * n].copy()
    z = x0[2 * n:2 * n + nq].copy()
    mode = np.zeros(nq, np.int64)
    if x0.shape[0] >= 2 * n + 2 * nq:
        for j in range(nq):
            mode[j] = int(x0[2 * n + nq + j])
    return State(q, v, z, mode)


@njit(cache=True)
def start_point(p, x0, pt, sched, out):
    """Initial state of every integrator: ``(q, v, z, mode)`` from ``x0``, a consistent interface
    state (return mapping at t = 0, not counted as slip or dissipation), the initial energy in
    the flags, and the t = 0 record / dense sample.  Returns ``(State, Tally, e0)``."""
    x = state_from(x0, pt.Mm.shape[0], pt.S.shape[0])
    tally = Tally(np.zeros(3), np.zeros(N_STATS))
    post_step(0.0, x, pt, tally, False)
    tally.stats[STAT_STUCK_W_ALL] = 0.0
    tally.stats[STAT_W_ALL] = 0.0
    tally.ecum[1] = 0.0
    e0, _ = energy(x.q, x.v, x.z, pt)
    out.flags[p, FLAG_E_MECH0] = e0
    if sched.n_trans == 0:
        record(0, x, tally.ecum, pt, out, p)
    if sched.dense_every > 0:
        dense_sample(0, x.q, x.v, pt.tip, out.dense, p)
    return x, tally, e0


@njit(cache=True, inline="always")
def illinois(a, ga, b, gb, th, gm, side):
    """One Illinois (modified regula falsi) update of the bracket ``[a, b]`` (``g(a) <= 0 <
    g(b)``) with the value ``gm = g(th)``; returns ``(a, ga, b, gb, th_next, side)``."""
    if gm > 0.0:
        b = th
        gb = gm
        if side == 1:
            ga *= 0.5
        side = 1
    else:
        a = th
        ga = gm
        if side == -1:
            gb *= 0.5
        side = -1
    th = a - ga * (b - a) / (gb - ga)
    if not (a < th < b):
        th = 0.5 * (a + b)
    return a, ga, b, gb, th, side


@njit(**LEAF)
def apply_switch(j, t, s, x, pt, tally):
    """Switch element ``j`` (slip ``s``) at a located event at time ``t``: stuck -> slipping in
    the direction of its traction (:func:`start_slip`), slipping -> stuck (``z`` frozen)."""
    if x.mode[j] == 0:
        start_slip(j, s, x.z, x.mode, pt.kt, pt.tau_k, pt.wq, tally.ecum)
        note_first_slip(tally.stats, t)
    else:
        x.mode[j] = 0

r"""Batched time integration of the two-layer curved beam with interlayer friction.

Python API (see docs/model.md, section "Simulator")::

    from beamsim.simulate import simulate, simulate_batch
    r = simulate(f0_rel=2.0, Omega=1.2, law="stick-slip", mu_s=0.3, p=1e-4, n_modes=3)
    r.poincare_tip          # (n_record + 1, 4): w, u1, u2 at the tip and the load-point displacement
    b = simulate_batch([dict(f0_rel=x, Omega=1.2) for x in (0.5, 1, 2, 4)], n_threads=2)
    b.summary()             # one row per point (pandas DataFrame)

Integrators (numba, ``prange`` over the points of a batch; each point's arithmetic is
independent of the others, so results do not depend on the number of threads):

* ``method="rk4"`` -- the reference: classical fixed-step RK4 on the state
  ``(q, v, z, W_in, D_fric, D_damp)``.  The stick/slip state of each Jenkins element is frozen
  inside a step, so the right-hand side is smooth there; every switch is located inside the
  step (event functions interpolated, then Illinois on the RK4 substep) and the step is split
  at it, so switching times depend continuously on the state (4th order through stick-slip);
  a return mapping after each step settles anything left.  Default step ``h = step_factor / omega_max`` (``omega_max``: largest natural
  frequency of the stuck system, plus the largest viscous rate of a regularised law), rounded
  so that a forcing period is an integer number of steps.
* ``method="newmark"`` -- average-acceleration Newmark (trapezoidal, A-stable, energy
  conserving for the linear part) with an implicit return-mapping of the Jenkins elements
  (semi-smooth Newton on the stick/slip pattern).  The stiff stuck interface does not limit
  its step, so it takes ``steps_per_period`` (default 256) steps per period.  Stick-slip law
  only.  It agrees with the RK4 reference to its second order of accuracy (tests).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields
from types import SimpleNamespace

import numba
import numpy as np
from numba import njit, prange

from beamsim.friction import Friction, smooth_traction
from beamsim.two_layer import (Geometry, TwoLayerModel, build_model, check_int,
                               check_nonnegative, check_positive, pressure_at)

__all__ = ["simulate", "simulate_batch", "SimResult", "BatchResult", "prepare_point", "restart_params",
           "ENERGY_COLUMNS", "TIP_COLUMNS"]

TIP_COLUMNS = ("w_tip", "u1_tip", "u2_tip", "load_point")
ENERGY_COLUMNS = ("W_in", "D_friction", "D_damping", "E_mech", "E_interface")
METHODS = {"rk4": 0, "newmark": 1, "expo": 2}


# =========================================================================== numba kernels
@njit(cache=True, inline="always")
def _deriv(t, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, gvec, f0, om,
           fc, fs, vs, kv, eps, damp, dq, dv, dz, de, tau):
    n = q.shape[0]
    nq = z.shape[0]
    F = f0 * (math.cos(om * t) - 1.0)
    dD = 0.0
    dC = 0.0
    for j in range(nq):
        s = 0.0
        sd = 0.0
        for k in range(n):
            s += S[j, k] * q[k]
            sd += S[j, k] * v[k]
        if law == 0:
            tj = kt * (s - z[j])
            if mode[j] != 0:
                dz[j] = sd
                dD += wq[j] * tj * sd
            else:
                dz[j] = 0.0
        else:
            tj = smooth_traction(sd, fc[j], fs[j], vs, kv, eps)
            dz[j] = 0.0
            dD += wq[j] * tj * sd
        if ct != 0.0:
            # interface dashpot (interface_damping) parallel to the whole friction element
            tau[j] = tj + ct * sd
            dC += wq[j] * ct * sd * sd
        else:
            tau[j] = tj
    pw = 0.0
    for i in range(n):
        acc = gv[i] * F
        for k in range(n):
            acc += Aq[i, k] * q[k]
        if damp:
            for k in range(n):
                acc += Av[i, k] * v[k]
        for j in range(nq):
            acc += Bt[i, j] * tau[j]
        dv[i] = acc
        dq[i] = v[i]
        pw += gvec[i] * v[i]
    pd = 0.0
    if damp:
        for i in range(n):
            ci = 0.0
            for k in range(n):
                ci += Cm[i, k] * v[k]
            pd += v[i] * ci
    de[0] = F * pw
    de[1] = dD
    de[2] = pd + dC


@njit(cache=True)
def _energy(q, v, z, law, Mm, Km, S, wq, kt):
    n = q.shape[0]
    e = 0.0
    for i in range(n):
        mi = 0.0
        ki = 0.0
        for k in range(n):
            mi += Mm[i, k] * v[k]
            ki += Km[i, k] * q[k]
        e += 0.5 * (v[i] * mi + q[i] * ki)
    ei = 0.0
    if law == 0:
        for j in range(z.shape[0]):
            s = 0.0
            for k in range(n):
                s += S[j, k] * q[k]
            ei += 0.5 * kt * wq[j] * (s - z[j]) ** 2
    return e + ei, ei


@njit(cache=True)
def _record(row, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, pc_state, pc_tip, pc_energy, p):
    n = q.shape[0]
    for i in range(n):
        pc_state[p, row, i] = q[i]
        pc_state[p, row, n + i] = v[i]
    for r in range(4):
        acc = 0.0
        for k in range(n):
            acc += tip[r, k] * q[k]
        pc_tip[p, row, r] = acc
    em, ei = _energy(q, v, z, law, Mm, Km, S, wq, kt)
    pc_energy[p, row, 0] = ecum[0]
    pc_energy[p, row, 1] = ecum[1]
    pc_energy[p, row, 2] = ecum[2]
    pc_energy[p, row, 3] = em
    pc_energy[p, row, 4] = ei


@njit(cache=True)
def _dense(row, q, v, tip, dense, p):
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
def _start_slip(j, s, z, mode, kt, tau_k, wq, ecum):
    """Stuck element ``j`` (slip ``s``) starts sliding in the direction of its traction:
    ``z`` moves so that the traction is ``tau_k``; the released elastic energy is booked as
    friction dissipation ``ecum[1]``.  Shared by the return mapping and the located switches."""
    tr = kt * (s - z[j])
    m = 1 if tr > 0 else -1
    znew = s - m * tau_k[j] / kt
    ecum[1] += wq[j] * 0.5 * kt * ((s - z[j]) ** 2 - (s - znew) ** 2)
    z[j] = znew
    mode[j] = m


@njit(cache=True)
def _post_step(t, q, v, z, mode, law, S, wq, kt, tau_s, tau_k, eps, ecum, stats, inrec,
               update=True):
    """Return mapping of the Jenkins elements after a step; slip indicators.

    stats: [0] ever slipped (0/1), [1] time of first slip, [2] stuck-weight sum (record),
    [3] weight sum (record), [4] stuck-weight sum (all), [5] weight sum (all)."""
    n = q.shape[0]
    nq = z.shape[0]
    stuck_w = 0.0
    tot_w = 0.0
    for j in range(nq):
        s = 0.0
        sd = 0.0
        for k in range(n):
            s += S[j, k] * q[k]
            sd += S[j, k] * v[k]
        stuck = False
        if law == 0 and not update:
            stuck = mode[j] == 0
            if mode[j] != 0 and stats[0] == 0.0:
                stats[0] = 1.0
                stats[1] = t
        elif law == 0:
            if tau_s[j] <= 0.0:
                # no stick possible (zero pressure): permanently sliding, zero traction
                mode[j] = 1
                z[j] = s
            elif mode[j] == 0:
                if abs(kt * (s - z[j])) > tau_s[j]:
                    _start_slip(j, s, z, mode, kt, tau_k, wq, ecum)
                else:
                    stuck = True
            else:
                if mode[j] * sd < 0.0:
                    mode[j] = 0
                    stuck = True
            if mode[j] != 0 and stats[0] == 0.0:
                stats[0] = 1.0
                stats[1] = t
        else:
            if abs(sd) < eps:
                stuck = True
            elif stats[0] == 0.0:
                stats[0] = 1.0
                stats[1] = t
        tot_w += wq[j]
        if stuck:
            stuck_w += wq[j]
    stats[4] += stuck_w
    stats[5] += tot_w
    if inrec:
        stats[2] += stuck_w
        stats[3] += tot_w


@njit(cache=True)
def _diverged(q, v, lim):
    for i in range(q.shape[0]):
        if not (abs(q[i]) <= lim) or not math.isfinite(v[i]):
            return True
    return False


@njit(cache=True)
def _end_of_step(p, k, t, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, n_per, n_trans, dense_every,
                 div_limit, pc_state, pc_tip, pc_energy, dense, flags):
    """Shared bookkeeping after step ``k`` (time ``t``) of every integrator: divergence flag
    (returns True: stop this point), Poincare record at period ends, dense output."""
    if _diverged(q, v, div_limit):
        flags[p, 0] = 1.0
        flags[p, 1] = t
        return True
    if k % n_per == 0:
        ip = k // n_per - n_trans
        if ip >= 0:
            _record(ip, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, pc_state, pc_tip, pc_energy, p)
    if dense_every > 0 and k % dense_every == 0:
        _dense(k // dense_every, q, v, tip, dense, p)
    return False


@njit(cache=True)
def _final_flags(p, stats, flags, q, v, z, mode, final):
    """Slip indicators of a finished point (see SimResult) and its final state
    ``(q, v, z, mode)`` (restart point of :mod:`beamsim.coupled_copies`)."""
    n = q.shape[0]
    nq = z.shape[0]
    for i in range(n):
        final[p, i] = q[i]
        final[p, n + i] = v[i]
    for j in range(nq):
        final[p, 2 * n + j] = z[j]
        final[p, 2 * n + nq + j] = mode[j]
    flags[p, 2] = stats[0]
    flags[p, 3] = stats[1] if stats[0] > 0 else np.nan
    flags[p, 4] = stats[2] / stats[3] if stats[3] > 0 else np.nan
    flags[p, 6] = stats[4] / stats[5] if stats[5] > 0 else np.nan


@njit(cache=True)
def _start_point(p, x0, law, S, wq, kt, tau_s, tau_k, eps, Mm, Km, tip, n_trans, dense_every,
                 pc_state, pc_tip, pc_energy, dense, flags):
    """Initial state of every integrator: ``(q, v, z, mode)`` from ``x0``, a consistent interface
    state (return mapping at t = 0, not counted as slip or dissipation), the initial energy in
    ``flags[p, 5]``, and the t = 0 record / dense sample.  Returns q, v, z, mode, ecum, stats, e0."""
    n = Mm.shape[0]
    nq = S.shape[0]
    q = x0[:n].copy()
    v = x0[n:2 * n].copy()
    z = x0[2 * n:2 * n + nq].copy()
    mode = np.zeros(nq, np.int64)
    if x0.shape[0] >= 2 * n + 2 * nq:
        for j in range(nq):
            mode[j] = int(x0[2 * n + nq + j])
    ecum = np.zeros(3)
    stats = np.zeros(6)
    _post_step(0.0, q, v, z, mode, law, S, wq, kt, tau_s, tau_k, eps, ecum, stats, False)
    stats[4] = 0.0
    stats[5] = 0.0
    ecum[1] = 0.0
    e0, _ = _energy(q, v, z, law, Mm, Km, S, wq, kt)
    flags[p, 5] = e0
    if n_trans == 0:
        _record(0, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, pc_state, pc_tip, pc_energy, p)
    if dense_every > 0:
        _dense(0, q, v, tip, dense, p)
    return q, v, z, mode, ecum, stats, e0


@njit(cache=True, inline="always")
def _stage_state(c, q, v, z, kq, kv, kz, tq, tv, tz):
    """RK4 stage state ``(tq, tv, tz) = (q, v, z) + c (kq, kv, kz)``."""
    for i in range(q.shape[0]):
        tq[i] = q[i] + c * kq[i]
        tv[i] = v[i] + c * kv[i]
    for j in range(z.shape[0]):
        tz[j] = z[j] + c * kz[j]


@njit(cache=True)
def _rk4_incr(t, hs, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0, om, fc, fs, vs,
              kv, eps, damp, kq, kvv, kz, ke, tau, qn, vn, zn, en, sq, sv, sz, dcoup, xq, xv, xz):
    """One classical RK4 step of length ``hs`` from ``(q, v, z)`` with the stick/slip state
    ``mode`` frozen: the new state goes to ``(qn, vn, zn)``, the energy-ledger increment to ``en``
    (the inputs are not modified).  The stage states are left in ``sq[st], sv[st], sz[st]``.
    A coupled copy (``dcoup > 0``) gets ``dcoup (x - y)`` added to every stage derivative, with
    the drive's stage states ``xq[st], xv[st], xz[st]`` (:mod:`beamsim.coupled_copies`)."""
    n = q.shape[0]
    nq = z.shape[0]
    hh = 0.5 * hs
    for st in range(4):
        if st == 0:
            _stage_state(0.0, q, v, z, q, v, z, sq[0], sv[0], sz[0])
            c = 0.0
        else:
            c = hs if st == 3 else hh
            _stage_state(c, q, v, z, kq[st - 1], kvv[st - 1], kz[st - 1], sq[st], sv[st], sz[st])
        _deriv(t + c, sq[st], sv[st], sz[st], mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0,
               om, fc, fs, vs, kv, eps, damp, kq[st], kvv[st], kz[st], ke[st], tau)
        if dcoup != 0.0:
            for i in range(n):
                kq[st, i] += dcoup * (xq[st, i] - sq[st, i])
                kvv[st, i] += dcoup * (xv[st, i] - sv[st, i])
            for j in range(nq):
                kz[st, j] += dcoup * (xz[st, j] - sz[st, j])
    h6 = hs / 6.0
    for i in range(n):
        qn[i] = q[i] + h6 * (kq[0, i] + 2.0 * kq[1, i] + 2.0 * kq[2, i] + kq[3, i])
        vn[i] = v[i] + h6 * (kvv[0, i] + 2.0 * kvv[1, i] + 2.0 * kvv[2, i] + kvv[3, i])
    for j in range(nq):
        zn[j] = z[j] + h6 * (kz[0, j] + 2.0 * kz[1, j] + 2.0 * kz[2, j] + kz[3, j])
    for r in range(3):
        en[r] = h6 * (ke[0, r] + 2.0 * ke[1, r] + 2.0 * ke[2, r] + ke[3, r])


@njit(cache=True, inline="always")
def _first_event(q, v, z, mode, qn, vn, zn, S, kt, tau_s):
    """Earliest stick/slip switch of the Jenkins elements inside a step from ``(q, v, z)`` to
    ``(qn, vn, zn)``: the event functions ``g = |k_t (s - z)| - tau_s`` (stuck) and
    ``g = -mode s'`` (slipping) are interpolated linearly between the step ends.  Returns
    ``(theta, j)``, the step fraction and the element, or ``(2.0, -1)`` if none switches."""
    n = q.shape[0]
    nq = z.shape[0]
    best = 2.0
    jb = -1
    for j in range(nq):
        if tau_s[j] <= 0.0:
            continue
        if mode[j] == 0:
            s0 = 0.0
            s1 = 0.0
            for k in range(n):
                s0 += S[j, k] * q[k]
                s1 += S[j, k] * qn[k]
            g0 = abs(kt * (s0 - z[j])) - tau_s[j]
            g1 = abs(kt * (s1 - zn[j])) - tau_s[j]
        else:
            d0 = 0.0
            d1 = 0.0
            for k in range(n):
                d0 += S[j, k] * v[k]
                d1 += S[j, k] * vn[k]
            g0 = -mode[j] * d0
            g1 = -mode[j] * d1
        if g1 > 0.0:
            th = 0.0 if g0 >= 0.0 else g0 / (g0 - g1)
            if th < best:
                best = th
                jb = j
    return best, jb


@njit(cache=True)
def _event_g(j, q, v, z, mode, S, kt, tau_s):
    """Event function of element ``j`` (> 0: its stick/slip state is violated)."""
    a = 0.0
    if mode[j] == 0:
        for k in range(q.shape[0]):
            a += S[j, k] * q[k]
        return abs(kt * (a - z[j])) - tau_s[j]
    for k in range(q.shape[0]):
        a += S[j, k] * v[k]
    return -mode[j] * a


#: Illinois iterations and relative tolerance of the event location inside a step
EVENT_ITERATIONS = 30
EVENT_RTOL = 1e-11


@njit(cache=True, inline="always")
def _illinois(a, ga, b, gb, th, gm, side):
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


@njit(cache=True)
def _apply_switch(j, t, q, z, mode, S, kt, tau_k, wq, ecum, stats):
    """Switch element ``j`` at a located event: stuck -> slipping in the direction of its
    traction (``z`` moved so that the traction is ``tau_k``; the released elastic energy is
    dissipated), slipping -> stuck (``z`` frozen)."""
    if mode[j] == 0:
        s = 0.0
        for k in range(q.shape[0]):
            s += S[j, k] * q[k]
        _start_slip(j, s, z, mode, kt, tau_k, wq, ecum)
        if stats[0] == 0.0:
            stats[0] = 1.0
            stats[1] = t
    else:
        mode[j] = 0


@njit(cache=True, inline="always")
def _accept(q, v, z, ecum, qn, vn, zn, en):
    for i in range(q.shape[0]):
        q[i] = qn[i]
        v[i] = vn[i]
    for j in range(z.shape[0]):
        z[j] = zn[j]
    for r in range(3):
        ecum[r] += en[r]


#: at most this many located switches per step (then the step is accepted and the return
#: mapping of ``_post_step`` settles the rest)
MAX_SWITCHES_PER_STEP = 64


@njit(cache=True)
def _located_step(t, hs, h_tol, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0, om,
                  tau_s, tau_k, fc, fs, vs, kv, eps, damp, ecum, stats, kq, kvv, kz, ke, tau, qn,
                  vn, zn, en, sq, sv, sz, dcoup, xq, xv, xz, xmode, xqn, xvn, xzn, xsq, xsv, xsz,
                  seg_t, seg_q, seg_v, seg_z, seg_m, record):
    """Advance ``(q, v, z, mode)`` from ``t`` over ``hs`` with RK4, splitting the step at every
    stick/slip switch (law 0): the earliest crossing of the linearly interpolated event
    functions, refined on the RK4 substep by Illinois iterations to ``EVENT_RTOL``, so that a
    switching time does not depend on how the step happens to be split.  Returns the number
    of switches and of substeps.

    ``record``: store the start time and state ``(q, v, z, mode)`` of every substep in
    ``seg_*`` (``seg_t[k]``, with ``seg_t[n_segments] = t + hs``); the drive of
    :mod:`beamsim.coupled_copies` records its segments so that its copies can follow it.

    ``dcoup > 0``: a coupled copy of a drive that starts at ``(xq, xv, xz)`` and keeps the
    stick/slip state ``xmode`` over the whole interval (one segment of the drive): every
    substep integrates that drive too (its local state is overwritten: a scratch copy) and adds
    ``dcoup (x - y)`` to every stage of the copy.  Substeps shorter than ``1e-12 h_tol`` end
    the step.  Returns ``(switches, substeps)``."""
    rem = hs
    tl = t
    n_switch = 0
    nseg = 0
    for it in range(MAX_SWITCHES_PER_STEP + 1):
        if record:
            seg_t[nseg] = tl
            seg_q[nseg] = q
            seg_v[nseg] = v
            seg_z[nseg] = z
            seg_m[nseg] = mode
        nseg += 1
        if dcoup != 0.0:
            # the drive's substep (local state x), whose stages enter the coupling
            _rk4_incr(tl, rem, xq, xv, xz, xmode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0,
                      om, fc, fs, vs, kv, eps, damp, kq, kvv, kz, ke, tau, xqn, xvn, xzn, en,
                      xsq, xsv, xsz, 0.0, xsq, xsv, xsz)
        _rk4_incr(tl, rem, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0, om,
                  fc, fs, vs, kv, eps, damp, kq, kvv, kz, ke, tau, qn, vn, zn, en, sq, sv, sz,
                  dcoup, xsq, xsv, xsz)
        th = 2.0
        j = -1
        if law == 0 and it < MAX_SWITCHES_PER_STEP:
            th, j = _first_event(q, v, z, mode, qn, vn, zn, S, kt, tau_s)
        if th >= 1.0:
            _accept(q, v, z, ecum, qn, vn, zn, en)
            break
        if th > 0.0:
            a = 0.0
            ga = _event_g(j, q, v, z, mode, S, kt, tau_s)
            b = 1.0
            gb = _event_g(j, qn, vn, zn, mode, S, kt, tau_s)
            tol = EVENT_RTOL * (abs(ga) + abs(gb))
            side = 0
            for itr in range(EVENT_ITERATIONS + 1):
                if dcoup != 0.0:
                    _rk4_incr(tl, th * rem, xq, xv, xz, xmode, law, Aq, Av, Bt, gv, S, wq, kt, ct,
                              Cm, g, f0, om, fc, fs, vs, kv, eps, damp, kq, kvv, kz, ke, tau, xqn,
                              xvn, xzn, en, xsq, xsv, xsz, 0.0, xsq, xsv, xsz)
                _rk4_incr(tl, th * rem, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g,
                          f0, om, fc, fs, vs, kv, eps, damp, kq, kvv, kz, ke, tau, qn, vn, zn, en,
                          sq, sv, sz, dcoup, xsq, xsv, xsz)
                gm = _event_g(j, qn, vn, zn, mode, S, kt, tau_s)
                if abs(gm) <= tol or b - a <= 1e-14 or itr == EVENT_ITERATIONS:
                    break
                a, ga, b, gb, th, side = _illinois(a, ga, b, gb, th, gm, side)
            hs_acc = th * rem
            _accept(q, v, z, ecum, qn, vn, zn, en)
            if dcoup != 0.0:
                for i in range(q.shape[0]):
                    xq[i] = xqn[i]
                    xv[i] = xvn[i]
                for i in range(z.shape[0]):
                    xz[i] = xzn[i]
        else:
            hs_acc = 0.0
        tl += hs_acc
        rem -= hs_acc
        _apply_switch(j, tl, q, z, mode, S, kt, tau_k, wq, ecum, stats)
        n_switch += 1
        if rem <= 1e-12 * h_tol:
            break
    if record:
        seg_t[nseg] = t + hs
    return n_switch, nseg


@njit(cache=True)
def _rk4_point(p, law, Aq, Av, Bt, gv, S, wq, kt, ct, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k,
               fc, fs, vs, kv, eps, damp, h, n_per, n_trans, n_rec, dense_every, div_limit, x0,
               pc_state, pc_tip, pc_energy, dense, flags, final):
    n = Aq.shape[0]
    nq = S.shape[0]
    q, v, z, mode, ecum, stats, e0 = _start_point(p, x0, law, S, wq, kt, tau_s, tau_k, eps, Mm, Km, tip,
                                                  n_trans, dense_every, pc_state, pc_tip,
                                                  pc_energy, dense, flags)
    kq = np.zeros((4, n)); kvv = np.zeros((4, n)); kz = np.zeros((4, nq)); ke = np.zeros((4, 3))
    sq = np.zeros((4, n)); sv = np.zeros((4, n)); sz = np.zeros((4, nq))
    qn = np.empty(n); vn = np.empty(n); zn = np.empty(nq); en = np.empty(3)
    tau = np.empty(nq)
    seg_t = np.empty(1); seg_q = np.empty((1, n)); seg_v = np.empty((1, n))
    seg_z = np.empty((1, nq)); seg_m = np.empty((1, nq), np.int64)
    n_total = (n_trans + n_rec) * n_per
    n_switch = 0
    for step in range(n_total):
        t = step * h
        # fast path: one RK4 step; only a step with a switch is redone with located switches
        _rk4_incr(t, h, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm, g, f0, om, fc, fs,
                  vs, kv, eps, damp, kq, kvv, kz, ke, tau, qn, vn, zn, en, sq, sv, sz, 0.0, sq,
                  sv, sz)
        th = 2.0
        if law == 0:
            th, _ = _first_event(q, v, z, mode, qn, vn, zn, S, kt, tau_s)
        if th >= 1.0:
            _accept(q, v, z, ecum, qn, vn, zn, en)
        else:
            nsw, _ = _located_step(t, h, h, q, v, z, mode, law, Aq, Av, Bt, gv, S, wq, kt, ct, Cm,
                                   g, f0, om, tau_s, tau_k, fc, fs, vs, kv, eps, damp, ecum, stats,
                                   kq, kvv, kz, ke, tau, qn, vn, zn, en, sq, sv, sz, 0.0, q, v, z,
                                   mode, qn, vn, zn, sq, sv, sz, seg_t, seg_q, seg_v, seg_z, seg_m,
                                   False)
            n_switch += nsw
        k = step + 1
        tn = k * h
        inrec = k > n_trans * n_per
        _post_step(tn, q, v, z, mode, law, S, wq, kt, tau_s, tau_k, eps, ecum, stats, inrec)
        if _end_of_step(p, k, tn, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, n_per, n_trans,
                        dense_every, div_limit, pc_state, pc_tip, pc_energy, dense, flags):
            break
    _final_flags(p, stats, flags, q, v, z, mode, final)
    flags[p, 8] = n_switch


# ---------------------------------------------------------------------------- Newmark
@njit(cache=True)
def _chol_solve(A, b, n):
    """Solve A x = b for SPD A (n x n) by Cholesky; returns x (A untouched)."""
    L = np.zeros((n, n))
    for i in range(n):
        for k in range(i + 1):
            acc = A[i, k]
            for m in range(k):
                acc -= L[i, m] * L[k, m]
            if i == k:
                L[i, i] = math.sqrt(acc) if acc > 0 else 1e-300
            else:
                L[i, k] = acc / L[k, k]
    y = np.empty(n)
    for i in range(n):
        acc = b[i]
        for m in range(i):
            acc -= L[i, m] * y[m]
        y[i] = acc / L[i, i]
    x = np.empty(n)
    for i in range(n - 1, -1, -1):
        acc = y[i]
        for m in range(i + 1, n):
            acc -= L[m, i] * x[m]
        x[i] = acc / L[i, i]
    return x


@njit(cache=True)
def _newmark_point(p, S, wq, kt, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k, damp, h, n_per,
                   n_trans, n_rec, dense_every, div_limit, x0, pc_state, pc_tip, pc_energy,
                   dense, flags, final):
    n = Mm.shape[0]
    nq = S.shape[0]
    law = 0
    q, v, z, mode, ecum, stats, e0 = _start_point(p, x0, law, S, wq, kt, tau_s, tau_k, 1.0, Mm, Km, tip,
                                                  n_trans, dense_every, pc_state, pc_tip,
                                                  pc_energy, dense, flags)
    a0 = 4.0 / (h * h)
    a1 = 2.0 / h
    # base effective matrix without interface: a0 M + a1 C + K
    Kb = a0 * Mm + Km
    if damp:
        Kb += a1 * Cm
    # tractions and acceleration at t = 0
    s = S @ q
    tau = np.empty(nq)
    for j in range(nq):
        tau[j] = kt * (s[j] - z[j])
    F = 0.0
    rhs0 = g * F - Km @ q - S.T @ (wq * tau)
    if damp:
        rhs0 -= Cm @ v
    acc = _chol_solve(Mm, rhs0, n)
    n_total = (n_trans + n_rec) * n_per
    stick = np.empty(nq, np.bool_)   # trial pattern for the new step
    sgn = np.empty(nq)
    Fprev = 0.0
    tau_prev = tau.copy()
    for step in range(n_total):
        k = step + 1
        tn = k * h
        Fn = f0 * (math.cos(om * tn) - 1.0)
        # predictor pieces: M (a0 q + a0 h v + a) + C (a1 q + v)
        bq = a0 * q + (4.0 / h) * v + acc
        rhs_base = g * Fn + Mm @ bq
        if damp:
            rhs_base += Cm @ (a1 * q + v)
        # initial guess of the pattern: current modes
        for j in range(nq):
            stick[j] = (mode[j] == 0) and tau_s[j] > 0.0
            sgn[j] = mode[j]
        qn = q.copy()
        for it in range(30):
            Ke = Kb.copy()
            r = rhs_base.copy()
            for j in range(nq):
                if stick[j]:
                    c = kt * wq[j]
                    for a in range(n):
                        Sa = S[j, a]
                        if Sa != 0.0:
                            for b in range(n):
                                Ke[a, b] += c * Sa * S[j, b]
                        r[a] += c * Sa * z[j]
                else:
                    tj = sgn[j] * tau_k[j] if tau_s[j] > 0.0 else 0.0
                    for a in range(n):
                        r[a] -= wq[j] * S[j, a] * tj
            qn = _chol_solve(Ke, r, n)
            changed = False
            for j in range(nq):
                if tau_s[j] <= 0.0:
                    continue
                sj = 0.0
                for b in range(n):
                    sj += S[j, b] * qn[b]
                if stick[j]:
                    tr = kt * (sj - z[j])
                    # a point sliding at the start of the step keeps sliding (at mu_k) if pushed
                    # on in the same direction; otherwise breaking loose needs mu_s
                    lim = tau_k[j] if (mode[j] != 0 and mode[j] * tr > 0) else tau_s[j]
                    if abs(tr) > lim * (1.0 + 1e-12):
                        stick[j] = False
                        sgn[j] = 1.0 if tr > 0 else -1.0
                        changed = True
                else:
                    # sliding in direction sgn is consistent iff the plastic slip increment
                    # z_{n+1} - z_n = s_{n+1} - sgn tau_k / k_t - z_n has the sign sgn
                    if sgn[j] * (sj - z[j] - sgn[j] * tau_k[j] / kt) < 0.0:
                        stick[j] = True
                        changed = True
            if not changed:
                break
        # accept: update z, modes, dissipation (trapezoidal work minus interface elastic change)
        dq_ = qn - q
        vn = a1 * dq_ - v
        accn = a0 * dq_ - (4.0 / h) * v - acc
        Dinc = 0.0
        for j in range(nq):
            sj = 0.0
            s0 = 0.0
            for b in range(n):
                sj += S[j, b] * qn[b]
                s0 += S[j, b] * q[b]
            e_old = 0.5 * kt * (s0 - z[j]) ** 2
            if tau_s[j] <= 0.0:
                z[j] = sj
                mode[j] = 1
                tnew = 0.0
            elif stick[j]:
                mode[j] = 0
                tnew = kt * (sj - z[j])
            else:
                z[j] = sj - sgn[j] * tau_k[j] / kt
                mode[j] = 1 if sgn[j] > 0 else -1
                tnew = sgn[j] * tau_k[j]
            e_new = 0.5 * kt * (sj - z[j]) ** 2
            Dinc += wq[j] * (0.5 * (tau_prev[j] + tnew) * (sj - s0) - (e_new - e_old))
            tau_prev[j] = tnew
        ecum[0] += 0.5 * (Fprev + Fn) * (g @ dq_)
        ecum[1] += Dinc
        if damp:
            vm = 0.5 * (v + vn)
            ecum[2] += h * (vm @ (Cm @ vm))
        Fprev = Fn
        q = qn
        v = vn
        acc = accn
        inrec = k > n_trans * n_per
        _post_step(tn, q, v, z, mode, law, S, wq, kt, tau_s, tau_k, 1.0, ecum, stats, inrec,
                   False)
        if _end_of_step(p, k, tn, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, n_per, n_trans,
                        dense_every, div_limit, pc_state, pc_tip, pc_energy, dense, flags):
            break
    _final_flags(p, stats, flags, q, v, z, mode, final)


# ---------------------------------------------------------------------------- exponential
@njit(cache=True, inline="always")
def _phi(l, tau):
    """(exp(l tau) - 1) / l, accurate for small |l tau| (l complex)."""
    x = l * tau
    if abs(x) < 1e-4:
        return tau * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)))
    return (np.exp(x) - 1.0) / l


@njit(cache=True)
def _pattern(stuck, Minv, Linv, Mm, Km, Cm, S, wq, kt, g, om, damp):
    """Eigen-decomposition ``A = V diag(lam) V^-1`` of the first-order matrix of the linear system
    with the stuck set ``stuck`` (springs k_t at the stuck points).  Undamped: from the real
    symmetric problem ``K_P phi = omega^2 M phi`` (lam = +-i omega, V and V^-1 in closed
    form); damped: complex eigen-decomposition.  Eigenvalues within 1e-9 of +-i omega_f are
    shifted by -1e-9 (|lam| + omega_f) (exact-resonance guard)."""
    n = Km.shape[0]
    nq = S.shape[0]
    n2 = 2 * n
    KP = Km.copy()
    for j in range(nq):
        if stuck[j]:
            c = kt * wq[j]
            for a in range(n):
                for b in range(n):
                    KP[a, b] += c * S[j, a] * S[j, b]
    if not damp:
        Kt = Linv @ KP @ Linv.T
        Kt = 0.5 * (Kt + Kt.T)
        w2, Y = np.linalg.eigh(Kt)
        Phi = Linv.T @ Y                     # M-orthonormal modes
        Psi = Phi.T @ Mm                     # Psi Phi = I
        lam = np.empty(n2, np.complex128)
        V = np.empty((n2, n2), np.complex128)
        Vi = np.empty((n2, n2), np.complex128)
        for k in range(n):
            wk = math.sqrt(max(w2[k], 1e-300))
            lam[k] = 1j * wk
            lam[n + k] = -1j * wk
            for a in range(n):
                V[a, k] = Phi[a, k]
                V[a, n + k] = Phi[a, k]
                V[n + a, k] = 1j * wk * Phi[a, k]
                V[n + a, n + k] = -1j * wk * Phi[a, k]
                Vi[k, a] = 0.5 * Psi[k, a]
                Vi[n + k, a] = 0.5 * Psi[k, a]
                Vi[k, n + a] = -0.5j / wk * Psi[k, a]
                Vi[n + k, n + a] = 0.5j / wk * Psi[k, a]
    else:
        A = np.zeros((n2, n2), np.complex128)
        MK = Minv @ KP
        MC = Minv @ Cm
        for a in range(n):
            A[a, n + a] = 1.0
            for b in range(n):
                A[n + a, b] = -MK[a, b]
                A[n + a, n + b] = -MC[a, b]
        lam, V = np.linalg.eig(A)
        Vi = np.linalg.inv(V)
    for k in range(n2):
        tol = 1e-9 * (abs(lam[k]) + om)
        if abs(lam[k] - 1j * om) < tol or abs(lam[k] + 1j * om) < tol:
            lam[k] = lam[k] - tol
    Sc = S.astype(np.complex128)
    SVq = Sc @ np.ascontiguousarray(V[:n, :])
    SVv = Sc @ np.ascontiguousarray(V[n:, :])
    gc = g.astype(np.complex128)
    cg = gc @ np.ascontiguousarray(V[n:, :])
    Mg = (Minv @ g).astype(np.complex128)
    gam = np.ascontiguousarray(Vi[:, n:]) @ Mg
    return lam, V, Vi, SVq, SVv, cg, gam


@njit(cache=True, inline="always")
def _phi_e(l, tau, e):
    """(e - 1) / l with e = exp(l tau) precomputed (series for small |l tau|)."""
    x = l * tau
    if abs(x) < 1e-4:
        return tau * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)))
    return (e - 1.0) / l


@njit(cache=True, inline="always")
def _psi(l, mu, tau, el, emu):
    """(exp(mu tau) - exp(l tau)) / (mu - l), given el = exp(l tau), emu = exp(mu tau)."""
    d = mu - l
    if abs(d * tau) < 1e-4:
        x = d * tau
        return el * tau * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)))
    return (emu - el) / d


@njit(cache=True)
def _zeta_at(tau, lam, z0, beta, gam, f0, om, t0, out, nh):
    """Modal state at t0 + tau (only the first nh terms: undamped systems store conjugate
    pairs k, n + k, and the second half is never needed in the hot loops)."""
    ep = np.exp(1j * om * t0)
    em = np.conj(ep)
    eip = np.exp(1j * om * tau)
    eim = np.conj(eip)
    io = 1j * om
    for k in range(nh):
        l = lam[k]
        el = np.exp(l * tau)
        ph = _phi_e(l, tau, el)
        psip = _psi(l, io, tau, el, eip)
        psim = _psi(l, -io, tau, el, eim)
        out[k] = el * z0[k] + beta[k] * ph + f0 * gam[k] * (0.5 * ep * psip + 0.5 * em * psim - ph)


@njit(cache=True)
def _work(tau1, lam, z0, beta, gam, cg, f0, om, t0):
    """Exact int_0^tau1 F(t0 + tau) g.v(tau) dtau for the interval solution."""
    ep = np.exp(1j * om * t0)
    em = np.conj(ep)
    io = 1j * om
    ap = 0.5 * f0 * ep
    am = 0.5 * f0 * em
    a0 = -f0 + 0.0j
    eip = np.exp(io * tau1)
    eim = np.conj(eip)
    total = 0.0j
    SB = 0.0j
    SC = 0.0j
    SD = 0.0j
    for k in range(lam.shape[0]):
        l = lam[k]
        fg = f0 * gam[k]
        Ak = z0[k] + beta[k] / l - fg / l - fg * 0.5 * ep / (io - l) - fg * 0.5 * em / (-io - l)
        SB += cg[k] * (-beta[k] / l + fg / l)
        SC += cg[k] * fg * 0.5 * ep / (io - l)
        SD += cg[k] * fg * 0.5 * em / (-io - l)
        el = np.exp(l * tau1)
        total += cg[k] * Ak * (ap * _phi_e(l + io, tau1, el * eip)
                               + am * _phi_e(l - io, tau1, el * eim) + a0 * _phi_e(l, tau1, el))
    pp_ = _phi_e(io, tau1, eip)
    pm_ = _phi_e(-io, tau1, eim)
    total += SB * (ap * pp_ + am * pm_ + a0 * tau1)
    total += SC * (ap * _phi_e(2 * io, tau1, eip * eip) + am * tau1 + a0 * pp_)
    total += SD * (ap * tau1 + am * _phi_e(-2 * io, tau1, eim * eim) + a0 * pm_)
    return total.real


@njit(cache=True)
def _cond(j, zeta, SVq, SVv, z, mode, kt, tau_s, nh, fac):
    """Event function of point j (> 0: the current stick/slip state is violated)."""
    if mode[j] == 0:
        s = 0.0
        for k in range(nh):
            s += (SVq[j, k] * zeta[k]).real
        return abs(kt * (fac * s - z[j])) - tau_s[j] * (1.0 + 1e-12)
    sd = 0.0
    for k in range(nh):
        sd += (SVv[j, k] * zeta[k]).real
    return -mode[j] * fac * sd


@njit(cache=True)
def _conds(zeta, SVq, SVv, z, mode, kt, tau_s, free, sbuf, sdbuf, fout, nh, fac):
    """All event functions at the modal state zeta; returns True if any is violated."""
    nq = SVq.shape[0]
    hit = False
    for j in range(nq):
        s = 0.0
        sd = 0.0
        for k in range(nh):
            s += (SVq[j, k] * zeta[k]).real
            sd += (SVv[j, k] * zeta[k]).real
        s *= fac
        sd *= fac
        sbuf[j] = s
        sdbuf[j] = sd
        if free[j]:
            fout[j] = -1.0
        elif mode[j] == 0:
            fout[j] = abs(kt * (s - z[j])) - tau_s[j] * (1.0 + 1e-12)
        else:
            fout[j] = -mode[j] * sd
        if fout[j] > 0.0:
            hit = True
    return hit


@njit(cache=True)
def _expo_point(p, S, wq, kt, Minv, Linv, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k, damp, h, n_per,
                n_trans, n_rec, dense_every, div_limit, x0, n_sub, cache_size,
                pc_state, pc_tip, pc_energy, dense, flags, final):
    n = Mm.shape[0]
    nq = S.shape[0]
    n2 = 2 * n
    law = 0
    q, v, z, mode, ecum, stats, e0 = _start_point(p, x0, law, S, wq, kt, tau_s, tau_k, 1.0, Mm, Km, tip,
                                                  n_trans, dense_every, pc_state, pc_tip,
                                                  pc_energy, dense, flags)
    free = np.zeros(nq, np.bool_)
    for j in range(nq):
        free[j] = tau_s[j] <= 0.0
    # pattern cache
    C = cache_size
    keys = np.full(C, -1, np.int64)
    c_lam = np.empty((C, n2), np.complex128)
    c_V = np.empty((C, n2, n2), np.complex128)
    c_Vi = np.empty((C, n2, n2), np.complex128)
    c_SVq = np.empty((C, nq, n2), np.complex128)
    c_SVv = np.empty((C, nq, n2), np.complex128)
    c_cg = np.empty((C, n2), np.complex128)
    c_gam = np.empty((C, n2), np.complex128)
    # undamped: modes k and n + k are complex conjugate pairs -> evaluate the first half only
    nh = n if not damp else n2
    fac = 2.0 if not damp else 1.0
    n_filled = 0
    n_eig = 0
    stuck = np.zeros(nq, np.bool_)
    x = np.empty(n2)
    zeta0 = np.empty(n2, np.complex128)
    zeta = np.empty(n2, np.complex128)
    ztmp = np.empty(n2, np.complex128)
    beta = np.empty(n2, np.complex128)
    rv = np.empty(n)
    r1 = np.empty(n2)
    r2 = np.empty(n2)
    zdot = np.empty(n2, np.complex128)
    sbuf = np.empty(nq)
    sdbuf = np.empty(nq)
    fcur = np.empty(nq)
    fprev = np.empty(nq)
    rate = np.empty(nq)
    n_total = (n_trans + n_rec) * n_per
    slot = -1
    need_pattern = True
    t0 = 0.0
    n_events = 0
    n_checks = 0
    for step in range(n_total):
        k_step = step + 1
        t_end = k_step * h
        guard = 0
        while True:
            if need_pattern:
                key = 0
                for j in range(nq):
                    stuck[j] = (mode[j] == 0) and not free[j]
                    if stuck[j]:
                        key |= (1 << j)
                slot = -1
                for c in range(n_filled):
                    if keys[c] == key:
                        slot = c
                        break
                if slot < 0:
                    lam_, V_, Vi_, SVq_, SVv_, cg_, gam_ = _pattern(stuck, Minv, Linv, Mm, Km,
                                                                    Cm, S, wq, kt, g, om, damp)
                    n_eig += 1
                    if n_filled < C:
                        slot = n_filled
                        n_filled += 1
                    else:
                        slot = n_eig % C
                    keys[slot] = key
                    c_lam[slot] = lam_
                    c_V[slot] = V_
                    c_Vi[slot] = Vi_
                    c_SVq[slot] = SVq_
                    c_SVv[slot] = SVv_
                    c_cg[slot] = cg_
                    c_gam[slot] = gam_
                # modal coordinates of the current state and the constant forcing beta
                for i in range(n):
                    x[i] = q[i]
                    x[n + i] = v[i]
                for i in range(n):
                    rv[i] = 0.0
                for j in range(nq):
                    if free[j]:
                        continue
                    if stuck[j]:
                        c = kt * wq[j] * z[j]
                    else:
                        c = -wq[j] * mode[j] * tau_k[j]
                    for i in range(n):
                        rv[i] += c * S[j, i]
                bv = Minv @ rv
                Vi = c_Vi[slot]
                for k in range(n2):
                    acc = 0.0j
                    acc2 = 0.0j
                    for i in range(n2):
                        acc += Vi[k, i] * x[i]
                    for i in range(n):
                        acc2 += Vi[k, n + i] * bv[i]
                    zeta0[k] = acc
                    beta[k] = acc2
                need_pattern = False
            lam = c_lam[slot]
            SVq = c_SVq[slot]
            SVv = c_SVv[slot]
            gam = c_gam[slot]
            span = t_end - t0
            # event search on (t0, t_end]: adaptive checks.  On this interval
            # zeta_k(tau) = A_k e^{lam_k tau} + B_k + C_k e^{i w tau} + D_k e^{-i w tau}, which
            # bounds the rate of every event function; the next check is placed where no
            # crossing can have happened before it (at most span / n_sub, at least
            # 0.1 / max|lam|).
            ep = np.exp(1j * om * t0)
            io = 1j * om
            lmax = 0.0
            for k in range(nh):
                l = lam[k]
                fg = f0 * gam[k]
                Ck = fg * 0.5 * ep / (io - l)
                Dk = fg * 0.5 * np.conj(ep) / (-io - l)
                Ak = zeta0[k] + beta[k] / l - fg / l - Ck - Dk
                al = abs(l)
                if al > lmax:
                    lmax = al
                r1[k] = al * al * abs(Ak) + om * om * (abs(Ck) + abs(Dk))
                r2[k] = al * al * al * abs(Ak) + om * om * om * (abs(Ck) + abs(Dk))
            for j in range(nq):
                # bound of the second derivative of the event function on the interval
                # (stuck: k_t |s_j''|, slipping: |s_j'''|)
                acc = 0.0
                if mode[j] == 0:
                    for k in range(nh):
                        acc += abs(SVq[j, k]) * r1[k]
                    rate[j] = kt * fac * acc
                else:
                    for k in range(nh):
                        acc += abs(SVq[j, k]) * r2[k]
                    rate[j] = fac * acc
            d_min = 0.1 / lmax
            d_max = span / n_sub
            ev_tau = -1.0
            lo = 0.0
            for k in range(n2):
                zeta[k] = zeta0[k]
            _conds(zeta, SVq, SVv, z, mode, kt, tau_s, free, sbuf, sdbuf, fcur, nh, fac)
            for sub in range(100000):
                dlt = d_max
                # zeta' = lam zeta + beta + gam F(t) at the current check
                Fc = f0 * (math.cos(om * (t0 + lo)) - 1.0)
                for k in range(nh):
                    zdot[k] = lam[k] * zeta[k] + beta[k] + gam[k] * Fc
                for j in range(nq):
                    fj = fcur[j]
                    if free[j] or fj >= 0.0:
                        continue
                    # exact f_j' and the bound M2 >= |f_j''|: no crossing before the root of
                    # f + f' d + M2 d^2 / 2 = 0
                    if mode[j] == 0:
                        d1 = kt * sdbuf[j] if sbuf[j] - z[j] >= 0.0 else -kt * sdbuf[j]
                    else:
                        sdd = 0.0
                        for k in range(nh):
                            sdd += (SVv[j, k] * zdot[k]).real
                        d1 = -mode[j] * fac * sdd
                    M2 = rate[j]
                    if M2 > 0.0:
                        dj = (-d1 + math.sqrt(d1 * d1 - 2.0 * M2 * fj)) / M2
                    elif d1 > 0.0:
                        dj = -fj / d1
                    else:
                        dj = d_max
                    if dj < dlt:
                        dlt = dj
                if dlt < d_min:
                    dlt = d_min
                tau = lo + dlt
                if tau >= span * (1.0 - 1e-14):
                    tau = span
                _zeta_at(tau, lam, zeta0, beta, gam, f0, om, t0, zeta, nh)
                n_checks += 1
                for j in range(nq):
                    fprev[j] = fcur[j]
                hit = _conds(zeta, SVq, SVv, z, mode, kt, tau_s, free, sbuf, sdbuf, fcur, nh,
                             fac)
                if hit:
                    # earliest crossing among the violated points: Illinois (modified regula
                    # falsi) on [lo, tau], bisection if it stalls
                    best = tau
                    for j in range(nq):
                        if free[j] or fcur[j] <= 0.0:
                            continue
                        a = lo
                        b = tau
                        fa = min(fprev[j], 0.0)
                        fb = fcur[j]
                        side = 0
                        for it in range(200):
                            if b - a <= 1e-12 * span:
                                break
                            if it >= 40 or it % 4 == 3 or fb - fa <= 0.0:
                                mid = 0.5 * (a + b)
                            else:
                                mid = b - fb * (b - a) / (fb - fa)
                                if not (a < mid < b):
                                    mid = 0.5 * (a + b)
                            _zeta_at(mid, lam, zeta0, beta, gam, f0, om, t0, ztmp, nh)
                            fm = _cond(j, ztmp, SVq, SVv, z, mode, kt, tau_s, nh, fac)
                            # bracket update shared with RK4's event refinement (its next
                            # point is not used: the rule above adds the bisection safeguard)
                            a, fa, b, fb, _, side = _illinois(a, fa, b, fb, mid, fm, side)
                        if b < best:
                            best = b
                    ev_tau = best
                    break
                lo = tau
                if tau >= span:
                    break
            tau1 = span if ev_tau < 0 else ev_tau
            if ev_tau >= 0:
                _zeta_at(tau1, lam, zeta0, beta, gam, f0, om, t0, zeta, nh)
            if nh < n2:
                for k in range(nh):
                    zeta[nh + k] = np.conj(zeta[k])
            # ledger over (t0, t0 + tau1)
            ecum[0] += _work(tau1, lam, zeta0, beta, gam, c_cg[slot], f0, om, t0)
            Vs = c_V[slot]
            for i in range(n2):
                acc = 0.0
                for k in range(n2):
                    acc += (Vs[i, k] * zeta[k]).real
                x[i] = acc
            for j in range(nq):
                s_new = 0.0
                for k in range(n2):
                    s_new += (SVq[j, k] * zeta[k]).real
                if free[j]:
                    z[j] = s_new
                elif mode[j] != 0:
                    s_old = z[j] + mode[j] * tau_k[j] / kt
                    ecum[1] += wq[j] * mode[j] * tau_k[j] * (s_new - s_old)
                    z[j] = s_new - mode[j] * tau_k[j] / kt
            for i in range(n):
                q[i] = x[i]
                v[i] = x[n + i]
            if ev_tau < 0:
                # no event: continue in the same pattern from t_end
                for k in range(n2):
                    zeta0[k] = zeta[k]
                t0 = t_end
                break
            # apply the switches at the event time
            t_ev = t0 + tau1
            for j in range(nq):
                if free[j]:
                    continue
                if _cond(j, zeta, SVq, SVv, z, mode, kt, tau_s, nh, fac) > 0.0:
                    if mode[j] == 0:
                        s = 0.0
                        for k in range(n2):
                            s += (SVq[j, k] * zeta[k]).real
                        _start_slip(j, s, z, mode, kt, tau_k, wq, ecum)
                        if stats[0] == 0.0:
                            stats[0] = 1.0
                            stats[1] = t_ev
                    else:
                        mode[j] = 0
            n_events += 1
            guard += 1
            t0 = t_ev
            need_pattern = True
            if guard > 10 * nq + 10:
                # Zeno guard: accept the state, resume on the grid
                t0 = t_end
                break
        # damping dissipation (damp > 0): remainder of the energy identity (docs/model.md)
        inrec = k_step > n_trans * n_per
        _post_step(t_end, q, v, z, mode, law, S, wq, kt, tau_s, tau_k, 1.0, ecum, stats, inrec,
                   False)
        if damp:
            em_, _ = _energy(q, v, z, law, Mm, Km, S, wq, kt)
            ecum[2] = ecum[0] - ecum[1] - (em_ - e0)
        if _end_of_step(p, k_step, t_end, q, v, z, ecum, law, Mm, Km, S, wq, kt, tip, n_per, n_trans,
                        dense_every, div_limit, pc_state, pc_tip, pc_energy, dense, flags):
            break
    _final_flags(p, stats, flags, q, v, z, mode, final)
    flags[p, 7] = n_eig
    flags[p, 8] = n_events
    flags[p, 9] = n_checks


@njit(cache=True, parallel=True)
def _run_batch_rk4(law, Aq, Av, Bt, gv, S, wq, kt, ct, Mm, Km, Cs, g, tip, f0, om, tau_s, tau_k,
                   fc, fs, vs, kv, eps, damp_s, h, n_per, n_trans, n_rec, dense_every, div_limit,
                   x0, pc_state, pc_tip, pc_energy, dense, flags, final):
    """RK4 over the points of a batch: the structural damping (``Av = -M^-1 C_struct``, ``Cs``,
    ``damp_s``) as a matrix, the interface dashpot ``ct`` inside the interface traction.
    (One compiled kernel per integrator, so a run compiles only what it uses.)"""
    P = f0.shape[0]
    for p in prange(P):
        _rk4_point(p, law[p], Aq[p], Av[p], Bt[p], gv[p], S[p], wq[p], kt[p], ct[p], Mm[p],
                   Km[p], Cs[p], g[p], tip[p], f0[p], om[p], tau_s[p], tau_k[p], fc[p], fs[p],
                   vs[p], kv[p], eps[p], damp_s[p], h[p], n_per[p], n_trans, n_rec,
                   dense_every[p], div_limit[p], x0[p], pc_state, pc_tip, pc_energy,
                   dense, flags, final)


@njit(cache=True, parallel=True)
def _run_batch_expo(S, wq, kt, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k, damp, h, n_per, n_trans,
                    n_rec, dense_every, div_limit, x0, Minv, Linv, n_sub, cache_size, pc_state,
                    pc_tip, pc_energy, dense, flags, final):
    """expo over the points of a batch (full damping matrix ``Cm``, flag ``damp``)."""
    P = f0.shape[0]
    for p in prange(P):
        _expo_point(p, S[p], wq[p], kt[p], Minv[p], Linv[p], Mm[p], Km[p], Cm[p], g[p], tip[p],
                    f0[p], om[p], tau_s[p], tau_k[p], damp[p], h[p], n_per[p], n_trans, n_rec,
                    dense_every[p], div_limit[p], x0[p], n_sub, cache_size, pc_state,
                    pc_tip, pc_energy, dense, flags, final)


@njit(cache=True, parallel=True)
def _run_batch_newmark(S, wq, kt, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k, damp, h, n_per,
                       n_trans, n_rec, dense_every, div_limit, x0, pc_state, pc_tip, pc_energy,
                       dense, flags, final):
    """Newmark over the points of a batch (full damping matrix ``Cm``, flag ``damp``)."""
    P = f0.shape[0]
    for p in prange(P):
        _newmark_point(p, S[p], wq[p], kt[p], Mm[p], Km[p], Cm[p], g[p], tip[p], f0[p],
                       om[p], tau_s[p], tau_k[p], damp[p], h[p], n_per[p], n_trans, n_rec,
                       dense_every[p], div_limit[p], x0[p], pc_state, pc_tip, pc_energy,
                       dense, flags, final)


# =========================================================================== Python API
_GEOM_KEYS = tuple(f.name for f in fields(Geometry))
_FRIC_KEYS = tuple(f.name for f in fields(Friction))
_LOAD_KEYS = ("f0", "f0_rel", "omega", "lam_f", "Omega")
_INIT_KEYS = ("q0", "v0", "z0", "mode0")
_POINT_KEYS = set(_GEOM_KEYS) | set(_FRIC_KEYS) | set(_LOAD_KEYS) | set(_INIT_KEYS)


@dataclass
class PreparedPoint:
    """Everything the kernel needs for one parameter point (see :func:`prepare_point`)."""

    model: TwoLayerModel
    friction: Friction
    f0: float
    omega: float
    f_cr: float
    eps_v: float
    tau_s: np.ndarray
    tau_k: np.ndarray
    fc: np.ndarray
    fs: np.ndarray
    x0: np.ndarray
    omega_max: float
    params: dict = field(repr=False)

    @property
    def Omega(self) -> float:
        return self.omega / self.model.omega1_stuck

    @property
    def lam_f(self) -> float:
        return self.omega**2


def _split(point: dict):
    unknown = set(point) - _POINT_KEYS
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; allowed: {sorted(_POINT_KEYS)}")
    geom = Geometry(**{k: point[k] for k in _GEOM_KEYS if k in point})
    fric = Friction(**{k: point[k] for k in _FRIC_KEYS if k in point})
    return geom, fric


def prepare_point(**point) -> PreparedPoint:
    """Validate one parameter point and derive the kernel inputs.

    Load: exactly one of ``f0`` (amplitude, units E b R) and ``f0_rel`` (= f0 / f_cr, default 2);
    exactly one of ``omega`` (angular frequency, units sqrt(E / rho R^2)), ``lam_f``
    (= omega^2, the paper's lambda) and ``Omega`` (= omega / omega_1 of the stuck beam,
    default 1).  Initial state ``q0``, ``v0`` (generalised coordinates, default 0), ``z0``
    (Jenkins internal slips, default 0), ``mode0`` (stick/slip state of each Jenkins element:
    0 stuck, +-1 slipping in that direction; default 0; stick-slip law only).  A point can be
    restarted from ``SimResult.final_state`` with :func:`restart_params`.
    """
    geom, fric = _split(point)
    model = build_model(geom)
    pj = pressure_at(model.theta_q, fric.p, fric.p_profile)
    f_cr = model.f_cr(fric.mu_s, fric.p, fric.p_profile)
    # load amplitude
    if "f0" in point and point["f0"] is not None and point.get("f0_rel") is not None:
        raise ValueError("give only one of f0 and f0_rel")
    if point.get("f0") is not None:
        f0 = check_nonnegative("f0", point["f0"])
    else:
        rel = check_nonnegative("f0_rel", point.get("f0_rel", 2.0))
        if not (math.isfinite(f_cr) and f_cr > 0):
            if rel != 0:
                raise ValueError("f0_rel needs a positive slip-onset load f_cr (mu_s * p > 0); "
                                 "give f0 instead")
            f0 = 0.0
        else:
            f0 = rel * f_cr
    # frequency
    given = [k for k in ("omega", "lam_f", "Omega") if point.get(k) is not None]
    if len(given) > 1:
        raise ValueError(f"give only one of omega, lam_f, Omega (got {given})")
    key = given[0] if given else "Omega"
    if key == "omega":
        omega = check_positive("omega", point["omega"])
    elif key == "lam_f":
        omega = math.sqrt(check_positive("lam_f", point["lam_f"]))
    else:
        omega = check_positive("Omega", point.get("Omega", 1.0)) * model.omega1_stuck
    # initial state
    n, nq = model.n, model.n_quad
    x0 = np.zeros(2 * n + 2 * nq)
    for name, sl, size in (("q0", slice(0, n), n), ("v0", slice(n, 2 * n), n),
                           ("z0", slice(2 * n, 2 * n + nq), nq),
                           ("mode0", slice(2 * n + nq, 2 * n + 2 * nq), nq)):
        val = point.get(name)
        if val is not None:
            arr = np.asarray(val, dtype=float).ravel()
            if arr.size != size:
                raise ValueError(f"{name} must have {size} entries, got {arr.size}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be finite")
            if name == "mode0" and not np.all(np.isin(arr, (-1.0, 0.0, 1.0))):
                raise ValueError("mode0 entries must be -1, 0 (stuck) or +1 (slipping direction)")
            x0[sl] = arr
    tau_s, tau_k, fc, fs = fric.limits(model.theta_q, pj)
    # regularisation band and stiffness of the regularised laws
    if fric.law == "stick-slip":
        eps_v = 1.0
        has_stick = bool(np.any(tau_s > 0))
        omega_max = model.omega_max_stuck if has_stick else model.omega_max_frictionless
    else:
        if fric.eps_v is not None:
            eps_v = float(fric.eps_v)
        else:
            s_unit = np.abs(model.S @ model.static_unit_frictionless).max()
            v_ref = omega * 2.0 * f0 * s_unit
            if v_ref <= 0:
                v_ref = omega * np.abs(model.S @ x0[:n]).max() + np.abs(model.S @ x0[n:2 * n]).max()
            eps_v = fric.eps_rel * v_ref if v_ref > 0 else 1e-12
        slope = np.maximum(fs, fc) / eps_v + fric.k_v
        Cv = (model.S.T * (model.wq * slope)) @ model.S
        import scipy.linalg as sla
        c_max = float(sla.eigh(Cv, model.M, eigvals_only=True)[-1])
        omega_max = model.omega_max_frictionless + max(c_max, 0.0)
    return PreparedPoint(model=model, friction=fric, f0=f0, omega=omega, f_cr=f_cr, eps_v=eps_v,
                         tau_s=tau_s, tau_k=tau_k, fc=fc, fs=fs, x0=x0, omega_max=omega_max,
                         params=dict(point))


@dataclass
class SimResult:
    """Result of one parameter point (all times and quantities dimensionless, docs/model.md).

    poincare_state : (n_record + 1, 2 n) generalised coordinates q and velocities v at
        ``t = (n_transient + k) T``, k = 0..n_record (T = 2 pi / omega).
    poincare_tip : (n_record + 1, 4) tip w, u1, u2 and the load-point displacement
        (``cos(beta) w - sin(beta) u1``, work-conjugate to F).
    energy : (n_record + 1, 5) W_in, D_friction, D_damping, E_mech (incl. interface elastic
        energy), E_interface -- cumulative since t = 0 (E_mech: current value).
    diss_per_cycle : (n_record,) friction dissipation in each recorded forcing period.
    dense_t, dense : optional dense history (columns TIP_COLUMNS [+ q, v]).
    final_state : (2 n + 2 n_quad,) state at the end of the run: q, v, Jenkins slips z, and the
        stick/slip state of each element (0 stuck, +-1 slipping); see :func:`restart_params`.
    """

    params: dict
    coord_names: list
    f0: float
    f_cr: float
    omega: float
    Omega: float
    lam_f: float
    h: float
    steps_per_period: int
    method: str
    t_poincare: np.ndarray
    poincare_state: np.ndarray
    poincare_tip: np.ndarray
    energy: np.ndarray
    E_mech0: float
    diverged: bool
    t_diverged: float
    slipped: bool
    t_first_slip: float
    stick_fraction: float
    stick_fraction_all: float
    n_patterns: int = 0
    n_events: int = 0
    n_checks: int = 0
    dense_t: np.ndarray | None = None
    dense: np.ndarray | None = None
    final_state: np.ndarray | None = None

    @property
    def diss_per_cycle(self) -> np.ndarray:
        return np.diff(self.energy[:, 1])

    @property
    def energy_residual(self) -> np.ndarray:
        """``E_mech - E_mech0 - (W_in - D_friction - D_damping)`` at the Poincare samples."""
        e = self.energy
        return e[:, 3] - self.E_mech0 - (e[:, 0] - e[:, 1] - e[:, 2])


@dataclass
class BatchResult:
    """Arrays with a leading point axis (see :class:`SimResult` for their meaning)."""

    points: list
    results: list
    wall_time: float

    def __len__(self):
        return len(self.results)

    def __getitem__(self, i) -> SimResult:
        return self.results[i]

    def summary(self):
        import pandas as pd

        rows = []
        for pt, r in zip(self.points, self.results):
            row = {k: v for k, v in pt.items() if np.isscalar(v) or v is None}
            last = r.poincare_tip[-1] if len(r.poincare_tip) else np.full(4, np.nan)
            row.update(f0=r.f0, f_cr=r.f_cr, f0_rel=(r.f0 / r.f_cr if r.f_cr > 0 else np.nan),
                       omega=r.omega, Omega=r.Omega, lam_f=r.lam_f, h=r.h,
                       steps_per_period=r.steps_per_period, method=r.method,
                       diverged=r.diverged, t_diverged=r.t_diverged, slipped=r.slipped,
                       t_first_slip=r.t_first_slip, stick_fraction=r.stick_fraction,
                       stick_fraction_all=r.stick_fraction_all,
                       diss_per_cycle=(float(np.nanmean(r.diss_per_cycle))
                                       if np.isfinite(r.diss_per_cycle).any() else np.nan),
                       W_in=r.energy[-1, 0], D_friction=r.energy[-1, 1],
                       energy_residual=r.energy_residual[-1],
                       **{f"{c}_last": last[i] for i, c in enumerate(TIP_COLUMNS)})
            rows.append(row)
        return pd.DataFrame(rows)


def period_steps(pp: PreparedPoint, method: str = "rk4", steps_per_period: int | None = None,
                 step_factor: float = 0.5) -> int:
    """Fixed steps per forcing period ``T = 2 pi / omega``: ``steps_per_period`` if given, else
    RK4 ``max(64, ceil(T omega_max / step_factor))`` (``omega_max``: fastest rate of the
    point's linear part), expo 64, Newmark 256.  (``expo`` is exact between located switches;
    its steps only set the output grid and the largest spacing of the event checks: on 25
    two-mode default-grid points over 368 periods, 64 and 128 steps per period give Poincare
    samples 7.6e-8 apart (median, relative), 256 and 128 4.9e-8, and 64 runs 25 % faster than
    128.)"""
    if steps_per_period is not None:
        return int(steps_per_period)
    if method == "newmark":
        return 256
    if method == "expo":
        return 64
    T = 2 * math.pi / pp.omega
    return max(64, int(math.ceil(T * pp.omega_max / step_factor)))


class StackedPoints(SimpleNamespace):
    """Per-point kernel inputs stacked along a leading point axis (see :func:`stack_points`)."""


def stack_points(prepared: list, div_limit: float = 1e3) -> StackedPoints:
    """Stack the kernel inputs of prepared points (same ``n`` and ``n_quad``): matrices of the
    first-order form (``Aq = -M^-1 K``, ``Av = -M^-1 C``, ``Bt = -M^-1 S^T W``, ``gv = M^-1 g``),
    friction limits, initial states ``x0 = (q, v, z, mode)`` and divergence limits."""
    P = len(prepared)
    n = prepared[0].model.n
    nq = prepared[0].model.n_quad
    Aq = np.empty((P, n, n)); Av = np.empty((P, n, n)); Bt = np.empty((P, n, nq))
    gv = np.empty((P, n)); S = np.empty((P, nq, n)); wq = np.empty((P, nq)); kt = np.empty(P)
    Mm = np.empty((P, n, n)); Km = np.empty((P, n, n)); Cm = np.empty((P, n, n))
    Cs = np.empty((P, n, n)); damp_s = np.zeros(P, np.bool_); ct = np.zeros(P)
    g = np.empty((P, n)); tip = np.empty((P, 4, n))
    f0 = np.empty(P); om = np.empty(P); tau_s = np.empty((P, nq)); tau_k = np.empty((P, nq))
    fc = np.empty((P, nq)); fs = np.empty((P, nq)); vs = np.empty(P); kv = np.empty(P)
    eps = np.empty(P); damp = np.zeros(P, np.bool_); law = np.empty(P, np.int64)
    x0 = np.empty((P, 2 * n + 2 * nq))
    Mi = np.empty((P, n, n))
    Li = np.empty((P, n, n))
    divl = np.empty(P)
    cache = {}
    for i, pp in enumerate(prepared):
        md = pp.model
        key = id(md)
        if key not in cache:
            Minv = np.linalg.inv(md.M)
            Cst = md.C if md.C_struct is None else md.C_struct
            cache[key] = (-Minv @ md.K, -Minv @ Cst, -Minv @ (md.S.T * md.wq), Minv @ md.g,
                          Minv, np.linalg.inv(np.linalg.cholesky(md.M)))
        Aq[i], Av[i], Bt[i], gv[i], Mi[i], Li[i] = cache[key]
        S[i], wq[i], kt[i] = md.S, md.wq, md.geom.k_t
        Mm[i], Km[i], Cm[i], g[i], tip[i] = md.M, md.K, md.C, md.g, md.tip
        f0[i], om[i] = pp.f0, pp.omega
        tau_s[i], tau_k[i], fc[i], fs[i] = pp.tau_s, pp.tau_k, pp.fc, pp.fs
        vs[i], kv[i], eps[i] = pp.friction.v_s, pp.friction.k_v, pp.eps_v
        damp[i] = bool(np.any(md.C != 0.0))
        Cs[i] = md.C if md.C_struct is None else md.C_struct
        damp_s[i] = bool(np.any(Cs[i] != 0.0))
        ct[i] = md.c_t
        law[i] = pp.friction.code
        x0[i] = pp.x0
        qref = max(2.0 * pp.f0 * np.abs(md.static_unit_frictionless).max(),
                   np.abs(pp.x0[:n]).max(), np.abs(pp.x0[n:2 * n]).max() / pp.omega)
        divl[i] = div_limit * (qref if qref > 0 else 1.0)
    return StackedPoints(Aq=Aq, Av=Av, Bt=Bt, gv=gv, S=S, wq=wq, kt=kt, ct=ct, Cs=Cs, damp_s=damp_s,
                         Mm=Mm, Km=Km, Cm=Cm, g=g,
                         tip=tip, f0=f0, om=om, tau_s=tau_s, tau_k=tau_k, fc=fc, fs=fs, vs=vs,
                         kv=kv, eps=eps, damp=damp, law=law, x0=x0, Mi=Mi, Li=Li, divl=divl)


def simulate_batch(points, *, n_transient: int = 50, n_record: int = 50,
                   steps_per_period: int | None = None, step_factor: float = 0.5,
                   method: str = "rk4", dense_per_period: int = 0, dense_full: bool = False,
                   div_limit: float = 1e6, n_threads: int | None = None,
                   event_checks: int = 4, pattern_cache: int = 128,
                   **common) -> BatchResult:
    """Simulate many parameter points in one compiled, thread-parallel call.

    points : sequence of dicts (or a pandas DataFrame, one row per point) of point parameters
        (geometry: alpha1, alpha2, beta, n_modes, k_t, n_quad, damping, bc; friction: law,
        mu_s, mu_k, p, p_profile, F_c, F_s, v_s, k_v, eps_v; load: f0 | f0_rel,
        omega | lam_f | Omega; initial state q0, v0, z0).  ``common`` supplies defaults.
    n_transient, n_record : forcing periods discarded / recorded (Poincare samples at the
        n_record + 1 period boundaries t = (n_transient + k) T).
    method : "rk4" (reference), "expo" (exact piecewise-linear propagation with event
        location; stick-slip law only) or "newmark" (implicit, stick-slip law only).
    steps_per_period : fixed steps per forcing period; default: RK4 ``ceil(T omega_max /
        step_factor)`` (at least 64), expo 128, Newmark 256.
    event_checks : expo: sub-samples per step at which the stick/slip conditions are checked
        before the crossing is located by bisection.
    pattern_cache : expo: number of stick patterns whose eigen-decomposition is cached.
    dense_per_period : if > 0, also store a dense history with this many samples per period.
    div_limit : a point whose max |q| exceeds ``div_limit * q_ref`` (or whose state becomes
        non-finite) is flagged as diverged and stopped; the others are unaffected.  ``q_ref`` is
        the largest of the frictionless static response to the peak load ``2 f0``, ``|q0|`` and
        ``|v0| / omega`` (the model is linear apart from friction, which only dissipates, so a
        growth by ``div_limit`` means a numerical instability).
    n_threads : numba threads for this call (default: numba's current setting).
    """
    if hasattr(points, "to_dict"):
        points = points.to_dict("records")
    points = [dict(common, **dict(pt)) for pt in points]
    if len(points) == 0:
        raise ValueError("points must not be empty")
    n_trans = check_int("n_transient", n_transient, 0)
    n_rec = check_int("n_record", n_record, 0)
    step_factor = check_positive("step_factor", step_factor)
    div_limit = check_positive("div_limit", div_limit)
    dpp = check_int("dense_per_period", dense_per_period, 0)
    if method not in METHODS:
        raise ValueError(f"method must be one of {tuple(METHODS)}, got {method!r}")
    if steps_per_period is not None:
        steps_per_period = check_int("steps_per_period", steps_per_period, 1)
    prepared = [prepare_point(**pt) for pt in points]
    n_sub = check_int("event_checks", event_checks, 1)
    cache_size = check_int("pattern_cache", pattern_cache, 1)
    if method in ("newmark", "expo"):
        for pp in prepared:
            if pp.friction.law != "stick-slip":
                raise ValueError(f"method={method!r} supports law='stick-slip' only")
            if method == "expo" and pp.model.n_quad > 62:
                raise ValueError("method='expo' supports n_quad <= 62")
    n = prepared[0].model.n
    nq = prepared[0].model.n_quad
    # expo pattern cache: at most ~100 MB per point in flight
    cache_size = max(2, min(cache_size, int(1e8 // (2 * (2 * n) ** 2 * 16 + 1))))
    for pp in prepared:
        if pp.model.n != n or pp.model.n_quad != nq:
            raise ValueError("all points of a batch must have the same n_modes and n_quad")
    P = len(prepared)
    h = np.empty(P)
    n_per = np.empty(P, np.int64)
    dense_every = np.zeros(P, np.int64)
    for i, pp in enumerate(prepared):
        T = 2 * math.pi / pp.omega
        m = period_steps(pp, method, steps_per_period, step_factor)
        if dpp > 0:
            m = int(math.ceil(m / dpp) * dpp)
            dense_every[i] = m // dpp
        n_per[i] = m
        h[i] = T / m
    k = stack_points(prepared, div_limit)
    Aq, Av, Bt, gv, S, wq, kt = k.Aq, k.Av, k.Bt, k.gv, k.S, k.wq, k.kt
    Mm, Km, Cm, g, tip, f0, om = k.Mm, k.Km, k.Cm, k.g, k.tip, k.f0, k.om
    tau_s, tau_k, fc, fs, vs, kv, eps = k.tau_s, k.tau_k, k.fc, k.fs, k.vs, k.kv, k.eps
    damp, law, x0, Mi, Li, divl = k.damp, k.law, k.x0, k.Mi, k.Li, k.divl
    n_dense = int(((n_trans + n_rec) * dpp) + 1) if dpp > 0 else 1
    ncol = 4 + (2 * n if dense_full else 0)
    pc_state = np.full((P, n_rec + 1, 2 * n), np.nan)
    pc_tip = np.full((P, n_rec + 1, 4), np.nan)
    pc_energy = np.full((P, n_rec + 1, 5), np.nan)
    dense = np.full((P, n_dense, ncol), np.nan)
    flags = np.zeros((P, 10))
    final = np.full((P, 2 * n + 2 * nq), np.nan)
    old_threads = numba.get_num_threads()
    if n_threads is not None:
        numba.set_num_threads(check_int("n_threads", n_threads, 1))
    t0 = time.perf_counter()
    try:
        if method == "rk4":
            _run_batch_rk4(law, Aq, Av, Bt, gv, S, wq, kt, k.ct, Mm, Km, k.Cs, g, tip, f0, om,
                           tau_s, tau_k, fc, fs, vs, kv, eps, k.damp_s, h, n_per, n_trans, n_rec,
                           dense_every, divl, x0, pc_state, pc_tip, pc_energy, dense, flags,
                           final)
        elif method == "expo":
            _run_batch_expo(S, wq, kt, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k, damp, h, n_per,
                            n_trans, n_rec, dense_every, divl, x0, Mi, Li, n_sub, cache_size,
                            pc_state, pc_tip, pc_energy, dense, flags, final)
        else:
            _run_batch_newmark(S, wq, kt, Mm, Km, Cm, g, tip, f0, om, tau_s, tau_k, damp, h,
                               n_per, n_trans, n_rec, dense_every, divl, x0, pc_state, pc_tip,
                               pc_energy, dense, flags, final)
    finally:
        if n_threads is not None:
            numba.set_num_threads(old_threads)
    wall = time.perf_counter() - t0
    results = []
    for i, pp in enumerate(prepared):
        T = 2 * math.pi / pp.omega
        tpc = (n_trans + np.arange(n_rec + 1)) * T
        dt = de = None
        if dpp > 0:
            dt = np.arange(n_dense) * (T / dpp)
            de = dense[i]
        results.append(SimResult(
            params=pp.params, coord_names=pp.model.coord_names, f0=pp.f0, f_cr=pp.f_cr,
            omega=pp.omega, Omega=pp.Omega, lam_f=pp.lam_f, h=float(h[i]),
            steps_per_period=int(n_per[i]), method=method, t_poincare=tpc,
            poincare_state=pc_state[i], poincare_tip=pc_tip[i], energy=pc_energy[i],
            E_mech0=float(flags[i, 5]), diverged=bool(flags[i, 0]),
            t_diverged=float(flags[i, 1]) if flags[i, 0] else np.nan,
            slipped=bool(flags[i, 2]), t_first_slip=float(flags[i, 3]),
            stick_fraction=float(flags[i, 4]), stick_fraction_all=float(flags[i, 6]),
            n_patterns=int(flags[i, 7]), n_events=int(flags[i, 8]), n_checks=int(flags[i, 9]),
            dense_t=dt, dense=de, final_state=final[i]))
    return BatchResult(points=points, results=results, wall_time=wall)


def restart_params(result: SimResult) -> dict:
    """Parameters that continue ``result`` from its final state (the forcing is periodic and
    every run ends on a period boundary, so restarting at ``t = 0`` is exact)."""
    n = len(result.coord_names)
    x = np.asarray(result.final_state, dtype=float)
    nq = (x.size - 2 * n) // 2
    return dict(result.params, q0=x[:n].copy(), v0=x[n:2 * n].copy(),
                z0=x[2 * n:2 * n + nq].copy(), mode0=x[2 * n + nq:].copy())


def simulate(n_transient: int = 50, n_record: int = 50, steps_per_period: int | None = None,
             step_factor: float = 0.5, method: str = "rk4", dense_per_period: int = 0,
             dense_full: bool = False, div_limit: float = 1e6, event_checks: int = 4,
             pattern_cache: int = 128, **point) -> SimResult:
    """Simulate one parameter point (keyword parameters as in :func:`simulate_batch`)."""
    b = simulate_batch([point], n_transient=n_transient, n_record=n_record,
                       steps_per_period=steps_per_period, step_factor=step_factor, method=method,
                       dense_per_period=dense_per_period, dense_full=dense_full,
                       div_limit=div_limit, n_threads=1, event_checks=event_checks,
                       pattern_cache=pattern_cache)
    return b.results[0]

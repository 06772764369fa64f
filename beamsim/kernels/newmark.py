"""Average-acceleration Newmark (trapezoidal, A-stable, energy conserving for the linear part)
with an implicit return mapping of the Jenkins elements: a semi-smooth Newton iteration on
the stick/slip pattern of the new step.  The stiff stuck interface does not limit its step.
Stick-slip law only; second order (tested against the RK4 reference).

Hot kernels are compiled with :data:`~beamsim.kernels.bundles.LEAF`'s floating-point flags.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from beamsim.kernels import common
from beamsim.kernels.bundles import point_at, schedule_at

#: ``Kb = 4 M / h^2 + 2 C / h + K`` (effective matrix without the interface), the acceleration
#: ``acc``, the trial stick set and slip directions, the interface tractions of the last step
NewmarkWork = namedtuple("NewmarkWork", ("Kb", "acc", "stick", "sgn", "tau_prev"))


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
def _start(x, pt, h):
    """Effective base matrix, tractions and acceleration at ``t = 0``."""
    n = pt.Mm.shape[0]
    nq = pt.S.shape[0]
    Kb = 4.0 / (h * h) * pt.Mm + pt.Km
    if pt.damp:
        Kb += 2.0 / h * pt.Cm
    s = pt.S @ x.q
    tau = np.empty(nq)
    for j in range(nq):
        tau[j] = pt.kt * (s[j] - x.z[j])
    F = 0.0
    rhs0 = pt.g * F - pt.Km @ x.q - pt.S.T @ (pt.wq * tau)
    if pt.damp:
        rhs0 -= pt.Cm @ x.v
    acc = _chol_solve(pt.Mm, rhs0, n)
    return NewmarkWork(Kb, acc, np.empty(nq, np.bool_), np.empty(nq), tau.copy())


@njit(cache=True, inline="always")
def _solve_pattern(tn, x, pt, h, wk):
    """New coordinates at ``tn`` and the load there: the linear Newmark step solved for a trial
    stick/slip pattern (starting from the current modes), the pattern corrected where the trial
    traction exceeds the friction limit or a sliding element's plastic slip increment reverses,
    until it is consistent (at most 30 iterations)."""
    q, v, z, mode = x.q, x.v, x.z, x.mode
    S, wq, kt, tau_s, tau_k = pt.S, pt.wq, pt.kt, pt.tau_s, pt.tau_k
    stick, sgn = wk.stick, wk.sgn
    n = q.shape[0]
    nq = z.shape[0]
    a0 = 4.0 / (h * h)
    a1 = 2.0 / h
    Fn = pt.f0 * (math.cos(pt.om * tn) - 1.0)
    # predictor pieces: M (a0 q + a0 h v + a) + C (a1 q + v)
    bq = a0 * q + (4.0 / h) * v + wk.acc
    rhs_base = pt.g * Fn + pt.Mm @ bq
    if pt.damp:
        rhs_base += pt.Cm @ (a1 * q + v)
    # initial guess of the pattern: current modes
    for j in range(nq):
        stick[j] = (mode[j] == 0) and tau_s[j] > 0.0
        sgn[j] = mode[j]
    qn = q.copy()
    for _ in range(30):
        Ke = wk.Kb.copy()
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
    return qn, Fn


@njit(cache=True, inline="always")
def _accept(qn, Fn, Fprev, x, pt, h, wk, ecum):
    """Take the step to ``qn``: new velocity and acceleration, Jenkins slips and modes, and the
    ledger (trapezoidal work of the load, friction work minus the change of the interface
    elastic energy, damping power at the mid velocity)."""
    q, v, z, mode = x.q, x.v, x.z, x.mode
    S, wq, kt, tau_s, tau_k = pt.S, pt.wq, pt.kt, pt.tau_s, pt.tau_k
    n = q.shape[0]
    a0 = 4.0 / (h * h)
    a1 = 2.0 / h
    dq_ = qn - q
    vn = a1 * dq_ - v
    accn = a0 * dq_ - (4.0 / h) * v - wk.acc
    Dinc = 0.0
    for j in range(z.shape[0]):
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
        elif wk.stick[j]:
            mode[j] = 0
            tnew = kt * (sj - z[j])
        else:
            z[j] = sj - wk.sgn[j] * tau_k[j] / kt
            mode[j] = 1 if wk.sgn[j] > 0 else -1
            tnew = wk.sgn[j] * tau_k[j]
        e_new = 0.5 * kt * (sj - z[j]) ** 2
        Dinc += wq[j] * (0.5 * (wk.tau_prev[j] + tnew) * (sj - s0) - (e_new - e_old))
        wk.tau_prev[j] = tnew
    ecum[0] += 0.5 * (Fprev + Fn) * (pt.g @ dq_)
    ecum[1] += Dinc
    if pt.damp:
        vm = 0.5 * (v + vn)
        ecum[2] += h * (vm @ (pt.Cm @ vm))
    q[:] = qn
    v[:] = vn
    wk.acc[:] = accn


@njit(cache=True)
def newmark_point(p, pt, sched, x0, out):
    """Integrate point ``p`` (the step contract of :mod:`beamsim.kernels`)."""
    x, tally, _ = common.start_point(p, x0, pt, sched, out)
    h = sched.h
    wk = _start(x, pt, h)
    Fprev = 0.0
    for step in range((sched.n_trans + sched.n_rec) * sched.n_per):
        k = step + 1
        tn = k * h
        qn, Fn = _solve_pattern(tn, x, pt, h, wk)
        _accept(qn, Fn, Fprev, x, pt, h, wk, tally.ecum)
        Fprev = Fn
        common.post_step(tn, x, pt, tally, k > sched.n_trans * sched.n_per, False)
        if common.end_of_step(p, k, tn, x, tally.ecum, pt, sched, out):
            break
    common.final_flags(p, tally.stats, out, x)


@njit(cache=True, nogil=True)
def run_point(stk, steps, out, p):
    """Newmark on point ``p`` of a batch (full damping matrix; an item of
    :func:`beamsim.kernels.thread_pool.run_items`)."""
    newmark_point(p, point_at(stk, p, False), schedule_at(steps, p), stk.x0[p], out)

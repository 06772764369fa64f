r"""Rigid stick: the ``k_t -> inf`` limit of the Jenkins interface (law ``rigid-stick``).

A stuck interface point ``j`` keeps its slip: ``s_j' = S_j q' = 0``; a sliding one carries the
kinetic traction ``tau_k sgn(s_j')`` (plus the interface dashpot ``c_t s_j'``).  The tractions
``tau_A`` of the stuck set ``A`` are the constraint forces that keep ``S_A q'' = 0``:

    S_A M^-1 S_A^T W_A tau_A = S_A a_free ,     a_free = M^-1 (g F - K q - C q' - S_sl^T W tau_sl)

The interface has more points than the Galerkin basis has independent slip shapes (``S`` has
rank 6 of 8 rows for two modes), so this system alone leaves the *self-equilibrated* part of
``tau_A`` (tractions with ``S_A^T W_A tau = 0``, no generalised force) undetermined.  The
penalty model fixes it: while ``A`` sticks its tractions change by ``k_t S_A dq``, i.e. only
within ``range(S_A)``, so the part of ``tau_A`` outside that range keeps the value it had when
the pattern began -- a residual (locked-in) traction.  Its limit ``k_t -> inf`` is therefore

    tau_A = F_A tau_0 + E_A a_free ,
    F_A = I - U (U^T W U)^-1 U^T W ,      E_A = U (U^T W U)^-1 Lambda^-1 U^T S_A ,

with ``G_A = S_A M^-1 S_A^T = U Lambda U^T`` (the eigenvectors ``U`` of its nonzero eigenvalues
span ``range(S_A)``) and ``tau_0`` the tractions just before the pattern began; that is how the
state keeps them: the Jenkins slot ``z_j`` of a stuck point holds its ``tau_0``.  Without
redundancy ``F_A = 0`` and ``tau_A`` is the plain constraint force.  Derivation and checks:
docs/model.md, section 6.

``F_A`` and ``E_A`` are cached per stick pattern (bit key) in a :data:`RigidCache` that each
point owns; a pattern is decomposed (cyclic Jacobi, no allocation: the fill runs inside the
hot kernels) on its first use.  The cache only saves work: a pattern's matrices do not depend
on when it was filled, so results do not depend on the cache.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from beamsim.friction import RIGID_STICK as RIGID_STICK_LAW
from beamsim.kernels import common
from beamsim.kernels.bundles import LEAF, RigidCache, RigidPoint

#: the friction-law code of the rigid stick (:data:`beamsim.friction.LAWS`)
RIGID_STICK = RIGID_STICK_LAW

#: slots of a point's pattern cache (a power of two; open addressing on the bit key, cleared
#: when half full)
CAPACITY = 512

#: relative size below which an eigenvalue of ``G_A`` counts as zero (a redundant constraint)
RANK_RTOL = 1e-9

#: after a switch, a stuck element breaks away at once only if its traction exceeds ``tau_s``
#: by more than this fraction (the rounding of ``F_A``, ``E_A``: 1e-7 measured with three modes);
#: one that sits at the limit
#: (``mu_s = mu_k``, a redundant element that stuck again) is left to the event functions,
#: which release it only if its traction keeps rising
SETTLE_RTOL = 1e-6

#: a sliding element whose slip shape lies in the stuck elements' span to this fraction (of
#: its ``M^-1`` norm squared) is redundant: the stuck ones fix its slip
REDUNDANT_RTOL = 1e-8



@njit(cache=True)
def new_cache(n, nq, capacity):
    """An empty :data:`RigidCache` for ``n`` coordinates and ``nq`` interface points."""
    return RigidCache(np.full(capacity, -1, np.int64), np.zeros((capacity, nq, nq)),
                      np.zeros((capacity, nq, n)), np.zeros((capacity, nq, n)),
                      np.zeros((capacity, n, nq)),
                      np.zeros((capacity, nq), np.int64), np.zeros((n, nq)), np.zeros((nq, nq)),
                      np.zeros((nq, nq)),
                      np.zeros((nq, nq)), np.zeros((nq, nq)), np.zeros((nq, nq)), np.zeros(nq),
                      np.zeros(nq, np.int64), np.zeros(1, np.int64))


@njit(cache=True)
def with_cache(pt):
    """The :data:`~beamsim.kernels.bundles.RigidPoint` of a point ``pt``: its inputs and a new
    :data:`RigidCache` (``M^-1 S^T`` and ``G = S M^-1 S^T`` filled)."""
    n = pt.Aq.shape[0]
    nq = pt.S.shape[0]
    rc = new_cache(n, nq, CAPACITY)
    MS = rc.MS
    for i in range(n):
        for b in range(nq):
            acc = 0.0
            for k in range(n):
                acc += pt.Minv[i, k] * pt.S[b, k]
            MS[i, b] = acc
    G = rc.G
    for a in range(nq):
        for b in range(nq):
            acc = 0.0
            for i in range(n):
                acc += pt.S[a, i] * MS[i, b]
            G[a, b] = acc
    # exact symmetry (the Jacobi sweeps assume it)
    for a in range(nq):
        for b in range(a):
            m = 0.5 * (G[a, b] + G[b, a])
            G[a, b] = m
            G[b, a] = m
    return RigidPoint(pt.law, pt.Aq, pt.Av, pt.Bt, pt.gv, pt.S, pt.wq, pt.kt, pt.ct, pt.Mm,
                      pt.Km, pt.Cm, pt.damp, pt.g, pt.tip, pt.f0, pt.om, pt.tau_s, pt.tau_k, pt.fc,
                      pt.fs, pt.vs, pt.kv, pt.eps, pt.Minv, pt.Linv, rc)


@njit(**LEAF)
def _jacobi(a, v, m):
    """Eigen-decomposition of the symmetric ``a[:m, :m]`` in place by cyclic Jacobi rotations:
    the eigenvalues end on the diagonal of ``a``, the eigenvectors in the columns of
    ``v[:m, :m]``."""
    for i in range(m):
        for k in range(m):
            v[i, k] = 1.0 if i == k else 0.0
    for sweep in range(60):
        off = 0.0
        dia = 0.0
        for i in range(m):
            dia += a[i, i] * a[i, i]
            for k in range(i + 1, m):
                off += a[i, k] * a[i, k]
        if off <= 1e-30 * dia or off == 0.0:
            return
        for p in range(m):
            for r in range(p + 1, m):
                apr = a[p, r]
                if apr == 0.0:
                    continue
                theta = (a[r, r] - a[p, p]) / (2.0 * apr)
                t = 1.0 / (abs(theta) + np.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                c = 1.0 / np.sqrt(t * t + 1.0)
                s = t * c
                for k in range(m):
                    akp = a[k, p]
                    akr = a[k, r]
                    a[k, p] = c * akp - s * akr
                    a[k, r] = s * akp + c * akr
                for k in range(m):
                    apk = a[p, k]
                    ark = a[r, k]
                    a[p, k] = c * apk - s * ark
                    a[r, k] = s * apk + c * ark
                for k in range(m):
                    vkp = v[k, p]
                    vkr = v[k, r]
                    v[k, p] = c * vkp - s * vkr
                    v[k, r] = s * vkp + c * vkr


@njit(**LEAF)
def _invert_spd(a, inv, r):
    """``inv[:r, :r] = a[:r, :r]^-1`` for a symmetric positive definite ``a`` (Gauss-Jordan;
    ``a`` is overwritten)."""
    for i in range(r):
        for k in range(r):
            inv[i, k] = 1.0 if i == k else 0.0
    for c in range(r):
        d = 1.0 / a[c, c]
        for k in range(r):
            a[c, k] *= d
            inv[c, k] *= d
        for i in range(r):
            if i != c:
                f = a[i, c]
                if f != 0.0:
                    for k in range(r):
                        a[i, k] -= f * a[c, k]
                        inv[i, k] -= f * inv[c, k]


@njit(**LEAF)
def _fill(slot, key, rc, pt):
    """Decompose the stick pattern ``key`` into cache slot ``slot``: ``F_A``, ``E_A``, the
    redundant sliding elements (``red``) with their elastic slip-rate rows ``R``, and the
    velocity projection ``Pv``."""
    nq = pt.S.shape[0]
    n = pt.S.shape[1]
    wq = pt.wq
    sa, sv, su, sw, sl = rc.sa, rc.sv, rc.su, rc.sw, rc.sl
    F = rc.F[slot]
    E = rc.E[slot]
    R = rc.R[slot]
    Pv = rc.Pv[slot]
    red = rc.red[slot]
    for a in range(nq):
        red[a] = 0
        for b in range(nq):
            F[a, b] = 0.0
        for i in range(n):
            E[a, i] = 0.0
            R[a, i] = 0.0
            Pv[i, a] = 0.0
    # the stuck elements, in order
    si = rc.si
    m = 0
    for j in range(nq):
        if (key >> j) & 1:
            si[m] = j
            m += 1
    if m == 0:
        return
    for a in range(m):
        for b in range(m):
            sa[a, b] = rc.G[si[a], si[b]]
    _jacobi(sa, sv, m)
    lmax = 0.0
    for a in range(m):
        if sa[a, a] > lmax:
            lmax = sa[a, a]
    # U (m x r) in su, the nonzero eigenvalues in sl
    r = 0
    for c in range(m):
        if sa[c, c] > RANK_RTOL * lmax:
            for a in range(m):
                su[a, r] = sv[a, c]
            sl[r] = sa[c, c]
            r += 1
    if r == 0:
        return
    # U^T W U (r x r) in sa, its inverse in sv
    for c in range(r):
        for d in range(r):
            acc = 0.0
            for a in range(m):
                acc += su[a, c] * wq[si[a]] * su[a, d]
            sa[c, d] = acc
    _invert_spd(sa, sv, r)
    # F = I - U (U^T W U)^-1 U^T W, on the stuck rows and columns
    for a in range(m):
        for c in range(r):
            acc = 0.0
            for d in range(r):
                acc += su[a, d] * sv[d, c]
            sw[a, c] = acc  # U (U^T W U)^-1
    for a in range(m):
        ja = si[a]
        for b in range(m):
            jb = si[b]
            acc = 0.0
            for c in range(r):
                acc += sw[a, c] * su[b, c]
            F[ja, jb] = (1.0 if a == b else 0.0) - acc * wq[jb]
    # E = U (U^T W U)^-1 Lambda^-1 U^T S_A
    for a in range(m):
        ja = si[a]
        for i in range(n):
            acc = 0.0
            for c in range(r):
                y = 0.0
                for b in range(m):
                    y += su[b, c] * pt.S[si[b], i]
                acc += sw[a, c] * y / sl[c]
            E[ja, i] = acc
    # velocity projection onto S_A v = 0 (M-orthogonal): Pv = M^-1 S_A^T U Lambda^-1 U^T
    for i in range(n):
        for c in range(r):
            y = 0.0
            for a in range(m):
                y += rc.MS[i, si[a]] * su[a, c]
            sv[0, c] = y / sl[c]  # (M^-1 S_A^T U Lambda^-1)[i, c]  (sv is free now)
        for a in range(m):
            acc = 0.0
            for c in range(r):
                acc += sv[0, c] * su[a, c]
            Pv[i, si[a]] = acc
    # sliding elements whose slip the stuck ones fix (S_j = c^T S_A): c = G_A^+ G[A, j], the
    # part of S_j outside the stuck rows' span 1 - G[j, A] c / G[j, j] (M^-1 metric), and
    # the elastic slip-rate row c^T E_A
    for j in range(nq):
        if (key >> j) & 1 or pt.tau_s[j] <= 0.0 or rc.G[j, j] <= 0.0:
            continue
        for c in range(r):
            y = 0.0
            for a in range(m):
                y += su[a, c] * rc.G[si[a], j]
            sw[c, 0] = y / sl[c]  # Lambda^-1 U^T G[A, j]  (sw is free now)
        proj = 0.0
        for a in range(m):
            ca = 0.0
            for c in range(r):
                ca += su[a, c] * sw[c, 0]
            proj += ca * rc.G[si[a], j]
            sa[a, 0] = ca  # c_a
        if 1.0 - proj / rc.G[j, j] > REDUNDANT_RTOL:
            continue
        red[j] = 1
        for i in range(n):
            acc = 0.0
            for a in range(m):
                acc += sa[a, 0] * E[si[a], i]
            R[j, i] = acc


@njit(**LEAF)
def pattern_key(mode):
    """Bit key of the stuck elements (``mode == 0``)."""
    key = 0
    for j in range(mode.shape[0]):
        if mode[j] == 0:
            key |= 1 << j
    return key


@njit(**LEAF)
def pattern_slot(mode, pt):
    """Cache slot of the stick pattern of ``mode`` (filled on a miss); -1: nothing stuck."""
    key = pattern_key(mode)
    if key == 0:
        return -1
    rc = pt.rc
    C = rc.keys.shape[0]  # a power of two
    h = (key ^ (key >> 9) ^ (key >> 18) ^ (key >> 27) ^ (key >> 36) ^ (key >> 45)) & (C - 1)
    for probe in range(C):
        s = (h + probe) % C
        k = rc.keys[s]
        if k == key:
            return s
        if k == -1:
            break
    if rc.count[0] >= C // 2:
        # the table is half full: start over (deterministic; only costs refills)
        for s in range(C):
            rc.keys[s] = -1
        rc.count[0] = 0
    for probe in range(C):
        s = (h + probe) % C
        if rc.keys[s] == -1:
            rc.keys[s] = key
            rc.count[0] += 1
            _fill(s, key, rc, pt)
            return s
    return -1


@njit(**LEAF)
def constraint_tractions(slot, z, afree, mode, pt, tau):
    """Tractions of the stuck elements ``tau_j = (F_A z)_j + (E_A a_free)_j`` into ``tau``
    (the other entries are left alone)."""
    if slot < 0:
        return
    F = pt.rc.F[slot]
    E = pt.rc.E[slot]
    nq = mode.shape[0]
    n = afree.shape[0]
    for j in range(nq):
        if mode[j] != 0:
            continue
        acc = 0.0
        for k in range(nq):
            if mode[k] == 0:
                acc += F[j, k] * z[k]
        for i in range(n):
            acc += E[j, i] * afree[i]
        tau[j] = acc


@njit(**LEAF)
def project_velocity(v, mode, pt):
    """Remove the slip rate of the stuck elements from ``v``: ``v -= M^-1 S_A^T G_A^+ S_A v``,
    the smallest change in kinetic energy that makes ``S_A v = 0`` (an inelastic tangential
    impact of the stuck points).  Applied where a state is given that need not respect its
    stuck set: at the start of a run, and when a Lyapunov copy starts at an offset from its
    drive or adopts the drive's stick/slip state.  Uses ``pt.rc.sl`` as scratch."""
    slot = pattern_slot(mode, pt)
    if slot < 0:
        return
    Pv = pt.rc.Pv[slot]
    S = pt.S
    n = v.shape[0]
    nq = mode.shape[0]
    sd = pt.rc.sl
    for j in range(nq):
        sd[j] = 0.0
        if mode[j] == 0:
            for k in range(n):
                sd[j] += S[j, k] * v[k]
    for i in range(n):
        acc = 0.0
        for j in range(nq):
            if mode[j] == 0:
                acc += Pv[i, j] * sd[j]
        v[i] -= acc


@njit(**LEAF)
def deriv(t, q, v, z, mode, pt, dq, dv, dz, de, tau):
    """Right-hand side of the rigid stick with the stick/slip state ``mode`` frozen (the
    contract of :func:`beamsim.kernels.rk4.deriv`): sliding elements carry ``mode tau_k +
    c_t s'``, stuck ones the constraint tractions of :func:`constraint_tractions`, so that
    ``S_A q'' = 0``; ``z' = 0`` (a stuck element's ``z`` is its residual-traction memory);
    ledger rates ``(F g.v, friction power of the sliding elements, damping power)``."""
    Bt, S, wq, ct = pt.Bt, pt.S, pt.wq, pt.ct
    n = q.shape[0]
    nq = z.shape[0]
    F = pt.f0 * (math.cos(pt.om * t) - 1.0)
    dD = 0.0
    dC = 0.0
    for j in range(nq):
        dz[j] = 0.0
        if mode[j] == 0:
            tau[j] = 0.0
            continue
        sd = 0.0
        for k in range(n):
            sd += S[j, k] * v[k]
        tj = mode[j] * pt.tau_k[j]
        dD += wq[j] * tj * sd
        if ct != 0.0:
            tj += ct * sd
            dC += wq[j] * ct * sd * sd
        tau[j] = tj
    pw = 0.0
    for i in range(n):
        acc = common.structural_acceleration(i, q, v, F, pt)
        for j in range(nq):
            if mode[j] != 0:
                acc += Bt[i, j] * tau[j]
        dv[i] = acc
        dq[i] = v[i]
        pw += pt.g[i] * v[i]
    slot = pattern_slot(mode, pt)
    if slot >= 0:
        constraint_tractions(slot, z, dv, mode, pt, tau)
        for i in range(n):
            acc = 0.0
            for j in range(nq):
                if mode[j] == 0:
                    acc += Bt[i, j] * tau[j]
            dv[i] += acc
    de[0] = F * pw
    de[1] = dD
    de[2] = common.damping_power(v, pt) + dC


@njit(**LEAF)
def tractions(t, q, v, z, mode, pt, w):
    """Interface tractions at ``(t, q, v, z)`` into ``w.tau`` (``w``: a
    :data:`beamsim.kernels.rk4.Stages` whose first stage rows serve as scratch)."""
    deriv(t, q, v, z, mode, pt, w.kq[0], w.kv[0], w.kz[0], w.ke[0], w.tau)


@njit(**LEAF)
def event_values(t, q, v, z, mode, pt, w, g):
    """Event functions of every element at ``(t, q, v, z)`` into ``g`` (> 0: the element's
    stick/slip state is violated; -1 for elements without friction):

    * stuck: ``|tau_j| - tau_s_j``;
    * sliding: ``-mode_j s_j'``; but when the stuck elements fix its slip (``S_j = c^T S_A``,
      the redundant elements of the pattern) ``s_j'`` is identically 0 in the rigid limit,
      and what decides is the rate at which its penalty spring would stretch,
      ``s_j' k_t -> c^T tau_A' = R_j . a_free'`` (the stuck tractions' rate); without it such
      an element would stick and break away again at every step.

    Uses the first stage rows of ``w`` and ``w.kq[1]`` as scratch."""
    tractions(t, q, v, z, mode, pt, w)
    events_from(t, v, mode, pt, w.tau, w.kv[0], w.kq[1], g)


@njit(**LEAF)
def events_from(t, v, mode, pt, tau, acc, scratch, g):
    """:func:`event_values` from the tractions ``tau`` and the acceleration ``acc`` at ``(t,
    q, v, z)`` (what :func:`deriv` returned there); ``scratch``: ``n`` values."""
    nq = mode.shape[0]
    n = v.shape[0]
    S, tau_s = pt.S, pt.tau_s
    slot = pattern_slot(mode, pt)
    need_rate = False
    if slot >= 0:
        for j in range(nq):
            if tau_s[j] > 0.0 and mode[j] != 0 and pt.rc.red[slot, j] != 0:
                need_rate = True
    if need_rate:
        _afree_rate(t, v, acc, mode, pt, scratch)
    for j in range(nq):
        if tau_s[j] <= 0.0:
            g[j] = -1.0
        elif mode[j] == 0:
            g[j] = abs(tau[j]) - tau_s[j]
        elif slot >= 0 and pt.rc.red[slot, j] != 0:
            R = pt.rc.R[slot]
            a = 0.0
            for i in range(n):
                a += R[j, i] * scratch[i]
            g[j] = -mode[j] * a
        else:
            a = 0.0
            for k in range(n):
                a += S[j, k] * v[k]
            g[j] = -mode[j] * a


@njit(**LEAF)
def _afree_rate(t, v, acc, mode, pt, out):
    """Time derivative of the unconstrained acceleration ``a_free`` (everything but the stuck
    tractions) along the motion with acceleration ``acc``: ``g F'(t) - M^-1 K v - M^-1 C
    acc - M^-1 S_L^T W c_t s_L''`` (the sliding tractions change only through the dashpot)."""
    n = v.shape[0]
    nq = mode.shape[0]
    Fd = -pt.f0 * pt.om * math.sin(pt.om * t)
    for i in range(n):
        r = pt.gv[i] * Fd
        for k in range(n):
            r += pt.Aq[i, k] * v[k]
        if pt.damp:
            for k in range(n):
                r += pt.Av[i, k] * acc[k]
        out[i] = r
    if pt.ct != 0.0:
        for j in range(nq):
            if mode[j] == 0:
                continue
            sdd = 0.0
            for k in range(n):
                sdd += pt.S[j, k] * acc[k]
            for i in range(n):
                out[i] += pt.Bt[i, j] * pt.ct * sdd


@njit(**LEAF)
def event_value(j, t, q, v, z, mode, pt, w):
    """Event function of element ``j`` (:func:`event_values`; ``w.kz[3]`` as scratch)."""
    event_values(t, q, v, z, mode, pt, w, w.kz[3])
    return w.kz[3, j]


@njit(**LEAF)
def first_event(t0, t1, x, w, pt):
    """Earliest switch inside a step from ``(t0, x)`` to ``(t1, w.qn, w.vn, w.zn)``: the event
    functions of :func:`event_values` interpolated linearly between the step ends (the
    contract of :func:`beamsim.kernels.rk4.first_event`).  The values at the start are the
    ones :func:`beamsim.kernels.rk4.rk4_incr` left in ``w.g0`` (from its first stage, the same
    state); ``w.kz[3]`` is scratch."""
    g0 = w.g0
    g1 = w.kz[3]
    event_values(t1, w.qn, w.vn, w.zn, x.mode, pt, w, g1)
    best = 2.0
    jb = -1
    for j in range(g0.shape[0]):
        ga = g0[j]
        gb = g1[j]
        if pt.tau_s[j] > 0.0 and gb > 0.0:
            th = 0.0 if ga >= 0.0 else ga / (ga - gb)
            if th < best:
                best = th
                jb = j
    return best, jb


@njit(**LEAF)
def switch(j, t, x, pt, tally, w):
    """Switch element ``j`` at a located event at time ``t``, then settle the pattern: a stuck
    element breaks away in the direction of its traction, a sliding one sticks; every element
    that is stuck afterwards keeps the traction it had just before as its residual-traction
    memory ``z`` (the penalty model's tractions are continuous through a switch); then any
    stuck element whose new constraint traction exceeds ``tau_s`` breaks away in turn (the
    most violated first; by more than :data:`SETTLE_RTOL`), until the pattern is admissible.
    No energy is released: a rigid stick stores none.  The velocity is not projected here: a
    located stick leaves a residual slip rate of at most ~3e-6 of the largest slip rate
    (measured, three modes), and projecting it away at every switch perturbed the sliding
    points near zero slip rate into extra switches (951 instead of 566 in the chatter test,
    and not step-converged).  Uses ``w.kz[2]`` as scratch."""
    mode, z = x.mode, x.z
    nq = mode.shape[0]
    before = w.kz[2]
    tractions(t, x.q, x.v, z, mode, pt, w)
    for k in range(nq):
        before[k] = w.tau[k]
    if mode[j] == 0:
        mode[j] = 1 if before[j] > 0.0 else -1
        common.note_first_slip(tally.stats, t)
    else:
        mode[j] = 0
    for it in range(nq + 1):
        for k in range(nq):
            if mode[k] == 0:
                z[k] = before[k]
        tractions(t, x.q, x.v, z, mode, pt, w)
        worst = 0.0
        jw = -1
        for k in range(nq):
            if mode[k] == 0 and pt.tau_s[k] > 0.0:
                exc = abs(w.tau[k]) - pt.tau_s[k] * (1.0 + SETTLE_RTOL)
                if exc > worst:
                    worst = exc
                    jw = k
        if jw < 0:
            break
        for k in range(nq):
            before[k] = w.tau[k]
        mode[jw] = 1 if before[jw] > 0.0 else -1
        common.note_first_slip(tally.stats, t)

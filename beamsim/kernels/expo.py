r"""``expo``: exact propagation of the piecewise-linear beam between located switches.

Between two stick/slip switches the beam is linear with constant coefficients: a stick
pattern (which Jenkins elements are stuck) fixes the stiffness ``K_P = K + k_t S_P^T W S_P``,
and the state obeys ``x' = A x + b + g_v F(t)``.  With the eigen-decomposition
``A = V diag(lam) V^-1`` (cached per pattern) the modal state has the closed form

.. math:: \zeta_k(\tau) = e^{\lambda_k \tau}\zeta_k(0) + \beta_k \phi(\lambda_k, \tau)
          + f_0 \gamma_k \big(\tfrac12 e^{i\omega t_0}\psi(\lambda_k, i\omega, \tau)
          + \tfrac12 e^{-i\omega t_0}\psi(\lambda_k, -i\omega, \tau) - \phi(\lambda_k, \tau)\big)

(``phi = (e^{l tau} - 1)/l``, ``psi = (e^{mu tau} - e^{l tau})/(mu - l)``), or in an
interval's coefficients ``zeta_k = A_k e^{lam_k tau} + B_k + C_k e^{i w tau} + D_k e^{-i w tau}``
where these do not cancel (:func:`_state_at`).  The event functions are checked at adaptive
points placed where no crossing can have happened before them (a bound of their second
derivative from the closed form, renewed at every check with the free modes' decay), on a
ladder of spacings ``d_min 2^(m/3)`` whose factors
``e^{lam_k d}`` are cached with the decomposition (a check advances the exponentials by one
multiplication); the earliest crossing is refined by Newton steps inside its bracket (the
slope from the interval's equation; regula falsi and bisection as safeguards), the switches
are applied and a new pattern starts.  The work of the load is integrated exactly;
the friction dissipation follows from the slip of the sliding elements; with damping the
damping dissipation is the remainder of the energy identity.  Stick-slip law only.  Steps
``h`` only set the output grid and the largest spacing of the checks.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from beamsim.kernels import common
from beamsim.kernels.bundles import LEAF, point_at, schedule_at
from beamsim.kernels.real_eig import real_eig
from beamsim.results import (
    FLAG_N_CHECKS,
    FLAG_N_EVENTS,
    FLAG_N_PATTERNS,
    FLAG_N_ZENO,
    STAT_STUCK_W_ALL,
    STAT_STUCK_W_RECORD,
    STAT_W_ALL,
    STAT_W_RECORD,
)

#: eigen-decompositions of ``C`` stick patterns: pattern bit keys, eigenvalues ``lam``, ``V``,
#: ``V^-1``, the slips and slip rates of the modes ``SVq = S V_q``, ``SVv = S V_v``, the load
#: power rows ``cg = g V_v``, the modal load ``gam = V^-1 [0; M^-1 g]``, the modal loads of
#: unit interface tractions ``gS[j] = V^-1 [0; M^-1 S_j^T]`` (:func:`project`); the mode order
#: (:func:`beamsim.kernels.real_eig.real_eig`): ``nc`` modes with ``Im lam > 0``, then the real ones, up to
#: ``nh``, then the conjugates of the first ``nc``; ``wt`` the weight of each of the first
#: ``nh`` modes in a real sum (2: the mode and its conjugate, 1: a real mode); ``aSVq =
#: wt |SVq|`` (the rate bounds' weights, :func:`_rate_bounds`); ``ladder`` the
#: check-step factors ``e^{lam_k d_m}`` of the first ``nh`` modes at the rungs ``d_m``
#: (:func:`_ladder`); ``count``
#: ``(filled slots, decompositions stored)``, ``model`` the model key of the entries.  An entry
#: depends on the model's matrices and the pattern only (the resonance guard, which depends on
#: a point's forcing frequency, is applied per point: :func:`resonant`), so trajectories
#: of every point of one model can share a cache, one trajectory at a time
#: (:func:`use_model`).
PatternCache = namedtuple("PatternCache", ("keys", "lam", "V", "Vi", "SVq", "SVv", "cg", "gam",
                                           "gS", "nh", "nc", "wt", "aSVq", "ladder", "count",
                                           "model"))

#: one pattern's entries of the cache (a ``ladder`` with no rungs: every check evaluates the
#: closed form's exponentials, as a point whose resonance guard shifted ``lam`` must)
Modes = namedtuple("Modes", ("lam", "V", "Vi", "SVq", "SVv", "cg", "gam", "gS", "nh", "nc", "wt",
                             "aSVq", "ladder"))

#: per-point scratch: permanently free elements, stuck set, real state ``xr``, modal states
#: ``zeta0`` (interval start), ``zeta`` (current), ``ztmp``, modal forcing ``beta``, the
#: weighted interface tractions ``rv`` (:func:`project`), the free parts of the rate bounds
#: ``r1, r2``, the bounds ``rate`` and their forced parts ``ratec``, the
#: scratch ``mag`` (:func:`_rate_bounds`, :func:`_decayed_rates`), modal rate ``zdot``, slips
#: ``sbuf``, slip rates ``sdbuf``, event functions
#: ``fcur, fprev``, counters ``cnt`` (filled decompositions computed, events, checks,
#: Zeno-guard steps); ``n_sub`` checks per step at least; ``glam`` the eigenvalues of the
#: slot ``gslot[0]`` with the point's resonance guard applied (``gslot[0] = -1``: the current
#: slot needs none, :func:`_pattern_slot`); the interval's closed-form coefficients ``ca, cb,
#: cc, cd`` (``A_k, B_k, C_k, D_k``, :func:`_rate_bounds`) and the exponentials ``el =
#: e^{lam_k tau}`` at the last check; the exponentials ``ez`` of the state the interval ends
#: in (:func:`_work` takes them), ``et`` those of ``ztmp``, and ``zbest`` the state at the
#: earliest switch a refinement has evaluated (:func:`_refine`)
ExpoWork = namedtuple("ExpoWork", ("free", "stuck", "xr", "zeta0", "zeta", "ztmp", "beta", "rv",
                                   "r1", "r2", "zdot", "sbuf", "sdbuf", "fcur", "fprev", "rate",
                                   "cnt", "n_sub", "glam", "gslot", "ca", "cb", "cc", "cd", "el",
                                   "ratec", "mag", "ez", "et", "zbest"))

_N_EIG, _N_EVENTS, _N_CHECKS, _N_ZENO = 0, 1, 2, 3
#: length of the counters ``cnt``
N_COUNTERS = 4
#: ``PatternCache.count``: filled slots, decompositions stored
_FILLED, _STORED = 0, 1
#: the Zeno guard's window: at most ``10 nq + 10`` switches per this fraction of a forcing
#: period (:func:`_step`; the output step of results versions 5-13, on which the guard
#: counted, before the output grid went to 16 steps per period)
ZENO_WINDOWS_PER_PERIOD = 64
#: rungs of the check-spacing ladder: spacings ``d_min 2^(m/3)``, ``m < LADDER_RUNGS`` (a
#: spacing the bound allows beyond the top rung takes the top rung)
LADDER_RUNGS = 30
#: the closed form in the interval's coefficients (:func:`_closed_form`) is used where
#: ``sep * span`` is at least this (below, its terms cancel and the divided differences of
#: :func:`_zeta_at` are used)
_SEP_MIN = 1e-3


@njit(**LEAF, inline="always")
def _cabs2(z):
    """``|z|^2`` of a complex ``z``."""
    return z.real * z.real + z.imag * z.imag


@njit(**LEAF, inline="always")
def _cabs(z):
    """``|z|`` of a complex ``z`` as ``sqrt(re^2 + im^2)``: numba's ``abs`` of a complex number
    calls libm's ``hypot``, which guards against overflow and underflow at several times the
    cost (the hot loops' magnitudes are far from either; what it cost: docs/performance.md)."""
    return math.sqrt(z.real * z.real + z.imag * z.imag)


@njit(**LEAF, inline="always")
def _eit(x):
    """``e^{i x}`` for a real ``x`` (``cos x + i sin x``: one ``sincos``, where numba's
    complex ``exp`` also evaluates ``exp(0)``)."""
    return complex(math.cos(x), math.sin(x))


@njit(cache=True)
def _pattern(stuck, pt):
    """Eigen-decomposition ``A = V diag(lam) V^-1`` of the first-order matrix of the linear system
    with the stuck set ``stuck`` (springs k_t at the stuck points).  Undamped: from the real
    symmetric problem ``K_P phi = omega^2 M phi`` (lam = +-i omega, V and V^-1 in closed
    form); damped: LAPACK's real eigen-decomposition of the first-order matrix in
    mass-normalised coordinates ``y = L^T q`` (``M = L L^T``), conjugate pairs ordered by
    :func:`beamsim.kernels.real_eig.real_eig`, mapped back to ``(q, v)``.  Depends on the
    model's matrices only (not on the forcing: the resonance guard is :func:`resonant`).
    ``V^-1 [0; M^-1 .]`` (the modal loads ``gam`` and ``gS``) is formed here once per pattern,
    never applied to a state's load vector: the mass matrix is ill-conditioned, so ``M^-1 r``
    of the stuck springs' large, balanced anchor loads ``r`` would leave a rounding error of
    ``eps cond(M)`` in the slow modes' net load at every switch (docs/lyapunov.md, section
    17).  Returns the :data:`Modes` entries."""
    Mm, Km, S, wq, kt, g = pt.Mm, pt.Km, pt.S, pt.wq, pt.kt, pt.g
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
    if not pt.damp:
        Kt = pt.Linv @ KP @ pt.Linv.T
        Kt = 0.5 * (Kt + Kt.T)
        w2, Y = np.linalg.eigh(Kt)
        Phi = pt.Linv.T @ Y                  # M-orthonormal modes
        Psi = Phi.T @ Mm                     # Psi Phi = I
        lam = np.empty(n2, np.complex128)
        V = np.empty((n2, n2), np.complex128)
        Vi = np.empty((n2, n2), np.complex128)
        ViM = np.empty((n2, n), np.complex128)
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
                # the velocity block of V^-1 times M^-1 in closed form (Psi M^-1 = Phi^T)
                ViM[k, a] = -0.5j / wk * Phi[a, k]
                ViM[n + k, a] = 0.5j / wk * Phi[a, k]
    else:
        # decomposed in mass-normalised coordinates y = L^T q (M = L L^T), where the stiffness
        # and damping are L^-1 K_P L^-T and L^-1 C L^-T: formed with M^-1 the first-order matrix
        # carries a rounding error of eps cond(M) (cond(M) ~ 1e7 at three modes; what it cost:
        # docs/performance.md, "The first-order matrices without the explicit inverse")
        c = np.ascontiguousarray
        Li = c(pt.Linv)
        LiT = c(Li.T)
        Kt = (Li @ KP) @ LiT
        Ct = (Li @ c(pt.Cm)) @ LiT
        A = np.zeros((n2, n2))
        for a in range(n):
            A[a, n + a] = 1.0
            for b in range(n):
                A[n + a, b] = -0.5 * (Kt[a, b] + Kt[b, a])      # symmetric, as they are
                A[n + a, n + b] = -0.5 * (Ct[a, b] + Ct[b, a])
        lam, W, nh, nc = real_eig(A)
        Wi = np.linalg.inv(W)
        # back to (q, v): V = diag(L^-T, L^-T) W, V^-1 = W^-1 diag(L^T, L^T), and the velocity
        # block of V^-1 times M^-1 is W^-1[:, n:] L^-1
        LT = c(np.linalg.cholesky(c(Mm)).T).astype(np.complex128)
        LiTc = LiT.astype(np.complex128)
        V = np.empty((n2, n2), np.complex128)
        Vi = np.empty((n2, n2), np.complex128)
        V[:n, :] = LiTc @ c(W[:n, :])
        V[n:, :] = LiTc @ c(W[n:, :])
        Vi[:, :n] = c(Wi[:, :n]) @ LT
        Vi[:, n:] = c(Wi[:, n:]) @ LT
        ViM = c(Wi[:, n:]) @ Li.astype(np.complex128)
    if not pt.damp:
        nh = nc = n
    wt = np.zeros(n2)
    for k in range(nh):
        wt[k] = 2.0 if k < nc else 1.0
    Sc = S.astype(np.complex128)
    SVq = Sc @ np.ascontiguousarray(V[:n, :])
    SVv = Sc @ np.ascontiguousarray(V[n:, :])
    gc = g.astype(np.complex128)
    cg = gc @ np.ascontiguousarray(V[n:, :])
    gam = ViM @ gc
    gS = Sc @ np.ascontiguousarray(ViM.T)
    return lam, V, Vi, SVq, SVv, cg, gam, gS, nh, nc, wt


@njit(cache=True, inline="always")
def _lmax(lam, nh):
    """Largest ``|lam_k|`` of the first ``nh`` modes (it sets the shortest check spacing
    ``d_min = 0.1 / lmax``)."""
    lmax = 0.0
    for k in range(nh):
        al = _cabs(lam[k])
        if al > lmax:
            lmax = al
    return lmax


@njit(cache=True, inline="always")
def _rung(d_min, m):
    """Spacing of rung ``m`` of the check ladder: ``d_min 2^(m/3)``."""
    return d_min * 2.0 ** (m / 3.0)


@njit(cache=True)
def _ladder(lam, nh, out):
    """Check-step factors ``out[m, k] = e^{lam_k d_m}`` of the first ``nh`` modes at the rungs
    ``d_m`` (:func:`_rung`, ``d_min = 0.1 / max |lam_k|``)."""
    d_min = 0.1 / _lmax(lam, nh)
    for m in range(out.shape[0]):
        d = _rung(d_min, m)
        for k in range(nh):
            out[m, k] = np.exp(lam[k] * d)


@njit(cache=True)
def weighted_abs(SVq, wt):
    """``wt_k |SVq_jk|``: the weights of the rate bounds (:func:`_rate_bounds`)."""
    out = np.empty(SVq.shape)
    for j in range(SVq.shape[0]):
        for k in range(SVq.shape[1]):
            out[j, k] = wt[k] * abs(SVq[j, k])
    return out


@njit(cache=True, inline="always")
def _phi_e(lk, tau, e):
    """(e - 1) / lk with e = exp(lk tau) precomputed (series for small |lk tau|); lk complex."""
    x = lk * tau
    if _cabs2(x) < 1e-8:
        return tau * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)))
    return (e - 1.0) / lk


@njit(cache=True, inline="always")
def _psi(lk, mu, tau, el, emu):
    """(exp(mu tau) - exp(lk tau)) / (mu - lk), given el = exp(lk tau), emu = exp(mu tau)."""
    d = mu - lk
    if _cabs2(d * tau) < 1e-8:
        x = d * tau
        return el * tau * (1.0 + x * (0.5 + x * (1.0 / 6.0 + x / 24.0)))
    return (emu - el) / d


@njit(**LEAF, inline="always")
def _zeta_at(tau, md, wk, t0, pt, out, eout):
    """Modal state at ``t0 + tau`` of the interval that started at ``t0`` in ``wk.zeta0`` (only
    the first ``md.nh`` terms: the others are conjugates of the first ``md.nc``, never needed
    in the hot loops); ``e^{lam_k tau}`` into ``eout``."""
    f0, om = pt.f0, pt.om
    lam, gam, z0, beta = md.lam, md.gam, wk.zeta0, wk.beta
    ep = _eit(om * t0)
    em = np.conj(ep)
    eip = _eit(om * tau)
    eim = np.conj(eip)
    io = 1j * om
    for k in range(md.nh):
        lk = lam[k]
        el = np.exp(lk * tau)
        eout[k] = el
        ph = _phi_e(lk, tau, el)
        psip = _psi(lk, io, tau, el, eip)
        psim = _psi(lk, -io, tau, el, eim)
        out[k] = el * z0[k] + beta[k] * ph + f0 * gam[k] * (0.5 * ep * psip + 0.5 * em * psim - ph)


@njit(**LEAF)
def _work(tau1, md, wk, t0, pt):
    """Exact ``int_0^tau1 F(t0 + tau) g.v(tau) dtau`` for the interval solution (``F`` is
    real, so the real sum over the first ``nh`` modes, each of the first ``nc`` twice); the
    exponentials ``e^{lam_k tau1}`` are those of the interval's end state (``wk.ez``)."""
    f0, om = pt.f0, pt.om
    lam, gam, cg, z0, beta, wt = md.lam, md.gam, md.cg, wk.zeta0, wk.beta, md.wt
    ep = _eit(om * t0)
    em = np.conj(ep)
    io = 1j * om
    ap = 0.5 * f0 * ep
    am = 0.5 * f0 * em
    a0 = -f0 + 0.0j
    eip = _eit(om * tau1)
    eim = np.conj(eip)
    total = 0.0j
    SB = 0.0j
    SC = 0.0j
    SD = 0.0j
    for k in range(md.nh):
        lk = lam[k]
        fg = f0 * gam[k]
        wcg = wt[k] * cg[k]
        Ak = z0[k] + beta[k] / lk - fg / lk - fg * 0.5 * ep / (io - lk) - fg * 0.5 * em / (-io - lk)
        SB += wcg * (-beta[k] / lk + fg / lk)
        SC += wcg * fg * 0.5 * ep / (io - lk)
        SD += wcg * fg * 0.5 * em / (-io - lk)
        el = wk.ez[k]
        total += wcg * Ak * (ap * _phi_e(lk + io, tau1, el * eip)
                               + am * _phi_e(lk - io, tau1, el * eim) + a0 * _phi_e(lk, tau1, el))
    pp_ = _phi_e(io, tau1, eip)
    pm_ = _phi_e(-io, tau1, eim)
    total += SB * (ap * pp_ + am * pm_ + a0 * tau1)
    total += SC * (ap * _phi_e(2 * io, tau1, eip * eip) + am * tau1 + a0 * pp_)
    total += SD * (ap * tau1 + am * _phi_e(-2 * io, tau1, eim * eim) + a0 * pm_)
    return total.real


@njit(**LEAF, inline="always")
def _cond(j, zeta, md, x, pt, wk):
    """Event function of element j at the modal state ``zeta`` (> 0: the current stick/slip
    state is violated)."""
    wt = md.wt
    if x.mode[j] == 0:
        s = 0.0
        for k in range(md.nh):
            s += wt[k] * (md.SVq[j, k] * zeta[k]).real
        return abs(pt.kt * (s - x.z[j])) - pt.tau_s[j] * (1.0 + 1e-12)
    sd = 0.0
    for k in range(md.nh):
        sd += wt[k] * (md.SVv[j, k] * zeta[k]).real
    return -x.mode[j] * sd


@njit(**LEAF, inline="always")
def _conds(zeta, md, x, pt, wk):
    """All event functions at the modal state ``zeta`` into ``wk.fcur`` (slips and slip rates
    into ``wk.sbuf, wk.sdbuf``); returns True if any is violated."""
    SVq, SVv, nh, wt = md.SVq, md.SVv, md.nh, md.wt
    fout = wk.fcur
    hit = False
    for j in range(SVq.shape[0]):
        s = 0.0
        sd = 0.0
        for k in range(nh):
            s += wt[k] * (SVq[j, k] * zeta[k]).real
            sd += wt[k] * (SVv[j, k] * zeta[k]).real
        wk.sbuf[j] = s
        wk.sdbuf[j] = sd
        if wk.free[j]:
            fout[j] = -1.0
        elif x.mode[j] == 0:
            fout[j] = abs(pt.kt * (s - x.z[j])) - pt.tau_s[j] * (1.0 + 1e-12)
        else:
            fout[j] = -x.mode[j] * sd
        if fout[j] > 0.0:
            hit = True
    return hit


@njit(**LEAF)
def _pattern_key(wk, x):
    """Bit key of the current stick pattern (bit j: element j stuck); sets ``wk.stuck``."""
    key = 0
    for j in range(x.z.shape[0]):
        wk.stuck[j] = (x.mode[j] == 0) and not wk.free[j]
        if wk.stuck[j]:
            key |= (1 << j)
    return key


@njit(cache=True)
def _fill_slot(key, cache, wk, pt):
    """Eigen-decompose the pattern ``wk.stuck`` (bit key ``key``) into a cache slot (the next
    empty one; when the cache is full, the slots in turn); returns it."""
    lam_, V_, Vi_, SVq_, SVv_, cg_, gam_, gS_, nh_, nc_, wt_ = _pattern(wk.stuck, pt)
    wk.cnt[_N_EIG] += 1
    count = cache.count
    C = cache.keys.shape[0]
    if count[_FILLED] < C:
        slot = count[_FILLED]
        count[_FILLED] += 1
    else:
        slot = count[_STORED] % C
    count[_STORED] += 1
    cache.keys[slot] = key
    cache.lam[slot] = lam_
    cache.V[slot] = V_
    cache.Vi[slot] = Vi_
    cache.SVq[slot] = SVq_
    cache.SVv[slot] = SVv_
    cache.cg[slot] = cg_
    cache.gam[slot] = gam_
    cache.gS[slot] = gS_
    cache.nh[slot] = nh_
    cache.nc[slot] = nc_
    cache.wt[slot] = wt_
    cache.aSVq[slot] = weighted_abs(SVq_, wt_)
    _ladder(lam_, nh_, cache.ladder[slot])
    return slot


@njit(**LEAF, inline="always")
def _near(lk, om, tol):
    """``|lk - i om| < tol`` or ``|lk + i om| < tol`` (compared squared)."""
    re2 = lk.real * lk.real
    return re2 + (lk.imag - om) ** 2 < tol * tol or re2 + (lk.imag + om) ** 2 < tol * tol


@njit(**LEAF)
def resonant(lam, om):
    """True if an eigenvalue is within ``tol = 1e-9 (|lam| + om)`` of ``+-i om``: the
    exact-resonance guard of a point with forcing frequency ``om`` (the closed forms divide by
    ``+-i om - lam``) must shift it (:func:`shift_resonant`)."""
    for k in range(lam.shape[0]):
        tol = 1e-9 * (_cabs(lam[k]) + om)
        if _near(lam[k], om, tol):
            return True
    return False


@njit(**LEAF)
def shift_resonant(lam, om, out):
    """``out = lam`` with every eigenvalue within ``tol`` of ``+-i om`` (:func:`resonant`)
    shifted by ``-tol``; ``out`` may be ``lam``."""
    for k in range(lam.shape[0]):
        tol = 1e-9 * (_cabs(lam[k]) + om)
        out[k] = lam[k]
        if _near(lam[k], om, tol):
            out[k] = lam[k] - tol


@njit(cache=True, _nrt=False)
def project(cache, slot, wk, x, pt):
    """Modal coordinates ``wk.zeta0`` of the current state and the constant modal forcing
    ``wk.beta`` of the stuck springs' anchors and the sliding elements' kinetic tractions in
    the pattern of cache slot ``slot`` (the first ``nh`` modes; the last ``nc`` are the
    conjugates of the first).  Without reference counting: its callers keep numba's, which
    would count every view of the slot's arrays, at every switch."""
    md = _modes(cache, slot, wk)
    q, v, z, mode = x.q, x.v, x.z, x.mode
    n = q.shape[0]
    n2 = 2 * n
    nq = z.shape[0]
    xr, rv = wk.xr, wk.rv
    for i in range(n):
        xr[i] = q[i]
        xr[n + i] = v[i]
    # the interface points' tractions (weighted): the modal forcing is their sum over the
    # pattern's unit-traction loads gS, never M^-1 of their load vector (:func:`_pattern`)
    for j in range(nq):
        if wk.free[j]:
            rv[j] = 0.0
        elif wk.stuck[j]:
            rv[j] = pt.kt * pt.wq[j] * z[j]
        else:
            rv[j] = -pt.wq[j] * mode[j] * pt.tau_k[j]
    # V^-1 is complex and the state real: the real and imaginary parts of each product
    # separately (a complex product with a real factor would multiply its zero imaginary part
    # too), two modes at a time (four independent sums, where one mode alone waits for each
    # addition); every sum runs in the order of i, so the values are those of the complex
    # sums to the bit
    Vi, gS, nh = md.Vi, md.gS, md.nh
    for k in range(0, nh, 2):
        k2 = min(k + 1, nh - 1)   # an odd last mode is summed twice, the same way
        ar = ai = ar2 = ai2 = 0.0
        for i in range(n2):
            ar += Vi[k, i].real * xr[i]
            ai += Vi[k, i].imag * xr[i]
            ar2 += Vi[k2, i].real * xr[i]
            ai2 += Vi[k2, i].imag * xr[i]
        br = bi = br2 = bi2 = 0.0
        for j in range(nq):
            br += gS[j, k].real * rv[j]
            bi += gS[j, k].imag * rv[j]
            br2 += gS[j, k2].real * rv[j]
            bi2 += gS[j, k2].imag * rv[j]
        wk.zeta0[k] = complex(ar, ai)
        wk.beta[k] = complex(br, bi)
        wk.zeta0[k2] = complex(ar2, ai2)
        wk.beta[k2] = complex(br2, bi2)
    for k in range(md.nc):
        wk.zeta0[md.nh + k] = np.conj(wk.zeta0[k])
        wk.beta[md.nh + k] = np.conj(wk.beta[k])


@njit(**LEAF, inline="always")
def _rate_bounds(t0, md, wk, x, pt):
    """Bounds of the second derivative of every event function on the interval from ``t0``
    (stuck: ``k_t |s_j''|``, slipping: ``|s_j'''|``) into ``wk.rate``, from the closed form
    ``zeta_k(tau) = A_k e^{lam_k tau} + B_k + C_k e^{i w tau} + D_k e^{-i w tau}`` (its
    coefficients into ``wk.ca, cb, cc, cd``); returns the largest ``|lam_k|`` and the
    separation ``min_k min(|lam_k|, |lam_k - i w|, |lam_k + i w|)`` (where it is small against
    ``1 / tau`` the coefficients cancel: :func:`_closed_form`)."""
    f0, om = pt.f0, pt.om
    lam, gam, r1, r2 = md.lam, md.gam, wk.r1, wk.r2
    ep = _eit(om * t0)
    io = 1j * om
    sep2 = math.inf
    lmax = 0.0
    for k in range(md.nh):
        lk = lam[k]
        al = _cabs(lk)
        if al > lmax:   # the same maximum, in the same order, as the ladder's (_lmax)
            lmax = al
        sep2 = min(sep2, al * al, _cabs2(io - lk), _cabs2(io + lk))
        fg = f0 * gam[k]
        Bk = (fg - wk.beta[k]) / lk
        Ck = fg * 0.5 * ep / (io - lk)
        Dk = fg * 0.5 * np.conj(ep) / (-io - lk)
        Ak = wk.zeta0[k] - Bk - Ck - Dk
        wk.ca[k] = Ak
        wk.cb[k] = Bk
        wk.cc[k] = Ck
        wk.cd[k] = Dk
        aA = _cabs(Ak)
        r1[k] = al * al * aA
        r2[k] = al * al * al * aA
        wk.mag[k] = om * om * (_cabs(Ck) + _cabs(Dk))
    # the bound is split: the forced part (constant over the interval) into wk.ratec, the free
    # part (r1, r2: amplitudes at the interval's start) decays, :func:`_decayed_rates`
    aS = md.aSVq
    for j in range(x.z.shape[0]):
        acc = 0.0
        accc = 0.0
        if x.mode[j] == 0:
            for k in range(md.nh):
                acc += aS[j, k] * r1[k]
                accc += aS[j, k] * wk.mag[k]
            wk.ratec[j] = pt.kt * accc
            wk.rate[j] = pt.kt * (acc + accc)
        else:
            for k in range(md.nh):
                acc += aS[j, k] * r2[k]
                accc += aS[j, k] * wk.mag[k]
            wk.ratec[j] = om * accc
            wk.rate[j] = acc + om * accc
    return lmax, math.sqrt(sep2)


@njit(**LEAF, inline="always")
def _next_check(lo, t0, d_max, d_min, md, wk, x, pt):
    """Distance from the check at ``lo`` to the next one: the first possible root of
    ``f + f' d + M2 d^2 / 2`` over the unviolated elements (exact ``f'``, ``M2`` from
    :func:`_rate_bounds`), within ``[d_min, d_max]``."""
    dlt = d_max
    # zeta' = lam zeta + beta + gam F(t) at the current check
    Fc = pt.f0 * (math.cos(pt.om * (t0 + lo)) - 1.0)
    for k in range(md.nh):
        wk.zdot[k] = md.lam[k] * wk.zeta[k] + wk.beta[k] + md.gam[k] * Fc
    for j in range(x.z.shape[0]):
        fj = wk.fcur[j]
        if wk.free[j] or fj >= 0.0:
            continue
        if x.mode[j] == 0:
            d1 = pt.kt * wk.sdbuf[j] if wk.sbuf[j] - x.z[j] >= 0.0 else -pt.kt * wk.sdbuf[j]
        else:
            sdd = 0.0
            for k in range(md.nh):
                sdd += md.wt[k] * (md.SVv[j, k] * wk.zdot[k]).real
            d1 = -x.mode[j] * sdd
        M2 = wk.rate[j]
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
    return dlt


@njit(**LEAF)
def _closed_form(tau, md, wk, pt, out, eout):
    """Modal state at ``tau`` from the interval's coefficients (:func:`_rate_bounds`): ``A_k
    e^{lam_k tau} + B_k + C_k e^{i w tau} + D_k e^{-i w tau}``, the first ``md.nh`` modes.
    Cheaper than :func:`_zeta_at` (no divisions), but its terms are up to ``1 / sep`` times
    the state (``sep`` from :func:`_rate_bounds`), so an interval uses it only where ``sep *
    span`` is at least :data:`_SEP_MIN` (:func:`_state_at`).  ``e^{lam_k tau}`` into ``eout``."""
    eiw = _eit(pt.om * tau)
    eiwc = np.conj(eiw)
    for k in range(md.nh):
        el = np.exp(md.lam[k] * tau)
        eout[k] = el
        out[k] = wk.ca[k] * el + wk.cb[k] + wk.cc[k] * eiw + wk.cd[k] * eiwc


@njit(**LEAF)
def _state_at(tau, closed, md, wk, t0, pt, out, eout):
    """Modal state at ``t0 + tau`` of the interval (``e^{lam_k tau}`` into ``eout``):
    :func:`_closed_form` if ``closed``, else :func:`_zeta_at`.  An interval uses one of them
    throughout (its refinement, its switch decisions and its end state, which is the state
    its refinement evaluated at the switch), so that the sign an element's event function
    had where its refinement evaluated it is the sign the switch sees.  (A bracket whose right
    end is still the check's, evaluated on the ladder, may end on a point where no element
    switches: the interval then ends there without a switch and the next one starts from
    it.)"""
    if closed:
        _closed_form(tau, md, wk, pt, out, eout)
    else:
        _zeta_at(tau, md, wk, t0, pt, out, eout)


@njit(**LEAF, inline="always")
def _slope(j, zeta, tau, t0, md, x, pt, wk):
    """Time derivative of element ``j``'s event function (:func:`_cond`) at the modal state
    ``zeta`` at ``t0 + tau``, from the interval's equation ``zeta' = lam zeta + beta + gam
    F(t0 + tau)`` (no exponential: the state is given)."""
    Fc = pt.f0 * (math.cos(pt.om * (t0 + tau)) - 1.0)
    wt = md.wt
    sd = 0.0
    if x.mode[j] == 0:
        s = 0.0
        for k in range(md.nh):
            s += wt[k] * (md.SVq[j, k] * zeta[k]).real
            sd += wt[k] * (md.SVq[j, k] * (md.lam[k] * zeta[k] + wk.beta[k] + md.gam[k] * Fc)).real
        return pt.kt * sd if s - x.z[j] >= 0.0 else -pt.kt * sd
    for k in range(md.nh):
        sd += wt[k] * (md.SVv[j, k] * (md.lam[k] * zeta[k] + wk.beta[k] + md.gam[k] * Fc)).real
    return -x.mode[j] * sd


@njit(**LEAF, inline="always")
def _refine(j, lo, tau, span, t0, md, wk, x, pt, closed, best):
    """Crossing of element ``j``'s event function ``f`` in ``[lo, tau]`` (``f(lo) <= 0 <
    f(tau)``, the modal state from :func:`_state_at`); returns the right end ``b`` of the final
    bracket, ``b - a <= 1e-12 span`` with ``f(b) > 0``.  Newton steps (the slope
    :func:`_slope` costs no exponential, the state does) inside the bracket, the first from
    ``tau`` with the check's own state; a step that leaves the bracket falls back to regula
    falsi, and from the 8th evaluation every third one (every one after the 40th) is a
    bisection.  A Newton step shorter than half the tolerance is pushed by half the tolerance
    past the root, so that the bracket closes from both sides.  A right end evaluated before
    ``best`` (the earliest switch found so far) leaves its state in ``wk.zbest`` and its
    exponentials in ``wk.ez``: the interval takes them instead of evaluating them again
    (:func:`_interval`; the same function at the same time, so the same bits)."""
    a = lo
    b = tau
    fa = min(wk.fprev[j], 0.0)
    fb = wk.fcur[j]
    tol = 1e-12 * span
    nxt = b - fb / _slope(j, wk.zeta, tau, t0, md, x, pt, wk)
    for it in range(200):
        if b - a <= tol:
            break
        if it >= 40 or (it >= 8 and it % 3 == 2):
            nxt = 0.5 * (a + b)
        elif not (a < nxt < b):
            nxt = b - fb * (b - a) / (fb - fa) if fb - fa > 0.0 else 0.5 * (a + b)
            if not (a < nxt < b):
                nxt = 0.5 * (a + b)
        _state_at(nxt, closed, md, wk, t0, pt, wk.ztmp, wk.et)
        fm = _cond(j, wk.ztmp, md, x, pt, wk)
        if fm > 0.0:
            b = nxt
            fb = fm
            if b < best:
                for k in range(md.nh):
                    wk.zbest[k] = wk.ztmp[k]
                    wk.ez[k] = wk.et[k]
        else:
            a = nxt
            fa = fm
        if b - a <= tol:
            break
        dx = -fm / _slope(j, wk.ztmp, nxt, t0, md, x, pt, wk)
        if abs(dx) < 0.5 * tol:
            dx += 0.5 * tol if fm <= 0.0 else -0.5 * tol
        nxt = nxt + dx
    return b


@njit(**LEAF, inline="always")
def _ladder_check(m, tau, md, wk, pt):
    """Modal state into ``wk.zeta`` at the check ``tau``, one rung ``m`` after the last check:
    ``e^{lam_k tau}`` advanced by the rung's factor (``wk.el``), then the closed form in the
    interval's coefficients (:func:`_rate_bounds`)."""
    eiw = _eit(pt.om * tau)
    eiwc = np.conj(eiw)
    lad = md.ladder
    for k in range(md.nh):
        e = wk.el[k] * lad[m, k]
        wk.el[k] = e
        wk.zeta[k] = wk.ca[k] * e + wk.cb[k] + wk.cc[k] * eiw + wk.cd[k] * eiwc


@njit(**LEAF, inline="always")
def _decayed_rates(md, wk, x, pt):
    """The rate bounds of :func:`_rate_bounds` renewed at a ladder check ``tau_c``: the free
    part of mode ``k`` is ``A_k e^{lam_k tau}``, and ``|e^{lam_k tau}| <= |e^{lam_k tau_c}|``
    (``wk.el``) for ``tau >= tau_c`` because ``Re lam_k <= 0`` (a passive structure; the
    resonance guard only shifts ``lam_k`` to the left), so the bounds with the amplitudes
    ``|A_k| |e^{lam_k tau_c}|`` hold from the check on.  The interface's fast modes decay
    within a fraction of an interval, so the checks that follow are spaced by the slow motion
    (their number and cost: docs/performance.md)."""
    for k in range(md.nh):
        wk.mag[k] = _cabs(wk.el[k])
    aS = md.aSVq
    for j in range(x.z.shape[0]):
        acc = 0.0
        if x.mode[j] == 0:
            for k in range(md.nh):
                acc += aS[j, k] * (wk.r1[k] * wk.mag[k])
            wk.rate[j] = wk.ratec[j] + pt.kt * acc
        else:
            for k in range(md.nh):
                acc += aS[j, k] * (wk.r2[k] * wk.mag[k])
            wk.rate[j] = wk.ratec[j] + acc


@njit(**LEAF)
def _find_event(t0, span, md, wk, x, pt):
    """Earliest switch in ``(t0, t0 + span]`` (interval offset, or -1.0 if none), whether
    the interval uses the closed form in its coefficients (:func:`_state_at`) and whether the
    state at the switch is in ``wk.zeta`` (no switch: the state at the span's end) or in
    ``wk.zbest`` (with its exponentials in ``wk.ez``, :func:`_refine`; else it must be
    evaluated): adaptive
    checks (:func:`_next_check`, at most ``span / n_sub`` and at least ``d_min = 0.1 /
    max|lam|`` apart; with a ladder and coefficients that do not cancel (:func:`_closed_form`),
    the longest rung within that spacing, :func:`_ladder_check`; the check at the interval's
    end from :func:`_state_at`), then :func:`_refine` on every violated element."""
    lmax, sep = _rate_bounds(t0, md, wk, x, pt)
    d_min = 0.1 / lmax
    d_max = span / wk.n_sub
    closed = sep * span >= _SEP_MIN
    rungs = md.ladder.shape[0] if closed else 0
    lo = 0.0
    for k in range(wk.zeta.shape[0]):
        wk.zeta[k] = wk.zeta0[k]
        wk.el[k] = 1.0
    _conds(wk.zeta, md, x, pt, wk)
    for _ in range(100000):
        d = _next_check(lo, t0, d_max, d_min, md, wk, x, pt)
        m = 0
        if rungs > 0:
            m = min(int(3.0 * math.log2(d / d_min)), rungs - 1)
            d = _rung(d_min, m)
        tau = lo + d
        if tau >= span * (1.0 - 1e-14):
            tau = span
            _state_at(tau, closed, md, wk, t0, pt, wk.zeta, wk.ez)
        elif rungs > 0:
            _ladder_check(m, tau, md, wk, pt)
            _decayed_rates(md, wk, x, pt)
        else:
            _zeta_at(tau, md, wk, t0, pt, wk.zeta, wk.et)
        wk.cnt[_N_CHECKS] += 1
        for j in range(x.z.shape[0]):
            wk.fprev[j] = wk.fcur[j]
        if _conds(wk.zeta, md, x, pt, wk):
            best = tau
            for j in range(x.z.shape[0]):
                if wk.free[j] or wk.fcur[j] <= 0.0:
                    continue
                b = _refine(j, lo, tau, span, t0, md, wk, x, pt, closed, best)
                if b < best:
                    best = b
            return best, closed, best < tau
        lo = tau
        if tau >= span:
            break
    return -1.0, closed, False


@njit(**LEAF)
def _advance(tau1, t0, md, wk, x, pt, ecum):
    """Take the modal state ``wk.zeta`` at ``t0 + tau1`` as the state: work of the load (exact),
    friction dissipation and slips ``z`` of the sliding elements, ``(q, v)``."""
    q, v, z, mode = x.q, x.v, x.z, x.mode
    n = q.shape[0]
    n2 = 2 * n
    zeta, xr = wk.zeta, wk.xr
    ecum[0] += _work(tau1, md, wk, t0, pt)
    Vs, wt = md.V, md.wt
    for i in range(n2):
        acc = 0.0
        for k in range(md.nh):
            acc += wt[k] * (Vs[i, k] * zeta[k]).real
        xr[i] = acc
    for j in range(z.shape[0]):
        s_new = 0.0
        for k in range(md.nh):
            s_new += wt[k] * (md.SVq[j, k] * zeta[k]).real
        if wk.free[j]:
            z[j] = s_new
        elif mode[j] != 0:
            s_old = z[j] + mode[j] * pt.tau_k[j] / pt.kt
            ecum[1] += pt.wq[j] * mode[j] * pt.tau_k[j] * (s_new - s_old)
            z[j] = s_new - mode[j] * pt.tau_k[j] / pt.kt
    for i in range(n):
        q[i] = xr[i]
        v[i] = xr[n + i]


@njit(**LEAF)
def _apply_events(t_ev, md, wk, x, pt, tally):
    """Switch every element whose event function is violated at ``wk.zeta`` (time ``t_ev``)."""
    for j in range(x.z.shape[0]):
        if wk.free[j]:
            continue
        if _cond(j, wk.zeta, md, x, pt, wk) > 0.0:
            s = 0.0
            if x.mode[j] == 0:
                for k in range(md.nh):
                    s += md.wt[k] * (md.SVq[j, k] * wk.zeta[k]).real
            common.apply_switch(j, t_ev, s, x, pt, tally)


@njit(cache=True)
def new_cache(n, nq, cache_size):
    """An empty :data:`PatternCache` of ``cache_size`` slots for a model of ``n`` coordinates
    and ``nq`` interface points (slots allocated, touched only when filled; model key 0, see
    :func:`use_model`)."""
    n2 = 2 * n
    C = cache_size
    return PatternCache(np.full(C, -1, np.int64), np.empty((C, n2), np.complex128),
                        np.empty((C, n2, n2), np.complex128), np.empty((C, n2, n2), np.complex128),
                        np.empty((C, nq, n2), np.complex128), np.empty((C, nq, n2), np.complex128),
                        np.empty((C, n2), np.complex128), np.empty((C, n2), np.complex128),
                        np.empty((C, nq, n2), np.complex128),
                        np.zeros(C, np.int64), np.zeros(C, np.int64), np.zeros((C, n2)),
                        np.empty((C, nq, n2)), np.empty((C, LADDER_RUNGS, n2), np.complex128),
                        np.zeros(2, np.int64), np.zeros(1, np.int64))


@njit(**LEAF)
def use_model(cache, model):
    """Make ``cache`` hold the decompositions of the model with key ``model`` (emptied if it
    held another model's).  The key must identify every matrix :func:`_pattern` reads
    (``beamsim.pattern_store.model_keys``)."""
    if cache.model[0] != model:
        cache.count[_FILLED] = 0
        cache.model[0] = model


@njit(cache=True)
def new_scratch(pt, n_sub, cnt):
    """The :data:`ExpoWork` scratch of one trajectory with the counters ``cnt`` (``int64``,
    :data:`N_COUNTERS`; trajectories may share them)."""
    n = pt.Mm.shape[0]
    nq = pt.S.shape[0]
    n2 = 2 * n
    free = np.zeros(nq, np.bool_)
    for j in range(nq):
        free[j] = pt.tau_s[j] <= 0.0
    return ExpoWork(free, np.zeros(nq, np.bool_), np.empty(n2), np.empty(n2, np.complex128),
                    np.empty(n2, np.complex128), np.empty(n2, np.complex128),
                    np.empty(n2, np.complex128), np.empty(nq), np.empty(n2), np.empty(n2),
                    np.empty(n2, np.complex128), np.empty(nq), np.empty(nq), np.empty(nq),
                    np.empty(nq), np.empty(nq), cnt, n_sub, np.empty(n2, np.complex128),
                    np.full(1, -1, np.int64), np.empty(n2, np.complex128),
                    np.empty(n2, np.complex128), np.empty(n2, np.complex128),
                    np.empty(n2, np.complex128), np.empty(n2, np.complex128), np.empty(nq),
                    np.empty(n2), np.empty(n2, np.complex128), np.empty(n2, np.complex128),
                    np.empty(n2, np.complex128))


@njit(cache=True, inline="always")
def slot_modes(cache, slot, lam, guarded):
    """The :data:`Modes` of cache slot ``slot`` with the eigenvalues ``lam``: the slot's own,
    or a point's guarded copy of them (``guarded``: its ladder, which the slot's own
    eigenvalues made, is left out)."""
    rungs = 0 if guarded else LADDER_RUNGS
    return Modes(lam, cache.V[slot], cache.Vi[slot], cache.SVq[slot],
                 cache.SVv[slot], cache.cg[slot], cache.gam[slot], cache.gS[slot], cache.nh[slot],
                 cache.nc[slot], cache.wt[slot], cache.aSVq[slot], cache.ladder[slot, :rungs])


@njit(cache=True, inline="always")
def _modes(cache, slot, wk):
    """The :data:`Modes` of cache slot ``slot`` as trajectory ``wk`` uses them (with its
    point's resonance guard, :func:`resonant`)."""
    if slot == wk.gslot[0]:
        return slot_modes(cache, slot, wk.glam, True)
    return slot_modes(cache, slot, cache.lam[slot], False)


@njit(cache=True, _nrt=False)
def _cached_slot(cache, wk, x):
    """``(slot, key)``: the cache slot of the current stick pattern (-1 if it is not cached)
    and the pattern's bit key (sets ``wk.stuck``)."""
    key = _pattern_key(wk, x)
    for c in range(cache.count[_FILLED]):
        if cache.keys[c] == key:
            return c, key
    return -1, key


@njit(cache=True, _nrt=False)
def _guard_slot(cache, slot, wk, pt):
    """Note in ``wk`` the resonance guard of this point for cache slot ``slot``
    (:func:`resonant`)."""
    wk.gslot[0] = -1
    if resonant(cache.lam[slot], pt.om):
        shift_resonant(cache.lam[slot], pt.om, wk.glam)
        wk.gslot[0] = slot


@njit(cache=True)
def _pattern_slot(cache, wk, x, pt):
    """Cache slot of the current stick pattern (decomposed on a miss), its resonance guard
    for this point noted in ``wk``.  The lookup and the guard are kernels without reference
    counting (this one keeps it for the decomposition's arrays)."""
    slot, key = _cached_slot(cache, wk, x)
    if slot < 0:
        slot = _fill_slot(key, cache, wk, pt)
    _guard_slot(cache, slot, wk, pt)
    return slot


@njit(**LEAF)
def _interval(t0, t_end, slot, cache, wk, x, pt, tally):
    """From ``t0`` in the pattern of cache slot ``slot`` to its first switch (applied) or to
    the step end ``t_end``; returns ``(time reached, True if it is a switch)``."""
    md = _modes(cache, slot, wk)
    n2 = wk.zeta.shape[0]
    span = t_end - t0
    ev_tau, closed, evaluated = _find_event(t0, span, md, wk, x, pt)
    tau1 = span if ev_tau < 0 else ev_tau
    if evaluated:
        for k in range(md.nh):
            wk.zeta[k] = wk.zbest[k]
    elif ev_tau >= 0:
        _state_at(tau1, closed, md, wk, t0, pt, wk.zeta, wk.ez)
    for k in range(md.nc):
        wk.zeta[md.nh + k] = np.conj(wk.zeta[k])
    _advance(tau1, t0, md, wk, x, pt, tally.ecum)
    if ev_tau < 0:
        # no event: continue in the same pattern from t_end
        for k in range(n2):
            wk.zeta0[k] = wk.zeta[k]
        return t_end, False
    t_ev = t0 + tau1
    _apply_events(t_ev, md, wk, x, pt, tally)
    wk.cnt[_N_EVENTS] += 1
    return t_ev, True


@njit(cache=True, inline="always")
def zeno_window(om):
    """Length of the Zeno guard's window: the :data:`ZENO_WINDOWS_PER_PERIOD`-th of the forcing
    period ``2 pi / om``."""
    return 2.0 * math.pi / om / ZENO_WINDOWS_PER_PERIOD


@njit(cache=True, inline="always")
def zeno_limit(nq):
    """The most switches the Zeno guard lets through in one window (``nq`` interface points)."""
    return 10 * nq + 10


@njit(cache=True, inline="always")
def zeno_count(t, t_win, guard, window):
    """Count a switch at time ``t`` in the Zeno guard's window that began at ``t_win`` with
    ``guard`` switches: a switch a window or more after ``t_win`` begins a new window.  Returns
    the window's start and its count, ``(t_win, guard)``; the guard fires when the count exceeds
    :func:`zeno_limit`.  The rule of ``expo``'s runs (:func:`_step`), its drive and its coupled
    copies (:mod:`beamsim.kernels.expo_copies`), whatever their output grid."""
    if t - t_win >= window:
        return t, 1
    return t_win, guard + 1


@njit(**LEAF, inline="always")
def _stuck_weights(x, pt):
    """Quadrature weight of the stuck elements (``mode 0``) and of all elements, summed in the
    same order (so equal to the bit when every element is stuck)."""
    sw = 0.0
    tw = 0.0
    for j in range(x.mode.shape[0]):
        tw += pt.wq[j]
        if x.mode[j] == 0:
            sw += pt.wq[j]
    return sw, tw


@njit(**LEAF, inline="always")
def _tally_interval(t0, t1, sw, tw, stats, inrec):
    """Stick statistics of the interval ``[t0, t1]`` spent in one stick pattern (its weights
    ``sw, tw`` from :func:`_stuck_weights`): the stuck and the total quadrature weight times
    the interval's length (``beamsim.results.STAT_*``: whole run, and the recorded periods if
    ``inrec``).  So ``expo``'s stick fractions are time averages, exact, where a sample at the
    step ends (``common.post_step``, the rule of the other integrators, whose steps are
    thousands per period) would miss a slip between two output steps; a stick fraction is 1
    exactly when no element slipped.  (The first slip is noted where it is located,
    :func:`beamsim.kernels.common.apply_switch`.)"""
    dt = t1 - t0
    stats[STAT_STUCK_W_ALL] += sw * dt
    stats[STAT_W_ALL] += tw * dt
    if inrec:
        stats[STAT_STUCK_W_RECORD] += sw * dt
        stats[STAT_W_RECORD] += tw * dt


@njit(cache=True)
def _step(t0, t_end, slot, cache, wk, x, pt, tally, inrec):
    """Advance from ``t0`` to the step end ``t_end`` through every switch in between, each
    interval's stick statistics tallied (:func:`_tally_interval`; ``inrec``: the step is in the
    recorded periods).  Zeno guard (:func:`zeno_count`): more than ``10 nq + 10`` switches
    within :data:`ZENO_WINDOWS_PER_PERIOD`-th of a forcing period, and the state is accepted as
    it is at the end of that window (a jump in time, counted, not tallied: the run is flagged,
    and the pipeline runs the point again on RK4).  Returns ``(t0, slot)`` for the next step
    (``slot = -1``: the pattern must be looked up)."""
    guard = 0
    window = zeno_window(pt.om)
    t_win = t0
    while True:
        if slot < 0:
            slot = _pattern_slot(cache, wk, x, pt)
            project(cache, slot, wk, x, pt)
        t_start = t0
        # the interval's pattern is the state's before its switches are applied: tallied first
        sw, tw = _stuck_weights(x, pt)
        t0, switched = _interval(t0, t_end, slot, cache, wk, x, pt, tally)
        _tally_interval(t_start, t0, sw, tw, tally.stats, inrec)
        if not switched:
            return t0, slot
        t_win, guard = zeno_count(t0, t_win, guard, window)
        slot = -1
        if guard > zeno_limit(x.z.shape[0]):
            # Zeno guard: accept the state, resume at the window's end (counted: the run is
            # flagged)
            wk.cnt[_N_ZENO] += 1
            t0 = min(t_win + window, t_end)
            if t0 >= t_end:
                return t_end, slot
            t_win = t0
            guard = 0


@njit(cache=True, nogil=True)
def run_point(stk, steps, n_sub, models, out, cache, p):
    """Integrate point ``p`` of a batch (:data:`~beamsim.kernels.bundles.PointStack` with the
    full damping matrix; the step contract of :mod:`beamsim.kernels`; an item of
    :func:`beamsim.kernels.thread_pool.run_items` with the calling thread's ``cache``):
    ``n_sub``: checks per step at least; ``cache``: the :data:`PatternCache` it uses (and may
    fill), ``models[p]``: the key of the point's model (:func:`use_model`).  The result does not
    depend on what the cache holds: a decomposition found there is the one the point would
    compute.  (One function, not a wrapper around a point kernel: numba optimises and
    generates the machine code of every callee again inside each caller, docs/performance.md,
    "Compilation".)"""
    pt = point_at(stk, p, False)
    sched = schedule_at(steps, p)
    x, tally, e0 = common.start_point(p, stk.x0[p], pt, sched, out)
    use_model(cache, models[p])
    wk = new_scratch(pt, n_sub, np.zeros(N_COUNTERS, np.int64))
    n_per = sched.n_per
    # int64 from the start: a literal -1 would have numba compile _step once more for it
    slot = np.int64(-1)
    t0 = 0.0
    for step in range((sched.n_trans + sched.n_rec) * n_per):
        k_step = step + 1
        t_end = k_step * sched.h
        # stick statistics per interval, exactly (_tally_interval), not sampled by post_step
        t0, slot = _step(t0, t_end, slot, cache, wk, x, pt, tally, k_step > sched.n_trans * n_per)
        if pt.damp:
            # damping dissipation: remainder of the energy identity (docs/model.md)
            em_, _ = common.energy(x.q, x.v, x.z, pt)
            tally.ecum[2] = tally.ecum[0] - tally.ecum[1] - (em_ - e0)
        if common.end_of_step(p, k_step, t_end, x, tally.ecum, pt, sched, out):
            break
    common.final_flags(p, tally.stats, out, x)
    out.flags[p, FLAG_N_PATTERNS] = wk.cnt[_N_EIG]
    out.flags[p, FLAG_N_EVENTS] = wk.cnt[_N_EVENTS]
    out.flags[p, FLAG_N_CHECKS] = wk.cnt[_N_CHECKS]
    out.flags[p, FLAG_N_ZENO] = wk.cnt[_N_ZENO]

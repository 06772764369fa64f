r"""The RK4 reference integrator with located stick/slip switches.

State ``(q, v, z, W_in, D_fric, D_damp)``; the stick/slip state of each Jenkins element is
frozen inside a step, so the right-hand side is smooth there.  Every switch is located inside
the step (event functions interpolated linearly, then refined by Illinois iterations on the
RK4 substep to ``EVENT_RTOL``) and the step is split at it, so switching times depend
continuously on the state; a return mapping after each step (:func:`common.post_step`)
settles anything left.  The same step serves the drive and the coupled copies of
:mod:`beamsim.kernels.copies` (``Coupling``).

Hot kernels are compiled with :data:`~beamsim.kernels.bundles.LEAF`'s floating-point flags.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit
from numba.extending import overload

from beamsim.friction import smooth_traction
from beamsim.kernels import common, rigid_stick
from beamsim.kernels.bundles import LEAF, RigidPoint, State, point_at, schedule_at
from beamsim.results import FLAG_N_EVENTS

#: scratch of one RK4 step: stage derivatives ``kq, kv, kz`` and ledger rates ``ke`` (4 rows),
#: tractions ``tau``, the step's end state ``qn, vn, zn`` and ledger increment ``en``, the
#: stage states ``sq, sv, sz`` (4 rows), and the rigid stick's event functions at the step's
#: start ``g0``
Stages = namedtuple("Stages", ("kq", "kv", "kz", "ke", "tau", "qn", "vn", "zn", "en", "sq", "sv",
                               "sz", "g0"))

#: one-way coupling ``d (x - y)`` of a copy to a drive that starts a substep at
#: ``(xq, xv, xz)`` with stick/slip state ``xmode``; ``xqn, xvn, xzn`` and ``xsq, xsv, xsz``
#: receive the drive's substep end state and stage states.  ``d = 0``: uncoupled.
Coupling = namedtuple("Coupling", ("d", "xq", "xv", "xz", "xmode", "xqn", "xvn", "xzn", "xsq",
                                   "xsv", "xsz"))

#: substeps of a step: start times ``t`` (one more entry: the step end) and start states
Segments = namedtuple("Segments", ("t", "q", "v", "z", "m"))

#: Illinois iterations and relative tolerance of the event location inside a step
EVENT_ITERATIONS = 30
EVENT_RTOL = 1e-11
#: at most this many located switches per step (then the step is accepted and the return
#: mapping of ``post_step`` settles the rest)
MAX_SWITCHES_PER_STEP = 64


@njit(cache=True)
def new_stages(n, nq):
    """Zeroed :data:`Stages` for ``n`` coordinates and ``nq`` Jenkins elements."""
    return Stages(np.zeros((4, n)), np.zeros((4, n)), np.zeros((4, nq)), np.zeros((4, 3)),
                  np.empty(nq), np.empty(n), np.empty(n), np.empty(nq), np.empty(3),
                  np.zeros((4, n)), np.zeros((4, n)), np.zeros((4, nq)), np.zeros(nq))


@njit(cache=True)
def new_segments(ns, n, nq):
    """:data:`Segments` room for ``ns`` substeps."""
    return Segments(np.empty(ns + 1), np.empty((ns, n)), np.empty((ns, n)), np.empty((ns, nq)),
                    np.zeros((ns, nq), np.int64))


@njit(cache=True, inline="always")
def store_substep(seg, k, x):
    """``seg.q[k], seg.v[k], seg.z[k], seg.m[k] = x`` (element by element: no temporary)."""
    for i in range(x.q.shape[0]):
        seg.q[k, i] = x.q[i]
        seg.v[k, i] = x.v[i]
    for j in range(x.z.shape[0]):
        seg.z[k, j] = x.z[j]
        seg.m[k, j] = x.mode[j]


@njit(cache=True, inline="always")
def uncoupled(x, w):
    """A :data:`Coupling` with ``d = 0`` (its arrays are never read)."""
    return Coupling(0.0, x.q, x.v, x.z, x.mode, w.qn, w.vn, w.zn, w.sq, w.sv, w.sz)


def _rigid(pt) -> bool:
    """At compile time: is the point type a :data:`~beamsim.kernels.bundles.RigidPoint`?"""
    return getattr(pt, "instance_class", None) is RigidPoint


def deriv(t, q, v, z, mode, pt, dq, dv, dz, de, tau):
    """Right-hand side (compiled kernels only): :func:`_jenkins_deriv` for a
    :data:`~beamsim.kernels.bundles.Point`, :func:`beamsim.kernels.rigid_stick.deriv` for a
    :data:`~beamsim.kernels.bundles.RigidPoint` -- chosen when the kernel is compiled, so a
    kernel of one contains no code of the other."""
    raise NotImplementedError("a compiled kernel's function")


@overload(deriv, inline="always")
def _deriv_of(t, q, v, z, mode, pt, dq, dv, dz, de, tau):
    if _rigid(pt):
        def impl(t, q, v, z, mode, pt, dq, dv, dz, de, tau):
            rigid_stick.deriv(t, q, v, z, mode, pt, dq, dv, dz, de, tau)
    else:
        def impl(t, q, v, z, mode, pt, dq, dv, dz, de, tau):
            _jenkins_deriv(t, q, v, z, mode, pt, dq, dv, dz, de, tau)
    return impl


@njit(cache=True, inline="always")
def _jenkins_deriv(t, q, v, z, mode, pt, dq, dv, dz, de, tau):
    """Right-hand side at ``(t, q, v, z)`` with the stick/slip state ``mode`` frozen:
    ``q' = v``, ``v' = Aq q + Av v + Bt tau + gv F(t)``, ``z' = s'`` on slipping elements, and
    the ledger rates ``de = (F g.v, friction power, damping power)``; ``tau`` receives the
    interface tractions (Jenkins or regularised law, plus the interface dashpot ``ct s'``)."""
    law = pt.law
    Bt, S, wq, kt, ct = pt.Bt, pt.S, pt.wq, pt.kt, pt.ct
    n = q.shape[0]
    nq = z.shape[0]
    F = pt.f0 * (math.cos(pt.om * t) - 1.0)
    dD = 0.0
    dC = 0.0
    for j in range(nq):
        s, sd = common.slip_and_rate(S, j, q, v)
        if law == 0:
            tj = kt * (s - z[j])
            if mode[j] != 0:
                dz[j] = sd
                dD += wq[j] * tj * sd
            else:
                dz[j] = 0.0
        else:
            tj = smooth_traction(sd, pt.fc[j], pt.fs[j], pt.vs, pt.kv, pt.eps)
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
        acc = common.structural_acceleration(i, q, v, F, pt)
        for j in range(nq):
            acc += Bt[i, j] * tau[j]
        dv[i] = acc
        dq[i] = v[i]
        pw += pt.g[i] * v[i]
    de[0] = F * pw
    de[1] = dD
    de[2] = common.damping_power(v, pt) + dC


@njit(cache=True, inline="always")
def _stage_state(c, q, v, z, kq, kv, kz, tq, tv, tz):
    """RK4 stage state ``(tq, tv, tz) = (q, v, z) + c (kq, kv, kz)``."""
    for i in range(q.shape[0]):
        tq[i] = q[i] + c * kq[i]
        tv[i] = v[i] + c * kv[i]
    for j in range(z.shape[0]):
        tz[j] = z[j] + c * kz[j]


@njit(**LEAF)
def rk4_incr(t, hs, x, pt, w, dcoup, xw):
    """One classical RK4 step of length ``hs`` from ``x`` with the stick/slip state frozen: the
    new state goes to ``(w.qn, w.vn, w.zn)``, the energy-ledger increment to ``w.en`` (``x`` is
    not modified); the stage states are left in ``w.sq, w.sv, w.sz``.  A coupled copy
    (``dcoup > 0``) gets ``dcoup (x_drive - y)`` added to every stage derivative, with the
    drive's stage states ``xw.sq, xw.sv, xw.sz``.  Rigid stick: the event functions at ``x``
    go to ``w.g0``."""
    q, v, z, mode = x.q, x.v, x.z, x.mode
    kq, kv, kz, ke, sq, sv, sz = w.kq, w.kv, w.kz, w.ke, w.sq, w.sv, w.sz
    n = q.shape[0]
    nq = z.shape[0]
    hh = 0.5 * hs
    for st in range(4):
        if st == 0:
            _stage_state(0.0, q, v, z, q, v, z, sq[0], sv[0], sz[0])
            c = 0.0
        else:
            c = hs if st == 3 else hh
            _stage_state(c, q, v, z, kq[st - 1], kv[st - 1], kz[st - 1], sq[st], sv[st], sz[st])
        deriv(t + c, sq[st], sv[st], sz[st], mode, pt, kq[st], kv[st], kz[st], ke[st], w.tau)
        if st == 0:
            # the rigid stick's event functions at the step's start (for first_event), from
            # this stage; kq[1] is free until stage 1
            start_events(t, v, mode, pt, w.tau, kv[0], kq[1], w.g0)
        if dcoup != 0.0:
            for i in range(n):
                kq[st, i] += dcoup * (xw.sq[st, i] - sq[st, i])
                kv[st, i] += dcoup * (xw.sv[st, i] - sv[st, i])
            for j in range(nq):
                kz[st, j] += dcoup * (xw.sz[st, j] - sz[st, j])
    h6 = hs / 6.0
    for i in range(n):
        w.qn[i] = q[i] + h6 * (kq[0, i] + 2.0 * kq[1, i] + 2.0 * kq[2, i] + kq[3, i])
        w.vn[i] = v[i] + h6 * (kv[0, i] + 2.0 * kv[1, i] + 2.0 * kv[2, i] + kv[3, i])
    for j in range(nq):
        w.zn[j] = z[j] + h6 * (kz[0, j] + 2.0 * kz[1, j] + 2.0 * kz[2, j] + kz[3, j])
    for r in range(3):
        w.en[r] = h6 * (ke[0, r] + 2.0 * ke[1, r] + 2.0 * ke[2, r] + ke[3, r])


def first_event(t0, t1, x, w, pt):
    """Earliest switch inside a step (compiled kernels only): :func:`_jenkins_first_event` or
    :func:`beamsim.kernels.rigid_stick.first_event`, by the point's type."""
    raise NotImplementedError("a compiled kernel's function")


@overload(first_event, inline="always")
def _first_event_of(t0, t1, x, w, pt):
    if _rigid(pt):
        def impl(t0, t1, x, w, pt):
            return rigid_stick.first_event(t0, t1, x, w, pt)
    else:
        def impl(t0, t1, x, w, pt):
            return _jenkins_first_event(t0, t1, x, w, pt)
    return impl


def start_events(t, v, mode, pt, tau, acc, scratch, g0):
    """The event functions at a step's start from its first stage (compiled kernels only): the
    rigid stick's (:func:`beamsim.kernels.rigid_stick.events_from`); nothing for a Jenkins
    point, whose event functions need no stage."""
    raise NotImplementedError("a compiled kernel's function")


@overload(start_events, inline="always")
def _start_events_of(t, v, mode, pt, tau, acc, scratch, g0):
    if _rigid(pt):
        def impl(t, v, mode, pt, tau, acc, scratch, g0):
            rigid_stick.events_from(t, v, mode, pt, tau, acc, scratch, g0)
    else:
        def impl(t, v, mode, pt, tau, acc, scratch, g0):
            pass
    return impl


def switch(j, t, x, pt, tally, w):
    """Switch element ``j`` at a located event (compiled kernels only):
    :func:`beamsim.kernels.common.apply_switch` or :func:`beamsim.kernels.rigid_stick.switch`."""
    raise NotImplementedError("a compiled kernel's function")


@overload(switch, inline="always")
def _switch_of(j, t, x, pt, tally, w):
    if _rigid(pt):
        def impl(j, t, x, pt, tally, w):
            rigid_stick.switch(j, t, x, pt, tally, w)
    else:
        def impl(j, t, x, pt, tally, w):
            s = 0.0
            for k in range(x.q.shape[0]):
                s += pt.S[j, k] * x.q[k]
            common.apply_switch(j, t, s, x, pt, tally)
    return impl


def project_velocity(v, mode, pt):
    """Make ``v`` respect the stuck set (compiled kernels only): the rigid stick's
    :func:`beamsim.kernels.rigid_stick.project_velocity`; nothing for a Jenkins point."""
    raise NotImplementedError("a compiled kernel's function")


@overload(project_velocity, inline="always")
def _project_velocity_of(v, mode, pt):
    if _rigid(pt):
        def impl(v, mode, pt):
            rigid_stick.project_velocity(v, mode, pt)
    else:
        def impl(v, mode, pt):
            pass
    return impl


@njit(cache=True, inline="always")
def _jenkins_first_event(t0, t1, x, w, pt):
    """Earliest stick/slip switch of the Jenkins elements inside a step from ``(t0, x)`` to
    ``(t1, w.qn, w.vn, w.zn)``: the event functions ``g = |k_t (s - z)| - tau_s`` (stuck) and
    ``g = -mode s'`` (slipping) are interpolated linearly between the step ends (the rigid
    stick: :func:`beamsim.kernels.rigid_stick.first_event`).  Returns ``(theta, j)``, the step
    fraction and the element, or ``(2.0, -1)`` if none switches."""
    q, v, z, mode, S, kt, tau_s = x.q, x.v, x.z, x.mode, pt.S, pt.kt, pt.tau_s
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
                s1 += S[j, k] * w.qn[k]
            g0 = abs(kt * (s0 - z[j])) - tau_s[j]
            g1 = abs(kt * (s1 - w.zn[j])) - tau_s[j]
        else:
            d0 = 0.0
            d1 = 0.0
            for k in range(n):
                d0 += S[j, k] * v[k]
                d1 += S[j, k] * w.vn[k]
            g0 = -mode[j] * d0
            g1 = -mode[j] * d1
        if g1 > 0.0:
            th = 0.0 if g0 >= 0.0 else g0 / (g0 - g1)
            if th < best:
                best = th
                jb = j
    return best, jb


def event_g(j, t, q, v, z, mode, pt, w):
    """Event function of element ``j`` at ``(t, q, v, z)`` (> 0: its stick/slip state is
    violated; compiled kernels only): :func:`_jenkins_event_g` or
    :func:`beamsim.kernels.rigid_stick.event_value` (``w``: scratch of its tractions)."""
    raise NotImplementedError("a compiled kernel's function")


@overload(event_g, inline="always")
def _event_g_of(j, t, q, v, z, mode, pt, w):
    if _rigid(pt):
        def impl(j, t, q, v, z, mode, pt, w):
            return rigid_stick.event_value(j, t, q, v, z, mode, pt, w)
    else:
        def impl(j, t, q, v, z, mode, pt, w):
            return _jenkins_event_g(j, q, v, z, mode, pt)
    return impl


@njit(**LEAF)
def _jenkins_event_g(j, q, v, z, mode, pt):
    """Event function of a Jenkins element (> 0: its stick/slip state is violated)."""
    a = 0.0
    S = pt.S
    if mode[j] == 0:
        for k in range(q.shape[0]):
            a += S[j, k] * q[k]
        return abs(pt.kt * (a - z[j])) - pt.tau_s[j]
    for k in range(q.shape[0]):
        a += S[j, k] * v[k]
    return -mode[j] * a


@njit(cache=True, inline="always")
def has_switches(law):
    """True for the laws with located stick/slip switches (Jenkins and rigid stick)."""
    return law == 0 or law == rigid_stick.RIGID_STICK


@njit(cache=True, inline="always")
def accept(x, ecum, w):
    """Take the step end ``(w.qn, w.vn, w.zn)`` as the state and book ``w.en``."""
    for i in range(x.q.shape[0]):
        x.q[i] = w.qn[i]
        x.v[i] = w.vn[i]
    for j in range(x.z.shape[0]):
        x.z[j] = w.zn[j]
    for r in range(3):
        ecum[r] += w.en[r]


@njit(**LEAF)
def try_full_step(t, h, x, pt, ecum, w, dcoup, xw):
    """The fast path of every RK4 step: one step of length ``h``; if no element switches inside
    it, accept it and return True, else leave ``x`` unchanged and return False (the caller
    then locates the switches, :func:`located_step`)."""
    rk4_incr(t, h, x, pt, w, dcoup, xw)
    th = 2.0
    if has_switches(pt.law):
        th, _ = first_event(t, t + h, x, w, pt)
    if th >= 1.0:
        accept(x, ecum, w)
        return True
    return False


@njit(**LEAF)
def _locate(j, tl, rem, th, x, pt, w, cp, xst, xw):
    """Refine the crossing of element ``j``'s event function inside the substep
    ``(tl, tl + rem)`` from its linear estimate ``th`` (Illinois on the RK4 substep, to
    ``EVENT_RTOL``); leaves the substep up to the crossing in ``w`` (and the drive's in ``xw``)
    and returns its fraction."""
    a = 0.0
    ga = event_g(j, tl, x.q, x.v, x.z, x.mode, pt, w)
    b = 1.0
    gb = event_g(j, tl + rem, w.qn, w.vn, w.zn, x.mode, pt, w)
    tol = EVENT_RTOL * (abs(ga) + abs(gb))
    side = 0
    for itr in range(EVENT_ITERATIONS + 1):
        if cp.d != 0.0:
            rk4_incr(tl, th * rem, xst, pt, xw, 0.0, xw)
        rk4_incr(tl, th * rem, x, pt, w, cp.d, xw)
        gm = event_g(j, tl + th * rem, w.qn, w.vn, w.zn, x.mode, pt, w)
        if abs(gm) <= tol or b - a <= 1e-14 or itr == EVENT_ITERATIONS:
            break
        a, ga, b, gb, th, side = common.illinois(a, ga, b, gb, th, gm, side)
    return th


@njit(**LEAF)
def located_step(t, hs, h_tol, x, pt, tally, w, cp, seg, record):
    """Advance ``x`` from ``t`` over ``hs`` with RK4, splitting the step at every stick/slip
    switch (law 0): the earliest crossing of the linearly interpolated event functions, refined
    by :func:`_locate`, so that a switching time does not depend on how the step happens to be
    split.  Substeps shorter than ``1e-12 h_tol`` end the step.  Returns
    ``(switches, substeps)``.

    ``record``: store the start time and state of every substep in ``seg`` (``seg.t[k]``, with
    ``seg.t[n_substeps] = t + hs``); the drive of :mod:`beamsim.kernels.copies` records its
    substeps so that its copies can follow it.

    ``cp.d > 0``: a coupled copy of a drive that starts at ``(cp.xq, cp.xv, cp.xz)`` and keeps
    the stick/slip state ``cp.xmode`` over the whole interval (one substep of the drive): every
    substep integrates that drive too (its local state is overwritten: a scratch copy) and adds
    ``cp.d (x - y)`` to every stage of the copy."""
    xst = State(cp.xq, cp.xv, cp.xz, cp.xmode)
    xw = Stages(w.kq, w.kv, w.kz, w.ke, w.tau, cp.xqn, cp.xvn, cp.xzn, w.en, cp.xsq, cp.xsv,
                cp.xsz, w.g0)
    rem = hs
    tl = t
    n_switch = 0
    nseg = 0
    for it in range(MAX_SWITCHES_PER_STEP + 1):
        if record:
            seg.t[nseg] = tl
            store_substep(seg, nseg, x)
        nseg += 1
        if cp.d != 0.0:
            # the drive's substep (local state xst), whose stages enter the coupling
            rk4_incr(tl, rem, xst, pt, xw, 0.0, xw)
        rk4_incr(tl, rem, x, pt, w, cp.d, xw)
        th = 2.0
        j = -1
        if has_switches(pt.law) and it < MAX_SWITCHES_PER_STEP:
            th, j = first_event(tl, tl + rem, x, w, pt)
        if th >= 1.0:
            accept(x, tally.ecum, w)
            break
        if th > 0.0:
            th = _locate(j, tl, rem, th, x, pt, w, cp, xst, xw)
            hs_acc = th * rem
            accept(x, tally.ecum, w)
            if cp.d != 0.0:
                for i in range(x.q.shape[0]):
                    cp.xq[i] = cp.xqn[i]
                    cp.xv[i] = cp.xvn[i]
                for i in range(x.z.shape[0]):
                    cp.xz[i] = cp.xzn[i]
        else:
            hs_acc = 0.0
        tl += hs_acc
        rem -= hs_acc
        switch(j, tl, x, pt, tally, w)
        n_switch += 1
        if rem <= 1e-12 * h_tol:
            break
    if record:
        seg.t[nseg] = t + hs
    return n_switch, nseg


@njit(cache=True)
def rk4_point(p, pt, sched, x0, out):
    """Integrate point ``p`` (the step contract of :mod:`beamsim.kernels`)."""
    x, tally, _ = common.start_point(p, x0, pt, sched, out)
    # a given initial velocity need not respect a rigid stuck set's constraint
    project_velocity(x.v, x.mode, pt)
    n = pt.Aq.shape[0]
    nq = pt.S.shape[0]
    w = new_stages(n, nq)
    cp = uncoupled(x, w)
    seg = new_segments(1, n, nq)
    h, n_per = sched.h, sched.n_per
    n_total = (sched.n_trans + sched.n_rec) * n_per
    n_switch = 0
    for step in range(n_total):
        t = step * h
        # fast path: one RK4 step; only a step with a switch is redone with located switches
        if not try_full_step(t, h, x, pt, tally.ecum, w, 0.0, w):
            nsw, _ = located_step(t, h, h, x, pt, tally, w, cp, seg, False)
            n_switch += nsw
        k = step + 1
        tn = k * h
        common.post_step(tn, x, pt, tally, k > sched.n_trans * n_per)
        if common.end_of_step(p, k, tn, x, tally.ecum, pt, sched, out):
            break
    common.final_flags(p, tally.stats, out, x)
    out.flags[p, FLAG_N_EVENTS] = n_switch


@njit(cache=True, nogil=True)
def run_point(stk, steps, out, p):
    """RK4 on point ``p`` of a batch (:data:`~beamsim.kernels.bundles.PointStack`; Jenkins or
    regularised laws; an item of :func:`beamsim.kernels.thread_pool.run_items`): the structural
    damping as a matrix, the interface dashpot inside the interface traction."""
    rk4_point(p, point_at(stk, p, True), schedule_at(steps, p), stk.x0[p], out)


@njit(cache=True, nogil=True)
def run_point_rigid(stk, steps, out, p):
    """:func:`run_point` for a rigid-stick point (a kernel of its own: compiled only when
    used)."""
    rk4_point(p, rigid_stick.with_cache(point_at(stk, p, True)), schedule_at(steps, p),
              stk.x0[p], out)

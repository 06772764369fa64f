"""Named argument bundles of the compiled kernels (numba passes named tuples as structs).

Every array of a ``*Stack`` bundle has a leading point axis; :func:`point_at` and
:func:`schedule_at` cut one point's view out of it inside an item kernel.
"""

from __future__ import annotations

from collections import namedtuple

from numba import njit

#: njit options of a hot kernel that allocates nothing (no array is created or returned):
#: compiled without numba's reference counting.  Every array a kernel reads out of a bundle
#: would otherwise cost an atomic reference-count increment and decrement per call, which
#: made the bundled kernels measurably slower than flat arguments (docs/architecture.md);
#: the caller owns every array, so none is needed.  A LEAF kernel may call only LEAF or
#: inlined kernels (numba compiles its callees with its flags).  Floating-point flags: sums
#: may be reassociated (vectorised) and multiply-adds fused, reciprocals used for divisions,
#: signed zeros ignored -- but never "no NaN / no Inf", which would let the compiler drop the
#: divergence checks (their measured effect on speed and results: docs/performance.md).
#: numba's on-disk cache is keyed by the modification time of the file that defines a
#: kernel, not of this one: a change here must come with a change of every kernel module.
LEAF = dict(cache=True, _nrt=False, fastmath={"reassoc", "contract", "nsz", "arcp"})

#: constant inputs of one point.  Matrices of the first-order form ``Aq = -M^-1 K``,
#: ``Av = -M^-1 C_struct``, ``Bt = -M^-1 S^T W``, ``gv = M^-1 g``; ``S`` slip at the quadrature
#: points, ``wq`` their weights, ``kt`` Jenkins stiffness, ``ct`` interface dashpot, ``Mm, Km,
#: Cm`` mass, stiffness and the damping matrix the integrator books (``damp``: it is nonzero),
#: ``g`` load vector, ``tip`` tip-response rows; load ``F(t) = f0 (cos(om t) - 1)``; friction
#: limits ``tau_s, tau_k`` (stick-slip) and ``fc, fs, vs, kv, eps`` (regularised laws); ``Minv``
#: and ``Linv`` = ``M^-1`` (the rigid stick's constraint tractions) and the inverse Cholesky
#: factor of ``M`` (expo's mass-normalised decompositions).
_POINT_INPUTS = ("law", "Aq", "Av", "Bt", "gv", "S", "wq", "kt", "ct", "Mm", "Km", "Cm", "damp",
                 "g", "tip", "f0", "om", "tau_s", "tau_k", "fc", "fs", "vs", "kv", "eps", "Minv",
                 "Linv")

#: the rigid stick's per-pattern matrices (:mod:`beamsim.kernels.rigid_stick`): ``keys`` (-1:
#: empty slot), ``F`` ``(C, nq, nq)``, ``E`` ``(C, nq, n)`` (rows and columns of the stuck
#: elements; zero elsewhere), ``red`` ``(C, nq)`` (1: a sliding element whose slip the stuck
#: ones fix) and ``R`` ``(C, nq, n)`` its elastic slip-rate row, ``Pv`` ``(C, n, nq)`` the
#: velocity projection onto the stuck constraints; ``MS = M^-1 S^T``, ``G = S M^-1 S^T``;
#: scratch of a fill (``sa, sv, su, sw`` square ``nq``, ``sl`` eigenvalues, ``si`` stuck
#: element indices); ``count`` filled slots
RigidCache = namedtuple("RigidCache", ("keys", "F", "E", "R", "Pv", "red", "MS", "G", "sa", "sv",
                                       "su", "sw", "sl", "si", "count"))

Point = namedtuple("Point", _POINT_INPUTS)

#: a rigid-stick point: :data:`Point`'s inputs and its pattern cache ``rc``.  A distinct type,
#: so that the kernels dispatch on it when they are compiled (``beamsim.kernels.law``) and
#: the other laws' kernels contain none of the rigid stick's code
RigidPoint = namedtuple("RigidPoint", _POINT_INPUTS + ("rc",))

#: every point's inputs stacked (``Cm, damp``: full damping; ``Cs, damp_s``: structural part;
#: ``x0``: initial states; ``divl``: divergence limits)
PointStack = namedtuple("PointStack", _POINT_INPUTS + ("Cs", "damp_s", "x0", "divl"))

#: step ``h``, steps per forcing period ``n_per``, transient and recorded periods, dense output
#: every ``dense_every`` steps (0: none), divergence limit of ``max |q|``
Schedule = namedtuple("Schedule", ("h", "n_per", "n_trans", "n_rec", "dense_every", "div_limit"))

#: the batch's outputs, indexed by the point: Poincare state / tip / energy, dense history,
#: flags (columns ``beamsim.results.FLAG_*``), final states
Outputs = namedtuple("Outputs", ("pc_state", "pc_tip", "pc_energy", "dense", "flags", "final"))

#: the integrated state: coordinates, velocities, Jenkins slips, stick/slip modes
State = namedtuple("State", ("q", "v", "z", "mode"))

#: cumulative energy ledger ``ecum = (W_in, D_friction, D_damping)`` and slip statistics
#: (columns ``beamsim.results.STAT_*``)
Tally = namedtuple("Tally", ("ecum", "stats"))


@njit(cache=True)
def point_at(stk, p, structural):
    """Point ``p`` of a :data:`PointStack`; ``structural``: book only the structural damping
    matrix (RK4, whose interface dashpot sits in the traction) instead of the full one."""
    Cm = stk.Cs[p] if structural else stk.Cm[p]
    damp = stk.damp_s[p] if structural else stk.damp[p]
    return Point(stk.law[p], stk.Aq[p], stk.Av[p], stk.Bt[p], stk.gv[p], stk.S[p], stk.wq[p],
                 stk.kt[p], stk.ct[p], stk.Mm[p], stk.Km[p], Cm, damp, stk.g[p], stk.tip[p],
                 stk.f0[p], stk.om[p], stk.tau_s[p], stk.tau_k[p], stk.fc[p], stk.fs[p],
                 stk.vs[p], stk.kv[p], stk.eps[p], stk.Minv[p], stk.Linv[p])


@njit(cache=True)
def schedule_at(sched, p):
    """Schedule of point ``p`` from one whose ``h, n_per, dense_every, div_limit`` are per point."""
    return Schedule(sched.h[p], sched.n_per[p], sched.n_trans, sched.n_rec,
                    sched.dense_every[p], sched.div_limit[p])

"""Benchmark: our integrators against the strongest peers, at equal accuracy against a
reference shown converged.

Run:  .venv/bin/python benchmarks/simulate.py [--quick]      (make bench: installs numbalsoda)

Two cases (docs/performance.md):

* ``start-up`` -- the paper's three-mode model (n = 20, 12 interface points), stick-slip
  ``mu = 0.3``, ``p = 1e-4``, ``f0 = 3 f_cr``, ``Omega = 1.5``, interface dashpot on (the
  pipeline's model); 2 transient + 4 recorded forcing periods: start-up dominates.
* ``long`` -- the default grid's two-mode model at ``Omega = 1.85``, ``f0_rel = 2`` with
  ``mu_s = mu_k = 0.3`` (the ODE form of the peers holds only equal coefficients), 300
  recorded periods from rest: a stable periodic orbit, so a trajectory error stays an error of
  the integrator, and the event handling of a long run dominates.

Accuracy = max over the Poincare samples (every period end) and the components of the full
``(q, v)`` state of ``|x - x_ref|``, divided by ``max |x_ref|``.

* **Reference**: RK4 with located switches at shrinking step factors; the differences between
  successive halvings are printed (4th order: the finest run's own error is about the last
  difference / 15), the finest run is the reference.
* **Ours**: ``rk4`` at step factors 2.8 .. 0.25 (2.8: at RK4's stability limit), ``expo``
  at a few output grids / check densities (``steps_per_period``, ``event_checks``),
  ``newmark`` for information; each run timed as a whole ``simulate()`` call (model set-up
  included), best of ``repeat``.
* **Peers**: ``numbalsoda`` (compiled DOP853 and LSODA, numba ``cfunc`` right-hand side with
  the sizes fixed at compile time, state scaled so that one absolute tolerance fits every
  component) and SciPy ``solve_ivp`` (numpy right-hand side, analytic Jacobian for the implicit
  methods; start-up case only: it steps in Python, a 300-period run takes minutes per
  tolerance).  Both integrate the continuous-time form of the same Jenkins interface
  (``z' = s'`` while at the limit and loading, traction clipped).  Tolerances ``rtol`` from
  1e-3 down, ``atol = rtol`` on the scaled state; the peers' integration alone is timed.
* For each target accuracy (1e-4: what the classifier needs; 1e-6) the fastest run of each
  family that reaches it; ratios per trajectory, single thread.
* Batch: 8 start-up points with 1 and 2 threads, ours (``expo``, ``rk4``) and numbalsoda
  (DOP853 in a numba ``prange`` loop), each at its loosest setting reaching 1e-4 at the
  benchmark point.

The last line is ``speedup_vs_best_peer_at_1e-4=<x>``: our fastest run reaching 1e-4 against
the faster of numbalsoda and solve_ivp reaching it, per trajectory, single thread, the smaller
of the two cases.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import math
import os
import sys
import time

import numpy as np
import scipy.linalg as sla
from scipy.integrate import solve_ivp

import beamsim  # noqa: F401  (first: pins BLAS threads before numpy loads)
from beamsim.simulate import prepare_point, simulate, simulate_batch

try:
    import numba
    from numba import carray, cfunc, njit, prange
    from numbalsoda import dop853, lsoda, lsoda_sig
except ImportError:          # pragma: no cover - the peer is optional for the package
    lsoda_sig = None

CASES = {
    "start-up": dict(point=dict(n_modes=3, k_t=10.0, law="stick-slip", mu_s=0.3, mu_k=0.3, p=1e-4,
                                f0_rel=3.0, Omega=1.5, interface_damping=0.5),
                     n_trans=2, n_rec=4, ref_factors=(0.25, 0.125, 0.0625), repeat=5, ivp=True),
    "long": dict(point=dict(n_modes=2, mu_s=0.3, mu_k=0.3, f0_rel=2.0, Omega=1.85,
                            interface_damping=0.5),
                 n_trans=0, n_rec=300, ref_factors=(0.5, 0.25), repeat=1, ivp=False),
}
TARGETS = (1e-4, 1e-6)
#: RK4 step factors ``h omega_max``, largest first (the run stops at the first that reaches the
#: finer target): 2.8 is 1 % inside RK4's stability limit on the imaginary axis (``2 sqrt 2``;
#: at 3.0 the start-up case's error was 7.5e-3, docs/performance.md)
RK4_FACTORS = (2.8, 2.0, 1.0, 0.5, 0.25)
EXPO_SETTINGS = ((4, 4), (16, 1), (32, 2), (64, 4))
PEER_RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)
#: SciPy's fastest methods here (RK45 and BDF took 21 s and 34 s at rtol 1e-3 for errors of
#: 1e-2 and 7e-4: docs/performance.md)
IVP_METHODS = ("DOP853", "LSODA", "Radau")
#: a family's tolerance scan stops once its runs have taken this long [s]
SCAN_BUDGET = 20.0


@contextlib.contextmanager
def c_stdout_silenced():
    """Silence the peers' C-level messages ('the problem seems to become stiff')."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            ctypes.CDLL(None).fflush(None)      # the C library's buffer, before fd 1 returns
            os.dup2(saved, 1)
            os.close(saved)


class Equations:
    """The point's equations as a plain ODE ``y' = f(t, y)``, ``y = (q, v, z)``."""

    def __init__(self, pp):
        m = pp.model
        self.n, self.nq = m.n, m.n_quad
        # Cholesky solves, as beamsim.point's first-order matrices (an explicit M^-1 leaves a
        # rounding floor of eps cond(M) in the trajectory: docs/performance.md)
        chol = sla.cho_factor(m.M, lower=True)
        self.Aq = -sla.cho_solve(chol, m.K)
        self.Av = -sla.cho_solve(chol, m.C)
        self.Bt = -sla.cho_solve(chol, m.S.T * m.wq)
        self.gv = sla.cho_solve(chol, m.g)
        self.S = m.S
        self.kt = m.geom.k_t
        if np.any(pp.tau_s != pp.tau_k):
            raise ValueError("the ODE form holds mu_s = mu_k only")
        self.lim = pp.tau_k.copy()
        self.f0, self.om = pp.f0, pp.omega
        self.nfev = 0

    def _state(self, y):
        n = self.n
        q, v, z = y[:n], y[n:2 * n], y[2 * n:]
        sd = self.S @ v
        r = self.kt * (self.S @ q - z)
        slip = (np.abs(r) >= self.lim) & (sd * r > 0)
        return q, v, sd, r, slip, np.abs(r) < self.lim

    def rhs(self, t, y):
        self.nfev += 1
        q, v, sd, r, slip, _ = self._state(y)
        tau = np.clip(r, -self.lim, self.lim)
        F = self.f0 * (math.cos(self.om * t) - 1.0)
        dv = self.Aq @ q + self.Av @ v + self.Bt @ tau + self.gv * F
        return np.concatenate([v, dv, np.where(slip, sd, 0.0)])

    def jac(self, t, y):
        n, nq = self.n, self.nq
        q, v, sd, r, slip, elastic = self._state(y)
        J = np.zeros((2 * n + nq, 2 * n + nq))
        J[:n, n:2 * n] = np.eye(n)
        ke = self.kt * elastic.astype(float)
        J[n:2 * n, :n] = self.Aq + (self.Bt * ke) @ self.S
        J[n:2 * n, n:2 * n] = self.Av
        J[n:2 * n, 2 * n:] = -(self.Bt * ke)
        J[2 * n:, n:2 * n] = self.S * slip[:, None]
        return J

    def data(self, scale):
        """Flat parameter vector of the compiled right-hand side (layout of :func:`numba_rhs`):
        the matrices with the state scaling folded in, so that the right-hand side works on
        ``u = y / scale`` at the cost of the unscaled one."""
        n = self.n
        sq, sv, sz = scale[:n], scale[n:2 * n], scale[2 * n:]
        return np.concatenate([
            [self.kt, self.f0, self.om],
            (self.Aq * sq[None, :] / sv[:, None]).ravel(),
            (self.Av * sv[None, :] / sv[:, None]).ravel(),
            (self.Bt / sv[:, None]).ravel(), self.gv / sv,
            (self.S * sq[None, :]).ravel(), (self.S * sv[None, :]).ravel(),
            self.lim, sz, sv / sq])


def numba_rhs(n, nq):
    """numbalsoda right-hand side for ``n`` coordinates and ``nq`` elements on the scaled state
    ``u = y / scale``: sizes fixed when it is compiled, no allocation, the scaling folded into
    the matrices (:meth:`Equations.data`)."""
    N = 2 * n + nq
    oA, oV = 3, 3 + n * n
    oB = oV + n * n
    og = oB + n * nq
    oSq = og + n
    oSv = oSq + nq * n
    ol = oSv + nq * n
    oz = ol + nq
    orq = oz + nq

    @cfunc(lsoda_sig, error_model="numpy", fastmath={"reassoc", "contract", "nsz", "arcp"})
    def rhs(t, u_, du_, p_):
        u = carray(u_, (N,))
        du = carray(du_, (N,))
        p = carray(p_, (orq + n,))
        kt, f0, om = p[0], p[1], p[2]
        F = f0 * (math.cos(om * t) - 1.0)
        for i in range(n):
            acc = p[og + i] * F
            for k in range(n):
                acc += p[oA + i * n + k] * u[k] + p[oV + i * n + k] * u[n + k]
            du[n + i] = acc
            du[i] = u[n + i] * p[orq + i]
        for j in range(nq):
            s = 0.0
            sd = 0.0
            for k in range(n):
                s += p[oSq + j * n + k] * u[k]
                sd += p[oSv + j * n + k] * u[n + k]
            lim = p[ol + j]
            r = kt * (s - u[2 * n + j] * p[oz + j])
            tau = min(max(r, -lim), lim)
            for i in range(n):
                du[n + i] += p[oB + i * nq + j] * tau
            du[2 * n + j] = (sd if (abs(r) >= lim and sd * r > 0.0) else 0.0) / p[oz + j]

    return rhs


def err_vs(ref, states):
    if states is None or not np.all(np.isfinite(states)):
        return np.inf
    return float(np.abs(states - ref).max() / np.abs(ref).max())


def timed(fn, repeat):
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


class Case:
    def __init__(self, name, spec):
        self.name, self.spec = name, spec
        self.point = spec["point"]
        self.pp = prepare_point(**self.point)
        self.eq = Equations(self.pp)
        T = 2 * math.pi / self.pp.omega
        self.t_eval = (spec["n_trans"] + np.arange(spec["n_rec"] + 1)) * T
        self.kw = dict(n_transient=spec["n_trans"], n_record=spec["n_rec"], **self.point)
        self.rows = []          # (family, setting, seconds, error)

    def reference(self):
        prev, diff = None, np.nan
        for f in self.spec["ref_factors"]:
            x = simulate(step_factor=f, **self.kw).poincare_state
            if prev is not None:
                diff = err_vs(x, prev)
                print(f"  reference RK4 step factor {f:g}: differs from {2 * f:g} by "
                      f"{diff:.1e}", flush=True)
            prev = x
        print(f"  reference = RK4 at step factor {f:g}, own error about {diff / 15:.1e}")
        self.ref = prev
        n = self.pp.model.n
        sc = np.abs(prev).max(0)
        zs = np.abs(prev[:, :n]).max() * np.abs(self.pp.model.S).max()
        sc = np.concatenate([sc, np.full(self.pp.model.n_quad, zs)])
        self.scale = np.maximum(sc, 1e-6 * sc.max())

    def add(self, family, setting, seconds, states):
        e = err_vs(self.ref, states)
        self.rows.append((family, setting, seconds, e))
        print(f"  {family:22s} {setting:28s} {seconds * 1e3:11.1f} ms   error {e:.1e}", flush=True)
        return e

    def ours(self):
        rep = self.spec["repeat"]
        for f in RK4_FACTORS:
            r, t = timed(lambda: simulate(step_factor=f, **self.kw), rep)
            e = self.add("ours rk4", f"step factor {f:g} ({r.steps_per_period}/period)", t,
                         r.poincare_state)
            if e < min(TARGETS):
                break
        for spp, ec in EXPO_SETTINGS:
            r, t = timed(lambda: simulate(method="expo", steps_per_period=spp, event_checks=ec,
                                          **self.kw), rep)
            self.add("ours expo", f"{spp}/period, {ec} checks/step", t, r.poincare_state)
            self.expo_counts = (r.n_checks, r.n_events, r.n_patterns)
        r, t = timed(lambda: simulate(method="newmark", **self.kw), rep)
        self.add("ours newmark", f"{r.steps_per_period}/period", t, r.poincare_state)

    def numbalsoda(self):
        n, nq = self.eq.n, self.eq.nq
        fn = numba_rhs(n, nq)
        self.cfunc_address = fn.address
        data = self.eq.data(self.scale)
        u0 = np.zeros(2 * n + nq)
        n_total = self.spec["n_trans"] + self.spec["n_rec"]
        t_eval = np.concatenate([[0.0], self.t_eval]) if self.spec["n_trans"] else self.t_eval
        rep = self.spec["repeat"]
        self.peer_rtol = {}
        for name, solver in (("numbalsoda DOP853", dop853), ("numbalsoda LSODA", lsoda)):
            with c_stdout_silenced():
                solver(fn.address, u0, t_eval[:2], data=data, rtol=1e-3, atol=1e-3,  # compile
                       mxstep=50_000_000)
            spent = 0.0
            for rtol in PEER_RTOLS:
                def run():
                    return solver(fn.address, u0, t_eval, data=data, rtol=rtol, atol=rtol,
                                  mxstep=50_000_000 * max(1, n_total // 100))
                with c_stdout_silenced():
                    (usol, ok), t = timed(run, rep)
                y = usol[-len(self.t_eval):, :2 * n] * self.scale[:2 * n] if ok else None
                e = self.add(name, f"rtol {rtol:.0e}", t, y)
                if e <= 1e-4 and name not in self.peer_rtol:
                    self.peer_rtol[name] = rtol
                spent += t * rep
                if e < min(TARGETS) or spent > SCAN_BUDGET:
                    break

    def scipy(self, quick):
        rtols = PEER_RTOLS[:5] if quick else PEER_RTOLS
        n = self.eq.n
        for method in IVP_METHODS:
            spent = 0.0
            for rtol in rtols:
                eq = Equations(self.pp)
                kw = dict(method=method, rtol=rtol, atol=rtol * self.scale, t_eval=self.t_eval)
                if method in ("Radau", "BDF", "LSODA"):
                    kw["jac"] = eq.jac
                t0 = time.perf_counter()
                sol = solve_ivp(eq.rhs, (0.0, self.t_eval[-1]), np.zeros(2 * n + eq.nq), **kw)
                t = time.perf_counter() - t0
                e = self.add(f"solve_ivp {method}", f"rtol {rtol:.0e} ({eq.nfev} f-evals)", t,
                             sol.y[:2 * n].T if sol.success else None)
                spent += t
                if e < min(TARGETS) or spent > SCAN_BUDGET:
                    break

    def best(self, prefix, target):
        c = [(t, fam, s, e) for fam, s, t, e in self.rows if fam.startswith(prefix) and e <= target]
        return min(c) if c else None


def batch(case, quick):
    """Throughput of 8 start-up points, 1 and 2 threads."""
    P = 8
    rng = np.random.default_rng(0)
    pts = [dict(f0_rel=float(a), Omega=float(w))
           for a, w in zip(rng.uniform(1.5, 4.0, P), rng.uniform(1.0, 2.0, P))]
    kw = {k: v for k, v in case.kw.items() if k not in ("f0_rel", "Omega")}
    best_rk4 = case.best("ours rk4", 1e-4)
    sf = float(best_rk4[2].split()[2]) if best_rk4 else 0.5
    res = {}
    for label, extra in (("expo", dict(method="expo", steps_per_period=4, event_checks=4)),
                         ("rk4", dict(method="rk4", step_factor=sf))):
        for th in (1, 2):
            simulate_batch(pts[:2], n_threads=th, **dict(kw, n_transient=0, n_record=1), **extra)
            _, wall = timed(lambda: simulate_batch(pts, n_threads=th, **kw, **extra), 2)
            res[(label, th)] = wall
    rtol = case.peer_rtol.get("numbalsoda DOP853", 1e-6)
    eqs = [Equations(prepare_point(**dict(case.point, **p))) for p in pts]
    datas = []
    for e in eqs:
        datas.append(e.data(case.scale))
    D = np.stack(datas)
    T = np.stack([(case.spec["n_trans"] + np.arange(case.spec["n_rec"] + 1)) * 2 * math.pi / e.om
                  for e in eqs])
    addr = case.cfunc_address
    N = 2 * eqs[0].n + eqs[0].nq

    @njit(parallel=True)
    def peer_batch(D, T, rtol):
        out = np.empty((D.shape[0], T.shape[1], N))
        for p in prange(D.shape[0]):
            usol, ok = dop853(addr, np.zeros(N), T[p], data=D[p], rtol=rtol, atol=rtol,
                              mxstep=50_000_000)
            out[p] = usol
        return out

    old = numba.get_num_threads()
    try:
        for th in (1, 2):
            numba.set_num_threads(th)
            with c_stdout_silenced():
                peer_batch(D[:1], T[:1, :2], rtol)
            with c_stdout_silenced():
                _, wall = timed(lambda: peer_batch(D, T, rtol), 2)
            res[("numbalsoda DOP853", th)] = wall
    finally:
        numba.set_num_threads(old)
    print(f"batch of {P} start-up points, ms per trajectory (1 thread / 2 threads, parallel "
          f"efficiency); settings reaching 1e-4 at the benchmark point:")
    for label in ("expo", "rk4", "numbalsoda DOP853"):
        t1, t2 = res[(label, 1)], res[(label, 2)]
        print(f"  {label:18s} {t1 / P * 1e3:9.1f} / {t2 / P * 1e3:9.1f} ms   "
              f"{t1 / (2 * t2) * 100:.0f} %")


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer tolerances, no batch")
    args = ap.parse_args(argv)
    if lsoda_sig is None:
        print("numbalsoda is not installed: `make bench` installs it (needs gfortran)")
        return 2
    t_start = time.perf_counter()
    # compile our kernels once
    for method in ("rk4", "expo", "newmark"):
        simulate(method=method, n_transient=0, n_record=1, **CASES["start-up"]["point"])
    speedups = {}
    cases = {}
    for name, spec in CASES.items():
        case = Case(name, spec)
        cases[name] = case
        m = case.pp.model
        print(f"case {name}: n = {m.n}, {m.n_quad} interface points, {2 * m.n + m.n_quad} ODE "
              f"states, omega_max / omega = {case.pp.omega_max / case.pp.omega:.0f}, "
              f"{spec['n_trans']} + {spec['n_rec']} periods", flush=True)
        case.reference()
        case.ours()
        chk, ev, pat = case.expo_counts
        n_per = spec["n_trans"] + spec["n_rec"]
        print(f"  expo at 64/period: {chk / n_per:.0f} event checks, {ev / n_per:.1f} switches "
              f"per period, {pat} stick patterns decomposed")
        case.numbalsoda()
        if spec["ivp"]:
            case.scipy(args.quick)
        for tgt in TARGETS:
            o = case.best("ours", tgt)
            peers = [b for b in (case.best("numbalsoda", tgt), case.best("solve_ivp", tgt)) if b]
            p = min(peers) if peers else None
            txt = f"  at {tgt:.0e}: "
            txt += f"{o[1]} {o[2]} {o[0] * 1e3:.1f} ms" if o else "ours: none reached it"
            txt += f"; best peer {p[1]} {p[2]} {p[0] * 1e3:.1f} ms" if p else "; no peer reached it"
            if o and p:
                txt += f"; speedup {p[0] / o[0]:.2f}"
                if tgt == 1e-4:
                    speedups[name] = p[0] / o[0]
            print(txt, flush=True)
    if not args.quick:
        batch(cases["start-up"], args.quick)
    print(f"benchmark wall time {time.perf_counter() - t_start:.0f} s")
    for name, s in speedups.items():
        print(f"speedup at 1e-4, case {name}: {s:.2f}")
    x = min(speedups.values()) if speedups else float("nan")
    print(f"speedup_vs_best_peer_at_1e-4={x:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

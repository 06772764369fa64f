"""Benchmark: the RK4 plain step in numba against the same step in C, on this machine.

Run:  .venv/bin/python benchmarks/c_reference.py [--steps N] [--repeat R]     (needs gcc)

The issue asks what our kernels would gain from code generation close to C speed.  This
measures the part of the RK4 integrator that dominates its time (docs/performance.md: the plain
step, 69-78 % of an RK4 run): ``N`` classical RK4 steps of the model's right-hand side with
the stick/slip state frozen (no event location, no return mapping), at the step the pipeline's
Lyapunov runs use (step factor 0.5), for both benchmark cases of ``benchmarks/simulate.py``
(the three-mode start-up model, n = 20 coordinates and 12 Jenkins elements; the default grid's
two-mode model, n = 14 and 8).  Half of the elements slip, half stick, so both branches of the
traction run.

* **numba**: the project's own ``beamsim.kernels.rk4.rk4_incr`` (with ``deriv``), called in a
  loop from an ``njit`` function, exactly as the integrator calls it; sizes known at run time.
* **C, run-time sizes**: the same operations in the same order, compiled by ``gcc -O3
  -march=native`` with the floating-point flags of the project's kernels (reassociation,
  contraction, reciprocals, no signed zeros; ``beamsim.kernels.bundles.LEAF``).
* **C, compile-time sizes**: the same source with ``n`` and ``nq`` as ``#define`` constants, so
  the compiler can unroll and vectorise the small products completely.

Printed per case: ns per step, the ratios to numba, the effective GFLOP/s (the step's
multiply-adds counted as two flops), and the largest difference of the end states between
numba and each C build relative to the largest ``|state|`` (the flags allow reassociation, so
last-digit differences are expected).  Every build runs the same start state; best of
``repeat`` timings.  Results: docs/performance.md ("A C reference").
"""

from __future__ import annotations

import argparse
import ctypes
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from numba import njit

import beamsim  # noqa: F401  (first: pins BLAS threads before numpy loads)
from beamsim.kernels.bundles import State, point_at
from beamsim.kernels.rk4 import new_stages, rk4_incr
from beamsim.point import period_steps, stack_points
from beamsim.simulate import prepare_point

sys.path.insert(0, str(Path(__file__).resolve().parent))
# benchmarks/simulate.py: its cases, its relative error and its best-of timing
from simulate import CASES, err_vs, timed  # noqa: E402

#: RK4 step factor of the Lyapunov runs (config/config.yaml numerics.lyapunov.step_factor)
STEP_FACTOR = 0.5
#: gcc flags: the numba kernels' floating-point flags (LEAF: reassoc, contract, arcp, nsz)
CFLAGS = ["-O3", "-march=native", "-shared", "-fPIC", "-fassociative-math", "-fno-signed-zeros",
          "-fno-trapping-math", "-freciprocal-math", "-ffp-contract=fast"]

C_SOURCE = r"""
#include <math.h>
#ifndef NN
#define DIMS , int n, int nq
#define N_ n
#define NQ_ nq
#else
#define DIMS
#define N_ NN
#define NQ_ NQQ
#endif

/* deriv of beamsim.kernels.rk4 for the stick-slip law (law 0) without structural damping */
static void deriv(double t, const double *q, const double *v, const double *z, const long *mode,
                  const double *Aq, const double *Bt, const double *gv, const double *S,
                  const double *wq, const double *g, double kt, double ct, double f0, double om,
                  double *dq, double *dv, double *dz, double *de, double *tau DIMS)
{
    double F = f0 * (cos(om * t) - 1.0), dD = 0.0, dC = 0.0;
    for (int j = 0; j < NQ_; j++) {
        double s = 0.0, sd = 0.0;
        for (int k = 0; k < N_; k++) { s += S[j * N_ + k] * q[k]; sd += S[j * N_ + k] * v[k]; }
        double tj = kt * (s - z[j]);
        if (mode[j] != 0) { dz[j] = sd; dD += wq[j] * tj * sd; } else { dz[j] = 0.0; }
        if (ct != 0.0) { tau[j] = tj + ct * sd; dC += wq[j] * ct * sd * sd; } else { tau[j] = tj; }
    }
    double pw = 0.0;
    for (int i = 0; i < N_; i++) {
        double acc = gv[i] * F;
        for (int k = 0; k < N_; k++) acc += Aq[i * N_ + k] * q[k];
        for (int j = 0; j < NQ_; j++) acc += Bt[i * NQ_ + j] * tau[j];
        dv[i] = acc; dq[i] = v[i]; pw += g[i] * v[i];
    }
    de[0] = F * pw; de[1] = dD; de[2] = dC;
}

/* n_steps of rk4_incr with the state copied back after each step; q, v, z, en updated */
void run(long n_steps, double t0, double h, double *q, double *v, double *z, const long *mode,
         const double *Aq, const double *Bt, const double *gv, const double *S, const double *wq,
         const double *g, double kt, double ct, double f0, double om, double *en DIMS)
{
    double kq[4][N_], kv[4][N_], kz[4][NQ_], ke[4][3], sq[4][N_], sv[4][N_], sz[4][NQ_], tau[NQ_];
    double hh = 0.5 * h, h6 = h / 6.0, t = t0;
    for (long step = 0; step < n_steps; step++) {
        for (int st = 0; st < 4; st++) {
            double c = st == 0 ? 0.0 : (st == 3 ? h : hh);
            if (st == 0) {
                for (int i = 0; i < N_; i++) { sq[0][i] = q[i]; sv[0][i] = v[i]; }
                for (int j = 0; j < NQ_; j++) sz[0][j] = z[j];
            } else {
                for (int i = 0; i < N_; i++) {
                    sq[st][i] = q[i] + c * kq[st - 1][i]; sv[st][i] = v[i] + c * kv[st - 1][i];
                }
                for (int j = 0; j < NQ_; j++) sz[st][j] = z[j] + c * kz[st - 1][j];
            }
            deriv(t + c, sq[st], sv[st], sz[st], mode, Aq, Bt, gv, S, wq, g, kt, ct, f0, om,
                  kq[st], kv[st], kz[st], ke[st], tau
#ifndef NN
                  , n, nq
#endif
                  );
        }
        for (int i = 0; i < N_; i++) {
            q[i] = q[i] + h6 * (kq[0][i] + 2.0 * kq[1][i] + 2.0 * kq[2][i] + kq[3][i]);
            v[i] = v[i] + h6 * (kv[0][i] + 2.0 * kv[1][i] + 2.0 * kv[2][i] + kv[3][i]);
        }
        for (int j = 0; j < NQ_; j++)
            z[j] = z[j] + h6 * (kz[0][j] + 2.0 * kz[1][j] + 2.0 * kz[2][j] + kz[3][j]);
        for (int r = 0; r < 3; r++)
            en[r] += h6 * (ke[0][r] + 2.0 * ke[1][r] + 2.0 * ke[2][r] + ke[3][r]);
        t += h;
    }
}
"""


@njit
def numba_run(stk, n_steps, t0, h, q, v, z, mode, en):
    """``n_steps`` of the project's ``rk4_incr`` from ``(q, v, z)`` with ``mode`` frozen; the
    state is copied back after every step as the integrator does."""
    pt = point_at(stk, 0, True)
    n = q.shape[0]
    nq = z.shape[0]
    w = new_stages(n, nq)
    x = State(q, v, z, mode)
    t = t0
    for _ in range(n_steps):
        rk4_incr(t, h, x, pt, w, 0.0, w)
        for i in range(n):
            q[i] = w.qn[i]
            v[i] = w.vn[i]
        for j in range(nq):
            z[j] = w.zn[j]
        for r in range(3):
            en[r] += w.en[r]
        t += h


def build(workdir: Path, name: str, defines: list[str]) -> ctypes.CDLL:
    src = workdir / "rk4_step.c"
    src.write_text(C_SOURCE)
    lib = workdir / f"{name}.so"
    subprocess.run(["gcc", *CFLAGS, *defines, str(src), "-o", str(lib), "-lm"], check=True)
    return ctypes.CDLL(str(lib))


def start_state(pp, stk):
    """A state on the forced response's scale: the frictionless static response to the peak
    load, a velocity of that size times omega, half the elements slipping."""
    md = pp.model
    n, nq = md.n, md.n_quad
    rng = np.random.default_rng(0)
    qs = 2.0 * pp.f0 * md.static_unit_frictionless
    q = qs * (1.0 + 0.1 * rng.standard_normal(n))
    v = pp.omega * qs * rng.standard_normal(n)
    z = stk.S[0] @ q * 0.5
    mode = np.zeros(nq, np.int64)
    mode[::2] = 1
    return q, v, z, mode


def case_row(name, spec, n_steps, repeat, workdir):
    pp = prepare_point(**spec["point"])
    stk = stack_points([pp])
    md = pp.model
    n, nq = md.n, md.n_quad
    if stk.law[0] != 0 or stk.damp_s[0]:
        raise ValueError("the C step covers the stick-slip law without structural damping")
    h = 2 * math.pi / pp.omega / period_steps(pp, "rk4", step_factor=STEP_FACTOR)
    q0, v0, z0, mode = start_state(pp, stk)
    flops = 2 * 4 * (2 * nq * n + n * n + n * nq)  # multiply-adds of the products per step

    def numba_call(steps):
        q, v, z, en = q0.copy(), v0.copy(), z0.copy(), np.zeros(3)
        numba_run(stk, steps, 0.0, h, q, v, z, mode, en)
        return np.concatenate([q, v, z])

    numba_call(10)  # compile
    x_numba, t_numba = timed(lambda: numba_call(n_steps), repeat)

    dbl = ctypes.POINTER(ctypes.c_double)
    lng = ctypes.POINTER(ctypes.c_long)
    mats = [np.ascontiguousarray(a[0]) for a in (stk.Aq, stk.Bt, stk.gv, stk.S, stk.wq, stk.g)]
    scal = [float(stk.kt[0]), float(stk.ct[0]), float(stk.f0[0]), float(stk.om[0])]
    rows = [("numba (rk4_incr)", t_numba, 0.0)]
    for label, defines, sizes in (("C, run-time sizes", [], [n, nq]),
                                  ("C, compile-time sizes", [f"-DNN={n}", f"-DNQQ={nq}"], [])):
        lib = build(workdir, f"{name}_{'fixed' if sizes == [] else 'rt'}", defines)

        def c_call(steps, lib=lib, sizes=sizes):
            q, v, z, en = q0.copy(), v0.copy(), z0.copy(), np.zeros(3)
            args = [ctypes.c_long(steps), ctypes.c_double(0.0), ctypes.c_double(h),
                    q.ctypes.data_as(dbl), v.ctypes.data_as(dbl), z.ctypes.data_as(dbl),
                    mode.ctypes.data_as(lng), *[a.ctypes.data_as(dbl) for a in mats],
                    *[ctypes.c_double(s) for s in scal], en.ctypes.data_as(dbl),
                    *[ctypes.c_int(s) for s in sizes]]
            lib.run(*args)
            return np.concatenate([q, v, z])

        x_c, t_c = timed(lambda: c_call(n_steps), repeat)
        rows.append((label, t_c, err_vs(x_numba, x_c)))
    print(f"\n{name}: n = {n}, nq = {nq}, {n_steps} steps at step factor {STEP_FACTOR} "
          f"(h omega_max = {STEP_FACTOR}), {flops} flops per step")
    print(f"{'build':<24} {'ns/step':>9} {'numba / it':>11} {'GFLOP/s':>8} {'end-state diff':>15}")
    for label, t, diff in rows:
        ns = t / n_steps * 1e9
        print(f"{label:<24} {ns:9.0f} {t_numba / t:11.2f} {flops / ns:8.2f} {diff:15.1e}")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, default=200_000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ratios = []
        for name, spec in CASES.items():
            rows = case_row(name, spec, args.steps, args.repeat, Path(tmp))
            ratios.append(rows[0][1] / rows[2][1])
    print(f"\nc_compile_time_sizes_vs_numba={min(ratios):.2f}..{max(ratios):.2f}")


if __name__ == "__main__":
    main()

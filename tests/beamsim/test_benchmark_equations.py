"""The benchmark's peers integrate the same equations as our kernels: its ODE form of the
Jenkins interface (benchmarks/simulate.py ``Equations``), integrated by SciPy at a tight
tolerance, follows our RK4 reference at a small step."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from beamsim.simulate import prepare_point, simulate

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "simulate.py"


def _benchmark_module():
    spec = importlib.util.spec_from_file_location("benchmark_simulate", _PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_peers_equations_are_ours():
    bench = _benchmark_module()
    point = dict(n_modes=1, k_t=3.0, mu_s=0.3, mu_k=0.3, f0_rel=3.0, Omega=1.5,
                 interface_damping=0.5)
    pp = prepare_point(**point)
    eq = bench.Equations(pp)
    T = 2 * math.pi / pp.omega
    t_eval = np.arange(4) * T
    n = eq.n
    ours = simulate(n_transient=0, n_record=3, step_factor=0.125, **point)
    assert ours.slipped
    ref = ours.poincare_state
    size = np.abs(ref).max()
    kw = dict(method="LSODA", jac=eq.jac, rtol=1e-9, atol=1e-9 * size, t_eval=t_eval)
    sol = solve_ivp(eq.rhs, (0.0, t_eval[-1]), np.zeros(2 * n + eq.nq), **kw)
    assert sol.success
    err = np.abs(sol.y[:2 * n].T - ref).max() / size
    # measured 0.9e-6 and 1.8e-6 in two runs: LSODA's error at rtol 1e-9 on the kinks of the
    # Jenkins element (RK4 at step factor 0.125: about 2e-10 in the benchmark's start-up case)
    print(f"\nbenchmark ODE form (LSODA rtol 1e-9) vs RK4 step factor 0.125: {err:.1e}")
    assert err < 1e-5
    # and it is a test: the ODE form without the friction limit (always stuck) is far off
    eq.lim = np.full_like(eq.lim, np.inf)
    stuck = solve_ivp(eq.rhs, (0.0, t_eval[-1]), np.zeros(2 * n + eq.nq), **dict(kw, rtol=1e-6))
    assert np.abs(stuck.y[:2 * n].T - ref).max() / size > 1e-2


def test_the_benchmark_refuses_unequal_friction_coefficients():
    bench = _benchmark_module()
    pp = prepare_point(n_modes=1, mu_s=0.45, mu_k=0.3, f0_rel=2.0, Omega=1.5)
    try:
        bench.Equations(pp)
    except ValueError as e:
        assert "mu_s = mu_k" in str(e)
    else:
        raise AssertionError("Equations accepted mu_s != mu_k")

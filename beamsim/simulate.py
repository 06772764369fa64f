r"""Batched time integration of the two-layer curved beam with interlayer friction: the public
entry.

Python API (see docs/model.md, section "Simulator")::

    from beamsim.simulate import simulate, simulate_batch
    r = simulate(f0_rel=2.0, Omega=1.2, law="stick-slip", mu_s=0.3, p=1e-4, n_modes=3)
    r.poincare_tip          # (n_record + 1, 4): w, u1, u2 at the tip and the load-point displacement
    b = simulate_batch([dict(f0_rel=x, Omega=1.2) for x in (0.5, 1, 2, 4)], n_threads=2)
    b.summary()             # one row per point (pandas DataFrame)

Integrators (:data:`METHODS`; numba kernels in :mod:`beamsim.kernels`, the points of a batch
on a pool of threads, :mod:`beamsim.kernels.thread_pool`; each point's arithmetic is
independent of the others, so results do not depend on the number of threads):

* ``method="rk4"`` -- the reference: classical fixed-step RK4 with every stick/slip switch
  located inside its step (:mod:`beamsim.kernels.rk4`).  Default step
  ``h = step_factor / omega_max`` (``omega_max``: largest natural frequency of the stuck
  system, plus the largest viscous rate of a regularised law), rounded so that a forcing
  period is an integer number of steps.
* ``method="expo"`` -- exact propagation of the piecewise-linear system between located
  switches (:mod:`beamsim.kernels.expo`); stick-slip law only.
* ``method="newmark"`` -- average-acceleration Newmark with an implicit return mapping
  (:mod:`beamsim.kernels.newmark`); stick-slip law only, second order.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np

from beamsim.friction import RIGID_STICK
from beamsim.kernels import expo, newmark, rk4
from beamsim.kernels.bundles import Outputs, Schedule
from beamsim.kernels.thread_pool import run_items
from beamsim.pattern_store import PatternStore, cache_slots, model_keys
from beamsim.point import (
    METHOD_LAWS,
    PreparedPoint,
    check_method_law,
    period_steps,
    prepare_point,
    stack_points,
)
from beamsim.results import (
    ENERGY_COLUMNS,
    INTEGRATORS,
    N_FLAGS,
    TIP_COLUMNS,
    BatchResult,
    SimResult,
    flag_fields,
)
from beamsim.two_layer import check_int, check_positive

__all__ = ["simulate", "simulate_batch", "SimResult", "BatchResult", "prepare_point", "state_params",
           "restart_params", "period_steps", "METHODS", "ENERGY_COLUMNS", "TIP_COLUMNS"]


@dataclass(frozen=True)
class Method:
    """An integrator of the method table: its batch runner ``run(stack, schedule, options,
    outputs, threads)`` and the friction laws it supports (``None``: all)."""

    run: Callable
    laws: tuple | None = None


def _run_rk4(stk, sched, opts, out, threads):
    # the rigid stick's kernel is its own (compiled only when a rigid point is run)
    rigid = stk.law == RIGID_STICK
    for kernel, sel in ((rk4.run_point, ~rigid), (rk4.run_point_rigid, rigid)):
        run_items(kernel, (stk, sched, out), np.flatnonzero(sel), threads)


def _run_expo(stk, sched, opts, out, threads):
    keys = model_keys(stk)
    store = opts["pattern_store"] or PatternStore()
    store.run(expo.run_point, (stk, sched, opts["event_checks"], keys, out), keys, stk,
              opts["pattern_cache"], threads)


def _run_newmark(stk, sched, opts, out, threads):
    run_items(newmark.run_point, (stk, sched, out), range(stk.f0.shape[0]), threads)


#: the method table: name -> :class:`Method`
METHODS = {
    "rk4": Method(_run_rk4),
    "expo": Method(_run_expo, laws=METHOD_LAWS["expo"]),
    "newmark": Method(_run_newmark, laws=METHOD_LAWS["newmark"]),
}
if tuple(METHODS) != INTEGRATORS:
    raise ImportError(f"beamsim.results.INTEGRATORS {INTEGRATORS} must name METHODS {tuple(METHODS)}")

#: the bit keys of stick patterns (expo's decompositions, the rigid stick's constraint
#: matrices) hold at most this many interface points
EXPO_MAX_QUAD = 62


def _check_method(method: str, prepared: list) -> None:
    if method not in METHODS:
        raise ValueError(f"method must be one of {tuple(METHODS)}, got {method!r}")
    for pp in prepared:
        check_method_law(method, pp.friction.law)
        if method == "expo" and pp.model.n_quad > EXPO_MAX_QUAD:
            raise ValueError(f"method='expo' supports n_quad <= {EXPO_MAX_QUAD}")
        if pp.friction.law == "rigid-stick" and pp.model.n_quad > EXPO_MAX_QUAD:
            raise ValueError(f"law='rigid-stick' supports n_quad <= {EXPO_MAX_QUAD}")
    n, nq = prepared[0].model.n, prepared[0].model.n_quad
    for pp in prepared:
        if pp.model.n != n or pp.model.n_quad != nq:
            raise ValueError("all points of a batch must have the same n_modes and n_quad")


def _schedule(prepared: list, method: str, steps_per_period, step_factor: float, dpp: int,
              n_trans: int, n_rec: int, divl: np.ndarray) -> Schedule:
    """Per-point steps (a forcing period is exactly ``n_per`` steps; with dense output a
    multiple of ``dense_per_period``)."""
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
    return Schedule(h, n_per, n_trans, n_rec, dense_every, divl)


def _outputs(P: int, n: int, nq: int, n_rec: int, n_dense: int, dense_full: bool) -> Outputs:
    ncol = 4 + (2 * n if dense_full else 0)
    return Outputs(pc_state=np.full((P, n_rec + 1, 2 * n), np.nan),
                   pc_tip=np.full((P, n_rec + 1, 4), np.nan),
                   pc_energy=np.full((P, n_rec + 1, 5), np.nan),
                   dense=np.full((P, n_dense, ncol), np.nan),
                   flags=np.zeros((P, N_FLAGS)),
                   final=np.full((P, 2 * n + 2 * nq), np.nan))


def _result(i: int, pp: PreparedPoint, method: str, sched: Schedule, out: Outputs,
            dpp: int) -> SimResult:
    T = 2 * math.pi / pp.omega
    dt = de = None
    if dpp > 0:
        dt = np.arange(out.dense.shape[1]) * (T / dpp)
        de = out.dense[i]
    return SimResult(
        params=pp.params, coord_names=pp.model.coord_names, f0=pp.f0, f_cr=pp.f_cr,
        omega=pp.omega, Omega=pp.Omega, lam_f=pp.lam_f, h=float(sched.h[i]),
        steps_per_period=int(sched.n_per[i]), method=method,
        t_poincare=(sched.n_trans + np.arange(sched.n_rec + 1)) * T,
        poincare_state=out.pc_state[i], poincare_tip=out.pc_tip[i], energy=out.pc_energy[i],
        dense_t=dt, dense=de, final_state=out.final[i], **flag_fields(out.flags[i]))


def simulate_batch(points, *, n_transient: int = 50, n_record: int = 50,
                   steps_per_period: int | None = None, step_factor: float = 0.5,
                   method: str = "rk4", dense_per_period: int = 0, dense_full: bool = False,
                   div_limit: float = 1e6, n_threads: int | None = None,
                   event_checks: int = 4, pattern_cache: int = 2048,
                   pattern_store: PatternStore | None = None, **common) -> BatchResult:
    """Simulate many parameter points in one compiled, thread-parallel call.

    points : sequence of dicts (or a pandas DataFrame, one row per point) of point parameters
        (geometry: alpha1, alpha2, beta, n_modes, k_t, n_quad, damping, bc; friction: law,
        mu_s, mu_k, p, p_profile, F_c, F_s, v_s, k_v, eps_v; load: f0 | f0_rel,
        omega | lam_f | Omega; initial state q0, v0, z0, mode0).  ``common`` supplies defaults.
    n_transient, n_record : forcing periods discarded / recorded (Poincare samples at the
        n_record + 1 period boundaries t = (n_transient + k) T).
    method : a name of :data:`METHODS`: "rk4" (reference), "expo" (exact piecewise-linear
        propagation with event location; stick-slip law only) or "newmark" (implicit,
        stick-slip law only).
    steps_per_period : fixed steps per forcing period; default :func:`period_steps`.
    event_checks : expo: checks per step at least before a crossing is located (Illinois with
        a bisection safeguard).
    pattern_cache : expo: number of stick patterns whose eigen-decomposition is cached (capped
        at about 100 MB per thread; the slots are allocated but touched only when used;
        a smaller cache changes the cost, not the result: a decomposition evicted and recomputed
        is the same to the bit).
    pattern_store : expo: a :class:`beamsim.pattern_store.PatternStore` whose per-thread caches
        this call uses and leaves filled for the next call that is handed it (default: caches
        of this call only, shared by its points).  It changes the cost and the counter
        ``n_patterns`` (decompositions computed), not the result.
    dense_per_period : if > 0, also store a dense history with this many samples per period.
    div_limit : a point whose max |q| exceeds ``div_limit * q_ref`` (or whose state becomes
        non-finite) is flagged as diverged and stopped; the others are unaffected.  ``q_ref`` is
        the largest of the frictionless static response to the peak load ``2 f0``, ``|q0|`` and
        ``|v0| / omega`` (the model is linear apart from friction, which only dissipates, so a
        growth by ``div_limit`` means a numerical instability).
    n_threads : threads running the points of this call (:func:`beamsim.kernels.thread_pool.run_items`;
        default: numba's setting, ``numba.get_num_threads()``, which ``NUMBA_NUM_THREADS`` and
        ``numba.set_num_threads`` set).
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
    opts = dict(event_checks=check_int("event_checks", event_checks, 1),
                pattern_cache=check_int("pattern_cache", pattern_cache, 1),
                pattern_store=pattern_store)
    _check_method(method, prepared)
    n, nq = prepared[0].model.n, prepared[0].model.n_quad
    opts["pattern_cache"] = cache_slots(opts["pattern_cache"], n)
    stk = stack_points(prepared, div_limit)
    sched = _schedule(prepared, method, steps_per_period, step_factor, dpp, n_trans, n_rec,
                      stk.divl)
    n_dense = int(((n_trans + n_rec) * dpp) + 1) if dpp > 0 else 1
    out = _outputs(len(prepared), n, nq, n_rec, n_dense, dense_full)
    threads = numba.get_num_threads() if n_threads is None else check_int("n_threads", n_threads, 1)
    t0 = time.perf_counter()
    METHODS[method].run(stk, sched, opts, out, threads)
    wall = time.perf_counter() - t0
    results = [_result(i, pp, method, sched, out, dpp) for i, pp in enumerate(prepared)]
    return BatchResult(points=points, results=results, wall_time=wall)


def state_params(params: dict, state, n: int) -> dict:
    """``params`` started from the full restart state ``state = (q, v, z, mode)`` (the layout of
    ``SimResult.final_state``) of a model with ``n`` generalised coordinates."""
    x = np.asarray(state, dtype=float)
    nq = (x.size - 2 * n) // 2
    return dict(params, q0=x[:n].copy(), v0=x[n:2 * n].copy(), z0=x[2 * n:2 * n + nq].copy(),
                mode0=x[2 * n + nq:].copy())


def restart_params(result: SimResult) -> dict:
    """Parameters that continue ``result`` from its final state (the forcing is periodic and
    every run ends on a period boundary, so restarting at ``t = 0`` is exact)."""
    return state_params(result.params, result.final_state, len(result.coord_names))


def simulate(n_transient: int = 50, n_record: int = 50, steps_per_period: int | None = None,
             step_factor: float = 0.5, method: str = "rk4", dense_per_period: int = 0,
             dense_full: bool = False, div_limit: float = 1e6, event_checks: int = 4,
             pattern_cache: int = 2048, **point) -> SimResult:
    """Simulate one parameter point (keyword parameters as in :func:`simulate_batch`)."""
    b = simulate_batch([point], n_transient=n_transient, n_record=n_record,
                       steps_per_period=steps_per_period, step_factor=step_factor, method=method,
                       dense_per_period=dense_per_period, dense_full=dense_full,
                       div_limit=div_limit, n_threads=1, event_checks=event_checks,
                       pattern_cache=pattern_cache)
    return b.results[0]

r"""Largest Lyapunov exponent of a numba right-hand side: Stefanski and Benettin.

Both estimators integrate with the same fixed-step RK4 kernel
(:mod:`analysis.lyapunov.coupled_rk4`) and measure errors in the same scaled norm.

* :func:`stefanski_lle` -- the synchronisation method of Stefanski & Kapitaniak
  (2000) [SK2000]_, [S2000]_: the *drive* :math:`\dot x = f(t, x)` is coupled
  one-way into an identical *response*

  .. math::  \dot y = f(t, y) + d\,(x - y)

  on every state variable.  The error :math:`e = y - x` obeys, to first order,
  :math:`\dot e = (J(t, x) - d\,I)\,e`, so the transverse exponents are exactly
  :math:`\lambda_i - d` and the smallest synchronising coupling is
  :math:`d_s = \lambda_1` (for :math:`\lambda_1 > 0`).  Baumann & Leine (2016)
  [BL2016]_ prove that for non-smooth systems (measure differential inclusions)
  :math:`\lambda_1` is a lower bound for :math:`d_s`.  No Jacobian, no saltation
  matrices: only trajectories are integrated, which is why the method applies to
  dry friction and impacts.
* :func:`benettin_lle` -- the two-trajectory estimate with periodic
  renormalisation (Benettin et al. 1980) [B1980]_, a cross-check on the same model.
* :func:`sample_trajectory` -- drive states after a transient (e.g. a stroboscopic series
  for :func:`analysis.lyapunov.nolds_rosenstein.nolds_lle`).

Stefanski, step by step:

1. Integrate the drive over ``t_transient``; measure the attractor size :math:`s_i`
   (per-component standard deviation) and a characteristic rate
   :math:`\omega_c = \mathrm{rms}_i(\mathrm{rms}(f_i)/s_i)`.
2. From the state at the end of the transient start ``batch`` responses
   :math:`y_j(0) = x(0) + e_0 s \odot u` (fixed random direction ``u``, RMS scaled size
   ``e0``), each with its own coupling :math:`d_j`, all integrated in one numba loop over
   ``t_measure``.
3. Decide synchronisation per coupling with the windowed, scale-aware rule of
   :mod:`analysis.lyapunov.sync_rule`: the windowed rate :math:`r(d)` of
   :math:`\ln\varepsilon` is the finite-time transverse exponent :math:`\approx\lambda_1 - d`,
   so the threshold is not biased by an arbitrary error tolerance.
4. Bracket :math:`d_s` (:mod:`analysis.lyapunov.sync_search`): ``d = 0`` plus a geometric
   ladder up to :math:`\omega_c` (extended upwards, at most to the RK4 stability limit
   :math:`2.5/\Delta t` of the stiff term :math:`-d e`), then multisection rounds until the
   bracket is narrower than ``max(rtol * d_hi, atol)``.
5. ``value`` is the zero of :math:`r(d)` interpolated inside the bracket,
   :math:`d_s \approx \lambda_1`.  If the pair already synchronises at ``d = 0`` the
   attractor is not chaotic and ``value`` is the measured convergence rate (least-squares
   slope of :math:`\ln\varepsilon` at ``d = 0`` above round-off).

All exponents are in the inverse time unit of the right-hand side
(``rhs(t, x, params)``); e.g. for a model written in the dimensionless time
:math:`\tau = \omega t` the exponent is per unit :math:`\tau`, and
:math:`\lambda_1 T_f = 2\pi\lambda_1` per forcing period.

References
----------
.. [SK2000] A. Stefanski, T. Kapitaniak, "Using chaos synchronization to
   estimate the largest Lyapunov exponent of nonsmooth systems", Discrete
   Dynamics in Nature and Society 4 (2000) 207-215.
.. [S2000] A. Stefanski, "Estimation of the largest Lyapunov exponent in
   systems with impacts", Chaos, Solitons & Fractals 11 (2000) 2443-2451.
.. [BL2016] M. Baumann, R. I. Leine, "Estimation of the maximal Lyapunov
   exponent of nonsmooth systems using chaos synchronization", 4th Joint
   International Conference on Multibody System Dynamics, Montreal, 2016.
.. [B1980] G. Benettin, L. Galgani, A. Giorgilli, J.-M. Strelcyn, "Lyapunov
   characteristic exponents for smooth dynamical systems ...", Meccanica 15
   (1980) 9-20.
"""

from __future__ import annotations

import math
import os
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from analysis.lyapunov import coupled_rk4
from analysis.lyapunov.coupled_rk4 import Grid, Renorm, check_inputs, check_positive_finite
from analysis.lyapunov.result import LLEResult
from analysis.lyapunov.sync_rule import coupling_cap, perturbation, sync_test, zero_tolerance
from analysis.lyapunov.sync_search import sync_search

__all__ = ["benettin_lle", "sample_trajectory", "stefanski_lle"]


@dataclass
class _CoupledBatches:
    """``run_batch(ds)`` of :func:`analysis.lyapunov.sync_search.sync_search` for a generic
    rhs: every coupling's response starts from ``y_start`` at the drive state ``xT``; the batch
    is split over ``n_threads`` threads, each integrating its own copy of the drive (the kernel
    releases the GIL; results do not depend on the split)."""

    rhs: Callable
    params: np.ndarray
    xT: np.ndarray
    y_start: np.ndarray
    inv_scale: np.ndarray
    grid: Grid
    ren: Renorm
    t_s: np.ndarray
    window: float
    free_e0: float | None
    n_threads: int
    n_evals: int = 0

    def _chunk(self, ds_chunk: np.ndarray) -> np.ndarray:
        ys0 = np.repeat(self.y_start[None, :], ds_chunk.size, axis=0)
        return coupled_rk4.run(self.rhs, self.xT, ys0, self.params, ds_chunk, self.inv_scale,
                               self.grid, self.ren)[3]

    def __call__(self, ds: np.ndarray):
        ds = np.ascontiguousarray(ds, dtype=np.float64)
        chunks = [c for c in np.array_split(ds, min(self.n_threads, ds.size)) if c.size]
        if len(chunks) == 1:
            log_err = self._chunk(chunks[0])
        else:
            with ThreadPoolExecutor(max_workers=len(chunks)) as pool:
                log_err = np.vstack(list(pool.map(self._chunk, chunks)))
        self.n_evals += 4 * self.grid.n_steps * (len(chunks) + ds.size)
        return sync_test(log_err, self.t_s, self.window, self.free_e0)


def stefanski_lle(rhs: Callable, x0: Any, params: Any, *, dt: float, t_transient: float,
                  t_measure: float, batch: int = 8, rtol: float = 2e-2,
                  atol: float | None = None, e0: float = 1e-6, window: float = 0.25,
                  n_samples: int = 2000, max_rounds: int = 12, seed: int = 0,
                  n_threads: int | None = None, zero_tol: float | None = None,
                  bounded: bool = True) -> LLEResult:
    r"""Largest Lyapunov exponent by the synchronisation method (Stefanski; steps in the
    module docstring).

    Parameters
    ----------
    rhs
        ``numba.njit`` function ``rhs(t, x, params) -> ndarray`` (may depend on t).
    x0
        Initial drive state (1-D, finite).
    params
        1-D float64 parameter array passed to ``rhs``.
    dt
        Fixed RK4 step (time unit of ``rhs``).
    t_transient
        Drive transient discarded before the test (time unit of ``rhs``); it is
        also the window over which the attractor size is measured.
    t_measure
        Length of each synchronisation test.  The resolution of d_s is about the
        spread of the finite-time exponent over this length.
    batch
        Number of couplings integrated together per round (>= 2).
    rtol, atol
        Stop when ``d_hi - d_lo <= max(rtol * d_hi, atol)``; ``atol`` defaults
        to ``1e-4 * omega_c``.
    e0
        Initial RMS scaled separation (relative to the attractor size).  Small,
        so that the test measures the linearised transverse dynamics.
    window
        Fraction of ``t_measure`` in each of the two averaging windows, in (0, 0.5].
    n_samples
        Number of error samples stored per response over ``t_measure``.
    max_rounds
        Safety cap on the number of batches.
    seed
        Seed of the perturbation direction.
    n_threads
        The batch is split over this many threads.  Default ``min(2, os.cpu_count())``.
        Results do not depend on it.
    zero_tol
        Exponents with ``|value| <= zero_tol`` are reported as zero (neutral direction: limit
        cycle, torus).  Default :func:`analysis.lyapunov.sync_rule.zero_tolerance`
        (``5 / t_measure``).
    bounded
        If True (default) a response whose error leaves the band
        ``[e0 * 1e-4, e0 * 1e4]`` is rescaled (about the drive, along its
        current direction) back to ``e0`` and the factor is carried in the
        recorded log-error, so the test sees the transverse dynamics without
        the round-off floor (a pair that reaches exact coincidence stays there)
        and without saturation at the attractor size.  Neither changes which d
        synchronises in the linear regime, but both bias a finite test: on an
        intermittent attractor a downward excursion of ln|x - y| to round-off
        is a spurious permanent synchronisation, an upward one is clipped at
        the attractor size; both pull d_s below lambda_1.  ``False`` gives the
        literal method (free error), kept for comparison.

    Returns
    -------
    LLEResult
        ``value`` in 1/(time unit of rhs); see the class for the diagnostics.
    """
    t_start = time.perf_counter()
    x0a, pa, dt, t_transient, t_measure = check_inputs(rhs, x0, params, dt, t_transient, t_measure)
    batch, rtol, e0, n_threads = _check_search(batch, rtol, e0, window, n_threads)
    xT, tT, scale, omega_c, n_tr = coupled_rk4.run_transient(rhs, x0a, pa, dt, t_transient)
    atol = 1e-4 * omega_c if atol is None else check_positive_finite("atol", atol)
    zero_tol = zero_tolerance(t_measure) if zero_tol is None else check_positive_finite(
        "zero_tol", zero_tol, allow_zero=True)
    n_meas = int(round(t_measure / dt))
    sample_every = max(1, n_meas // int(n_samples))
    n_meas = (n_meas // sample_every) * sample_every
    t_s = (np.arange(n_meas // sample_every) + 1) * sample_every * dt
    ren = Renorm(1, e0, e0 * 1e-4, e0 * 1e4) if bounded else Renorm(0, e0, 0.0, 0.0)
    runner = _CoupledBatches(rhs, pa, xT, xT + e0 * scale * perturbation(x0a.size, seed), 1.0 / scale,
                             Grid(tT, dt, n_meas, sample_every), ren, t_s, window,
                             None if bounded else e0, n_threads, n_evals=4 * n_tr)
    res = sync_search(runner, t_s=t_s, batch=batch, rtol=rtol, atol=atol, omega_c=omega_c,
                      d_cap=coupling_cap(dt), zero_tol=zero_tol, e0=e0, bounded=bounded,
                      max_rounds=max_rounds)
    res.scale = scale
    res.runtime = time.perf_counter() - t_start
    res.n_rhs_evals = runner.n_evals
    return res


def _check_search(batch, rtol, e0, window, n_threads) -> tuple[int, float, float, int]:
    """Validated ``(batch, rtol, e0, n_threads)`` of :func:`stefanski_lle`."""
    if int(batch) < 2:
        raise ValueError(f"batch must be >= 2, got {batch!r}")
    rtol = check_positive_finite("rtol", rtol)
    e0 = check_positive_finite("e0", e0)
    if not (0.0 < float(window) <= 0.5):
        raise ValueError(f"window must be in (0, 0.5], got {window!r}")
    n_threads = min(2, os.cpu_count() or 1) if n_threads is None else int(n_threads)
    if n_threads < 1:
        raise ValueError(f"n_threads must be >= 1, got {n_threads!r}")
    return int(batch), rtol, e0, n_threads


def benettin_lle(rhs: Callable, x0: Any, params: Any, *, dt: float, t_transient: float,
                 t_measure: float, d0: float = 1e-8, renorm_every: int = 10,
                 n_blocks: int = 10, seed: int = 0) -> LLEResult:
    r"""Largest Lyapunov exponent by two trajectories with renormalisation.

    After the transient a companion trajectory is started at a scaled RMS
    distance ``d0`` from the drive; every ``renorm_every`` steps
    (:math:`\Delta t_r = ` ``renorm_every * dt``) the separation
    :math:`\varepsilon_k` is measured in the same scaled norm as
    :func:`stefanski_lle` and reset to ``d0`` along its current direction.

    .. math:: \lambda_1 \approx \frac{1}{K\,\Delta t_r}\sum_{k=1}^{K}
              \ln\frac{\varepsilon_k}{d_0}

    The norm choice does not change the limit.  The standard error is from
    ``n_blocks`` block means.  For discontinuous right-hand sides the
    finite-difference form (no Jacobian) stays valid as long as the pair is close
    enough that they rarely straddle a switching surface within one step
    (probability ~ d0 / (speed * dt) per crossing).

    Parameters are as in :func:`stefanski_lle`; ``d0`` is relative to the
    attractor size, ``renorm_every`` in steps.

    Returns
    -------
    LLEResult
        ``value`` in 1/(time unit of rhs); ``extras`` holds ``stderr``,
        ``running`` (running estimate at each renormalisation) and
        ``running_time``.
    """
    t_start = time.perf_counter()
    x0a, pa, dt, t_transient, t_measure = check_inputs(rhs, x0, params, dt, t_transient, t_measure)
    d0 = check_positive_finite("d0", d0)
    if int(renorm_every) < 1:
        raise ValueError(f"renorm_every must be an integer >= 1, got {renorm_every!r}")
    renorm_every = int(renorm_every)
    n = x0a.size
    xT, tT, scale, omega_c, n_tr = coupled_rk4.run_transient(rhs, x0a, pa, dt, t_transient)
    n_meas = int(round(t_measure / dt))
    n_meas = (n_meas // renorm_every) * renorm_every
    if n_meas < renorm_every * max(2, n_blocks):
        raise ValueError("t_measure too short for renorm_every and n_blocks")
    y0 = (xT + d0 * scale * perturbation(n, seed))[None, :]
    out = coupled_rk4.run(rhs, xT, y0, pa, np.zeros(1), 1.0 / scale, Grid(tT, dt, n_meas, n_meas),
                          Renorm(renorm_every, d0, 0.0, 0.0))
    growth = out[8][0]
    if not np.all(np.isfinite(growth)):
        bad = int(np.count_nonzero(~np.isfinite(growth)))
        warnings.warn(f"benettin_lle: {bad} renormalisation interval(s) with zero or "
                      f"non-finite separation were skipped", RuntimeWarning, stacklevel=2)
        growth = growth[np.isfinite(growth)]
    dtr = renorm_every * dt
    value = float(growth.mean() / dtr)
    blocks = np.array_split(growth, n_blocks)
    bmeans = np.array([b.mean() / dtr for b in blocks if b.size])
    stderr = float(bmeans.std(ddof=1) / math.sqrt(bmeans.size)) if bmeans.size > 1 else float("nan")
    running = np.cumsum(growth) / (dtr * np.arange(1, growth.size + 1))
    return LLEResult(
        value=value, method="benettin",
        verdict=f"time average of ln(separation growth) over {growth.size} renormalisations "
                f"of {dtr:.4g} time units",
        chaotic=bool(value > 0.0), scale=scale, runtime=time.perf_counter() - t_start,
        n_rhs_evals=4 * (n_tr + 2 * n_meas),
        extras={"stderr": stderr, "running": running,
                "running_time": dtr * np.arange(1, growth.size + 1), "omega_c": omega_c})


def sample_trajectory(rhs: Callable, x0: Any, params: Any, *, dt: float, t_transient: float,
                      n_samples: int, sample_every: int) -> tuple[np.ndarray, np.ndarray]:
    """Drive states every ``sample_every`` RK4 steps after a transient.

    For a forced system of period ``T_f`` choose ``dt = T_f / m`` and
    ``sample_every = m`` to get the stroboscopic (Poincare) series, one point per
    forcing period.

    Returns
    -------
    times : (n_samples,) array
    states : (n_samples, n) array
    """
    x0a, pa, dt, t_transient, _ = check_inputs(rhs, x0, params, dt, t_transient, 20 * float(dt))
    if int(n_samples) < 1 or int(sample_every) < 1:
        raise ValueError("n_samples and sample_every must be integers >= 1")
    n = x0a.size
    xT, tT, _, _, _ = coupled_rk4.run_transient(rhs, x0a, pa, dt, t_transient)
    n_steps = int(n_samples) * int(sample_every)
    out = coupled_rk4.run(rhs, xT, coupled_rk4.no_responses(n), pa, np.empty(0), np.ones(n),
                          Grid(tT, dt, n_steps, int(sample_every)), coupled_rk4.NO_RENORM)
    times = tT + dt * int(sample_every) * (np.arange(int(n_samples)) + 1)
    return times, out[4]

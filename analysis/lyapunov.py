r"""Largest Lyapunov exponent of a numba right-hand side.

Three estimators on the same footing (same fixed-step RK4, same state scaling):

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
  renormalisation (Benettin et al. 1980), a cross-check on the same model.
* :func:`nolds_lle` -- Rosenstein's time-series estimate (``nolds.lyap_r``) on a
  sampled or stroboscopic series.

All exponents are in the inverse time unit of the right-hand side
(``rhs(t, x, params)``); e.g. for a model written in the dimensionless time
:math:`\tau = \omega t` the exponent is per unit :math:`\tau`, and
:math:`\lambda_1 T_f = 2\pi\lambda_1` per forcing period.

The right-hand side contract is ``rhs(t: float, x: float64[:], params:
float64[:]) -> float64[:]`` compiled with ``numba.njit``; the dispatcher is
passed as a first-class argument into the compiled integrator, so it is inlined
and each new rhs costs one compilation (about 1-2 s) of the kernel.

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
.. [R1993] M. T. Rosenstein, J. J. Collins, C. J. De Luca, "A practical method
   for calculating largest Lyapunov exponents from small data sets", Physica D
   65 (1993) 117-134.
"""
from __future__ import annotations

import importlib.util
import math
import os
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from numba import njit
from numba.core.registry import CPUDispatcher

__all__ = [
    "LLEResult",
    "stefanski_lle",
    "sync_search",
    "benettin_lle",
    "nolds_lle",
    "sample_trajectory",
    "attractor_scale",
]

#: RK4's stability limit on the negative real axis is dt*|mu| < 2.785; the
#: coupling term -d e must stay inside it, so candidate couplings are capped at
#: ``_RK4_REAL_LIMIT / dt``.
_RK4_REAL_LIMIT = 2.5
#: relative error (RMS of the scaled difference) treated as round-off: below it
#: log|x - y| no longer measures a convergence rate.
_ROUNDOFF_FLOOR = 1e-11
_TINY = 1e-300


# --------------------------------------------------------------------------
# result
# --------------------------------------------------------------------------
@dataclass
class LLEResult:
    """Largest Lyapunov exponent and how it was obtained.

    Attributes
    ----------
    value
        lambda_1 estimate in 1 / (time unit of the rhs).  ``nan`` when no
        verdict could be reached (see ``verdict``).
    method
        ``"stefanski"``, ``"benettin"`` or ``"nolds-rosenstein"``.
    verdict
        How the value was reached, in words, e.g. ``"chaotic: d_s bracketed"``
        or ``"non-chaotic: synchronised at d = 0 ..."``.
    chaotic
        True when the estimator found lambda_1 > 0 (Stefanski: the pair does
        not synchronise at d = 0; Benettin/nolds: value > 0).
    bracket
        Stefanski only: ``(d_lo, d_hi)``, the largest coupling found *not* to
        synchronise and the smallest found to synchronise (1/time unit).
    sync_error
        Stefanski only: RMS scaled synchronisation error |x - y| (relative to
        the attractor size, see ``scale``) sampled at ``sync_time`` for each
        coupling in ``sync_d`` of the last batch (and the d = 0 run first).
    sync_time, sync_d
        Sample times (from the start of the test window) and couplings of the
        rows of ``sync_error``.
    rounds
        Stefanski only: one dict per batch with the candidate couplings, the
        measured windowed error-change rate ``rate`` (1/time unit, negative =
        synchronising) and the boolean ``synced``.
    scale
        Per-component attractor size (standard deviation over the drive
        transient) used to make errors dimensionless.
    runtime
        Wall time in seconds (including the numba compile on first use of an
        rhs).
    n_rhs_evals
        Number of right-hand side evaluations, a machine-independent cost.
    extras
        Method-specific diagnostics (Benettin: running estimate and standard
        error; nolds: the divergence curve and fit).
    """

    value: float
    method: str
    verdict: str
    chaotic: bool
    bracket: tuple[float, float] | None = None
    sync_error: np.ndarray | None = None
    sync_time: np.ndarray | None = None
    sync_d: np.ndarray | None = None
    rounds: list[dict[str, Any]] = field(default_factory=list)
    scale: np.ndarray | None = None
    runtime: float = 0.0
    n_rhs_evals: int = 0
    extras: dict[str, Any] = field(default_factory=dict)

    def __float__(self) -> float:  # convenience: float(result)
        return float(self.value)


# --------------------------------------------------------------------------
# compiled kernel: one drive, B coupled responses, fixed-step RK4
# --------------------------------------------------------------------------
@njit(cache=False, nogil=True)
def _coupled_rk4(rhs, t0, x0, ys0, params, dt, n_steps, ds, inv_scale,
                 sample_every, renorm_every, renorm_size, band_lo,
                 band_hi):  # pragma: no cover - compiled
    """Integrate a drive x and B responses y_j' = f(t, y_j) + d_j (x - y_j).

    The 1 + B systems are advanced together by one RK4 step of the joint
    (drive, responses) system: response stage j uses the drive's stage j state,
    so the coupled system is integrated consistently to 4th order.

    Errors are measured in the RMS scaled norm
    ``e_j = sqrt(mean(((y_j - x) * inv_scale)**2))`` (dimensionless).

    Renormalisation (only if ``renorm_every > 0``; checked every
    ``renorm_every`` steps):

    * ``band_hi <= band_lo`` (Benettin mode): each response is always reset to
      ``x + (y_j - x) * renorm_size / e_j`` and ``log(e_j / renorm_size)`` is
      stored in ``growth``.
    * ``band_hi > band_lo`` (band mode): a response is reset to size
      ``renorm_size`` only when ``e_j`` leaves ``[band_lo, band_hi]``; the log
      of the factor is accumulated in an offset that is added to the sampled
      ``log_err``, so ``log_err`` is the log of the *unbounded* error that the
      linearised coupled dynamics would have, without round-off floor or
      saturation.  ``growth`` is then empty.

    Returns
    -------
    x, ys, t            final drive, responses and time
    log_err             (B, n_steps // sample_every) log of e_j at samples
    drive               (n_steps // sample_every, n) sampled drive states
    s1, s2, sf2         per-component sums of (x - x0), (x - x0)**2 and f(t, x)**2
    growth              (B, n_steps // renorm_every) log growth per renormalisation
    """
    n = x0.shape[0]
    nb = ys0.shape[0]
    x = x0.copy()
    ys = ys0.copy()
    n_samp = n_steps // sample_every
    log_err = np.empty((nb, n_samp))
    drive = np.empty((n_samp, n))
    s1 = np.zeros(n)
    s2 = np.zeros(n)
    sf2 = np.zeros(n)
    always = band_hi <= band_lo
    if renorm_every > 0 and always:
        n_ren = n_steps // renorm_every
    else:
        n_ren = 0
    growth = np.zeros((nb, n_ren))
    log_off = np.zeros(nb)
    half = 0.5 * dt
    sixth = dt / 6.0
    x2 = np.empty(n)
    x3 = np.empty(n)
    x4 = np.empty(n)
    yy = np.empty(n)
    acc4 = np.empty(n)
    for step in range(n_steps):
        t = t0 + step * dt
        th = t + half
        t1 = t + dt
        # drive stages (kept: the responses' stages are coupled to them)
        k1 = rhs(t, x, params)
        for i in range(n):
            x2[i] = x[i] + half * k1[i]
        k2 = rhs(th, x2, params)
        for i in range(n):
            x3[i] = x[i] + half * k2[i]
        k3 = rhs(th, x3, params)
        for i in range(n):
            x4[i] = x[i] + dt * k3[i]
        k4 = rhs(t1, x4, params)
        for i in range(n):
            dx = x[i] - x0[i]  # shifted by the start state: no cancellation in the variance
            s1[i] += dx
            s2[i] += dx * dx
            sf2[i] += k1[i] * k1[i]
        for j in range(nb):
            d = ds[j]
            # stage 1
            for i in range(n):
                yy[i] = ys[j, i]
            l = rhs(t, yy, params)
            for i in range(n):
                li = l[i] + d * (x[i] - yy[i])
                acc4[i] = li
                yy[i] = ys[j, i] + half * li
            # stage 2
            l = rhs(th, yy, params)
            for i in range(n):
                li = l[i] + d * (x2[i] - yy[i])
                acc4[i] += 2.0 * li
                yy[i] = ys[j, i] + half * li
            # stage 3
            l = rhs(th, yy, params)
            for i in range(n):
                li = l[i] + d * (x3[i] - yy[i])
                acc4[i] += 2.0 * li
                yy[i] = ys[j, i] + dt * li
            # stage 4
            l = rhs(t1, yy, params)
            for i in range(n):
                li = l[i] + d * (x4[i] - yy[i])
                ys[j, i] = ys[j, i] + sixth * (acc4[i] + li)
        for i in range(n):
            x[i] = x[i] + sixth * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
        if (step + 1) % sample_every == 0:
            k = (step + 1) // sample_every - 1
            for i in range(n):
                drive[k, i] = x[i]
            for j in range(nb):
                acc = 0.0
                for i in range(n):
                    e = (ys[j, i] - x[i]) * inv_scale[i]
                    acc += e * e
                log_err[j, k] = 0.5 * math.log(max(acc / n, _TINY)) + log_off[j]
        if renorm_every > 0 and (step + 1) % renorm_every == 0:
            k = (step + 1) // renorm_every - 1
            for j in range(nb):
                acc = 0.0
                for i in range(n):
                    e = (ys[j, i] - x[i]) * inv_scale[i]
                    acc += e * e
                en = math.sqrt(acc / n)
                if always:
                    if en > 0.0 and math.isfinite(en):
                        growth[j, k] = math.log(en / renorm_size)
                        fac = renorm_size / en
                        for i in range(n):
                            ys[j, i] = x[i] + (ys[j, i] - x[i]) * fac
                    else:
                        growth[j, k] = np.nan
                elif (en < band_lo or en > band_hi) and en > 0.0 and math.isfinite(en):
                    log_off[j] += math.log(en / renorm_size)
                    fac = renorm_size / en
                    for i in range(n):
                        ys[j, i] = x[i] + (ys[j, i] - x[i]) * fac
    return x, ys, t0 + n_steps * dt, log_err, drive, s1, s2, sf2, growth


# --------------------------------------------------------------------------
# validation helpers
# --------------------------------------------------------------------------
def _check_positive_finite(name: str, value: Any, *, allow_zero: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        cond = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {cond}, got {value!r}")
    return v


def _check_inputs(rhs: Callable, x0: Any, params: Any, dt: Any, t_transient: Any,
                  t_measure: Any) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    if not isinstance(rhs, CPUDispatcher):
        raise ValueError("rhs must be a numba.njit-compiled function rhs(t, x, params) -> ndarray")
    dt = _check_positive_finite("dt", dt)
    t_transient = _check_positive_finite("t_transient", t_transient, allow_zero=True)
    t_measure = _check_positive_finite("t_measure", t_measure)
    x0a = np.array(x0, dtype=np.float64, copy=True)
    if x0a.ndim != 1 or x0a.size == 0:
        raise ValueError(f"x0 must be a non-empty 1-D array, got shape {x0a.shape}")
    if not np.all(np.isfinite(x0a)):
        raise ValueError("x0 must be finite (found nan or inf)")
    pa = np.array(params, dtype=np.float64, copy=True)
    if pa.ndim == 0:
        pa = pa.reshape(1)
    if pa.ndim != 1:
        raise ValueError(f"params must be a 1-D float array, got shape {pa.shape}")
    if not np.all(np.isfinite(pa)):
        raise ValueError("params must be finite (found nan or inf)")
    if t_measure < 20 * dt:
        raise ValueError(f"t_measure must span at least 20 steps of dt (t_measure={t_measure}, dt={dt})")
    f0 = np.asarray(rhs(0.0, x0a, pa))
    if f0.shape != x0a.shape:
        raise ValueError(f"rhs(t, x0, params) returned shape {f0.shape}, expected {x0a.shape} (x0)")
    if not np.all(np.isfinite(f0)):
        raise ValueError("rhs(0, x0, params) is not finite: check x0 and params")
    return x0a, pa, dt, t_transient, t_measure


def _empty_ys(n: int) -> np.ndarray:
    return np.empty((0, n), dtype=np.float64)


def attractor_scale(s1: np.ndarray, s2: np.ndarray, n_steps: int) -> np.ndarray:
    r"""Per-component size of the attractor from running sums.

    :math:`s_i = \sqrt{\langle x_i^2\rangle - \langle x_i\rangle^2}` over the drive
    transient (same unit as :math:`x_i`; the sums may be of a shifted state,
    the variance does not change).  Components that hardly move are floored
    at 1e-6 of the largest (so an error in them is still measured), and if the
    whole drive is stationary (a fixed point reached exactly) the scale falls
    back to 1 in the state's own units.
    """
    if n_steps <= 0:
        return np.ones_like(s1)
    mean = s1 / n_steps
    var = np.maximum(s2 / n_steps - mean * mean, 0.0)
    s = np.sqrt(var)
    smax = float(np.max(s))
    if not math.isfinite(smax) or smax <= 0.0:
        return np.ones_like(s1)
    return np.maximum(s, 1e-6 * smax)


def _run_transient(rhs, x0, params, dt, t_transient):
    """Integrate the drive over the transient; return state, time, scale, rate."""
    n = x0.size
    n_tr = int(round(t_transient / dt))
    # sample rarely: only the statistics matter here
    res = _coupled_rk4(rhs, 0.0, x0, _empty_ys(n), params, dt, n_tr,
                       np.empty(0), np.ones(n), max(n_tr, 1), 0, 1.0, 0.0, 0.0)
    x, _, t, _, _, s1, s2, sf2, _ = res
    if not np.all(np.isfinite(x)):
        raise FloatingPointError("drive diverged during the transient (non-finite state): "
                                 "reduce dt or check x0/params")
    if n_tr > 0:
        scale = attractor_scale(s1, s2, n_tr)
        # characteristic rate: RMS speed / size, per component, averaged
        rate = float(np.sqrt(np.mean(sf2 / n_tr / scale**2)))
    else:
        scale = np.ones(n)
        rate = float(np.sqrt(np.mean(np.asarray(rhs(0.0, x0, params)) ** 2)))
    if not math.isfinite(rate) or rate <= 0:
        rate = 1.0
    return x, t, scale, rate, n_tr


def _window_rate(log_err: np.ndarray, t_s: np.ndarray, frac: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Change of the window-averaged log error per unit time, for each row.

    rate = (mean log e over last window - mean log e over first window)
           / (distance between window centres)
    """
    ns = t_s.size
    w = max(2, int(round(frac * ns)))
    first = log_err[:, :w].mean(axis=1)
    last = log_err[:, ns - w:].mean(axis=1)
    span = t_s[ns - w:].mean() - t_s[:w].mean()
    return (last - first) / span, first, last


def _exp_clip(log_err: np.ndarray) -> np.ndarray:
    """exp of a log-error array without overflow warnings (clipped to float range)."""
    return np.exp(np.clip(log_err, -745.0, 709.0))


def _perturbation(n: int, seed: int) -> np.ndarray:
    """Fixed unit direction (RMS norm 1) for the initial separation."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    return u / math.sqrt(np.mean(u * u))


# --------------------------------------------------------------------------
# Stefanski
# --------------------------------------------------------------------------
def stefanski_lle(rhs: Callable, x0: Any, params: Any, *, dt: float, t_transient: float,
                  t_measure: float, batch: int = 8, rtol: float = 2e-2,
                  atol: float | None = None, e0: float = 1e-6, window: float = 0.25,
                  n_samples: int = 2000, max_rounds: int = 12, seed: int = 0,
                  n_threads: int | None = None, zero_tol: float | None = None,
                  bounded: bool = True) -> LLEResult:
    r"""Largest Lyapunov exponent by the synchronisation method (Stefanski).

    Method
    ------
    1. Integrate the drive :math:`\dot x = f(t, x)` over ``t_transient``; measure
       the attractor size :math:`s_i` (per-component standard deviation) and a
       characteristic rate :math:`\omega_c = \mathrm{rms}_i(\mathrm{rms}(f_i)/s_i)`.
    2. From the state at the end of the transient start ``batch`` responses
       :math:`y_j(0) = x(0) + e_0 s \odot u` (fixed random direction ``u``, RMS
       scaled size ``e0``), each with its own coupling :math:`d_j`:
       :math:`\dot y_j = f(t, y_j) + d_j (x - y_j)`, all integrated in one numba
       loop over ``t_measure``.
    3. Synchronisation test (scale-aware, over windows): with the dimensionless
       error :math:`\varepsilon_j = \mathrm{rms}_i((y_{j,i}-x_i)/s_i)`, compare the
       mean of :math:`\ln\varepsilon_j` over the last ``window`` fraction of the
       test with its mean over the first ``window`` fraction.  The pair
       synchronises iff the error shrank, i.e. the windowed rate
       :math:`r(d) = \Delta\overline{\ln\varepsilon}/\Delta t < 0` (with
       ``bounded=False`` also the last-window error must be below ``e0``, and
       an error at round-off always counts as synchronised).  Since
       :math:`r(d)` is the finite-time transverse exponent
       :math:`\approx\lambda_1 - d`, the threshold is not biased by an arbitrary
       error tolerance.
    4. Bracket :math:`d_s`: the first batch is ``d = 0`` plus a geometric ladder up
       to :math:`\omega_c` (extended upwards, at most to the RK4 stability limit
       :math:`2.5/\Delta t` of the stiff term :math:`-d e`, if nothing
       synchronises).  Then each further batch places ``batch`` equally spaced
       candidates inside the bracket (multisection: the bracket shrinks by
       ``batch + 1`` per round) until its width is below
       ``max(rtol * d_hi, atol)``.  Every round restarts from the same drive
       state and perturbation, so :math:`r(d)` is a deterministic function of
       ``d`` and the bisection is well defined.
    5. ``value`` is the root of the linear interpolation of :math:`r(d)` between
       the bracket ends (inside the bracket), :math:`d_s \approx \lambda_1`.  If the
       pair already synchronises at ``d = 0`` the attractor is not chaotic and
       ``value`` is the measured convergence rate: the least-squares slope of
       :math:`\ln\varepsilon` vs time over the ``d = 0`` run, using only samples
       above round-off (:math:`\varepsilon > 10^{-11}`).

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
        Number of couplings integrated together per round.
    rtol, atol
        Stop when ``d_hi - d_lo <= max(rtol * d_hi, atol)``; ``atol`` defaults
        to ``1e-4 * omega_c``.
    e0
        Initial RMS scaled separation (relative to the attractor size).  Small,
        so that the test measures the linearised transverse dynamics.
    window
        Fraction of ``t_measure`` in each of the two averaging windows.
    n_samples
        Number of error samples stored per response over ``t_measure``.
    max_rounds
        Safety cap on the number of batches.
    seed
        Seed of the perturbation direction.
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
    zero_tol
        Exponents with ``|value| <= zero_tol`` are reported as zero (neutral
        direction: limit cycle, torus).  Default ``5 / t_measure``: the windowed
        log-error is only resolved to O(1), so rates below a few / t_measure are
        indistinguishable from 0.
    n_threads
        The batch is split over this many threads (each integrates its own copy
        of the drive; the compiled kernel releases the GIL).  Default:
        ``min(2, os.cpu_count())``.  Results do not depend on it.

    Returns
    -------
    LLEResult
        ``value`` in 1/(time unit of rhs); see the class for the diagnostics.
    """
    t_start = time.perf_counter()
    x0a, pa, dt, t_transient, t_measure = _check_inputs(rhs, x0, params, dt, t_transient, t_measure)
    if int(batch) < 2:
        raise ValueError(f"batch must be >= 2, got {batch!r}")
    batch = int(batch)
    rtol = _check_positive_finite("rtol", rtol)
    e0 = _check_positive_finite("e0", e0)
    if not (0.0 < float(window) <= 0.5):
        raise ValueError(f"window must be in (0, 0.5], got {window!r}")
    n = x0a.size
    n_threads = min(2, os.cpu_count() or 1) if n_threads is None else int(n_threads)
    if n_threads < 1:
        raise ValueError(f"n_threads must be >= 1, got {n_threads!r}")

    xT, tT, scale, omega_c, n_tr = _run_transient(rhs, x0a, pa, dt, t_transient)
    inv_scale = 1.0 / scale
    atol = 1e-4 * omega_c if atol is None else _check_positive_finite("atol", atol)
    zero_tol = 5.0 / t_measure if zero_tol is None else _check_positive_finite(
        "zero_tol", zero_tol, allow_zero=True)
    n_meas = int(round(t_measure / dt))
    sample_every = max(1, n_meas // int(n_samples))
    n_meas = (n_meas // sample_every) * sample_every
    t_s = (np.arange(n_meas // sample_every) + 1) * sample_every * dt
    y_start = xT + e0 * scale * _perturbation(n, seed)
    if bounded:
        renorm_every, band_lo, band_hi = 1, e0 * 1e-4, e0 * 1e4
    else:
        renorm_every, band_lo, band_hi = 0, 0.0, 0.0
    d_cap = _RK4_REAL_LIMIT / dt
    n_evals = 4 * n_tr

    def run_chunk(ds_chunk: np.ndarray) -> np.ndarray:
        ys0 = np.repeat(y_start[None, :], ds_chunk.size, axis=0)
        out = _coupled_rk4(rhs, tT, xT, ys0, pa, dt, n_meas, ds_chunk, inv_scale,
                           sample_every, renorm_every, e0, band_lo, band_hi)
        return out[3]

    def run_batch(ds: np.ndarray):
        nonlocal n_evals
        ds = np.ascontiguousarray(ds, dtype=np.float64)
        chunks = [c for c in np.array_split(ds, min(n_threads, ds.size)) if c.size]
        if len(chunks) == 1:
            log_err = run_chunk(chunks[0])
        else:  # the kernel releases the GIL: one drive copy per thread
            with ThreadPoolExecutor(max_workers=len(chunks)) as pool:
                log_err = np.vstack(list(pool.map(run_chunk, chunks)))
        n_evals += 4 * n_meas * (len(chunks) + ds.size)
        log_err = np.where(np.isfinite(log_err), log_err, np.inf)  # diverged -> not synced
        rate, first, last = _window_rate(log_err, t_s, window)
        rate = np.where(np.isfinite(rate), rate, np.inf)
        # synchronised: the windowed error shrank, or it sits at round-off
        # (unbounded mode: both windows at the floor give rate 0).  With a free
        # error (bounded=False) a saturated pair has rate ~ 0 +- noise, so the
        # error must also have ended below its starting size e0.
        synced = rate < 0.0
        if not bounded:
            synced &= last < math.log(e0)
        synced |= last <= math.log(_ROUNDOFF_FLOOR)
        return rate, log_err, synced

    res = sync_search(run_batch, t_s=t_s, batch=batch, rtol=rtol, atol=atol, omega_c=omega_c,
                      d_cap=d_cap, zero_tol=zero_tol, e0=e0, bounded=bounded,
                      max_rounds=max_rounds)
    res.scale = scale
    res.runtime = time.perf_counter() - t_start
    res.n_rhs_evals = n_evals
    return res


def sync_search(run_batch: Callable, *, t_s: np.ndarray, batch: int, rtol: float, atol: float,
                omega_c: float, d_cap: float, zero_tol: float, e0: float, bounded: bool,
                max_rounds: int, zero_first: bool = False,
                ladder_hint: float | None = None) -> LLEResult:
    """Bracket search for the synchronising coupling d_s (steps 4-5 of :func:`stefanski_lle`),
    shared by the generic estimator and the beam's (:mod:`analysis.beam_lyapunov`).

    ``run_batch(ds) -> (rate, log_err, synced)`` integrates one response per coupling in
    ``ds`` from the same drive state and perturbation and returns the windowed error rates,
    the log-error histories (rows, sampled at ``t_s``) and the synchronisation decisions.
    ``zero_first``: test ``d = 0`` alone first (most beam points are not chaotic, and then
    nothing else is needed): if it synchronises, or its windowed rate (the finite-time
    exponent of the free pair) is within ``zero_tol``, the exponent is reported from it; the
    ladder and the bisection run only when ``r(0) > zero_tol``.
    ``ladder_hint``: an estimate of ``lambda_1`` from another method (the beam's Benettin
    copy), used with ``zero_first`` when it is finite and above ``zero_tol``: the ladder is
    then ``hint * 2^(k/2)``, ``k = -2 .. batch - 4`` (half to ``2^((batch-4)/2)`` times the
    hint, steps of ``sqrt 2``) instead of the factor-2 ladder below ``omega_c``, so one
    multisection round usually closes the bracket to ``rtol``.  The hint only places the
    candidates: the decisions are the synchronisation tests, the bracket is extended upwards
    (factor 2) if nothing synchronises, and a ladder that synchronises everywhere brackets
    ``d_s`` in ``[0, lowest]``.  ``scale``,
    ``runtime`` and ``n_rhs_evals`` of the result are left for the caller to fill.
    """
    t_start = time.perf_counter()
    scale = None
    n_evals = 0
    rounds: list[dict[str, Any]] = []
    # ---- round 1: d = 0 and a geometric ladder up to omega_c --------------
    top = min(omega_c, d_cap)
    ladder = top * 2.0 ** np.arange(-(batch - 2), 1, dtype=float)
    if zero_first and ladder_hint is not None and math.isfinite(ladder_hint) and ladder_hint > zero_tol:
        steps = np.arange(batch - 1, dtype=float) / 2 - 1.0  # 0.5 ... 2^((batch-4)/2) x hint
        ladder = np.unique(np.minimum(ladder_hint * 2.0 ** steps, d_cap))
    ds = np.array([0.0]) if zero_first else np.concatenate(([0.0], ladder))
    rate, log_err, synced = run_batch(ds)
    rounds.append({"d": ds.copy(), "rate": rate.copy(), "synced": synced.copy()})
    zero_log_err = log_err[0].copy()
    if zero_first and not synced[0] and rate[0] <= zero_tol:
        # the free pair's finite-time transverse exponent r(0) ~ lambda_1 is within the
        # resolution: d_s <= zero_tol, reported as zero (neutral direction) without bisection
        return LLEResult(
            value=float(rate[0]), method="stefanski",
            verdict=f"zero exponent (neutral direction, e.g. limit cycle or torus): windowed "
                    f"rate at d = 0 {rate[0]:.3g} <= zero_tol = {zero_tol:.3g}, so d_s <= zero_tol",
            chaotic=False, bracket=(0.0, float(zero_tol)), sync_error=_exp_clip(log_err),
            sync_time=t_s, sync_d=ds, rounds=rounds, scale=scale,
            runtime=time.perf_counter() - t_start, n_rhs_evals=n_evals,
            extras={"omega_c": omega_c, "rate_d0": float(rate[0]), "log_sync_error": log_err,
                    "bounded": bounded})
    if zero_first and not synced[0]:
        rate2, log_err2, synced2 = run_batch(ladder)
        rounds.append({"d": ladder.copy(), "rate": rate2.copy(), "synced": synced2.copy()})
        ds = np.concatenate(([0.0], ladder))
        rate = np.concatenate((rate, rate2))
        log_err = np.vstack((log_err, log_err2))
        synced = np.concatenate((synced, synced2))
    last_ds, last_log_err = ds, log_err

    if synced[0]:
        # ---- non-chaotic: measured convergence rate at d = 0 -------------
        if bounded:  # the recorded error is unbounded: no round-off floor
            ok = np.isfinite(zero_log_err) & (zero_log_err > math.log(_TINY) + 1.0)
        else:
            ok = zero_log_err > math.log(_ROUNDOFF_FLOOR)
        if np.count_nonzero(ok) >= 3:
            slope = float(np.polyfit(t_s[ok], zero_log_err[ok], 1)[0])
            how = "least-squares slope of ln|x-y| vs t at d = 0 above round-off"
        else:  # converged to round-off within a few samples: bound from first decay
            k = int(np.argmax(~ok)) + 1
            slope = float((zero_log_err[k - 1] - math.log(e0)) / t_s[k - 1])
            how = "decay to round-off within the first samples (lower bound on |rate|)"
        kind = ("zero exponent (neutral direction, e.g. limit cycle or torus)"
                if abs(slope) <= zero_tol else "non-chaotic")
        return LLEResult(
            value=slope,
            method="stefanski",
            verdict=f"{kind}: pair synchronises at d = 0; value is the measured "
                    f"convergence rate ({how})",
            chaotic=False, bracket=(0.0, 0.0), sync_error=_exp_clip(log_err),
            sync_time=t_s, sync_d=ds, rounds=rounds, scale=scale,
            runtime=time.perf_counter() - t_start, n_rhs_evals=n_evals,
            extras={"omega_c": omega_c, "rate_d0": float(rate[0]), "log_sync_error": log_err,
                    "bounded": bounded})

    # ---- extend upwards until something synchronises ---------------------
    while not synced[-1]:  # until the largest coupling tried synchronises
        if ds[-1] >= d_cap or len(rounds) >= max_rounds:
            return LLEResult(
                value=float("nan"), method="stefanski",
                verdict=f"undetermined: no synchronisation up to d = {ds[-1]:.4g} "
                        f"(RK4 limit 2.5/dt = {d_cap:.4g}); lambda_1 >= {ds[-1]:.4g} or "
                        f"t_measure too short",
                chaotic=True, bracket=(float(ds[-1]), float("inf")), sync_error=_exp_clip(log_err),
                sync_time=t_s, sync_d=ds, rounds=rounds, scale=scale,
                runtime=time.perf_counter() - t_start, n_rhs_evals=n_evals,
                extras={"omega_c": omega_c})
        lo = ds[-1]
        ds = np.minimum(lo * 2.0 ** np.arange(1, batch + 1, dtype=float), d_cap)
        ds = np.unique(ds)
        rate, log_err, synced = run_batch(ds)
        rounds.append({"d": ds.copy(), "rate": rate.copy(), "synced": synced.copy()})
        ds = np.concatenate(([lo], ds))
        synced = np.concatenate(([False], synced))
        last_ds, last_log_err = ds[1:], log_err

    all_d = np.concatenate([r["d"] for r in rounds])
    all_s = np.concatenate([r["synced"] for r in rounds])

    def bracket_from(all_d: np.ndarray, all_s: np.ndarray) -> tuple[float, float, int]:
        order = np.argsort(all_d, kind="stable")
        d_sorted, s_sorted = all_d[order], all_s[order]
        # smallest d above which every tested coupling synchronises
        not_synced = np.nonzero(~s_sorted)[0]
        k_hi = not_synced[-1] + 1 if not_synced.size else 0
        k_hi = min(k_hi, d_sorted.size - 1)  # guard: the top is synced by construction
        d_hi = float(d_sorted[k_hi])
        d_lo = float(d_sorted[k_hi - 1]) if k_hi > 0 else 0.0
        # non-monotone decisions (synced below an unsynced coupling)
        n_viol = int(np.count_nonzero(s_sorted[:k_hi]))
        return d_lo, d_hi, n_viol

    all_r = np.concatenate([r["rate"] for r in rounds])
    d_lo, d_hi, n_viol = bracket_from(all_d, all_s)
    while (d_hi - d_lo) > max(rtol * d_hi, atol) and len(rounds) < max_rounds:
        ds = np.linspace(d_lo, d_hi, batch + 2)[1:-1]
        rate, log_err, synced = run_batch(ds)
        rounds.append({"d": ds.copy(), "rate": rate.copy(), "synced": synced.copy()})
        last_ds, last_log_err = ds, log_err
        all_d = np.concatenate([all_d, ds])
        all_s = np.concatenate([all_s, synced])
        all_r = np.concatenate([all_r, rate])
        d_lo, d_hi, n_viol = bracket_from(all_d, all_s)

    converged = (d_hi - d_lo) <= max(rtol * d_hi, atol)
    # r(d) ~ lambda_1 - d near the threshold: interpolate its zero in the bracket
    r_lo = float(all_r[np.nonzero(all_d == d_lo)[0][-1]]) if np.any(all_d == d_lo) else float("nan")
    r_hi = float(all_r[np.nonzero(all_d == d_hi)[0][-1]])
    if math.isfinite(r_lo) and r_lo >= 0.0 > r_hi:
        d_s = d_lo + (d_hi - d_lo) * r_lo / (r_lo - r_hi)
    else:
        d_s = 0.5 * (d_lo + d_hi)
    if d_s > zero_tol:
        verdict = ("chaotic: pair does not synchronise at d = 0; value = d_s, zero of the "
                   "windowed error rate r(d) interpolated inside the bracket")
    else:
        verdict = (f"zero exponent (neutral direction, e.g. limit cycle or torus): "
                   f"d_s = {d_s:.3g} <= zero_tol = {zero_tol:.3g}")
    if not converged:
        verdict += f" (bracket not converged after {len(rounds)} rounds)"
    if n_viol:
        verdict += f"; {n_viol} non-monotone decision(s) below d_hi (finite-time noise)"
    if len(rounds) == 1:  # bracket settled by the first batch (which holds d = 0)
        rows_d, rows_log = last_ds, last_log_err
    else:
        rows_d = np.concatenate(([0.0], last_ds))
        rows_log = np.vstack([zero_log_err[None, :], last_log_err])
    rows_err = _exp_clip(rows_log)
    return LLEResult(
        value=d_s, method="stefanski", verdict=verdict, chaotic=bool(d_s > zero_tol),
        bracket=(d_lo, d_hi), sync_error=rows_err, sync_time=t_s, sync_d=rows_d,
        rounds=rounds, scale=scale, runtime=time.perf_counter() - t_start,
        n_rhs_evals=n_evals,
        extras={"omega_c": omega_c, "converged": bool(converged), "non_monotone": n_viol,
                "d_s_midpoint": 0.5 * (d_lo + d_hi), "zero_tol": zero_tol,
                "log_sync_error": rows_log, "bounded": bounded})



# --------------------------------------------------------------------------
# Benettin
# --------------------------------------------------------------------------
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
    x0a, pa, dt, t_transient, t_measure = _check_inputs(rhs, x0, params, dt, t_transient, t_measure)
    d0 = _check_positive_finite("d0", d0)
    if int(renorm_every) < 1:
        raise ValueError(f"renorm_every must be an integer >= 1, got {renorm_every!r}")
    renorm_every = int(renorm_every)
    n = x0a.size
    xT, tT, scale, omega_c, n_tr = _run_transient(rhs, x0a, pa, dt, t_transient)
    n_meas = int(round(t_measure / dt))
    n_meas = (n_meas // renorm_every) * renorm_every
    if n_meas < renorm_every * max(2, n_blocks):
        raise ValueError("t_measure too short for renorm_every and n_blocks")
    y0 = (xT + d0 * scale * _perturbation(n, seed))[None, :]
    out = _coupled_rk4(rhs, tT, xT, y0, pa, dt, n_meas, np.zeros(1), 1.0 / scale,
                       n_meas, renorm_every, d0, 0.0, 0.0)
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


# --------------------------------------------------------------------------
# sampled series (for nolds) and nolds wrapper
# --------------------------------------------------------------------------
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
    x0a, pa, dt, t_transient, _ = _check_inputs(rhs, x0, params, dt, t_transient, 20 * float(dt))
    if int(n_samples) < 1 or int(sample_every) < 1:
        raise ValueError("n_samples and sample_every must be integers >= 1")
    n = x0a.size
    xT, tT, _, _, _ = _run_transient(rhs, x0a, pa, dt, t_transient)
    n_steps = int(n_samples) * int(sample_every)
    out = _coupled_rk4(rhs, tT, xT, _empty_ys(n), pa, dt, n_steps, np.empty(0),
                       np.ones(n), int(sample_every), 0, 1.0, 0.0, 0.0)
    times = tT + dt * int(sample_every) * (np.arange(int(n_samples)) + 1)
    return times, out[4]


def _load_lyap_r() -> Callable:
    """Return ``nolds.lyap_r``.

    nolds 0.6.3 fails to import on our Python 3.11 (``TypeError: 'nolds.datasets'
    is not a package``, CSchoel/nolds issue #80: ``importlib.resources.files``
    is called on a module).  ``lyap_r`` itself lives in ``nolds/measures.py``,
    which only needs numpy, so in that case the module is loaded on its own
    without running the package ``__init__``.
    """
    try:
        import nolds  # noqa: PLC0415
        return nolds.lyap_r
    except TypeError:
        spec = importlib.util.find_spec("nolds")
        if spec is None or not spec.submodule_search_locations:
            raise
        path = os.path.join(list(spec.submodule_search_locations)[0], "measures.py")
        mspec = importlib.util.spec_from_file_location("_nolds_measures", path)
        mod = importlib.util.module_from_spec(mspec)
        mspec.loader.exec_module(mod)  # type: ignore[union-attr]
        return mod.lyap_r


def nolds_lle(series: Any, *, sample_dt: float, emb_dim: int = 10, lag: int | None = None,
              min_tsep: int | None = None, trajectory_len: int = 20, fit_offset: int = 0,
              min_neighbors: int = 20) -> LLEResult:
    r"""Rosenstein estimate (``nolds.lyap_r``) on a sampled scalar series.

    ``nolds.lyap_r`` returns the slope of the mean log divergence per *sample*
    (we call it with ``tau=1``); the exponent per time unit is
    :math:`\lambda_1 = \text{slope} / \Delta t_s` with ``sample_dt`` =
    :math:`\Delta t_s` the sampling interval (for a stroboscopic series, the
    forcing period).  ``fit="poly"`` (least squares) is always used: nolds'
    default RANSAC fit needs scikit-learn, which this project does not install.

    Note: nolds' own test (``test_lyap_lorenz``) asserts ``lyap_r`` = 2.4 +- 0.5
    for the Lorenz system; 2.4 is not lambda_1 (0.906 for (10, 28, 8/3)) but a
    dimension-like value (the project brief identifies it as the Kaplan-Yorke
    dimension; from Sprott's spectrum 0.9056, 0, -14.5723 the Kaplan-Yorke
    dimension is 2 + 0.9056/14.5723 = 2.06).  Do not use it as a reference.  Rosenstein's method is sensitive to ``emb_dim``,
    ``lag``, ``min_tsep`` and ``trajectory_len`` (the fit must cover the linear
    part of the divergence curve only); treat it as an order-of-magnitude
    cross-check, not a reference.

    Parameters
    ----------
    series
        1-D finite series (e.g. one state component).
    sample_dt
        Time between samples, in the time unit of the model.
    emb_dim, lag, min_tsep, trajectory_len, fit_offset, min_neighbors
        Passed to ``nolds.lyap_r`` (``lag``/``min_tsep`` in samples).

    Returns
    -------
    LLEResult
        ``extras`` holds ``slope_per_sample``, the divergence curve ``ks``,
        ``div_traj`` and the fitted ``poly``.
    """
    t_start = time.perf_counter()
    sample_dt = _check_positive_finite("sample_dt", sample_dt)
    data = np.asarray(series, dtype=np.float64)
    if data.ndim != 1 or data.size < 10:
        raise ValueError(f"series must be a 1-D array with >= 10 samples, got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise ValueError("series must be finite (found nan or inf)")
    lyap_r = _load_lyap_r()
    slope, (ks, div_traj, poly) = lyap_r(
        data, emb_dim=emb_dim, lag=lag, min_tsep=min_tsep, tau=1,
        min_neighbors=min_neighbors, trajectory_len=trajectory_len, fit="poly",
        debug_data=True, fit_offset=fit_offset)
    value = float(slope) / sample_dt
    return LLEResult(
        value=value, method="nolds-rosenstein",
        verdict=f"Rosenstein slope {float(slope):.4g} per sample / sample_dt {sample_dt:.4g}",
        chaotic=bool(value > 0), runtime=time.perf_counter() - t_start,
        extras={"slope_per_sample": float(slope), "ks": np.asarray(ks),
                "div_traj": np.asarray(div_traj), "poly": np.asarray(poly)})

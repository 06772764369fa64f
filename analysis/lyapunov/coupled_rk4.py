r"""One drive and B coupled responses of a numba right-hand side, fixed-step RK4, one kernel.

The generic estimators (:mod:`analysis.lyapunov.generic`) integrate through :func:`run`:

.. math:: \dot x = f(t, x), \qquad \dot y_j = f(t, y_j) + d_j\,(x - y_j), \quad j = 1..B .

The ``1 + B`` systems advance by one RK4 step of the joint system: response stage ``k`` uses the
drive's stage-``k`` state, so the coupled system is integrated consistently to 4th order.
Errors are measured in the RMS scaled norm ``e_j = sqrt(mean(((y_j - x) * inv_scale)**2))``
(dimensionless).

The right-hand side contract is ``rhs(t: float, x: float64[:], params: float64[:]) ->
float64[:]``, compiled with ``numba.njit``; the dispatcher is a first-class argument of the
kernel, so it is inlined and each new rhs costs one compilation of the kernel.
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Any, Callable

import numpy as np
from numba import njit
from numba.core.registry import CPUDispatcher

from analysis.lyapunov.sync_rule import TINY

__all__ = ["Grid", "Renorm", "attractor_scale", "check_inputs", "check_positive_finite", "run",
           "run_transient"]

#: time grid of a run: start time, step, number of steps, sample every ``sample_every`` steps
Grid = namedtuple("Grid", ("t0", "dt", "n_steps", "sample_every"))

#: renormalisation of the responses, checked every ``every`` steps (0: never).
#: ``band_hi <= band_lo`` (Benettin mode): every response is reset to size ``size`` and the log
#: of the factor stored in ``growth``.  ``band_hi > band_lo`` (band mode): a response is reset
#: to ``size`` only when its error leaves ``[band_lo, band_hi]``; the log of the factor is
#: carried in the sampled ``log_err``, which is then the log of the *unbounded* error of the
#: linearised coupled dynamics (no round-off floor, no saturation).
Renorm = namedtuple("Renorm", ("every", "size", "band_lo", "band_hi"))

#: no renormalisation
NO_RENORM = Renorm(0, 1.0, 0.0, 0.0)


@njit(cache=False, nogil=True)
def _drive_stages(rhs, t, dt, x, params, xs, ks):  # pragma: no cover - compiled
    """The drive's four RK4 stage states ``xs[1..3]`` (``xs[0]`` is not used) and slopes
    ``ks[0..3]`` at time ``t``."""
    n = x.shape[0]
    half = 0.5 * dt
    ks[0] = rhs(t, x, params)
    for i in range(n):
        xs[1, i] = x[i] + half * ks[0, i]
    ks[1] = rhs(t + half, xs[1], params)
    for i in range(n):
        xs[2, i] = x[i] + half * ks[1, i]
    ks[2] = rhs(t + half, xs[2], params)
    for i in range(n):
        xs[3, i] = x[i] + dt * ks[2, i]
    ks[3] = rhs(t + dt, xs[3], params)


@njit(cache=False, nogil=True)
def _response_step(rhs, t, dt, x, xs, y, d, params, yy, acc4):  # pragma: no cover - compiled
    """One RK4 step of ``y' = f(t, y) + d (x - y)`` in place, stage ``k`` coupled to the drive's
    stage-``k`` state (``x``, then ``xs[1..3]``)."""
    n = x.shape[0]
    half = 0.5 * dt
    sixth = dt / 6.0
    th = t + half
    for i in range(n):
        yy[i] = y[i]
    fy = rhs(t, yy, params)
    for i in range(n):
        li = fy[i] + d * (x[i] - yy[i])
        acc4[i] = li
        yy[i] = y[i] + half * li
    fy = rhs(th, yy, params)
    for i in range(n):
        li = fy[i] + d * (xs[1, i] - yy[i])
        acc4[i] += 2.0 * li
        yy[i] = y[i] + half * li
    fy = rhs(th, yy, params)
    for i in range(n):
        li = fy[i] + d * (xs[2, i] - yy[i])
        acc4[i] += 2.0 * li
        yy[i] = y[i] + dt * li
    fy = rhs(t + dt, yy, params)
    for i in range(n):
        li = fy[i] + d * (xs[3, i] - yy[i])
        y[i] = y[i] + sixth * (acc4[i] + li)


@njit(cache=True, nogil=True)
def _scaled_error(y, x, inv_scale):  # pragma: no cover - compiled
    """``sum_i ((y_i - x_i) inv_scale_i)^2``."""
    acc = 0.0
    for i in range(x.shape[0]):
        e = (y[i] - x[i]) * inv_scale[i]
        acc += e * e
    return acc


@njit(cache=True, nogil=True)
def _renormalise(ys, x, inv_scale, ren, k, growth, log_off):  # pragma: no cover - compiled
    """Renormalisation ``k`` of every response (see :data:`Renorm`)."""
    n = x.shape[0]
    always = ren.band_hi <= ren.band_lo
    for j in range(ys.shape[0]):
        en = math.sqrt(_scaled_error(ys[j], x, inv_scale) / n)
        if always:
            if en > 0.0 and math.isfinite(en):
                growth[j, k] = math.log(en / ren.size)
            else:
                growth[j, k] = np.nan
                continue
        elif not ((en < ren.band_lo or en > ren.band_hi) and en > 0.0 and math.isfinite(en)):
            continue
        else:
            log_off[j] += math.log(en / ren.size)
        fac = ren.size / en
        for i in range(n):
            ys[j, i] = x[i] + (ys[j, i] - x[i]) * fac


@njit(cache=False, nogil=True)
def run(rhs, x0, ys0, params, ds, inv_scale, grid, ren):  # pragma: no cover - compiled
    """Integrate the drive ``x`` from ``x0`` and the responses from ``ys0`` (rows, couplings
    ``ds``) over ``grid`` with the renormalisation ``ren``.

    Returns ``(x, ys, t, log_err, drive, s1, s2, sf2, growth)``: final drive, responses and
    time; ``log_err`` ``(B, n_steps // sample_every)`` log of ``e_j`` at the samples (plus the
    carried band factors); ``drive`` the sampled drive states; ``s1, s2, sf2`` per-component
    sums of ``x - x0``, ``(x - x0)^2`` and ``f(t, x)^2`` over the steps; ``growth``
    ``(B, n_steps // every)`` log growth per renormalisation (Benettin mode, else empty).
    """
    n = x0.shape[0]
    nb = ys0.shape[0]
    x = x0.copy()
    ys = ys0.copy()
    n_samp = grid.n_steps // grid.sample_every
    log_err = np.empty((nb, n_samp))
    drive = np.empty((n_samp, n))
    s1 = np.zeros(n)
    s2 = np.zeros(n)
    sf2 = np.zeros(n)
    n_ren = grid.n_steps // ren.every if ren.every > 0 and ren.band_hi <= ren.band_lo else 0
    growth = np.zeros((nb, n_ren))
    log_off = np.zeros(nb)
    sixth = grid.dt / 6.0
    xs = np.empty((4, n))
    ks = np.empty((4, n))
    yy = np.empty(n)
    acc4 = np.empty(n)
    for step in range(grid.n_steps):
        t = grid.t0 + step * grid.dt
        _drive_stages(rhs, t, grid.dt, x, params, xs, ks)
        for i in range(n):
            dx = x[i] - x0[i]  # shifted by the start state: no cancellation in the variance
            s1[i] += dx
            s2[i] += dx * dx
            sf2[i] += ks[0, i] * ks[0, i]
        for j in range(nb):
            _response_step(rhs, t, grid.dt, x, xs, ys[j], ds[j], params, yy, acc4)
        for i in range(n):
            x[i] = x[i] + sixth * (ks[0, i] + 2.0 * ks[1, i] + 2.0 * ks[2, i] + ks[3, i])
        if (step + 1) % grid.sample_every == 0:
            k = (step + 1) // grid.sample_every - 1
            for i in range(n):
                drive[k, i] = x[i]
            for j in range(nb):
                log_err[j, k] = 0.5 * math.log(max(_scaled_error(ys[j], x, inv_scale) / n, TINY)) + log_off[j]
        if ren.every > 0 and (step + 1) % ren.every == 0:
            _renormalise(ys, x, inv_scale, ren, (step + 1) // ren.every - 1, growth, log_off)
    return x, ys, grid.t0 + grid.n_steps * grid.dt, log_err, drive, s1, s2, sf2, growth


# --------------------------------------------------------------------------- input checks
def check_positive_finite(name: str, value: Any, *, allow_zero: bool = False) -> float:
    """``float(value)``, or a ValueError naming ``name`` unless finite and > 0 (>= 0)."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        cond = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {cond}, got {value!r}")
    return v


def check_inputs(rhs: Callable, x0: Any, params: Any, dt: Any, t_transient: Any,
                 t_measure: Any) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """Validated ``(x0, params, dt, t_transient, t_measure)`` of a generic estimate; the rhs
    must be a numba dispatcher returning a finite array of the state's shape at ``x0``."""
    if not isinstance(rhs, CPUDispatcher):
        raise ValueError("rhs must be a numba.njit-compiled function rhs(t, x, params) -> ndarray")
    dt = check_positive_finite("dt", dt)
    t_transient = check_positive_finite("t_transient", t_transient, allow_zero=True)
    t_measure = check_positive_finite("t_measure", t_measure)
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


# --------------------------------------------------------------------------- the transient
def no_responses(n: int) -> np.ndarray:
    """An empty ``(0, n)`` set of responses (drive only)."""
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


def run_transient(rhs, x0, params, dt, t_transient):
    """Integrate the drive over the transient.  Returns ``(x, t, scale, rate, n_steps)``: end
    state and time, the attractor size (:func:`attractor_scale`), the characteristic rate
    ``rms_i(rms(f_i) / s_i)`` (1 if it cannot be measured) and the number of steps."""
    n = x0.size
    n_tr = int(round(t_transient / dt))
    # sample rarely: only the statistics matter here
    res = run(rhs, x0, no_responses(n), params, np.empty(0), np.ones(n),
              Grid(0.0, dt, n_tr, max(n_tr, 1)), NO_RENORM)
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

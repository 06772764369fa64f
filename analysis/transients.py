r"""Slow transients in a Poincare record: convergence towards a periodic orbit, and drift.

:func:`analysis.regimes.is_settled` compares the two halves of a record; a transient slower
than the record passes it, and the classifier then reads the remnant as structure: a slowly
decaying period-5 remnant around a fixed point as "period 5", a converging spiral (a focus of
the stroboscopic map, rotating by ``2 pi / 18`` per period) as "period 18", a slow monotone
drift superposed on an oscillation as "quasi-periodic".  The two tests here look for the
signature of each directly.

**Convergence** (:func:`converging_period`).  For a lag ``m`` the scaled distance
``d_i = max_j |x_{i+m, j} - x_{i, j}| / S_j`` is zero on a period-``m`` orbit and stationary
on a settled torus or chaotic attractor; while a trajectory converges to a period-``m`` orbit
(spiral or not) it decays geometrically.  The record is cut into ``n_parts`` consecutive
parts; the lag is *converging* when the medians of ``ln d_i`` over the parts decrease
strictly from part to part and the first exceeds the last by ``ln(min_decay)``.  Lags whose
first part is already at round-off (``d < 1e-9``) are skipped.  The smallest converging lag
``<= m_max`` is returned.  A settled orbit of period ``m`` has ``d`` at round-off (no trend)
for lag ``m`` and a stationary ``d`` for other lags; a settled torus or chaotic record has
part medians that fluctuate without a monotone fall (the median of many values moves little).

**Drift** (:func:`drifting_component`).  The means of ``n_blocks`` consecutive blocks of a
component follow a line whose slope is significant against their scatter (t-test) and whose
change over the record exceeds ``min_drift S_j``.  A torus whose slowest rotation is longer
than the record looks like that too;
such a record does not show what the attractor is either, so calling it unsettled (and running
longer) is the honest answer.

**Near a shorter period** (:func:`near_shorter_period`).  A remnant that decays too slowly
for either test, around an orbit of period ``d``, can carry a pattern of period ``m`` (a
multiple of ``d``) that the period test resolves while the remnant keeps ``x`` just outside
its tolerance of period ``d``: the record reads period ``m``, but within a small multiple
of the tolerance it is period ``d`` already.  A genuine period-``m`` orbit near a
period-``d`` one (just past a period-multiplying bifurcation) looks the same on one record,
so this is not a transient verdict: the pipeline runs such a record on
(:func:`analysis.pipeline.stages.long_run_due`) and lets the longer run tell them apart.
"""

from __future__ import annotations

import numpy as np

__all__ = ["converging_period", "drifting_component", "near_shorter_period"]

#: a scaled lag distance below this is round-off (the lag is a period already)
ROUNDOFF_DISTANCE = 1e-9


def _strictly_monotone(v: np.ndarray) -> int:
    """+1 / -1 if ``v`` increases / decreases strictly, else 0."""
    d = np.diff(v)
    if np.all(d > 0):
        return 1
    if np.all(d < 0):
        return -1
    return 0


def _part_medians(v: np.ndarray, n_parts: int) -> np.ndarray:
    """Medians of the ``n_parts`` consecutive parts of ``v`` that ``np.array_split`` makes (the
    first ``len(v) mod n_parts`` parts one longer), each part's median as ``np.median`` of it."""
    q, r = divmod(v.shape[0], n_parts)
    long_parts = v[:r * (q + 1)].reshape(r, q + 1)
    short_parts = v[r * (q + 1):].reshape(n_parts - r, q)
    return np.concatenate([np.median(long_parts, axis=1), np.median(short_parts, axis=1)])


def converging_period(x: np.ndarray, scales: np.ndarray, *, m_max: int = 32, n_parts: int = 8,
                      min_decay: float = 1.25, min_reps: int = 8) -> tuple[int, float] | None:
    """Smallest lag ``m <= m_max`` towards whose period the record converges (module docstring)
    and the decay factor of the lag distance from the first part to the last, or ``None``.

    x : ``(N, d)`` samples, one row per period; scales : ``(d,)`` positive component scales.
    n_parts, min_decay : parts of the record and the smallest first-to-last decay factor.
    min_reps : lags with fewer than ``min_reps * n_parts`` distances are not tested.
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    for m in range(1, int(m_max) + 1):
        if n - m < min_reps * n_parts:
            break
        d = np.max(np.abs(x[m:] - x[:-m]) / scales, axis=1)
        med = _part_medians(np.log(np.maximum(d, 1e-300)), n_parts)
        if med[0] < np.log(ROUNDOFF_DISTANCE):
            continue
        if _strictly_monotone(med) < 0 and med[0] - med[-1] > np.log(min_decay):
            return m, float(np.exp(med[0] - med[-1]))
    return None


def drifting_component(x: np.ndarray, scales: np.ndarray, *, n_blocks: int = 16,
                       min_drift: float = 0.05, alpha: float = 0.01) -> tuple[int, float] | None:
    """First component with a significant linear drift, and that drift (least-squares slope
    of the block means times the record length, over the component's scale), or ``None``.

    The record is cut into ``n_blocks`` blocks; a component drifts when ``|D_j| > min_drift``
    and the slope of its block means is significant against their scatter about the line
    (two-sided t-test, level ``alpha / d`` per component, ``n_blocks - 2`` degrees of
    freedom): a chaotic record's block means wander, a torus' or periodic orbit's lie still,
    so a trend stands out there and is discounted where the record is noisy."""
    from scipy.special import stdtrit  # Student's t quantile (what scipy.stats.t.ppf calls),
    # without importing scipy.stats: slow to import, in every classify job

    x = np.asarray(x, dtype=float)
    n, d = x.shape
    nb = int(n_blocks)
    size = n // nb
    if size < 2 or nb < 4:
        return None
    means = x[n - nb * size:].reshape(nb, size, d).mean(axis=1) / scales
    t = (np.arange(nb) + 0.5) * size  # block centres, in samples
    tc = t - t.mean()
    slope = tc @ (means - means.mean(axis=0)) / np.sum(tc ** 2)
    drift = slope * n
    resid = means - means.mean(axis=0) - np.outer(tc, slope)
    se = np.sqrt(np.sum(resid ** 2, axis=0) / (nb - 2) / np.sum(tc ** 2))
    crit = float(stdtrit(nb - 2, 1.0 - alpha / (2.0 * d)))
    for j in range(d):
        if abs(drift[j]) > min_drift and abs(slope[j]) > crit * se[j]:
            return j, float(drift[j])
    return None


def near_shorter_period(x: np.ndarray, period: int, *, factor: float = 2.0, rtol: float = 0.02,
                        scale_floor_rtol: float = 0.1) -> int | None:
    """The shortest divisor ``d < period`` of a period-``period`` reading whose period-test
    residual (:func:`analysis.poincare.detect_period`, scales of
    :func:`analysis.poincare.component_scales` with ``scale_floor_rtol``) is within
    ``factor * rtol``, or ``None`` (also for ``period <= 1``).  ``rtol`` is the period test's
    tolerance (the classifier's ``period_rtol``): the record is then at most ``factor`` times
    the tolerance away from period ``d`` (module docstring, "Near a shorter period")."""
    from analysis.poincare import component_scales, detect_period

    m = int(period)
    if m <= 1:
        return None
    x = np.asarray(x, dtype=float)
    scales = component_scales(x, floor_rtol=scale_floor_rtol)
    # every residual below m (a negative tolerance stops at none; min_repeats the classifier's)
    residuals = detect_period(x, m_max=m - 1, rtol=-1.0, scales=scales, min_repeats=3).residuals
    near = [d for d in range(1, m) if m % d == 0 and residuals[d - 1] <= factor * rtol]
    return near[0] if near else None

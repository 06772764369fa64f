r"""Mean lifetime of a transient from right-censored escape times (exponential model).

A chaotic set that is not an attractor (a chaotic saddle) holds trajectories for a random
time whose distribution has an exponential tail: the fraction still on the set after a time
``t`` falls as ``exp(-kappa t)`` once the trajectories have spread over it (Kantz & Grassberger
1985; Lai & Tel, *Transient Chaos*, 2011, ch. 1-2).  ``kappa`` is the escape rate and
``tau = 1 / kappa`` the mean lifetime.  :func:`exponential_lifetime` estimates them from ``n``
independent trajectories observed each up to its own horizon: ``d`` of them escaped at the
times ``t_i``, the others are right-censored at the time they were last known on the set.

Maximum likelihood: ``kappa_hat = d / S`` with ``S`` the total time observed on the set (the
escape times plus the censoring times).  The 95 % interval is Garwood's (1936) Poisson
interval for ``d`` events in an exposure ``S`` (Cox & Oakes, *Analysis of Survival Data*,
1984, section 3.3): ``kappa`` in ``[chi2_{a/2}(2 d) / (2 S), chi2_{1-a/2}(2 d + 2) / (2 S)]``;
it is conservative (covers at least its level) for a Poisson count in a fixed exposure, and
under the fixed horizons used here its coverage is measured in the tests.  With ``d = 0`` the
point estimate of ``tau`` is infinite and the interval's lower end ``2 S / chi2_{1-a/2}(2)``
(``S / 3.69`` at 95 %) is a lower bound on the mean lifetime.

Units are those of the times given (forcing periods in the pipeline).  With escape times
counted in whole units (the period in which a trajectory last slips, plus one), ``d / S`` is
exactly the maximum-likelihood escape probability per unit (a geometric lifetime, mean ``S /
d``); it equals the continuous rate ``kappa`` to first order in ``kappa`` times the unit.  The
model assumes a memoryless escape, which holds after the trajectories have decorrelated (a few
Lyapunov times after a perturbed start).

Copies of one start are not independent until they have decorrelated: before that they are one
trajectory, and counting each as a trajectory of its own multiplies the exposure and the
escapes by their number, with an interval as narrow as if they were independent.  ``entries``
left-truncates each trajectory at its own entry time (delayed entry: Klein & Moeschberger,
*Survival Analysis*, 2003, ch. 3): only its time after the entry counts, and an escape or
censoring at or before the entry leaves it out.  With a memoryless escape the
maximum-likelihood estimate stays ``d / S``, ``S`` now the time observed after the entries.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["LifetimeEstimate", "exponential_lifetime"]


class LifetimeEstimate(NamedTuple):
    """Result of :func:`exponential_lifetime` (times in the units of the input).

    n : the trajectories that count; escaped : how many of them escaped (``d``); exposure :
    ``S``, the total time observed on the set; rate : ``d / S`` (the escape rate's
    maximum-likelihood estimate); lifetime : ``1 / rate`` (``inf`` when none escaped);
    lifetime_lo, lifetime_hi : the interval of the mean lifetime at ``level`` (``lifetime_hi``
    is ``inf`` when none escaped: then ``lifetime_lo`` is a lower bound).
    """

    n: int
    escaped: int
    exposure: float
    rate: float
    lifetime: float
    lifetime_lo: float
    lifetime_hi: float


def exponential_lifetime(times, escaped, level: float = 0.95, entries=None) -> LifetimeEstimate:
    """The escape rate and mean lifetime of an exponential escape from right-censored times.

    Parameters
    ----------
    times : per trajectory, the escape time if it escaped, else the last time it was known on
        the set (its censoring time); non-negative, finite.
    escaped : per trajectory, whether ``times`` is an escape (``True``) or a censoring.
    level : two-sided confidence level of the interval, in (0, 1).
    entries : per trajectory, the time from which it counts (left truncation; default 0 for
        all; ``inf``: it does not count); a trajectory whose ``times`` is at or before a
        positive entry is left out.

    Returns
    -------
    :class:`LifetimeEstimate` (``n``: the trajectories that count); with no exposure (``S =
    0``: no trajectory counts, or all at their entry) every estimate is ``nan``.
    """
    t = np.asarray(times, dtype=float).ravel()
    e = np.asarray(escaped, dtype=bool).ravel()
    if t.shape != e.shape:
        raise ValueError(f"times and escaped differ in length: {t.size} and {e.size}")
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError("times must be finite and non-negative")
    if not 0.0 < level < 1.0:
        raise ValueError(f"level = {level!r}; allowed: 0 < level < 1")
    if entries is not None:
        start = np.asarray(entries, dtype=float).ravel()
        if start.shape != t.shape or np.any(np.isnan(start)) or np.any(start < 0):
            raise ValueError("entries must be one non-negative time (or inf) per trajectory")
        counts = (t > start) | (start == 0.0)  # entry 0: as without entries
        t, e = t[counts] - start[counts], e[counts]
    from scipy.stats import chi2  # here, not at import: the workflow's plan imports this module

    d, s = int(e.sum()), float(t.sum())
    if s <= 0.0:
        return LifetimeEstimate(t.size, d, s, np.nan, np.nan, np.nan, np.nan)
    a = 1.0 - level
    rate_lo = chi2.ppf(a / 2, 2 * d) / (2 * s) if d > 0 else 0.0
    rate_hi = chi2.ppf(1 - a / 2, 2 * d + 2) / (2 * s)
    rate = d / s
    return LifetimeEstimate(t.size, d, s, rate, 1.0 / rate if d else np.inf, 1.0 / rate_hi,
                            1.0 / rate_lo if d else np.inf)

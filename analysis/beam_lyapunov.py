r"""Largest Lyapunov exponent of the beam from two trajectories (no renormalisation).

Every grid point is integrated twice in the same batch: the reference from rest and a twin
whose initial generalised coordinates are displaced by ``delta0`` times the frictionless static
response to the peak load (``2 f0 K0^-1 g``, the natural scale of the response). Both are
recorded once per forcing period ``T`` from ``t = 0``. The scaled separation

.. math::  d_k = \left\| (x_k - \tilde x_k) / \sigma \right\|_2 ,

(``x = (q, v)`` at ``t = kT``, ``sigma`` the per-component spread of the reference's
post-transient Poincare samples, floored at ``1e-3`` of the largest) grows or decays as
``exp(lambda_1 k T)`` while it is small. ``lambda_1`` is the least-squares slope of
``log d_k`` against ``t_k = k T`` over the periods where ``d_k`` lies between the round-off
floor (``1e-11``) and the saturation level (``1e-2``), after ``k_skip`` periods of alignment
with the most unstable direction. Only trajectories are compared (no Jacobian), so the estimate
is valid for the discontinuous stick-slip dynamics, like the Stefanski method it cross-checks
(:mod:`analysis.lyapunov`).

Limits, stated with the result (``verdict``):

* the separation is measured from ``t = 0``, so on a strongly chaotic point it may saturate
  during the transient; the fit then uses the early growth (transient dynamics, flagged);
* a separation that stays at the round-off floor gives no slope: ``lambda_1 <= 0`` is all that
  can be said, reported as the slope of its decay before reaching the floor (or ``0``);
* a neutral direction (the undamped stuck beam, a torus) gives a slope ``~ 0`` (linear growth
  of the phase error).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: scaled separation regarded as round-off / as saturated
FLOOR = 1e-11
SATURATION = 1e-2


@dataclass(frozen=True)
class TwinLLE:
    value: float  # lambda_1 per unit (dimensionless) time
    per_period: float  # lambda_1 T
    window: tuple[int, int]  # periods used by the fit
    verdict: str


def twin_perturbation(prepared, delta0: float = 1e-11) -> np.ndarray:
    """Initial displacement ``q0`` of the twin: ``delta0`` times the frictionless static
    response to the peak load ``2 f0`` (zero load: ``delta0`` per coordinate)."""
    u = 2.0 * prepared.f0 * np.asarray(prepared.model.static_unit_frictionless, dtype=float)
    if not np.any(u):
        u = np.ones(prepared.model.n)
    return delta0 * u


def separation(ref: np.ndarray, twin: np.ndarray, settled_from: int) -> np.ndarray:
    """``d_k`` for Poincare records of shape (n_periods + 1, n_components)."""
    tail = ref[settled_from:]
    sigma = tail.std(axis=0)
    sigma = np.maximum(sigma, 1e-3 * max(sigma.max(), np.abs(tail).max(), 1e-300))
    return np.sqrt((((ref - twin) / sigma) ** 2).sum(axis=1))


def twin_lle(ref: np.ndarray, twin: np.ndarray, period: float, settled_from: int,
             k_skip: int = 3, min_points: int = 8) -> TwinLLE:
    """``lambda_1`` from the separation of two Poincare records (see the module docstring)."""
    d = separation(ref, twin, settled_from)
    if not np.all(np.isfinite(d)):
        return TwinLLE(np.nan, np.nan, (0, 0), "non-finite separation")
    k = np.arange(d.size)
    sat = np.nonzero(d >= SATURATION)[0]
    k_end = int(sat[0]) if sat.size else d.size
    usable = (k >= k_skip) & (k < k_end) & (d > FLOOR)
    idx = np.nonzero(usable)[0]
    if idx.size >= min_points:
        # contiguous run from the first usable period (a separation that dips to the floor
        # and re-emerges is noise, not growth)
        gaps = np.nonzero(np.diff(idx) > 1)[0]
        run = idx[: gaps[0] + 1] if gaps.size else idx
        if run.size >= min_points:
            slope = np.polyfit(k[run] * period, np.log(d[run]), 1)[0]
            where = "transient" if run[0] < settled_from else "attractor"
            kind = ("saturated at period %d" % k_end) if sat.size else "unsaturated"
            return TwinLLE(float(slope), float(slope * period), (int(run[0]), int(run[-1])),
                           f"fit over periods {run[0]}-{run[-1]} ({where}, {kind})")
    if sat.size and k_end < k_skip + min_points:
        # saturates almost at once: very strong divergence, resolved only coarsely
        kk = np.arange(1, max(k_end, 2))
        slope = np.log(SATURATION / max(d[0], FLOOR)) / (kk[-1] * period)
        return TwinLLE(float(slope), float(slope * period), (0, int(k_end)),
                       "saturated within %d periods: lower bound from the growth to saturation" % k_end)
    return TwinLLE(0.0, 0.0, (0, 0), "separation at the round-off floor: lambda_1 <= 0 (not resolved)")

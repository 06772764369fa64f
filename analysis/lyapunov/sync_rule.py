r"""The synchronisation decision of the Stefanski method and its constants, written once.

Every Stefanski estimate in the project -- the generic one on a numba right-hand side
(:mod:`analysis.lyapunov.generic`) and the beam's (:mod:`analysis.lyapunov.beam`) -- decides
"does the response synchronise with the drive at coupling ``d``?" with :func:`sync_test`:

* the scaled error :math:`\varepsilon(t) = \mathrm{rms}_i((y_i - x_i)/s_i)` is recorded as
  :math:`\ln\varepsilon` at the sample times ``t_s``;
* its windowed rate :math:`r(d) = (\overline{\ln\varepsilon}_{\text{last}} -
  \overline{\ln\varepsilon}_{\text{first}}) / \Delta t` compares the means over the first and
  the last ``window`` fraction of the test (:func:`window_rate`); :math:`r(d)` is the
  finite-time transverse exponent :math:`\approx \lambda_1 - d`;
* the pair synchronises iff :math:`r(d) < 0`, or the last window sits at round-off
  (:data:`LOG_ROUNDOFF`); for a free (not renormalised) error the last window must also be
  below the start size ``e0`` (a saturated pair has :math:`r \approx 0 \pm` noise);
* a diverged record (NaN or :math:`+\infty`) never synchronises; :math:`-\infty` (exact
  coincidence, which the beam's copies can reach) is kept and counts as synchronised.

Constants:

* :data:`RK4_REAL_LIMIT`: RK4's stability interval on the negative real axis is
  :math:`h|\mu| < 2.785`; the coupling term :math:`-d\,e` must stay inside it, so candidate
  couplings are capped at ``RK4_REAL_LIMIT / h`` (:func:`coupling_cap`).
* :data:`ROUNDOFF_FLOOR`: relative error treated as round-off (exact coincidence).
* :data:`ZERO_RESOLUTION`: the windowed log-error is resolved to O(1) over the measuring time
  ``t_m``, so exponents with :math:`|\lambda_1| \le` ``ZERO_RESOLUTION / t_m`` are reported as
  zero (:func:`zero_tolerance`; per forcing period: ``ZERO_RESOLUTION / n_periods``).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["LOG_ROUNDOFF", "RK4_REAL_LIMIT", "ROUNDOFF_FLOOR", "TINY", "ZERO_RESOLUTION",
           "coupling_cap", "exp_clip", "perturbation", "sync_test", "window_rate", "zero_tolerance"]

#: largest ``h d`` of a candidate coupling (RK4 is stable for ``h |mu| < 2.785`` on the real axis)
RK4_REAL_LIMIT = 2.5
#: relative (scaled RMS) error regarded as round-off / exact coincidence
ROUNDOFF_FLOOR = 1e-11
#: its logarithm, the level of ``ln eps`` below which a pair counts as synchronised
LOG_ROUNDOFF = math.log(ROUNDOFF_FLOOR)
#: smallest positive error the kernels take the log of
TINY = 1e-300
#: ``|lambda_1| t_m`` below this is reported as a zero exponent (``t_m``: measuring time)
ZERO_RESOLUTION = 5.0


def zero_tolerance(t_measure: float) -> float:
    """Exponents with ``|lambda_1| <= ZERO_RESOLUTION / t_measure`` are zero (1 / time unit of
    ``t_measure``)."""
    return ZERO_RESOLUTION / t_measure


def coupling_cap(h: float) -> float:
    """Largest coupling ``d`` an RK4 step ``h`` integrates stably: ``RK4_REAL_LIMIT / h``."""
    return RK4_REAL_LIMIT / h


def window_rate(log_err: np.ndarray, t_s: np.ndarray,
                frac: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Change of the window-averaged log error per unit time, for each row of ``log_err``
    (sampled at ``t_s``): ``(rate, first, last)`` with ``first``/``last`` the means of
    ``ln eps`` over the first/last ``frac`` of the samples (at least 2) and
    ``rate = (last - first) / (distance between the window centres)``."""
    ns = t_s.size
    w = max(2, int(round(frac * ns)))
    first = log_err[:, :w].mean(axis=1)
    last = log_err[:, ns - w:].mean(axis=1)
    span = t_s[ns - w:].mean() - t_s[:w].mean()
    return (last - first) / span, first, last


def sync_test(log_err: np.ndarray, t_s: np.ndarray, window: float,
              free_e0: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The synchronisation decision for each row of ``log_err`` (``ln eps`` at ``t_s``).

    ``free_e0``: the start size of a free (never renormalised) error; then a pair must also end
    below it.  ``None`` for a renormalised record, whose ``ln eps`` carries every rescaling
    factor.  Returns ``(rate, log_err, synced)``: the windowed rates (``inf`` where the record
    diverged), the record with NaN and ``+inf`` mapped to ``+inf``, and the decisions.
    """
    log_err = np.where(np.isnan(log_err) | (log_err == np.inf), np.inf, log_err)
    rate, _, last = window_rate(log_err, t_s, window)
    rate = np.where(np.isfinite(rate), rate, np.inf)
    synced = rate < 0.0
    if free_e0 is not None:
        synced &= last < math.log(free_e0)
    synced |= last <= LOG_ROUNDOFF
    return rate, log_err, synced


def exp_clip(log_err: np.ndarray) -> np.ndarray:
    """exp of a log-error array without overflow warnings (clipped to the float range)."""
    return np.exp(np.clip(log_err, -745.0, 709.0))


def perturbation(n: int, seed: int) -> np.ndarray:
    """Fixed pseudo-random unit direction (RMS norm 1, seeded) for the initial separation."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(n)
    return u / math.sqrt(np.mean(u * u))

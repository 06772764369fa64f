r"""Bracket search for the smallest synchronising coupling :math:`d_s \approx \lambda_1`.

Shared by the generic Stefanski estimator (:func:`analysis.lyapunov.generic.stefanski_lle`) and
the beam's (:func:`analysis.lyapunov.beam.beam_lle`); each supplies ``run_batch(ds) -> (rate,
log_err, synced)``, which integrates one response per coupling in ``ds`` from the same drive
state and perturbation and applies :func:`analysis.lyapunov.sync_rule.sync_test`.

Phases (one function each):

1. *First round* (:func:`_first_ladder`): ``d = 0`` and a geometric ladder -- factor 2 below
   ``omega_c``, or, with a ``ladder_hint`` (an estimate of :math:`\lambda_1` from another
   method), ``hint * 2^(k/2)``, ``k = -2 .. batch - 4``.  With ``zero_first`` the ``d = 0`` test
   runs alone first: most beam points are not chaotic and need nothing else.
2. *Not chaotic* (:func:`_converging`, :func:`_neutral_at_zero`): the pair synchronises at
   ``d = 0`` -- the value is the measured convergence rate -- or (``zero_first``) the free
   pair's windowed rate is within ``zero_tol`` -- the value is that rate.
3. *Extend upwards* (:func:`_extend_upwards`): factor 2 until the largest coupling tried
   synchronises (at most to the RK4 limit ``d_cap``).
4. *Multisection* (:func:`_multisection`): ``batch`` equally spaced candidates inside the
   bracket per round until its width is below ``max(rtol d_hi, atol)``.
5. *Value* (:func:`_chaotic_result`): the zero of :math:`r(d) \approx \lambda_1 - d`,
   linearly interpolated between the bracket ends.

Every round restarts from the same drive state and perturbation, so :math:`r(d)` is a
deterministic function of ``d`` and the bisection is well defined.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from analysis.lyapunov.result import LLEResult
from analysis.lyapunov.sync_rule import LOG_ROUNDOFF, RK4_REAL_LIMIT, TINY, exp_clip

__all__ = ["sync_search"]

NEUTRAL = "zero exponent (neutral direction, e.g. limit cycle or torus)"


@dataclass
class _Search:
    """What every phase needs: the batch runner, the search settings and the rounds so far."""

    run_batch: Callable
    t_s: np.ndarray
    omega_c: float
    zero_tol: float
    e0: float
    bounded: bool
    t_start: float
    rounds: list[dict[str, Any]] = field(default_factory=list)

    def run(self, ds: np.ndarray):
        """One round: integrate the couplings ``ds`` and record the decisions."""
        rate, log_err, synced = self.run_batch(ds)
        self.rounds.append({"d": ds.copy(), "rate": rate.copy(), "synced": synced.copy()})
        return rate, log_err, synced

    def result(self, **kw) -> LLEResult:
        return LLEResult(method="stefanski", sync_time=self.t_s, rounds=self.rounds, scale=None,
                         runtime=time.perf_counter() - self.t_start, n_rhs_evals=0, **kw)


def sync_search(run_batch: Callable, *, t_s: np.ndarray, batch: int, rtol: float, atol: float,
                omega_c: float, d_cap: float, zero_tol: float, e0: float, bounded: bool,
                max_rounds: int, zero_first: bool = False,
                ladder_hint: float | None = None) -> LLEResult:
    """Bracket ``d_s`` and return the Stefanski estimate (see the module docstring).

    t_s : sample times of the recorded ``ln eps`` (from the start of a test).
    batch, max_rounds : couplings per round and the cap on rounds.
    rtol, atol : stop when ``d_hi - d_lo <= max(rtol * d_hi, atol)``.
    omega_c, d_cap : top of the default ladder (a characteristic rate) and the largest coupling
        RK4 integrates stably (:func:`analysis.lyapunov.sync_rule.coupling_cap`).
    zero_tol : ``d_s`` or rates within it are a zero exponent.
    e0, bounded : start size of the error; whether the record is renormalised (then it has no
        round-off floor).
    zero_first, ladder_hint : see the module docstring (phase 1); the hint only places the
        candidates, the decisions are the synchronisation tests.

    ``scale``, ``runtime`` and ``n_rhs_evals`` of the result are left for the caller to fill.
    """
    s = _Search(run_batch, t_s, omega_c, zero_tol, e0, bounded, time.perf_counter())
    ladder = _first_ladder(batch, omega_c, d_cap, zero_tol, zero_first, ladder_hint)
    ds = np.array([0.0]) if zero_first else np.concatenate(([0.0], ladder))
    rate, log_err, synced = s.run(ds)
    zero_log_err = log_err[0].copy()
    if zero_first and not synced[0] and rate[0] <= zero_tol:
        return _neutral_at_zero(s, rate, log_err, ds)
    if zero_first and not synced[0]:
        rate2, log_err2, synced2 = s.run(ladder)
        ds = np.concatenate(([0.0], ladder))
        rate = np.concatenate((rate, rate2))
        log_err = np.vstack((log_err, log_err2))
        synced = np.concatenate((synced, synced2))
    if synced[0]:
        return _converging(s, zero_log_err, rate, log_err, ds)
    last = _extend_upwards(s, ds, log_err, synced, batch, d_cap, max_rounds)
    if isinstance(last, LLEResult):
        return last
    return _multisection(s, last, zero_log_err, batch, rtol, atol, max_rounds)


def _first_ladder(batch: int, omega_c: float, d_cap: float, zero_tol: float, zero_first: bool,
                  ladder_hint: float | None) -> np.ndarray:
    """Candidate couplings of the first round besides ``d = 0``."""
    top = min(omega_c, d_cap)
    ladder = top * 2.0 ** np.arange(-(batch - 2), 1, dtype=float)
    if zero_first and ladder_hint is not None and math.isfinite(ladder_hint) and ladder_hint > zero_tol:
        steps = np.arange(batch - 1, dtype=float) / 2 - 1.0  # 0.5 ... 2^((batch-4)/2) x hint
        ladder = np.unique(np.minimum(ladder_hint * 2.0 ** steps, d_cap))
    return ladder


def _neutral_at_zero(s: _Search, rate, log_err, ds) -> LLEResult:
    """The free pair's finite-time transverse exponent ``r(0) ~ lambda_1`` is within the
    resolution: ``d_s <= zero_tol``, reported as zero without bisection."""
    return s.result(
        value=float(rate[0]),
        verdict=f"{NEUTRAL}: windowed rate at d = 0 {rate[0]:.3g} <= zero_tol = "
                f"{s.zero_tol:.3g}, so d_s <= zero_tol",
        chaotic=False, bracket=(0.0, float(s.zero_tol)), sync_error=exp_clip(log_err), sync_d=ds,
        extras={"omega_c": s.omega_c, "rate_d0": float(rate[0]), "log_sync_error": log_err,
                "bounded": s.bounded})


def _converging(s: _Search, zero_log_err, rate, log_err, ds) -> LLEResult:
    """Not chaotic: the pair synchronises at ``d = 0``; the value is its measured convergence
    rate (least-squares slope of ``ln eps`` above round-off, or a bound from the first decay)."""
    if s.bounded:  # the recorded error is unbounded: no round-off floor
        ok = np.isfinite(zero_log_err) & (zero_log_err > math.log(TINY) + 1.0)
    else:
        ok = zero_log_err > LOG_ROUNDOFF
    if np.count_nonzero(ok) >= 3:
        slope = float(np.polyfit(s.t_s[ok], zero_log_err[ok], 1)[0])
        how = "least-squares slope of ln|x-y| vs t at d = 0 above round-off"
    else:  # converged to round-off within a few samples: bound from first decay
        k = int(np.argmax(~ok)) + 1
        slope = float((zero_log_err[k - 1] - math.log(s.e0)) / s.t_s[k - 1])
        how = "decay to round-off within the first samples (lower bound on |rate|)"
    kind = NEUTRAL if abs(slope) <= s.zero_tol else "non-chaotic"
    return s.result(
        value=slope,
        verdict=f"{kind}: pair synchronises at d = 0; value is the measured convergence rate ({how})",
        chaotic=False, bracket=(0.0, 0.0), sync_error=exp_clip(log_err), sync_d=ds,
        extras={"omega_c": s.omega_c, "rate_d0": float(rate[0]), "log_sync_error": log_err,
                "bounded": s.bounded})


def _extend_upwards(s: _Search, ds, log_err, synced, batch: int, d_cap: float, max_rounds: int):
    """Double the couplings until the largest one synchronises.  Returns the last round's
    ``(couplings, log_err)``, or the *undetermined* result when ``d_cap`` or ``max_rounds``
    is reached first."""
    last = (ds, log_err)
    while not synced[-1]:  # until the largest coupling tried synchronises
        if ds[-1] >= d_cap or len(s.rounds) >= max_rounds:
            return s.result(
                value=float("nan"),
                verdict=f"undetermined: no synchronisation up to d = {ds[-1]:.4g} "
                        f"(RK4 limit {RK4_REAL_LIMIT:g}/dt = {d_cap:.4g}); lambda_1 >= {ds[-1]:.4g} or "
                        f"t_measure too short",
                chaotic=True, bracket=(float(ds[-1]), float("inf")), sync_error=exp_clip(log_err),
                sync_d=ds, extras={"omega_c": s.omega_c})
        lo = ds[-1]
        ds = np.unique(np.minimum(lo * 2.0 ** np.arange(1, batch + 1, dtype=float), d_cap))
        _, log_err, synced = s.run(ds)
        last = (ds, log_err)
        ds = np.concatenate(([lo], ds))
        synced = np.concatenate(([False], synced))
    return last


def _bracket(all_d: np.ndarray, all_s: np.ndarray) -> tuple[float, float, int]:
    """``(d_lo, d_hi, n_viol)``: ``d_hi`` the smallest tested coupling above which every tested
    one synchronises, ``d_lo`` the next lower one (0 if none), ``n_viol`` the couplings below
    ``d_hi`` that synchronised (non-monotone decisions: finite-time noise)."""
    order = np.argsort(all_d, kind="stable")
    d_sorted, s_sorted = all_d[order], all_s[order]
    not_synced = np.nonzero(~s_sorted)[0]
    k_hi = not_synced[-1] + 1 if not_synced.size else 0
    k_hi = min(k_hi, d_sorted.size - 1)  # guard: the top is synced by construction
    d_hi = float(d_sorted[k_hi])
    d_lo = float(d_sorted[k_hi - 1]) if k_hi > 0 else 0.0
    return d_lo, d_hi, int(np.count_nonzero(s_sorted[:k_hi]))


def _multisection(s: _Search, last, zero_log_err, batch: int, rtol: float, atol: float,
                  max_rounds: int) -> LLEResult:
    """Shrink the bracket by ``batch + 1`` per round, then interpolate ``d_s``."""
    all_d = np.concatenate([r["d"] for r in s.rounds])
    all_s = np.concatenate([r["synced"] for r in s.rounds])
    all_r = np.concatenate([r["rate"] for r in s.rounds])
    d_lo, d_hi, n_viol = _bracket(all_d, all_s)
    while (d_hi - d_lo) > max(rtol * d_hi, atol) and len(s.rounds) < max_rounds:
        ds = np.linspace(d_lo, d_hi, batch + 2)[1:-1]
        rate, log_err, synced = s.run(ds)
        last = (ds, log_err)
        all_d = np.concatenate([all_d, ds])
        all_s = np.concatenate([all_s, synced])
        all_r = np.concatenate([all_r, rate])
        d_lo, d_hi, n_viol = _bracket(all_d, all_s)
    converged = (d_hi - d_lo) <= max(rtol * d_hi, atol)
    return _chaotic_result(s, (d_lo, d_hi), all_d, all_r, n_viol, converged, last, zero_log_err)


def _chaotic_result(s: _Search, bracket, all_d, all_r, n_viol: int, converged: bool, last,
                    zero_log_err) -> LLEResult:
    """``d_s``: the zero of ``r(d) ~ lambda_1 - d`` interpolated inside the bracket (its
    midpoint where the end rates do not straddle zero)."""
    d_lo, d_hi = bracket
    r_lo = float(all_r[np.nonzero(all_d == d_lo)[0][-1]]) if np.any(all_d == d_lo) else float("nan")
    r_hi = float(all_r[np.nonzero(all_d == d_hi)[0][-1]])
    if math.isfinite(r_lo) and r_lo >= 0.0 > r_hi:
        d_s = d_lo + (d_hi - d_lo) * r_lo / (r_lo - r_hi)
    else:
        d_s = 0.5 * (d_lo + d_hi)
    if d_s > s.zero_tol:
        verdict = ("chaotic: pair does not synchronise at d = 0; value = d_s, zero of the "
                   "windowed error rate r(d) interpolated inside the bracket")
    else:
        verdict = f"{NEUTRAL}: d_s = {d_s:.3g} <= zero_tol = {s.zero_tol:.3g}"
    if not converged:
        verdict += f" (bracket not converged after {len(s.rounds)} rounds)"
    if n_viol:
        verdict += f"; {n_viol} non-monotone decision(s) below d_hi (finite-time noise)"
    last_ds, last_log_err = last
    if len(s.rounds) == 1:  # bracket settled by the first batch (which holds d = 0)
        rows_d, rows_log = last_ds, last_log_err
    else:
        rows_d = np.concatenate(([0.0], last_ds))
        rows_log = np.vstack([zero_log_err[None, :], last_log_err])
    return s.result(
        value=d_s, verdict=verdict, chaotic=bool(d_s > s.zero_tol), bracket=(d_lo, d_hi),
        sync_error=exp_clip(rows_log), sync_d=rows_d,
        extras={"omega_c": s.omega_c, "converged": bool(converged), "non_monotone": n_viol,
                "d_s_midpoint": 0.5 * (d_lo + d_hi), "zero_tol": s.zero_tol,
                "log_sync_error": rows_log, "bounded": s.bounded})

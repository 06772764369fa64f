"""Validation of the largest-Lyapunov-exponent estimators (analysis/lyapunov/).

Tolerances are fixed in advance from the statistics of a finite-time exponent,
not fitted to the outcome:

* Lorenz: 3 % of 0.906 (project brief).  At t_measure = 400 the Benettin block
  standard error is about 1.4 %, so 3 % is ~2 sigma for each estimator.
* Other chaotic systems: 5 %, both against the published value and between
  Stefanski and Benettin.  At the lengths used (Rossler 5000 time units, the
  forced Duffing systems 2400 forcing periods) the Benettin block standard error
  is 2.5-3 % of lambda_1, and quoted values of these small exponents themselves
  differ by a few per cent (Rossler: 0.0714 in Sprott 2003, 0.0729 from a
  ChaosTools.jl run).  Stefanski and
  Benettin average the same drive trajectory over nearly the same interval, so
  their difference is smaller than either one's distance to the true value.
* Limit cycle: |lambda_1| < 0.1 * 0.0714 (a tenth of the smallest chaotic
  exponent in the set), i.e. clearly separated from every chaotic value.
* Stable focus / forced linear oscillator: 2 % of the closed form -zeta*omega.
  The estimate is a least-squares slope of an exactly exponential envelope
  (modulated by the oscillation), so only the fit's ripple bias remains.
* nolds (Rosenstein) on 1500 samples: right sign and within a factor 1.5 of
  lambda_1; it is a cross-check only (its fit range and embedding bias it by
  tens of per cent).
"""
from __future__ import annotations

import math
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from analysis.lyapunov import (
    LLEResult,
    benettin_lle,
    nolds_lle,
    sample_trajectory,
    stefanski_lle,
    sync_search,
)
from analysis.lyapunov.reference_systems import REFERENCE_SYSTEMS, get_system

LORENZ_LAMBDA1 = 0.906  # project brief; Sprott (2003): 0.9056


@lru_cache(maxsize=None)
def _estimates(name: str) -> tuple[LLEResult, LLEResult]:
    """Stefanski and Benettin on one reference system (computed once per session)."""
    s = get_system(name)
    kw = dict(dt=s.dt, t_transient=s.t_transient, t_measure=s.t_measure)
    return (stefanski_lle(s.rhs, s.x0, s.params, **kw),
            benettin_lle(s.rhs, s.x0, s.params, **kw))


def _rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b)


# --------------------------------------------------------------------------
# Lorenz
# --------------------------------------------------------------------------
def test_lorenz_stefanski_within_3_percent():
    st, _ = _estimates("lorenz")
    assert st.method == "stefanski"
    assert st.chaotic
    assert _rel(st.value, LORENZ_LAMBDA1) < 0.03, st.value
    d_lo, d_hi = st.bracket
    assert d_lo <= st.value <= d_hi
    # d_lo does not synchronise, d_hi does: check the recorded decisions
    all_d = np.concatenate([r["d"] for r in st.rounds])
    all_s = np.concatenate([r["synced"] for r in st.rounds])
    assert not all_s[np.nonzero(all_d == d_lo)[0][-1]]
    assert all_s[np.nonzero(all_d == d_hi)[0][-1]]
    assert (d_hi - d_lo) <= 0.02 * d_hi + 1e-12


def test_lorenz_benettin_within_3_percent():
    _, be = _estimates("lorenz")
    assert be.method == "benettin"
    assert _rel(be.value, LORENZ_LAMBDA1) < 0.03, be.value


def test_lorenz_stefanski_diagnostics():
    st, _ = _estimates("lorenz")
    assert st.sync_error.shape == (st.sync_d.size, st.sync_time.size)
    assert st.sync_d[0] == 0.0
    # the d = 0 row does not synchronise: its error ends far above e0 = 1e-6
    assert st.sync_error[0, -50:].mean() > 1e-3
    # the largest coupling of the last batch synchronises: error ends below e0
    assert st.sync_error[-1, -50:].max() < 1e-6
    assert st.scale.shape == (3,) and np.all(st.scale > 0)
    assert st.n_rhs_evals > 0 and st.runtime > 0
    assert "chaotic" in st.verdict


# --------------------------------------------------------------------------
# other chaotic systems: published values and Stefanski vs Benettin
# --------------------------------------------------------------------------
def _check_chaotic(name: str, tol: float = 0.05) -> None:
    s = get_system(name)
    st, be = _estimates(name)
    assert st.chaotic and be.value > 0
    assert _rel(st.value, be.value) < tol, (st.value, be.value)
    if s.reference is not None:
        assert _rel(st.value, s.reference) < tol, (st.value, s.reference)
        assert _rel(be.value, s.reference) < tol, (be.value, s.reference)


def test_rossler_published_and_agreement():
    _check_chaotic("rossler")


@pytest.mark.slow
def test_ueda_forced_duffing_published_and_agreement():
    _check_chaotic("ueda_duffing")


@pytest.mark.slow
def test_dry_friction_duffing_stefanski_agrees_with_benettin():
    s = get_system("duffing_dry_friction")
    assert not s.smooth and s.reference is None
    _check_chaotic("duffing_dry_friction")


# --------------------------------------------------------------------------
# non-chaotic: limit cycle and stable fixed point
# --------------------------------------------------------------------------
def test_limit_cycle_gives_zero():
    st, be = _estimates("van_der_pol")
    smallest_chaotic = min(s.reference for s in REFERENCE_SYSTEMS.values()
                           if s.kind == "chaotic" and s.reference is not None)
    assert abs(st.value) < 0.1 * smallest_chaotic, st.value
    assert abs(be.value) < 0.1 * smallest_chaotic, be.value
    assert not st.chaotic
    assert "zero exponent" in st.verdict


def test_stable_focus_gives_closed_form():
    s = get_system("damped_oscillator")
    zeta, omega = s.params
    expected = -zeta * omega
    st, be = _estimates("damped_oscillator")
    assert not st.chaotic
    assert st.verdict.startswith("non-chaotic")
    assert st.bracket == (0.0, 0.0)
    assert _rel(st.value, expected) < 0.02, st.value
    assert _rel(be.value, expected) < 0.02, be.value


@njit
def _forced_linear(t, x, p):
    """x'' + 2 zeta omega x' + omega^2 x = F cos(Omega t); p = [zeta, omega, F, Omega]."""
    out = np.empty(2)
    out[0] = x[1]
    out[1] = -2.0 * p[0] * p[1] * x[1] - p[1] * p[1] * x[0] + p[2] * math.cos(p[3] * t)
    return out


def test_forced_linear_oscillator_uses_time_and_gives_closed_form():
    """Non-autonomous closed form: the periodic response of a forced damped
    linear oscillator attracts at rate -zeta*omega.  If drive and response saw
    different forcing times, the error would settle at a forced-amplitude level
    instead of decaying, and the test would fail."""
    p = np.array([0.05, 1.0, 3.0, 1.3])
    st = stefanski_lle(_forced_linear, [1.0, 0.0], p, dt=0.01, t_transient=50.0,
                       t_measure=400.0)
    assert not st.chaotic
    assert _rel(st.value, -0.05) < 0.02, st.value


# --------------------------------------------------------------------------
# reproducibility
# --------------------------------------------------------------------------
def test_deterministic_and_independent_of_threads():
    s = get_system("lorenz")
    kw = dict(dt=s.dt, t_transient=20.0, t_measure=100.0)
    a = stefanski_lle(s.rhs, s.x0, s.params, n_threads=1, **kw)
    b = stefanski_lle(s.rhs, s.x0, s.params, n_threads=2, **kw)
    assert a.value == b.value
    assert a.bracket == b.bracket


def test_literal_unbounded_variant_runs_on_lorenz():
    """The literal method (free error, no rescaling) agrees on Lorenz too."""
    s = get_system("lorenz")
    st = stefanski_lle(s.rhs, s.x0, s.params, dt=s.dt, t_transient=s.t_transient,
                       t_measure=s.t_measure, bounded=False)
    assert _rel(st.value, LORENZ_LAMBDA1) < 0.03, st.value


# --------------------------------------------------------------------------
# nolds cross-check
# --------------------------------------------------------------------------
def test_nolds_lorenz_order_of_magnitude():
    s = get_system("lorenz")
    _, states = sample_trajectory(s.rhs, s.x0, s.params, dt=0.01, t_transient=100.0,
                                  n_samples=1500, sample_every=5)
    res = nolds_lle(states[:, 0], sample_dt=0.05, emb_dim=5, trajectory_len=20)
    assert res.method == "nolds-rosenstein"
    assert LORENZ_LAMBDA1 / 1.5 < res.value < LORENZ_LAMBDA1 * 1.5, res.value
    # per-time-unit conversion: same series, double sample_dt -> half the exponent
    res2 = nolds_lle(states[:, 0], sample_dt=0.10, emb_dim=5, trajectory_len=20)
    assert res2.value == pytest.approx(res.value / 2.0, rel=1e-12)


# --------------------------------------------------------------------------
# input validation
# --------------------------------------------------------------------------
@pytest.mark.parametrize("func", [stefanski_lle, benettin_lle])
@pytest.mark.parametrize("bad_dt", [0.0, -0.01, float("nan"), float("inf"), "x"])
def test_bad_dt_raises(func, bad_dt):
    s = get_system("lorenz")
    with pytest.raises(ValueError, match="dt"):
        func(s.rhs, s.x0, s.params, dt=bad_dt, t_transient=1.0, t_measure=10.0)


@pytest.mark.parametrize("func", [stefanski_lle, benettin_lle])
@pytest.mark.parametrize("bad_x0", [[1.0, float("nan"), 1.0], [float("inf"), 0.0, 0.0]])
def test_nonfinite_x0_raises(func, bad_x0):
    s = get_system("lorenz")
    with pytest.raises(ValueError, match="x0"):
        func(s.rhs, bad_x0, s.params, dt=0.01, t_transient=1.0, t_measure=10.0)


@pytest.mark.parametrize("kwargs, name", [
    (dict(t_transient=-1.0, t_measure=10.0), "t_transient"),
    (dict(t_transient=1.0, t_measure=float("nan")), "t_measure"),
])
def test_bad_times_raise(kwargs, name):
    s = get_system("lorenz")
    with pytest.raises(ValueError, match=name):
        stefanski_lle(s.rhs, s.x0, s.params, dt=0.01, **kwargs)


def test_bad_params_and_shapes_raise():
    s = get_system("lorenz")
    with pytest.raises(ValueError, match="params"):
        stefanski_lle(s.rhs, s.x0, [10.0, float("nan"), 1.0], dt=0.01, t_transient=1.0,
                      t_measure=10.0)
    with pytest.raises(ValueError, match="x0"):
        stefanski_lle(s.rhs, [[1.0, 1.0, 1.0]], s.params, dt=0.01, t_transient=1.0,
                      t_measure=10.0)
    vdp = get_system("van_der_pol")
    with pytest.raises(ValueError, match="x0"):  # rhs returns 2 values for a 3-vector
        stefanski_lle(vdp.rhs, [1.0, 1.0, 1.0], vdp.params, dt=0.01, t_transient=1.0,
                      t_measure=10.0)


def test_non_numba_rhs_raises():
    with pytest.raises(ValueError, match="rhs"):
        stefanski_lle(lambda t, x, p: -x, [1.0], [0.0], dt=0.01, t_transient=1.0,
                      t_measure=10.0)


def test_nolds_bad_input_raises():
    with pytest.raises(ValueError, match="sample_dt"):
        nolds_lle(np.sin(np.arange(100.0)), sample_dt=0.0)
    with pytest.raises(ValueError, match="series"):
        nolds_lle(np.array([1.0, float("nan")] * 20), sample_dt=1.0)


def _linear_rate_batch(lam: float, t_s: np.ndarray, e0: float, calls: list):
    """A response family with the linear theory's rate ``r(d) = lam - d`` (synchronised where
    it is negative), as the beam's run_batch returns it; ``calls`` collects the batches."""
    def run_batch(ds):
        ds = np.asarray(ds, dtype=float)
        calls.append(ds.copy())
        rate = lam - ds
        log_err = math.log(e0) + rate[:, None] * t_s[None, :]
        return rate, log_err, rate < 0.0
    return run_batch


@pytest.mark.parametrize("hint_factor", [None, 1.0, 0.7, 0.05, 30.0])
def test_seeded_ladder_finds_the_threshold_wherever_the_hint_is(hint_factor):
    """sync_search with ``ladder_hint`` (the beam's Benettin estimate): the threshold ``d_s =
    lam`` is found to ``rtol`` with a good hint, a poor one (0.7x), and hints 20x too small or 30x
    too large (the bracket is then extended upwards or opened down to 0); a hint near the value
    saves rounds against the factor-2 ladder below omega_c."""
    lam, omega_c, t_s, e0 = 0.37, 50.0, np.linspace(0.5, 50.0, 100), 1e-6
    out = {}
    hints = (None,) if hint_factor is None else (None, hint_factor * lam)
    for hint in hints:
        calls: list = []
        res = sync_search(_linear_rate_batch(lam, t_s, e0, calls), t_s=t_s, batch=8, rtol=0.05,
                          atol=1e-6, omega_c=omega_c, d_cap=1e3, zero_tol=0.05, e0=e0,
                          bounded=True, max_rounds=12, zero_first=True, ladder_hint=hint)
        assert res.chaotic
        assert abs(res.value - lam) <= 0.05 * lam, (hint, res.value, res.bracket)
        lo, hi = res.bracket
        assert lo <= lam <= hi and hi - lo <= 0.05 * hi, (hint, res.bracket)
        out[hint] = len(calls)
    if hint_factor in (1.0, 0.7):
        assert out[hint_factor * lam] < out[None], out


def test_nolds_warns_once_per_message():
    """nolds' notes on the lag / min_tsep it picks itself come once per process and message,
    not at every call (they filled a map job's log: nolds was imported again at every call,
    which reset Python's warning registries).  In a subprocess, with Python's default filters:
    pytest installs its own."""
    code = ("import numpy as np\n"
            "from analysis.lyapunov.nolds_rosenstein import nolds_lle\n"
            "x = np.sin(0.05 * np.arange(400.0))\n"  # slowly varying: nolds picks min_tsep
            "v = [nolds_lle(x, sample_dt=1.0, emb_dim=4).value for _ in range(4)]\n"
            "assert len(set(v)) == 1, v\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[2], timeout=120)
    assert out.returncode == 0, out.stderr
    notes = [ln for ln in out.stderr.splitlines() if "RuntimeWarning" in ln]
    assert notes, "the series should make nolds pick its own min_tsep"
    assert len(notes) == len(set(notes)), out.stderr

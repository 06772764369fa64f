"""analysis.lifetimes: the exponential escape-rate estimate from censored times, against a map
whose escape is known in closed form, against SciPy's censored fit, and its interval's
coverage."""

import numpy as np
import pytest
from scipy import stats

from analysis.lifetimes import exponential_lifetime


def _tent_escapes(slope: float, n: int, horizon: int, seed: int = 0):
    """Escape steps of ``n`` uniform starts of the open tent map ``x -> slope min(x, 1 - x)``
    (``slope > 2``; a start escapes at the first step that leaves ``[0, 1]``), censored at
    ``horizon`` steps."""
    x = np.random.default_rng(seed).uniform(0.0, 1.0, n)
    t = np.full(n, float(horizon))
    out = np.zeros(n, dtype=bool)
    for k in range(1, horizon + 1):
        x = slope * np.minimum(x, 1.0 - x)
        new = (x > 1.0) & ~out
        t[new], out[new] = k, True
    return t, out


def test_the_open_tent_map_escapes_at_its_closed_form_rate():
    """The uniform density is conditionally invariant for the open tent map of slope ``s``:
    the fraction left after ``k`` steps is exactly ``(2 / s)^k``, so a start escapes at each
    step with probability ``1 - 2 / s`` and its mean lifetime is ``1 / (1 - 2 / s)`` steps.
    With censoring at a horizon shorter than some lifetimes, the estimate finds it within its
    interval (the continuous escape rate ``ln(s / 2)`` is the same to first order in it)."""
    for slope, horizon in ((2.5, 6), (2.2, 40)):
        t, esc = _tent_escapes(slope, 20000, horizon)
        est = exponential_lifetime(t, esc)
        exact = 1.0 / (1.0 - 2.0 / slope)
        assert 0 < est.escaped < est.n  # censored and escaped both present
        assert est.lifetime_lo < exact < est.lifetime_hi
        assert est.lifetime == pytest.approx(exact, rel=0.03)
        assert est.rate == pytest.approx(1.0 - 2.0 / slope, rel=0.03)  # the per-step escape probability


def test_it_is_scipys_censored_maximum_likelihood_fit():
    rng = np.random.default_rng(1)
    life = rng.exponential(300.0, 40)
    horizon = 400.0
    t, esc = np.minimum(life, horizon), life < horizon
    est = exponential_lifetime(t, esc)
    data = stats.CensoredData(uncensored=t[esc], right=t[~esc])
    loc, scale = stats.expon.fit(data, floc=0)
    assert est.lifetime == pytest.approx(scale, rel=1e-6)
    assert est.rate * est.exposure == est.escaped


def test_the_interval_covers_the_mean_lifetime_at_its_level():
    """Seeded replicates of 8 copies censored at 2000 (the pipeline's default sizes) of an
    exponential lifetime of 1500: the 95 % interval covers 1500 in 95 % of them or a little
    more (the Poisson interval is conservative), and misses on both sides."""
    rng = np.random.default_rng(2)
    tau, horizon, reps = 1500.0, 2000.0, 4000
    below = above = 0
    for _ in range(reps):
        life = rng.exponential(tau, 8)
        est = exponential_lifetime(np.minimum(life, horizon), life < horizon)
        below += est.lifetime_hi < tau
        above += est.lifetime_lo > tau
    cover = 1.0 - (below + above) / reps
    assert 0.94 <= cover <= 0.985
    assert below > 0 and above > 0


def _coverage(tau, horizon, reps, copies, entries, seed):
    """Coverage of ``tau`` by the 95 % interval over ``reps`` replicates of ``copies`` copies
    that share one exponential lifetime (one trajectory, as copies of a torus are), censored
    at ``horizon``, with ``entries`` (``None``: every copy from the start)."""
    rng = np.random.default_rng(seed)
    hit = 0
    for _ in range(reps):
        life = np.full(copies, rng.exponential(tau))
        est = exponential_lifetime(np.minimum(life, horizon), life < horizon, entries=entries)
        hit += est.lifetime_lo <= tau <= est.lifetime_hi
    return hit / reps


def test_copies_of_one_trajectory_count_once():
    """Eight copies that are one trajectory: counted as eight, the interval covers the mean
    lifetime in far fewer than 95 % of replicates (their exposure and escapes are eightfold, the
    interval as narrow as for eight independent ones); with the other seven left-truncated at
    ``inf`` (they never decorrelate) it covers at its level again."""
    tau, horizon, reps = 1500.0, 2000.0, 2000
    assert _coverage(tau, horizon, reps, 8, None, seed=3) < 0.8
    assert _coverage(tau, horizon, reps, 8, [0.0] + [np.inf] * 7, seed=3) >= 0.94


def test_left_truncated_copies_keep_the_rate_of_a_memoryless_escape():
    """Independent exponential lifetimes, every copy but the first counted only from ``t_e``
    = 300 (those gone before are left out): the estimate finds the mean lifetime within its
    interval and covers it at its level; with every entry 0 it is the estimate without entries."""
    rng = np.random.default_rng(4)
    tau, horizon, t_e = 1500.0, 2000.0, 300.0
    life = rng.exponential(tau, 20000)
    entries = np.where(np.arange(life.size) % 8 == 0, 0.0, t_e)
    est = exponential_lifetime(np.minimum(life, horizon), life < horizon, entries=entries)
    kept = (life > entries) | (entries == 0)
    assert est.n == kept.sum() < life.size
    assert est.lifetime_lo < tau < est.lifetime_hi and est.lifetime == pytest.approx(tau, rel=0.03)
    t, esc = np.minimum(life, horizon), life < horizon
    assert exponential_lifetime(t, esc, entries=np.zeros(life.size)) == exponential_lifetime(t, esc)
    rng = np.random.default_rng(5)
    below = above = 0
    for _ in range(2000):
        life = rng.exponential(tau, 8)
        e = exponential_lifetime(np.minimum(life, horizon), life < horizon, entries=[0.0] + [t_e] * 7)
        below += e.lifetime_hi < tau
        above += e.lifetime_lo > tau
    assert 0.94 <= 1.0 - (below + above) / 2000 <= 0.99


def test_no_escape_gives_a_lower_bound():
    """No escape in a total exposure ``S``: the mean lifetime is at least ``2 S / chi2_0.975(2)``
    (``S / 3.69``), the probability of no event in ``S`` at that lifetime being 2.5 %."""
    est = exponential_lifetime([2000.0] * 8, [False] * 8)
    assert est.escaped == 0 and est.rate == 0.0 and est.lifetime == np.inf and est.lifetime_hi == np.inf
    assert est.lifetime_lo == pytest.approx(16000.0 / 3.6889, rel=1e-4)
    assert np.exp(-16000.0 / est.lifetime_lo) == pytest.approx(0.025, rel=1e-9)


def test_refuses_bad_input():
    with pytest.raises(ValueError, match="differ in length"):
        exponential_lifetime([1.0, 2.0], [True])
    with pytest.raises(ValueError, match="non-negative"):
        exponential_lifetime([-1.0], [True])
    with pytest.raises(ValueError, match="level"):
        exponential_lifetime([1.0], [True], level=1.0)
    assert np.isnan(exponential_lifetime([], []).lifetime)
    with pytest.raises(ValueError, match="entries"):
        exponential_lifetime([1.0, 2.0], [True, True], entries=[0.0])
    with pytest.raises(ValueError, match="entries"):
        exponential_lifetime([1.0], [True], entries=[-1.0])
    with pytest.raises(ValueError, match="entries"):
        exponential_lifetime([1.0], [True], entries=[np.nan])


def test_a_trajectory_counts_only_after_its_entry():
    """Entry 0 counts from the start (even an escape at 0); a positive entry at or after the
    trajectory's time leaves it out; otherwise only the time after the entry counts."""
    est = exponential_lifetime([5.0, 5.0, 7.0], [True, True, True], entries=[0.0, 5.0, 5.0])
    assert (est.n, est.escaped, est.exposure) == (2, 2, 7.0)
    est = exponential_lifetime([0.0, 9.0, 3.0], [True, False, True], entries=[0.0, 2.0, np.inf])
    assert (est.n, est.escaped, est.exposure) == (2, 1, 7.0)
    assert np.isnan(exponential_lifetime([4.0], [True], entries=[np.inf]).lifetime)

"""lambda_1 as a statistic (analysis.lyapunov.block_statistics) and the classifier's use of its
confidence interval (analysis.regimes.classify with ``lle_interval``)."""

from __future__ import annotations

import numpy as np
import pytest
from test_regimes import henon, logistic, torus2

from analysis.lyapunov.block_statistics import (
    DIVERGED,
    NON_POSITIVE,
    POSITIVE,
    UNDETERMINED,
    BlockPlan,
    block_statistics,
    boundary_constant,
    decide,
    look_errors,
)
from analysis.regimes import CHAOTIC, PERIODIC, QUASI_PERIODIC, classify
from analysis.regimes import UNDETERMINED as LABEL_UNDETERMINED

T = 2.0 * np.pi


def record(lam_T: float, n: int, noise: float, seed: int) -> np.ndarray:
    """``ln eps`` at period ends of a separation growing at ``lam_T`` per period with
    independent per-period fluctuations of size ``noise`` (a random walk around the line)."""
    steps = lam_T + noise * np.random.default_rng(seed).standard_normal(n)
    return np.concatenate([[np.log(1e-6)], np.log(1e-6) + np.cumsum(steps)])


def test_mean_is_the_rate_over_the_measured_stretch() -> None:
    le = record(0.3, 225, 0.5, 1)
    st = block_statistics(le, T)
    assert st.n_periods == 200 and st.blocks.size == 8
    assert st.mean * T == pytest.approx((le[225] - le[25]) / 200, rel=1e-12)
    m, se, lo, hi = st.per_period
    assert lo < m < hi and se > 0


def test_interval_coverage() -> None:
    """The 95 % interval holds the true rate in about 95 % of independent records."""
    hits = 0
    for seed in range(400):
        _, _, lo, hi = block_statistics(record(0.15, 225, 0.6, seed), T).per_period
        hits += lo <= 0.15 <= hi
    assert 0.91 <= hits / 400 <= 0.985, hits


def test_verdicts() -> None:
    assert block_statistics(record(0.3, 225, 0.3, 2), T).verdict == POSITIVE
    assert block_statistics(record(-0.1, 225, 0.3, 2), T).verdict == NON_POSITIVE
    # weak chaos inside the noise of a short record: not decided
    assert block_statistics(record(0.06, 100, 1.0, 3), T).verdict == UNDETERMINED
    # a neutral direction growing linearly (shear): zero exponent, not chaos
    t = np.arange(226.0)
    assert block_statistics(np.log(1e-6 * (1.0 + t)), T).verdict == NON_POSITIVE
    bad = record(0.3, 225, 0.3, 2)
    bad[100] = np.nan
    assert block_statistics(bad, T).verdict == DIVERGED
    coincide = record(-0.1, 225, 0.3, 2)
    coincide[150:] = -np.inf
    st = block_statistics(coincide, T)
    assert st.verdict == NON_POSITIVE and st.mean == -np.inf


def test_decide_and_plan() -> None:
    assert decide(0.06, 0.2, 0.05) == POSITIVE
    assert decide(-0.1, 0.05, 0.05) == NON_POSITIVE
    assert decide(0.0, 0.1, 0.05) == UNDETERMINED
    plan = BlockPlan()
    assert plan.first_periods == 100 and plan.max_periods == 425
    with pytest.raises(ValueError, match="BlockPlan"):
        BlockPlan(min_blocks=5, max_blocks=3)
    with pytest.raises(ValueError, match="BlockPlan.boundary"):
        BlockPlan(boundary="bonferroni")
    with pytest.raises(ValueError, match="need burn_in"):
        block_statistics(np.zeros(40), T)


def sequential_verdicts(plan: BlockPlan, lam_T: float, noise: float, n: int) -> dict[str, int]:
    """Verdicts of ``plan`` run sequentially on ``n`` independent records (seeds ``0 .. n-1``)."""
    verdicts = [plan.sequential(record(lam_T, plan.max_periods, noise, seed), T).verdict
                for seed in range(n)]
    return {v: verdicts.count(v) for v in (POSITIVE, NON_POSITIVE, UNDETERMINED)}


@pytest.mark.parametrize("boundary, lam_T", [("none", 0.06), ("obrien-fleming", 0.15)])
def test_sequential_plan_stops_where_the_verdict_is_first_taken(boundary, lam_T) -> None:
    """``sequential`` runs the first record, then one block more while undetermined, and its
    statistics are those of the record cut where it stopped, each look's interval at its own
    level (a rate that stops at many looks: O'Brien-Fleming's first looks stop only clear
    records)."""
    plan = BlockPlan(max_blocks=16, boundary=boundary)
    stops = set()
    for seed in range(40):
        le = record(lam_T, plan.max_periods, 1.0, seed)
        st = plan.sequential(le, T)
        n = plan.burn_in + st.n_periods
        stops.add(n)
        assert st.mean == plan.statistics(le[:n + 1], T).mean
        assert st.look_error == plan.look_error(st.blocks.size) and st.confidence == 0.95
        assert not plan.continues(st)
        for m in range(plan.first_periods, n, plan.block):  # undetermined before
            assert plan.statistics(le[:m + 1], T).verdict == UNDETERMINED
    assert max(stops) == plan.max_periods and len(stops) > 3, stops
    if boundary == "none":
        assert min(stops) == plan.first_periods
    with pytest.raises(ValueError, match="needs 425"):
        plan.sequential(record(0.0, 300, 1.0, 0), T)


def test_uncorrected_looks_inflate_the_error_rates() -> None:
    """Every look at the stated 95 % (``boundary="none"``, the rule until results version 22):
    a record whose true rate is zero (a torus) is called positive more often than one
    fixed-length interval's 2.5 % would suggest when its blocks are noisy, and more looks raise
    it; at the margin a verdict for chaos is taken in more than twice the nominal 2.5 %.  Noise
    1.0 per period gives a block standard deviation of 0.2 per period."""
    n = 1000
    positives = {}
    for max_blocks, limit in ((8, 0.04), (16, 0.05)):
        plan = BlockPlan(max_blocks=max_blocks, boundary="none")
        zero = sequential_verdicts(plan, 0.0, 1.0, n)
        assert zero[POSITIVE] / n <= limit, (max_blocks, zero)
        positives[max_blocks] = zero[POSITIVE]
        chaos = sequential_verdicts(plan, 0.3, 1.0, n)
        assert chaos[NON_POSITIVE] == 0, (max_blocks, chaos)
    # the records of a seed share their first 225 periods: the later looks add positives
    assert positives[16] > positives[8], positives
    at_margin = sequential_verdicts(BlockPlan(max_blocks=16, boundary="none"), 0.05, 1.0, n)
    assert at_margin[POSITIVE] / n > 0.05 and at_margin[NON_POSITIVE] / n > 0.05, at_margin


def test_look_errors() -> None:
    """One look is the plain interval; Pocock's looks share one error, O'Brien-Fleming's are
    smallest (widest intervals) at the first looks; both are stricter than the stated level at
    every look."""
    assert look_errors("pocock", 5, 5, 0.95) == pytest.approx([0.05], abs=1e-12)
    assert look_errors("obrien-fleming", 5, 5, 0.95) == pytest.approx([0.05], abs=1e-12)
    assert np.all(look_errors("none", 3, 16, 0.95) == pytest.approx(0.05, abs=1e-15))
    pocock = look_errors("pocock", 3, 16, 0.95)
    obf = look_errors("obrien-fleming", 3, 16, 0.95)
    assert pocock.size == obf.size == 14 and np.ptp(pocock) == 0 and pocock[0] < 0.05
    assert np.all(np.diff(obf) > 0) and obf[-1] < 0.05 and obf[0] < pocock[0] < obf[-1]
    assert boundary_constant("pocock", 3, 16, 0.95) > boundary_constant("pocock", 3, 8, 0.95)
    with pytest.raises(ValueError, match="boundary"):
        boundary_constant("none", 3, 16, 0.95)


@pytest.mark.parametrize("boundary", ["pocock", "obrien-fleming", "none"])
def test_a_group_sequential_boundary_holds_the_stated_level(boundary) -> None:
    """The looks after 3 ... 16 blocks, each at its boundary's error (calibrated by
    :func:`boundary_constant` on its own simulated t statistics), run through
    ``BlockPlan.sequential`` on records drawn here: at a true rate equal to the margin each
    verdict is taken in about (1 - 0.95) / 2 = 2.5 % of the records (2000 records: standard
    error 0.35 %) and the interval a record stops at holds the true rate in at least about 95 %
    of them (repeated confidence intervals), and a torus is called positive in at most 2.5 %.
    Every look at 95 % (``none``) fails them (about 10 % per side, 81 %, 3.3 %)."""
    n = 2000
    plan = BlockPlan(max_blocks=16, boundary=boundary)
    verdicts, covered = {POSITIVE: 0, NON_POSITIVE: 0, UNDETERMINED: 0}, 0
    for seed in range(n):
        st = plan.sequential(record(0.05, plan.max_periods, 1.0, seed), T)
        verdicts[st.verdict] += 1
        covered += st.per_period[2] <= 0.05 <= st.per_period[3]
    zero = sequential_verdicts(plan, 0.0, 1.0, n)
    held = (all(0.015 <= verdicts[v] / n <= 0.035 for v in (POSITIVE, NON_POSITIVE))
            and covered / n >= 0.94 and zero[POSITIVE] / n <= 0.025)
    assert held == (boundary != "none"), (boundary, verdicts, covered, zero)


def test_a_wide_boundary_keeps_its_first_looks_apart_from_one() -> None:
    """O'Brien-Fleming over 2 ... 40 blocks: the first looks' errors are far below the spacing
    of doubles near 1 (their levels round to 1), and the intervals are computed from the
    errors, so the plan still measures and the first look's interval is finite and wider than
    the last's."""
    plan = BlockPlan(block=5, burn_in=5, min_blocks=2, max_blocks=40)
    errors = look_errors(plan.boundary, plan.min_blocks, plan.max_blocks, plan.confidence)
    assert errors[0] < 1e-16 and 1.0 - errors[0] == 1.0
    assert np.all(np.diff(errors) > 0) and errors[-1] < 0.05
    le = record(0.2, plan.max_periods, 1.0, 0)
    first = plan.statistics(le[:plan.first_periods + 1], T)
    last = plan.statistics(le, T)
    assert np.isfinite(first.lo) and first.hi - first.lo > last.hi - last.lo > 0
    assert first.look_error == errors[0] and "two-sided error" in first.summary()


def test_obrien_fleming_keeps_the_power_on_weak_chaos() -> None:
    """Both boundaries pay for the held level with wider intervals; O'Brien-Fleming spends its
    error late, so at the last looks, where weak chaos is decided, its intervals are the
    narrower: of records at 0.15 per period it decides more chaotic than Pocock, and it never
    calls strong chaos (0.3 per period) non-positive."""
    n = 1000
    obf = BlockPlan(max_blocks=16)
    pocock = BlockPlan(max_blocks=16, boundary="pocock")
    weak_obf = sequential_verdicts(obf, 0.15, 0.6, n)
    weak_pocock = sequential_verdicts(pocock, 0.15, 0.6, n)
    assert weak_obf[POSITIVE] > weak_pocock[POSITIVE] + 50 and weak_obf[POSITIVE] > 0.75 * n, \
        (weak_obf, weak_pocock)
    strong = sequential_verdicts(obf, 0.3, 1.0, n)
    assert strong[NON_POSITIVE] == 0 and strong[POSITIVE] > 0.95 * n, strong


def test_classify_with_an_interval() -> None:
    chaos = henon(300)
    assert classify(chaos, 0.4, lle_interval=(0.3, 0.5), lle_threshold=0.05).label == CHAOTIC
    res = classify(chaos, 0.1, lle_interval=(0.0, 0.2), lle_threshold=0.05)
    assert res.label == LABEL_UNDETERMINED and "straddles" in res.reason
    # the exponent contradicts the data: undetermined, the conflict named
    res = classify(torus2(300), 0.4, lle_interval=(0.3, 0.5), lle_threshold=0.05)
    assert res.label == LABEL_UNDETERMINED and "CONFLICT" in res.reason
    res = classify(logistic(4.0, 300, 100), -0.3, lle_interval=(-0.4, -0.2), lle_threshold=0.05)
    assert res.label == LABEL_UNDETERMINED and "CONFLICT" in res.reason
    assert classify(torus2(300), 0.0, lle_interval=(-0.02, 0.02), lle_threshold=0.05).label == QUASI_PERIODIC
    # a period found stands, whatever the interval
    p3 = logistic(3.83, 300)
    assert classify(p3, 0.0, lle_interval=(-0.1, 0.2), lle_threshold=0.05).label == PERIODIC
    with pytest.raises(ValueError, match="lle_interval"):
        classify(chaos, 0.1, lle_interval=(0.2, 0.0))
    with pytest.raises(ValueError, match="lle_interval"):
        classify(chaos, None, lle_interval=(0.0, 0.2))

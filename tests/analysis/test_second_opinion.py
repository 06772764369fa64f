"""The RK4 pair's second opinion on the ``expo`` pair's long record
(``numerics.lyapunov.confirm``; analysis.lyapunov.beam.rk4_long_record,
analysis.pipeline.stages._second_opinion; docs/lyapunov.md, section 15).

Independent checks: the second opinion is the record the RK4 pair of ``beam_lle`` measures (to
the bit); it replaces exactly the ``expo`` records whose interval is not at or below the margin
and keeps the ``expo`` statistics beside it; and at a grazing period-1 orbit of the default map
(the period test over 256 samples says period 1, so an attracting periodic orbit,
``lambda_1 <= 0``) the RK4 pair reads a non-positive exponent at two steps, which is what the
second opinion exists for: the ``expo`` pair reads chaos there."""

from __future__ import annotations

import math

import numpy as np
import pytest
from beam_copies import CHAOTIC_2MODES, GRAZING, GRAZING_TRANSIENT, SLIPPING, STUCK
from test_regimes import logistic

from analysis.lyapunov.beam import (
    RK4_SECOND_OPINION,
    attractor_scale,
    beam_lle,
    response_scale,
    rk4_long_record,
)
from analysis.lyapunov.block_statistics import NON_POSITIVE, POSITIVE, BlockPlan
from analysis.pipeline.config import Numerics
from analysis.pipeline.stages import _second_opinion, reference_run
from analysis.regimes import classify, poincare_says_chaotic
from beamsim.simulate import prepare_point, simulate_batch

SHORT = BlockPlan(block=5, burn_in=5, min_blocks=2, max_blocks=4, margin=0.05)
LONG = BlockPlan(block=25, burn_in=5, min_blocks=2, max_blocks=8, margin=0.05)


def _settled(points, n_transient=30):
    res = simulate_batch(points, n_transient=n_transient, n_record=30, method="expo", n_threads=2)
    prepared = [prepare_point(**p) for p in points]
    scales = np.stack([attractor_scale(r.poincare_state, response_scale(pp), pp.omega)
                       for r, pp in zip(res, prepared)])
    return prepared, np.stack([r.final_state for r in res]), scales


def test_the_second_opinion_is_the_rk4_pairs_record():
    """``rk4_long_record`` gives the block statistics of ``beam_lle``'s RK4 free copy with the
    same plan, bitwise, a point's record independent of the other points in the call, and
    continues an undetermined record as ``beam_lle`` does."""
    prepared, starts, scales = _settled([SLIPPING, STUCK])
    mine = rk4_long_record(prepared, starts, scales, plan=SHORT, n_threads=2)
    ref = beam_lle(prepared, starts, scales, n_periods=5, plan=SHORT, n_threads=2)
    alone = rk4_long_record(prepared[1:], starts[1:], scales[1:], plan=SHORT, n_threads=1)
    for a, est in zip(mine, ref):
        b = est.statistics
        assert np.array_equal(a.blocks, b.blocks)
        assert (a.mean, a.lo, a.hi, a.verdict) == (b.mean, b.lo, b.hi, b.verdict)
    assert np.array_equal(alone[0].blocks, mine[1].blocks)


def test_only_records_not_at_or_below_the_margin_are_measured_again():
    """``_second_opinion`` with ``confirm: all``: the ``expo`` pair's positive record (the
    two-mode chaotic point) is replaced by the RK4 pair's (``rk4_long_record``'s, to the bit),
    its ``expo`` statistics kept as ``screen`` and its ``free_copy`` named; a non-positive one
    (the one-mode slipping orbit) is left as it was.  With the default ``contradicted`` the
    chaotic point's record is left too when its Poincare samples say chaos on their own: they
    are the fully chaotic logistic map's here (``x -> 3.99 x (1 - x)`` in every column, whatever
    the beam's last bits), because the chaotic point's own
    256 samples say chaos or not depending on the transient and the last bits (results version
    26: not after 200 periods, yes after 300 and 400, not over 1024 samples: an intermittent
    set).  The records run on blocks of 25 periods (up to 8): on :data:`SHORT`'s 5-period
    blocks the chaotic point's record stopped undetermined in version 26 (``lambda_1 T`` 0.43,
    interval -0.11 to 0.97 after 4 blocks) where 25-period blocks read it positive (0.51, 0.23
    to 0.79) from each of three transients (60, 100, 200 periods)."""
    for point, replaced in ((CHAOTIC_2MODES, True), (SLIPPING, False)):
        prepared, starts, scales = _settled([point], n_transient=60)
        n = prepared[0].model.n
        records = [np.outer(logistic(3.99, 257, transient=100)[:, 0] - 0.5, np.linspace(1.0, 2.0, 2 * n))
                   if replaced else
                   simulate_batch([point], n_transient=200, n_record=256, method="expo")[0].poincare_state]
        assert poincare_says_chaotic(records[0]) == replaced        # the premise
        for confirm in ("contradicted", "all"):
            res = beam_lle(prepared, starts, scales, n_periods=5, plan=LONG, n_threads=2,
                           free_method="expo", free_e0=1e-4, ladder_method="expo")
            expo = res[0].statistics
            assert expo.verdict == (POSITIVE if replaced else NON_POSITIVE), expo
            lopt = Numerics.from_dict({"lyapunov": {"confirm": confirm}}).lyapunov
            _second_opinion(res, prepared, starts, scales, records, LONG, lopt, None, 2)
            if not replaced or confirm == "contradicted":
                assert res[0].statistics is expo and res[0].screen is None and res[0].free_copy == "expo"
                continue
            rk4 = rk4_long_record(prepared, starts, scales, plan=LONG, step_factor=lopt.step_factor)[0]
            assert res[0].free_copy == RK4_SECOND_OPINION and res[0].screen is expo
            assert np.array_equal(res[0].statistics.blocks, rk4.blocks)


def test_the_default_rule_measures_again_where_the_record_does_not_say_chaos():
    """``_second_opinion`` with the default ``contradicted``, on the one-mode slipping orbit
    (a period-1 record, not chaos-like) whose ``expo`` statistics are set to a positive and to a
    straddling verdict: both are measured again on the RK4 pair (its record, to the bit), the
    ``expo`` statistics kept as ``screen``.  The selection is what is tested; the beam's own
    ``expo`` readings at such orbits are the grazing test's."""
    import dataclasses

    from analysis.lyapunov.block_statistics import UNDETERMINED

    prepared, starts, scales = _settled([SLIPPING], n_transient=60)
    records = [simulate_batch([SLIPPING], n_transient=60, n_record=128, method="expo")[0].poincare_state]
    assert not poincare_says_chaotic(records[0])
    lopt = Numerics().lyapunov
    rk4 = rk4_long_record(prepared, starts, scales, plan=SHORT, step_factor=lopt.step_factor)[0]
    for verdict in (POSITIVE, UNDETERMINED):
        res = beam_lle(prepared, starts, scales, n_periods=5, plan=SHORT, n_threads=2,
                       free_method="expo", free_e0=1e-4, ladder_method="expo")
        res[0].statistics = dataclasses.replace(res[0].statistics, verdict=verdict)
        faked = res[0].statistics
        _second_opinion(res, prepared, starts, scales, records, SHORT, lopt, None, 2)
        assert res[0].free_copy == RK4_SECOND_OPINION and res[0].screen is faked
        assert np.array_equal(res[0].statistics.blocks, rk4.blocks)
        assert res[0].statistics.verdict == rk4.verdict


@pytest.fixture(scope="module")
def grazing():
    """The grazing cell from rest, through its table's transient, and 256 recorded periods."""
    from analysis.pipeline.config import as_numerics

    nm = as_numerics({})
    r = reference_run(GRAZING, nm, n_transient=GRAZING_TRANSIENT, n_record=256)
    pp = prepare_point(**GRAZING)
    return pp, r, attractor_scale(r.poincare_state, response_scale(pp), pp.omega)


def test_the_rk4_pair_reads_a_grazing_period_one_orbit_as_non_chaotic(grazing):
    """At the grazing period-1 orbit the period test finds period 1 over the 256 samples (an
    attracting orbit: ``lambda_1 <= 0``), and the RK4 pair's long record with the pipeline's
    plan is non-positive at the pipeline's step factor 0.5 and at 0.25.  The ``expo`` pair's
    record is printed, not asserted: it read ``lambda_1 T`` +0.87 [+0.47, +1.27] on the map's
    trajectory (docs/lyapunov.md, section 15), the reason for the second opinion."""
    pp, r, scale = grazing
    res = classify(r.poincare_state)
    assert res.label == "periodic" and res.period == 1 and res.indicators["period_test"] == 1, res.reason
    plan = Numerics().lyapunov.block_plan()
    T = 2 * math.pi / pp.omega
    res = beam_lle([pp], r.final_state[None], scale[None], n_periods=25, plan=plan, n_threads=2,
                   free_method="expo", free_e0=1e-4, ladder_method="expo")
    expo = res[0].statistics
    print(f"\nexpo pair: {expo.summary()}")
    # the pipeline's default rule: a period-1 record does not say chaos, so where the expo pair
    # is not non-positive the RK4 pair decides; either way the verdict is non-positive
    lopt = Numerics().lyapunov
    _second_opinion(res, [pp], r.final_state[None], scale[None], [r.poincare_state], plan, lopt, None, 2)
    assert (res[0].free_copy == RK4_SECOND_OPINION) == (expo.verdict != NON_POSITIVE)
    assert res[0].statistics.verdict == NON_POSITIVE, res[0].statistics.summary()
    for sf in (0.5, 0.25):
        st = rk4_long_record([pp], r.final_state[None], scale[None], plan=plan, step_factor=sf,
                             n_threads=2)[0]
        print(f"RK4 pair, step factor {sf}: lambda_1 T = {st.mean * T:+.3f} [{st.lo * T:+.3f}, "
              f"{st.hi * T:+.3f}] over {st.n_periods} periods: {st.verdict}")
        assert st.verdict == NON_POSITIVE, (sf, st.mean * T, st.lo * T, st.hi * T)

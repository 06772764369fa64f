"""Slow transients (analysis.transients, analysis.regimes.transient_reason) and the pipeline's
handling of them: a slowly decaying remnant, a converging spiral and a slow drift must end
``unsettled``, never periodic with m > 1 or quasi-periodic; settled records must pass."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from test_regimes import LABELLED, P5, _chaotic_windows, add_noise, torus2

from analysis.pipeline.stages import classify_points
from analysis.regimes import PERIODIC, QUASI_PERIODIC, UNSETTLED, classify, transient_reason

N = 257  # the pipeline's record: n_record + 1 samples


def remnant(amp: float, decay: float, n: int = N) -> np.ndarray:
    """A fixed point of the stroboscopic map with a period-5 remnant of relative size ``amp``
    that decays ``decay`` times over the record (the audit's "period 5" that was period 1
    after 400 periods): two components carry it, two sit still."""
    i = np.arange(n)
    pat = np.column_stack([P5[i % 5], np.roll(P5, 2)[i % 5], 0 * i, 0 * i]) * (decay ** (-i / n))[:, None]
    return np.array([1.0, -0.5, 0.8, 0.3]) + amp * pat


def spiral(decay: float, turn: int = 18, n: int = N) -> np.ndarray:
    """A focus of the stroboscopic map: rotation by ``2 pi / turn`` per period, amplitude
    falling ``decay`` times over the record (the audit's "period 18")."""
    i = np.arange(n)
    rot = np.column_stack([np.cos(2 * np.pi * i / turn), np.sin(2 * np.pi * i / turn)])
    return np.array([1.0, -0.5]) + 0.3 * rot * (decay ** (-i / n))[:, None]


def drifting(base: np.ndarray, drift: float) -> np.ndarray:
    """``base`` with a linear drift of ``drift`` times the spread of its first component."""
    x = base.copy()
    x[:, 0] += drift * np.ptp(x[:, 0]) * np.arange(x.shape[0]) / x.shape[0]
    return x


SLOW = {
    **{f"remnant-{a}-{d}": remnant(a, d) for a in (0.002, 0.005, 0.02) for d in (1.3, 2.0)},
    **{f"spiral-{d}": spiral(d) for d in (1.5, 2.5, 4.0)},
    "drift-torus-0.06": drifting(torus2(N), 0.06),
    "drift-torus-0.1": drifting(torus2(N), 0.1),
    "drift-period3-0.06": drifting(np.random.default_rng(3).normal(size=(3, 3))[np.arange(N) % 3], 0.06),
}


def _pipeline_label(x: np.ndarray, lle_T: tuple[float, float, float] = (0.0, -0.01, 0.01)) -> str:
    """The pipeline's label of a record (classify stage), with a regular exponent."""
    T = 2.0 * np.pi
    sim = pd.DataFrame([{"point_id": "p", "omega": 1.0, "diverged": False, "n_transient_used": 200,
                         "poincare_state": x.tolist()}])
    lyap = pd.DataFrame([{"point_id": "p", "lle_mean": lle_T[0] / T, "lle_lo": lle_T[1] / T,
                          "lle_hi": lle_T[2] / T}])
    return classify_points(sim, lyap).iloc[0]


@pytest.mark.parametrize("name", list(SLOW))
def test_slow_transients_end_unsettled(name: str) -> None:
    x = SLOW[name]
    row = _pipeline_label(x)
    assert row["label"] == UNSETTLED, (name, row["label"], row["reason"])
    assert "transient not over" in row["reason"]


def test_slow_transients_fool_the_classifier_alone() -> None:
    """Without the trend tests these records are labelled periodic-m > 1 or quasi-periodic
    (so the test above can fail)."""
    fooled = 0
    for x in SLOW.values():
        res = classify(x)
        fooled += (res.label == PERIODIC and res.period > 1) or res.label == QUASI_PERIODIC
    assert fooled >= len(SLOW) - 3, fooled


@pytest.mark.parametrize("noise", [0.0, 1e-4])
def test_settled_records_pass(noise: float) -> None:
    for name, (gen, _, _) in LABELLED.items():
        for x in (gen(), gen()[:N]):
            assert transient_reason(add_noise(x, noise)) is None, name


def test_false_alarm_rate_on_chaotic_windows() -> None:
    """Stationary chaotic windows of the pipeline's length: measured 4 of 80 called transient
    (the halves test, the drift test at level 0.01 per component)."""
    for d in (0, 40):
        windows = _chaotic_windows(N, 40, d)
        alarms = sum(transient_reason(w) is not None for w in windows)
        assert alarms <= 6, (d, alarms)


def test_a_decay_below_the_period_tolerance_is_settled() -> None:
    """A remnant that never reaches the period test's tolerance does not hold the label back
    (period 1 is right from the start)."""
    x = remnant(1e-5, 2.0)
    assert transient_reason(x) is None
    assert classify(x).period == 1


def test_which_points_need_the_long_record():
    """analysis.pipeline.stages.long_record_exemption: transients, periodic records and stuck
    stick-slip records are exempt (the label does not depend on the exponent, or lambda_1 <= 0
    exactly); a stuck record of a regularised law and a non-periodic slipping one are not."""
    from analysis.pipeline.stages import LINEAR_VERDICT, long_record_exemption

    def row(x, stick):
        return pd.Series({"poincare_state": x.tolist(), "stick_fraction": stick})

    torus = torus2(N)
    assert "the record is a transient" in long_record_exemption(row(SLOW["spiral-2.5"], 0.5), {})
    periodic = np.random.default_rng(0).normal(size=(3, 2))[np.arange(N) % 3]
    assert "periodic record" in long_record_exemption(row(periodic, 0.5), {})
    assert long_record_exemption(row(torus, 1.0), {"law": "stick-slip"}) == LINEAR_VERDICT
    assert long_record_exemption(row(torus, 1.0), {"law": "full-slip"}) is None
    assert long_record_exemption(row(torus, 0.9), {}) is None

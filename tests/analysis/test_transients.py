"""Slow transients (analysis.transients, analysis.regimes.transient_reason) and the pipeline's
handling of them: a slowly decaying remnant, a converging spiral and a slow drift must end
``unsettled``, never periodic with m > 1 or quasi-periodic; settled records must pass."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from test_regimes import LABELLED, P5, _chaotic_windows, add_noise, torus2

from analysis.pipeline.stages import classify_points
from analysis.regimes import (
    PERIODIC,
    QUASI_PERIODIC,
    UNSETTLED,
    classify,
    continuation_reason,
    is_settled,
    is_transient,
    poincare_signature,
    transient_reason,
)

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


def test_is_transient_is_transient_reasons_verdict() -> None:
    """The pipeline's cheaper order (trend tests first) gives ``transient_reason``'s verdict on
    records of every kind: settled ones, slow transients, stationary and drifting chaos, and
    records that fail the halves test alone (a chaotic window settling onto its attractor,
    which the trend tests let pass, so a skipped halves test would be seen) or a trend test
    alone (a slow remnant the halves test passes)."""
    i = np.arange(129)[:, None]
    settling = [w + np.ptp(w, axis=0) * np.exp(-i / 40.0) for w in _chaotic_windows(129, 10)]
    records = ([gen() for gen, _, _ in LABELLED.values()] + list(SLOW.values())
               + _chaotic_windows(N, 10, 40) + settling)
    halves_only = trend_only = 0
    for x in records:
        why = transient_reason(x)
        assert is_transient(x) == (why is not None), why
        halves = why is not None and why.startswith("first and second half")
        halves_only += halves and transient_reason(x, rtol=np.inf) is None   # the trend tests pass
        trend_only += why is not None and not halves
    assert not all(is_settled(x) for x in settling)
    assert halves_only >= 1 and trend_only >= 1, (halves_only, trend_only)


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
    assert long_record_exemption(row(torus, 1.0), {"law": "rigid-stick"}) == LINEAR_VERDICT
    assert long_record_exemption(row(torus, 1.0), {"law": "full-slip"}) is None
    assert long_record_exemption(row(torus, 0.9), {}) is None
    # a stuck record is linear first, periodic-looking or not (its label comes from lambda_1)
    assert long_record_exemption(row(periodic, 1.0), {"law": "stick-slip"}) == LINEAR_VERDICT


def test_a_stuck_record_with_a_negative_exponent_is_periodic_1():
    """classify_points: a record with every element stuck (LINEAR_VERDICT) is labelled by its
    exact exponent: negative (the stuck beam's free vibration decays onto the forced response)
    gives periodic-1 whatever the samples show (here a torus), with the reason; zero (an
    undamped stuck mode) leaves the samples' reading, quasi-periodic."""
    from analysis.pipeline.stages import LINEAR_VERDICT

    x = torus2(N)
    sim = pd.DataFrame([{"point_id": "p", "omega": 1.0, "diverged": False, "n_transient_used": 200,
                         "poincare_state": x.tolist(), "continuation_reason": ""}])
    T = 2.0 * np.pi
    for lam, want in ((-1e-6 / T, ("periodic", 1)), (0.0, (QUASI_PERIODIC, None))):
        lyap = pd.DataFrame([{"point_id": "p", "lle_mean": lam, "lle_lo": lam, "lle_hi": lam,
                              "lle_verdict": LINEAR_VERDICT}])
        row = classify_points(sim, lyap).iloc[0]
        assert row["label"] == want[0], row["reason"]
        if want[1] is not None:
            assert row["period"] == 1 and "every element stuck" in row["reason"]
            assert "falling by e in 1e+06 periods" in row["reason"], row["reason"]
    # with the end state's bound on the future tractions (beamsim.shakedown): below 1 the label
    # stands with the proof in its reason; at or above 1 a later slip is not excluded and the
    # record is undetermined, whatever its exponent
    for bound, want in ((0.97, "periodic"), (1.0, "undetermined"), (1.3, "undetermined")):
        lyap = pd.DataFrame([{"point_id": "p", "lle_mean": -1e-6 / T, "lle_lo": -1e-6 / T,
                              "lle_hi": -1e-6 / T, "lle_verdict": LINEAR_VERDICT, "stuck_bound": bound}])
        row = classify_points(sim, lyap).iloc[0]
        assert row["label"] == want, (bound, row["reason"])
        assert (f"{bound:.3f}" in row["reason"]) and ("slip" in row["reason"]), row["reason"]
        assert pd.isna(row["period"]) == (want == "undetermined")
    # below the shakedown limit (the simulate record's shakedown_ratio < 1) a later slip is not
    # excluded by the bound, but every motion's total slip is finite: the motion ends on a
    # locked orbit, periodic-1 with that reason; above it the bound's verdict stands
    for kinetic, want in ((0.5, "periodic"), (1.2, "undetermined")):
        lyap = pd.DataFrame([{"point_id": "p", "lle_mean": -1e-6 / T, "lle_lo": -1e-6 / T,
                              "lle_hi": -1e-6 / T, "lle_verdict": LINEAR_VERDICT, "stuck_bound": 1.3}])
        row = classify_points(sim.assign(shakedown_ratio=kinetic, stick_fraction=1.0), lyap).iloc[0]
        assert row["label"] == want, (kinetic, row["reason"])
        assert ("shakedown limit" in row["reason"]) == (want == "periodic"), row["reason"]
    # the same exponent without the linear verdict (a measured one) does not relabel the torus
    lyap = pd.DataFrame([{"point_id": "p", "lle_mean": -1e-6 / T, "lle_lo": -0.01 / T,
                          "lle_hi": 0.01 / T, "lle_verdict": "non-positive"}])
    assert classify_points(sim, lyap).iloc[0]["label"] == QUASI_PERIODIC


# ----------------------------------------------------------------------------- continuation check
@pytest.mark.parametrize("noise", [0.0, 1e-4])
def test_continuing_a_settled_record_keeps_its_signature(noise: float) -> None:
    """Two consecutive records of every labelled set (periodic, tori, chaos) and of stationary
    chaotic windows pass the continuation check: no false alarm."""
    for name, (gen, _, _) in LABELLED.items():
        x = add_noise(gen(), noise)
        assert continuation_reason(x[:N], x[N:2 * N]) is None, name
    windows = _chaotic_windows(N, 20, 40)  # logistic and Henon windows alternate
    for a, b in zip(windows[:-2], windows[2:]):  # consecutive windows of one system
        assert continuation_reason(a, b) is None


@pytest.mark.parametrize("amp", [0.001, 0.003, 0.02])
def test_continuing_a_slow_remnant_finds_the_transient(amp: float) -> None:
    """A period-5 remnant decaying by 20 % per record passes the record's own tests (the decay
    inside one record is below their resolution) and is read as period 5; the next record
    differs (period 1 at the smallest amplitude, a smaller pattern at the others)."""
    x = remnant(amp, 1.2**2, 2 * N)
    first, then = x[:N], x[N:]
    assert transient_reason(first) is None and poincare_signature(first) == "periodic-5"
    why = continuation_reason(first, then)
    assert why is not None
    expected = "periodic-5 to periodic-1" if amp == 0.001 else "pattern shrinks by a factor 1.2"
    assert expected in why, why


@pytest.mark.parametrize("turn", [18, 2.618034, 7.77])
def test_continuing_a_slow_spiral_finds_the_transient(turn: float) -> None:
    """A focus decaying 1.2x per record (about 1400 periods to fall by e) rotating by 2 pi / 18
    or by angles of no short period: each record passes its own tests (1.25x is their threshold) and
    both records read alike, so the signature and pattern tests pass; the two records joined
    show the convergence (1.44x over the double baseline).  Before results version 21 such a
    spiral was labelled quasi-periodic or periodic-18 (referee review, 2026-11-28)."""
    x = spiral(1.2 ** 2, turn=turn, n=2 * N - 1)
    first, then = x[:N], x[N - 1:]
    assert transient_reason(first) is None and transient_reason(then) is None
    assert poincare_signature(first) == poincare_signature(then)
    why = continuation_reason(first, then)
    assert why is not None and "joined, are a transient: converging" in why, why


def test_the_joined_test_can_be_left_out() -> None:
    """``joined=False`` (the pipeline's choice for a record stuck at every element, which rule 3
    labels exactly) keeps the signature and pattern tests and drops the joined one."""
    x = spiral(1.2 ** 2, turn=18, n=2 * N - 1)
    first, then = x[:N], x[N - 1:]
    assert continuation_reason(first, then) is not None
    assert continuation_reason(first, then, joined=False) is None
    y = remnant(0.003, 1.2 ** 2, 2 * N)
    assert "pattern shrinks" in continuation_reason(y[:N], y[N:], joined=False)


@pytest.mark.xfail(strict=True, reason="a decay slower than about 1.12x per record (an e-fold in "
                   "more than 2200 periods) is not seen by one continuation check")
def test_known_limit_a_slower_spiral_passes_the_continuation_check() -> None:
    x = spiral(1.05 ** 2, turn=18, n=2 * N - 1)
    assert continuation_reason(x[:N], x[N - 1:]) is not None


def test_the_joined_check_rarely_alarms_on_stationary_chaos() -> None:
    """Consecutive windows of long logistic (r = 4) and Henon records (the latter as it is and
    mixed into 40 components), 200 pairs each: measured 1 of the 400 distinct joined records
    called a transient (with the drift test 4; it is left out of the joined check).  A false
    alarm costs one more check, not the label: the next pair is tested afresh."""
    alarms = 0
    for d in (0, 40):
        w = _chaotic_windows(N, 201, d)
        for a, b in zip(w[:-2], w[2:]):  # consecutive windows of one system
            joined = np.vstack([a, b[1:]])
            alarms += transient_reason(joined, min_drift=np.inf) is not None
    assert alarms <= 8, alarms  # of 2 x 400 pairs (the logistic ones twice): 1 % allowed


def test_continuing_a_locking_torus_finds_the_transient() -> None:
    """A torus that locks onto a period-3 orbit after its record."""
    why = continuation_reason(torus2(N), np.random.default_rng(3).normal(size=(3, 2))[np.arange(N) % 3])
    assert why is not None and "from aperiodic to periodic-3" in why


def test_a_failed_continuation_check_is_unsettled() -> None:
    """The classify stage labels a record whose last continuation check failed unsettled, with
    the check's reason, and the Lyapunov stage does not run its long record for it."""
    from analysis.pipeline.stages import long_record_exemption

    x = torus2(N)
    why = "continuing by 256 periods changes the record from aperiodic to periodic-3"
    sim = pd.DataFrame([{"point_id": "p", "omega": 1.0, "diverged": False, "n_transient_used": 968,
                         "poincare_state": x.tolist(), "continuation_reason": why}])
    T = 2.0 * np.pi
    lyap = pd.DataFrame([{"point_id": "p", "lle_mean": 0.0, "lle_lo": -0.01 / T, "lle_hi": 0.01 / T}])
    row = classify_points(sim, lyap).iloc[0]
    assert row["label"] == UNSETTLED and why in row["reason"] and "968" in row["reason"], row["reason"]
    assert classify_points(sim.assign(continuation_reason=""), lyap).iloc[0]["label"] == QUASI_PERIODIC
    sim_row = sim.iloc[0].copy()
    sim_row["stick_fraction"] = 0.5
    assert "the record is a transient" in long_record_exemption(sim_row, {})


def test_the_continuation_check_finds_a_slow_remnant_of_the_beam() -> None:
    """A default-grid point (two modes, Omega 5.97, f0_rel 1.06) whose record after 200 periods
    passes the record's own tests and reads period 5; a run of 2000 periods (the reference,
    independent of the check) settles on period 1.  The continuation check gets period 1 from
    the 200-period start: its first check fails (the record changes), the second passes.  (The
    runs without the check are also without the long run, which since results version 30
    follows such a record: its period 5 lies within twice the period tolerance of period 1.)"""
    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import simulate_runs
    from analysis.transients import near_shorter_period

    params = {"alpha1": 0.005, "alpha2": 0.005, "beta": 0.4, "bc": "clamped-free", "n_modes": 2,
              "k_t": 10.0, "damping": 0.0, "interface_viscosity": 0.0939, "law": "stick-slip",
              "mu_s": 0.45, "mu_k": 0.3, "p": 1e-4, "f0_rel": 1.05666829058, "Omega": 5.96758223128}

    def run(nm: Numerics) -> dict:
        return simulate_runs([{"point_id": "p", "params": params}], nm, 1)[0]

    unchecked = run(Numerics(continuation_check=False, n_long_transient=0))
    x = np.asarray(unchecked["poincare_state"])
    assert unchecked["n_transient_used"] == 200 and transient_reason(x) is None
    assert poincare_signature(x) == "periodic-5" and near_shorter_period(x, 5) == 1
    reference = run(Numerics(n_transient=2000, n_transient_max=2000, continuation_check=False,
                             n_long_transient=0))
    assert poincare_signature(np.asarray(reference["poincare_state"])) == "periodic-1"
    checked = run(Numerics())
    assert poincare_signature(np.asarray(checked["poincare_state"])) == "periodic-1"
    assert checked["n_transient_used"] == 200 + 2 * 256 and checked["continuation_reason"] == ""


class _ScriptedRuns:
    """``simulate_batch`` counting its batches (``runs``: ``(n_transient, points)``) and
    numbering the records it returns, so that record tests can be scripted per run."""

    def __init__(self, monkeypatch):
        import beamsim.simulate

        self.runs: list[tuple[int, int]] = []
        self.record_of: dict[int, int] = {}
        real = beamsim.simulate.simulate_batch

        def batch(params, n_transient, **kw):
            out = real(params, n_transient=n_transient, **kw)
            self.runs.append((n_transient, len(params)))
            for r in out.results:
                self.record_of[id(r.poincare_state)] = len(self.runs)
            return out

        monkeypatch.setattr(beamsim.simulate, "simulate_batch", batch)

    def run_of(self, x) -> int:
        return self.record_of[id(x)]


def test_a_record_kept_after_a_further_transient_is_checked_again(monkeypatch) -> None:
    """simulate_runs' bookkeeping, with the record tests scripted on real (short, one-mode)
    runs: the first record passes its own tests and goes to the continuation check; the check's
    record is still a transient, so a further adaptive transient and record follow; that new
    record must be checked again before the point is done (run order: transient + record, check,
    transient + record, check), and the transient used counts every run."""
    import analysis.regimes
    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import simulate_runs

    script = _ScriptedRuns(monkeypatch)

    def scripted_transient(x):  # the first check's record (run 2) is still a transient
        return script.run_of(x) == 2

    monkeypatch.setattr(analysis.regimes, "is_transient", scripted_transient)
    monkeypatch.setattr(analysis.regimes, "continuation_reason", lambda a, b, **kw: None)
    nm = Numerics(n_transient=3, n_record=5, n_transient_max=100, n_long_transient=0)
    params = {"n_modes": 1, "law": "stick-slip", "mu_s": 0.3, "mu_k": 0.3, "f0_rel": 2.0, "Omega": 1.5}
    out = simulate_runs([{"point_id": "p", "params": params}], nm, 1)[0]
    assert script.runs == [(3, 1), (0, 1), (3, 1), (0, 1)], script.runs
    assert out["n_transient_used"] == 2 * 3 + 3 * 5 and out["continuation_reason"] == ""
    assert not out["long_run"]


def test_the_long_run_follows_an_aperiodic_or_unsettled_record_once(monkeypatch) -> None:
    """simulate_runs' long run (``numerics.n_long_transient``), with the record tests scripted
    on real one-mode runs.  A record that passed its tests and its check but shows no period is
    run on once by ``n_long_transient`` periods and a fresh record, which is checked again; the
    record kept is that one (``long_run``), its transient counts every run; a record that still
    shows no period after it is not run on again.  A record still a transient at the cap (the
    map's ``unsettled``) has the long run too, and its fresh record the adaptive transient's
    budget of a run from rest.  A record with a period has none, nor does one with every
    element stuck (the linear analysis labels it), nor one below the shakedown limit (the
    theorem does)."""
    import analysis.regimes
    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import simulate_runs

    script = _ScriptedRuns(monkeypatch)
    transient_runs: set[int] = set()
    monkeypatch.setattr(analysis.regimes, "is_transient", lambda x: script.run_of(x) in transient_runs)
    monkeypatch.setattr(analysis.regimes, "continuation_reason", lambda a, b, **kw: None)
    monkeypatch.setattr(analysis.regimes, "poincare_signature", lambda x: "aperiodic")
    nm = Numerics(n_transient=3, n_record=128, n_transient_max=100, n_long_transient=40)
    params = {"n_modes": 1, "law": "stick-slip", "mu_s": 0.45, "mu_k": 0.3, "f0_rel": 2.0, "Omega": 1.5}
    out = simulate_runs([{"point_id": "p", "params": params}], nm, 1)[0]
    assert script.runs == [(3, 1), (0, 1), (40, 1), (0, 1)], script.runs
    assert out["long_run"] and out["n_transient_used"] == 3 + 128 + (128 + 40) + 128
    # the long run is the continuation of the run without it, to the bit
    import beamsim.simulate
    from beamsim.simulate import restart_params

    without = simulate_runs([{"point_id": "p", "params": params}], replace(nm, n_long_transient=0), 1)[0]
    assert not without["long_run"] and without["n_transient_used"] == 3 + 128
    kw = dict(n_record=128, method="expo", n_threads=1)
    start = beamsim.simulate.simulate_batch([params], n_transient=3, **kw).results[0]
    start = beamsim.simulate.simulate_batch([restart_params(start)], n_transient=0, **kw).results[0]
    assert np.array_equal(start.final_state, without["final_state"])
    long = beamsim.simulate.simulate_batch([restart_params(start)], n_transient=40, **kw).results[0]
    check = beamsim.simulate.simulate_batch([restart_params(long)], n_transient=0, **kw).results[0]
    assert np.array_equal(check.poincare_state, out["poincare_state"])
    # unsettled at the cap (every record of the first start a transient): the long run, then
    # the adaptive transient again within the budget of a run from rest (one more transient)
    script.runs.clear()
    transient_runs.update(range(1, 100))
    capped = replace(nm, n_transient_max=3 + 131)
    out = simulate_runs([{"point_id": "q", "params": params}], capped, 1)[0]
    after = [n for n, _ in script.runs]
    assert after[:2] == [3, 3] and after[2] == 40 and after[3:] == [3], after
    assert out["long_run"] and out["n_transient_used"] == 3 + 131 + 168 + 131
    # no long run: a record with a period, every element stuck, below the shakedown limit
    transient_runs.clear()
    monkeypatch.setattr(analysis.regimes, "poincare_signature", lambda x: "periodic-3")
    assert not simulate_runs([{"point_id": "r", "params": params}], nm, 1)[0]["long_run"]
    # (a record too short for the period test shows no period)
    assert simulate_runs([{"point_id": "r", "params": params}], replace(nm, n_record=5), 1)[0]["long_run"]
    monkeypatch.setattr(analysis.regimes, "poincare_signature", lambda x: "aperiodic")
    stuck = simulate_runs([{"point_id": "s", "params": params | {"f0_rel": 0.2}}], nm, 1)[0]
    assert stuck["stick_fraction"] == 1.0 and not stuck["long_run"]
    # a point's records do not depend on its batch: with the stuck point beside it (no long
    # run), on two threads, the first point's record is the one it has alone, to the bit
    pair = simulate_runs([{"point_id": "s", "params": params | {"f0_rel": 0.2}},
                          {"point_id": "p", "params": params}], nm, 2)
    assert pair[1]["long_run"] and not pair[0]["long_run"]
    alone = simulate_runs([{"point_id": "p", "params": params}], nm, 1)[0]
    for key in ("poincare_state", "final_state", "n_transient_used"):
        assert np.array_equal(pair[1][key], alone[key]), key
    from kicked_start import kicked_locked_orbit

    from analysis.pipeline.stages import locked_ratios
    from beamsim.point import prepare_point
    from beamsim.simulate import state_params

    low = params | {"interface_viscosity": 0.0939}
    low = low | {"f0_rel": 2.0 * 0.9 / locked_ratios(low)[1]}  # 0.9 of the shakedown limit
    pp = prepare_point(**low)
    kicked = state_params(low, kicked_locked_orbit(pp), pp.model.n)  # a start that slips
    # (a short record, which would have the long run above the limit, still slipping at the cap)
    short = replace(nm, n_record=5, n_transient_max=11)
    below = simulate_runs([{"point_id": "b", "params": kicked}], short, 1)[0]
    assert below["stick_fraction"] < 1.0 and below["shakedown_ratio"] < 1.0 and not below["long_run"]


def _run_default_cell(Omega: float, f0_rel: float, nm) -> dict:
    """``simulate_runs``' record of one cell of the default map (three modes, its friction and
    interface) under numerics ``nm``."""
    from analysis.pipeline.stages import simulate_runs

    params = {"alpha1": 0.005, "alpha2": 0.005, "beta": 0.4, "bc": "clamped-free", "n_modes": 3,
              "k_t": 10.0, "damping": 0.0, "interface_viscosity": 0.0939, "law": "stick-slip",
              "mu_s": 0.45, "mu_k": 0.3, "p": 1e-4, "f0_rel": f0_rel, "Omega": Omega}
    return simulate_runs([{"point_id": "p", "params": params}], nm, 1)[0]


def test_the_long_run_settles_an_unsettled_cell_of_the_default_map() -> None:
    """A cell of the default map (three modes, Omega 6.58, f0_rel 0.919) that the adaptive
    transient leaves ``unsettled``: after 2536 periods, continuing by 256 turns period 1 into
    period 7.  benchmarks/long_runs.py found it period-1 after 4000 periods more; with the
    shipped long run its record is a settled period-1 record that passes the continuation
    check."""
    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import unsettled_reason

    def run(nm: Numerics) -> dict:
        return _run_default_cell(6.58004611203, 0.919420813593, nm)

    short = run(Numerics(n_long_transient=0))
    assert not short["long_run"] and "periodic-1 to periodic-7" in unsettled_reason(short)
    assert Numerics().n_long_transient == 4000
    long = run(Numerics())
    x = np.asarray(long["poincare_state"])
    assert long["long_run"] and unsettled_reason(long) is None and transient_reason(x) is None
    assert poincare_signature(x) == "periodic-1"
    assert long["n_transient_used"] == short["n_transient_used"] + 256 + 4000 + 256


def _period_pattern(m: int, n: int = N, seed: int = 0) -> np.ndarray:
    """A period-``m`` pattern of unit spread in 3 components (samples ``n``)."""
    pat = np.random.default_rng(seed).uniform(-0.5, 0.5, size=(m, 3))
    return pat[np.arange(n) % m] / np.ptp(pat, axis=0)


@pytest.mark.parametrize("amp, near", [(0.03, 1), (0.035, 1), (0.05, None), (0.2, None)])
def test_a_period_m_reading_near_period_1_is_found(amp: float, near: int | None) -> None:
    """A fixed point with a period-16 wobble of ``amp`` of its component scale (the floor,
    a tenth of the largest magnitude, as at the beam's remnant): period 16 to the classifier,
    and within twice the period test's tolerance of period 1 when the wobble's spread is."""
    from analysis.poincare import component_scales
    from analysis.transients import near_shorter_period

    x = np.array([1.0, -0.5, 0.8]) + 0.1 * amp * _period_pattern(16)
    assert poincare_signature(x) == "periodic-16"
    assert near_shorter_period(x, 16) == near
    # period 1's residual is the wobble's spread over the scale (a tenth of max |x|: about amp)
    r1 = float(np.max(np.ptp(x, axis=0) / component_scales(x)))
    assert abs(r1 - amp) < 0.01 * amp
    assert near_shorter_period(x, 16, factor=r1 / 0.02 * 1.001) == 1
    assert near_shorter_period(x, 16, factor=r1 / 0.02 * 0.999) is None


def test_a_period_m_reading_near_a_divisor_is_found_and_not_near_another_period() -> None:
    """A period-11 orbit with a period-22 wobble of 3 % of the spread is near period 11 (its
    divisor), not near period 2; a clean period-22 orbit and a period-2 orbit are near none;
    a period-1 reading has no shorter period."""
    from analysis.transients import near_shorter_period

    base = _period_pattern(11)
    x = base + 0.03 * _period_pattern(22, seed=1)
    assert poincare_signature(x) == "periodic-22" and near_shorter_period(x, 22) == 11
    assert near_shorter_period(_period_pattern(22, seed=1), 22) is None
    assert near_shorter_period(_period_pattern(2), 2) is None
    assert near_shorter_period(np.ones((N, 3)), 1) is None


def test_the_long_run_follows_a_period_16_remnant_of_the_default_map() -> None:
    """A cell of the default map (three modes, Omega 5.97, f0_rel 0.858) that results version
    28 labelled periodic-16: a period-1 orbit with a slowly decaying wobble that keeps it 1.3
    times the period tolerance from period 1.  4000 periods more (the long run, since results
    version 30 also after such a record) leave a settled period-1 record."""
    from analysis.pipeline.config import Numerics
    from analysis.transients import near_shorter_period

    def run(nm: Numerics) -> dict:
        return _run_default_cell(5.96758223128, 0.857634334011, nm)

    short = run(Numerics(n_long_transient=0))
    x = np.asarray(short["poincare_state"])
    assert not short["long_run"] and transient_reason(x) is None and short["continuation_reason"] == ""
    assert poincare_signature(x) == "periodic-16" and near_shorter_period(x, 16) == 1
    long = run(Numerics())
    x = np.asarray(long["poincare_state"])
    assert long["long_run"] and transient_reason(x) is None and long["continuation_reason"] == ""
    assert poincare_signature(x) == "periodic-1"
    assert long["n_transient_used"] == short["n_transient_used"] + 256 + 4000 + 256


def test_part_medians_are_those_of_array_split() -> None:
    """``converging_period``'s part medians (equal-length parts in one call) are ``np.median``
    of each part ``np.array_split`` makes, to the bit, whatever the remainder."""
    from analysis.transients import _part_medians

    v = np.log(np.random.default_rng(5).random(250))
    for n in (250, 249, 243, 241, 64):
        for parts in (8, 7, 5):
            ref = np.array([np.median(p) for p in np.array_split(v[:n], parts)])
            assert _part_medians(v[:n], parts).tobytes() == ref.tobytes(), (n, parts)

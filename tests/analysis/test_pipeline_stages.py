"""The regime pipeline's stage functions (analysis.pipeline.stages) outside Snakemake: which
integrator a point's reference run uses, and that the fast one gives the regime map of the
RK4 reference."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from analysis.pipeline.grid import expand_grid
from analysis.pipeline.stages import (
    classify_points,
    integrator,
    lyapunov_points,
    poincare_array,
    simulate_points,
)
from analysis.pipeline.store import PointStore


def test_auto_integrator_is_expo_for_stick_slip_and_rk4_for_the_other_laws():
    assert integrator("auto", {"law": "stick-slip"}) == "expo"
    assert integrator("auto", {}) == "expo"  # stick-slip is the model default
    assert integrator("auto", {"law": "full-slip"}) == "rk4"
    assert integrator("auto", {"law": "stribeck"}) == "rk4"
    assert integrator("auto", {"law": "rigid-stick"}) == "rk4"
    for method in ("rk4", "expo", "newmark"):
        assert integrator(method, {"law": "stick-slip"}) == method


#: one-mode points of the default grid's friction: stuck torus, period-m, period 1, slip near
#: resonance
POINTS = [{"Omega": 2.5, "f0_rel": 0.8}, {"Omega": 5.0, "f0_rel": 1.05}, {"Omega": 1.5, "f0_rel": 2.64},
          {"Omega": 4.7, "f0_rel": 1.3}, {"Omega": 1.25, "f0_rel": 3.0}]


def test_expo_and_rk4_reference_runs_give_the_same_labels(tmp_path):
    """The pipeline's `auto` reference runs (expo) against the RK4 reference, through the
    simulate and classify stages (labels from the Poincare indicators; lambda_1 left out): the
    same label and period at every point.  On the periodic orbits the stroboscopic samples agree
    to 1e-4 of the largest coordinate and 2e-3 of the largest velocity (measured at Omega =
    1.25, f0_rel = 3: 4.5e-6 and 9.1e-4 against RK4 at a quarter of the step, whatever expo's
    output grid, 64 or 512 steps; RK4 at step factor 1.0 is 2.7e-4 off there: the velocities
    carry the fast interface modes, most likely the ones that feel expo's event-location error,
    docs/model.md).  Both are far inside the classifier's period tolerance (2 % of a component's
    scale, at least 0.2 % of the largest).  On the quasi-periodic ones the records drift along
    the torus, so the sets are compared: quantiles within that period tolerance, 2e-2 of the
    largest (measured at most 5.6e-3 in results version 28).  These are the records of the runs
    from rest without the long run (``n_long_transient``): after it (4000 periods more) the
    labels still agree, but one torus's velocity quantiles differ by 1.98e-2 (results version
    28), the integrators' difference carried along the tori's neutral directions 4000 periods
    longer."""
    model = {"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "interface_damping": 0.5, "Omega": 1.0,
             "f0_rel": 1.0}
    grid = {"axes": {"Omega": sorted({p["Omega"] for p in POINTS}),
                     "f0_rel": sorted({p["f0_rel"] for p in POINTS})}}
    tables, labels = {}, {}
    for method in ("auto", "rk4"):
        numerics = {"method": method, "n_transient": 60, "n_record": 128, "step_factor": 1.0,
                    "n_long_transient": 0}
        pts = [p for p in expand_grid("t", grid, model, numerics)
               if {"Omega": p.params["Omega"], "f0_rel": p.params["f0_rel"]} in POINTS]
        assert len(pts) == len(POINTS)
        payload = [{"point_id": p.point_id, "params": p.params} for p in pts]
        sim = simulate_points(payload, numerics, str(tmp_path / method), threads=2)
        assert (sim["method"] == ("expo" if method == "auto" else "rk4")).all()
        empty = pd.DataFrame({"point_id": [], "lle_stefanski": []})
        lab = classify_points(sim, empty)
        tables[method] = sim
        labels[method] = list(zip(lab["label"], lab["period"].astype(object)))
    assert labels["auto"] == labels["rk4"], labels
    assert len({lab for lab, _ in labels["rk4"]}) >= 2  # the points are not all of one kind
    # periodic orbits: sample by sample; quasi-periodic ones drift along the torus (a neutral
    # direction keeps any difference), so there the sets are compared: quantiles per component
    pairs = zip(labels["rk4"], tables["auto"]["poincare_state"], tables["rk4"]["poincare_state"])
    for (lab, _), a, b in pairs:
        xa, xb = poincare_array(a), poincare_array(b)
        n = xb.shape[1] // 2
        for grp, tol in ((slice(0, n), 1e-4), (slice(n, 2 * n), 2e-3)):  # coordinates, velocities
            size = np.max(np.abs(xb[:, grp]))
            if lab == "periodic":
                err = np.max(np.abs(xa[:, grp] - xb[:, grp])) / size
                assert err < tol, (lab, err)
            else:
                qs = np.linspace(0.05, 0.95, 7)
                qa, qb = np.quantile(xa[:, grp], qs, axis=0), np.quantile(xb[:, grp], qs, axis=0)
                err = np.max(np.abs(qa - qb)) / size
                assert err < 2e-2, (lab, err)


def _payload(params_list, numerics):
    from analysis.pipeline.grid import point_id

    return [{"point_id": point_id(p, numerics), "params": p} for p in params_list]


GOOD = {"n_modes": 1, "Omega": 2.5, "f0_rel": 2.0, "mu_s": 0.45, "mu_k": 0.3, "interface_damping": 0.5}
# the interface dashpot's rate, 2 zeta_t omega_max = 20 omega_max, is far outside RK4's stability
# interval at the pipeline's step h = 1 / omega_max: this (valid) point diverges with RK4
UNSTABLE = dict(GOOD, interface_damping=10.0)
# a short transient and no long run: the stages' bookkeeping, not the points' attractors
RK4 = {"method": "rk4", "n_transient": 3, "n_record": 128, "n_transient_max": 3, "step_factor": 1.0,
       "n_long_transient": 0,
       "lyapunov": {"n_periods": 10, "block_periods": 3, "burn_in": 1, "min_blocks": 2, "max_blocks": 3}}


def test_a_diverging_point_is_recorded_and_leaves_its_batch_alone(tmp_path):
    both = _payload([GOOD, UNSTABLE], RK4)
    sim = simulate_points(both, RK4, str(tmp_path / "both"), threads=2)
    alone = simulate_points(both[:1], RK4, str(tmp_path / "alone"), threads=1)
    assert list(sim["diverged"]) == [False, True]
    for col in ("poincare_state", "final_state", "stick_fraction", "diss_per_cycle"):
        assert np.asarray(sim[col][0]).tobytes() == np.asarray(alone[col][0]).tobytes(), col
    lle = lyapunov_points(both, sim, RK4, str(tmp_path / "both"), threads=2)
    assert lle["lle_stefanski_verdict"][1] == "not computed: diverged"
    assert np.isfinite(lle["lle_stefanski"][0]) and np.isnan(lle["lle_stefanski"][1])
    labels = classify_points(sim, lle)
    assert labels["label"][1] == "diverged" and labels["reason"][1] == "integration diverged"
    assert labels["label"][0] != "diverged"


def test_a_damaged_store_record_is_recomputed_not_loaded(tmp_path):
    pts = _payload([GOOD, dict(GOOD, Omega=1.5)], RK4)
    first = simulate_points(pts, RK4, str(tmp_path), threads=2)
    store = PointStore(tmp_path, "simulate")
    path = store.path(pts[1]["point_id"])
    path.write_bytes(path.read_bytes()[:200])  # truncated, as by a full disk
    assert store.find(pts[1]["point_id"]) is None
    again = simulate_points(pts, RK4, str(tmp_path), threads=2)
    pd.testing.assert_frame_equal(again, first)
    assert store.find(pts[1]["point_id"]) is not None


def test_the_ladder_setting_reaches_the_stefanski_column_only(tmp_path):
    """``numerics.lyapunov.ladder`` (``expo``, the default, or ``rk4``) picks the integrator of
    the Stefanski ladder only: at a chaotic two-mode point the Stefanski value changes and stays
    chaotic, the label's columns (the free copy's Benettin value and block statistics) are the
    same to the bit.  ``confirm: none``, so that no second opinion replaces the ``expo`` pair's
    reading (until results version 25 the test relied on the point's 256 Poincare samples
    saying chaos on their own, which for this intermittent set depends on the last bits)."""
    from beam_copies import CHAOTIC_2MODES as point

    base = {"n_transient": 200, "n_record": 256, "n_transient_max": 200, "continuation_check": False,
            "n_long_transient": 0,  # the record after 200 periods (after 4000 more it is not chaotic)
            "lyapunov": {"n_periods": 20, "block_periods": 5, "burn_in": 1, "min_blocks": 2, "max_blocks": 2,
                         "confirm": "none"}}
    rk4 = base | {"lyapunov": base["lyapunov"] | {"ladder": "rk4"}}
    pts = _payload([point], base)
    sim = simulate_points(pts, base, str(tmp_path), threads=2)
    b = lyapunov_points(pts, sim, base, str(tmp_path / "expo"), threads=2)
    a = lyapunov_points(_payload([point], rk4), sim.assign(point_id=_payload([point], rk4)[0]["point_id"]),
                        rk4, str(tmp_path / "rk4"), threads=2)
    for col in ("lle_benettin", "lle_mean", "lle_lo", "lle_hi", "lle_verdict"):
        assert np.array_equal(a[col].to_numpy(), b[col].to_numpy(), equal_nan=a[col].dtype.kind == "f"), col
    assert np.isfinite(a["lle_benettin"][0])
    assert a["lle_free_copy"][0] == b["lle_free_copy"][0] == "expo"
    assert a["lle_stefanski_verdict"][0].startswith("chaotic"), a["lle_stefanski_verdict"][0]
    assert b["lle_stefanski_verdict"][0].startswith("chaotic"), b["lle_stefanski_verdict"][0]
    assert a["lle_stefanski"][0] != b["lle_stefanski"][0]


def test_a_points_lyapunov_record_does_not_depend_on_its_batch(tmp_path):
    """The Lyapunov stage runs every point as a task of its own on the job's threads
    (``lyapunov_each``); a point's record is the one a batch of points gives
    (``lyapunov_runs``, every kernel threaded over the batch), to the bit, on one thread or
    two: a chaotic two-mode point (Stefanski ladder, long record) and a periodic one."""
    from beam_copies import CHAOTIC_2MODES as chaotic

    from analysis.pipeline.config import as_numerics
    from analysis.pipeline.stages import lyapunov_records, lyapunov_runs

    base = {"n_transient": 60, "n_record": 128, "n_transient_max": 60, "continuation_check": False,
            "n_long_transient": 0,
            "lyapunov": {"n_periods": 20, "block_periods": 5, "burn_in": 1, "min_blocks": 2, "max_blocks": 3}}
    pts = _payload([chaotic, chaotic | {"f0_rel": 0.9 * chaotic.get("f0_rel", 2.0)}], base)
    sim = simulate_points(pts, base, str(tmp_path), threads=2).set_index("point_id")
    nm = as_numerics(base)
    batch = lyapunov_runs(pts, sim, nm, 2)
    for threads in (1, 2):
        each = lyapunov_records(pts, sim, nm, threads)
        for b, e in zip(batch, each):
            assert b.keys() == e.keys()
            for col in b:
                assert np.asarray(b[col]).tobytes() == np.asarray(e[col]).tobytes(), (threads, col)
    assert batch[0]["lle_stefanski_verdict"].startswith("chaotic"), batch[0]["lle_stefanski_verdict"]


def test_a_stuck_record_gets_the_exact_exponent_and_its_attractor(tmp_path):
    """A one-mode point of the default friction below the slip onset: every element stays stuck
    over the record, whose Poincare samples show the free vibration the start-up left (a
    torus-like set).  The Lyapunov stage gives it the stuck beam's exact exponent (minus the
    slowest decay rate, not a window value) and the classify stage the attractor: with the
    interface dashpot every stuck mode is damped, so the free vibration decays onto the forced
    response, period 1.  Without any damping the stuck modes never decay: exponent 0, and the
    record's own reading stands (quasi-periodic)."""
    from analysis.pipeline.stages import LINEAR_VERDICT
    from beamsim.point import prepare_point

    numerics = {"n_transient": 60, "n_record": 128, "n_transient_max": 60}
    labels = {}
    for c_t in (0.0939, 0.0):
        model = {"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "interface_viscosity": c_t,
                 "Omega": 2.5, "f0_rel": 0.8}
        pts = expand_grid("t", {"axes": {"Omega": [2.5]}}, model, numerics)
        payload = [{"point_id": p.point_id, "params": p.params} for p in pts]
        sim = simulate_points(payload, numerics, str(tmp_path / str(c_t)), threads=1)
        assert sim["stick_fraction"].iloc[0] == 1.0
        lyap = lyapunov_points(payload, sim, numerics, str(tmp_path / str(c_t)), threads=1)
        rec = lyap.iloc[0]
        rate = prepare_point(**pts[0].params).model.stuck_decay_rate()
        assert rec["lle_verdict"] == LINEAR_VERDICT
        assert rec["lle_mean"] == rec["lle_lo"] == rec["lle_hi"] == -rate
        row = classify_points(sim, lyap).iloc[0]
        labels[c_t] = (row["label"], row["period"])
        # the end state's bound on the future tractions (beamsim.shakedown): with the dashpot no
        # element can slip again; without it the free vibration the start-up left can still
        # reach a slip limit (it does, about 5000 periods later: tests/beamsim/test_shakedown.py)
        assert (0.0 < rec["stuck_bound"] < 1.0) == (c_t > 0), (c_t, rec["stuck_bound"])
        if c_t > 0:
            assert rate > 0.0 and "every element stuck over the record" in row["reason"], row["reason"]
            assert "no element can slip again" in row["reason"], row["reason"]
        else:
            assert rate == 0.0
    assert labels[0.0939] == ("periodic", 1)
    assert labels[0.0][0] == "quasi-periodic", labels


def test_the_noise_floor_setting_reaches_the_stage(tmp_path):
    """``numerics.lyapunov.expo_floor`` reaches ``beam_lle`` through the Lyapunov stage: with
    the default guard (0.1 of ``expo_e0``) a one-mode slipping point keeps the ``expo`` pair and
    its table row carries the floor it measured; with a guard below that floor the same point
    runs on the RK4 pair (``lle_free_copy`` says why); with ``null`` no floor is measured."""
    from analysis.lyapunov.beam import EXPO_FLOOR_FALLBACK

    base = {"n_transient": 60, "n_record": 128, "n_transient_max": 60, "continuation_check": False,
            "n_long_transient": 0,
            "lyapunov": {"n_periods": 10, "block_periods": 5, "burn_in": 1, "min_blocks": 2, "max_blocks": 2}}
    point = dict(GOOD, f0_rel=2.5, mu_s=0.6)
    rows = {}
    for floor in (0.1, 1e-9, None):
        nm = base | {"lyapunov": base["lyapunov"] | {"expo_floor": floor}}
        pts = _payload([point], nm)
        sim = simulate_points(pts, nm, str(tmp_path / str(floor)), threads=2)
        rows[floor] = lyapunov_points(pts, sim, nm, str(tmp_path / f"l{floor}"), threads=2).iloc[0]
    n = rows[0.1]["lle_expo_floor"]
    assert rows[0.1]["lle_free_copy"] == "expo" and 1e-9 * 1e-4 < n < 0.1 * 1e-4, n
    assert rows[1e-9]["lle_free_copy"] == EXPO_FLOOR_FALLBACK and rows[1e-9]["lle_expo_floor"] == n
    assert rows[None]["lle_free_copy"] == "expo" and np.isnan(rows[None]["lle_expo_floor"])
    assert rows[None]["lle_mean"] == rows[0.1]["lle_mean"]


def test_a_slipping_record_below_the_shakedown_limit_is_continued_until_it_stops_slipping():
    """One mode at 0.9 of its shakedown limit (every motion slips a finite total distance,
    :func:`beamsim.shakedown.locked_orbit`), started with a velocity kick that keeps it slipping
    for about 200 periods: its first records slip, so the adaptive transient continues them
    until one is stuck at every element (labelled then by the stuck-record rule); with a cap
    too short for that the record is still a transient, the reason names the shakedown limit,
    and the classify stage labels it periodic-1 by the theorem (not settled), but only below
    the limit: with the ratio NaN or at 1 or above the slipping record is no transient by this
    rule (its samples decide).
    The same start at 1.3 of the limit is not held back by this rule (a record that slips
    there can be on an attractor)."""
    from kicked_start import kicked_locked_orbit

    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import locked_ratios, records_table, simulate_runs, unsettled_reason
    from beamsim.point import prepare_point
    from beamsim.simulate import state_params

    base = {"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "interface_viscosity": 0.0939, "Omega": 2.5,
            "f0_rel": 0.8}
    rk = locked_ratios(base)[1]

    def kicked(target: float) -> dict:
        p = base | {"f0_rel": base["f0_rel"] * target / rk}
        pp = prepare_point(**p)
        return state_params(p, kicked_locked_orbit(pp), pp.model.n)

    nm = Numerics(n_transient=20, n_record=32, n_transient_max=400, continuation_check=False,
                  n_long_transient=0)
    p = kicked(0.9)
    assert locked_ratios(p)[1] < 1.0
    rec = simulate_runs([{"point_id": "a", "params": p}], nm, 1)[0]
    assert rec["stick_fraction"] == 1.0 and rec["n_transient_used"] > 100
    assert rec["shakedown_ratio"] == pytest.approx(0.9) and unsettled_reason(rec) is None
    short = simulate_runs([{"point_id": "a", "params": p}], Numerics(n_transient=20, n_record=32,
                                                                     n_transient_max=60,
                                                                     continuation_check=False), 1)[0]
    assert short["stick_fraction"] < 1.0 and "shakedown limit" in unsettled_reason(short)
    # the classify stage: still a transient at the cap, but below the shakedown limit of a damped
    # stuck beam the attractor is known (a locked period-1 orbit), so the label is periodic-1
    sim = records_table([{"point_id": "a"}], [short])
    lyap = pd.DataFrame([{"point_id": "a", "lle_mean": np.nan, "lle_lo": np.nan, "lle_hi": np.nan}])
    row = classify_points(sim, lyap).iloc[0]
    assert (row["label"], row["period"]) == ("periodic", 1), row["reason"]
    assert row["reason"].startswith("period 1 by the shakedown limit") and not row["settled"]
    for other in (np.nan, 1.0, 1.3):  # the rule's boundary: no ratio, at the limit, above it
        why = unsettled_reason(short | {"shakedown_ratio": other})
        assert why is None or "shakedown" not in why
    # without any damping the slips still stop, but the free vibration left never decays: no
    # ratio, no rule (the record is labelled by what it shows)
    assert np.isnan(locked_ratios(base | {"interface_viscosity": 0.0})[1])
    for law in ({"law": "full-slip"}, {"law": "rigid-stick", "mu_s": 0.3}):  # no elastic stick: no ratios
        assert np.isnan(locked_ratios(base | law)).all()
    lock, kin = locked_ratios(base)
    assert kin == pytest.approx(lock * base["mu_s"] / base["mu_k"], rel=1e-12)
    above = simulate_runs([{"point_id": "b", "params": kicked(1.3)}], nm, 1)[0]
    assert above["n_transient_used"] == 20 and above["stick_fraction"] < 1.0
    assert unsettled_reason(above) is None or "shakedown" not in unsettled_reason(above)


@pytest.mark.parametrize("method", ["expo", "rk4"])
def test_the_shakedown_rule_holds_back_only_runs_whose_energy_falls(method, monkeypatch):
    """The rule continues a slipping record below the shakedown limit because every exact motion
    there has a falling energy ``W`` of its difference from the locked orbit
    (:func:`beamsim.shakedown.difference_energy`).  The pipeline checks that on its own runs
    (:class:`analysis.pipeline.stages.ShakedownWatch`): on the kicked start at 0.9 of the limit
    ``W`` at the start and at every run's end falls (both integrators; the independent check:
    the theorem), by orders of magnitude while the record slips, and no trouble is recorded.
    Where ``W`` grows (a fake ``W`` that grows after the first run: what an integrator that is
    not following the model would give) the record is not continued, carries the reason, and
    is ``unsettled`` with no verdict, not periodic-1 by the theorem, and the Lyapunov stage's
    verdict says the same.  Also: a start on the locked orbit (``W = 0``) and an unloaded point
    at rest (a zero locked orbit) are no trouble, and the continuation check's runs are
    watched too."""
    from kicked_start import kicked_locked_orbit

    import beamsim.shakedown
    from analysis.pipeline.config import Numerics
    from analysis.pipeline.stages import (
        locked_ratios,
        long_record_exemption,
        records_table,
        simulate_runs,
        unsettled_reason,
    )
    from beamsim.point import prepare_point
    from beamsim.simulate import state_params

    base = {"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "interface_viscosity": 0.0939, "Omega": 2.5,
            "f0_rel": 0.8}
    p = base | {"f0_rel": base["f0_rel"] * 0.9 / locked_ratios(base)[1]}
    pp = prepare_point(**p)
    p = state_params(p, kicked_locked_orbit(pp), pp.model.n)
    nm = Numerics(method=method, n_transient=20, n_record=32, n_transient_max=400, continuation_check=False)
    real = beamsim.shakedown.difference_energy
    seen: list[float] = []

    def spy(*args):
        seen.append(real(*args))
        return seen[-1]

    monkeypatch.setattr(beamsim.shakedown, "difference_energy", spy)
    rec = simulate_runs([{"point_id": "a", "params": p}], nm, 1)[0]
    runs = 1 + (rec["n_transient_used"] - 20) // (20 + 32)
    assert rec["shakedown_trouble"] == "" and rec["stick_fraction"] == 1.0 and runs > 3
    assert len(seen) == 2 + runs  # the state at rest (the scale), the start and every run's end
    w = seen[1:]
    assert np.all(np.diff(w) <= 1e-9 * np.asarray(w[:-1])), w
    assert w[-1] < 1e-3 * w[0]
    # a start on the locked orbit itself: W = 0 there and after, up to rounding, which is no
    # growth (measured against the orbit's own energy, not against a zero)
    monkeypatch.setattr(beamsim.shakedown, "difference_energy", real)
    on = state_params(p, beamsim.shakedown.locked_orbit(pp).state, pp.model.n)
    rec = simulate_runs([{"point_id": "o", "params": on}], nm, 1)[0]
    assert rec["shakedown_trouble"] == "" and rec["stick_fraction"] == 1.0
    fake = iter([1.0, 10.0, 8.0, 9.0, 1.0, 0.5, 0.1])  # W at rest (the scale), the start, runs
    monkeypatch.setattr(beamsim.shakedown, "difference_energy", lambda *args: next(fake))
    rec = simulate_runs([{"point_id": "a", "params": p}], nm, 1)[0]
    assert "grew from 8 to 9" in rec["shakedown_trouble"] and rec["n_transient_used"] == 20 + 52
    assert rec["stick_fraction"] < 1.0 and unsettled_reason(rec) == rec["shakedown_trouble"]
    sim = records_table([{"point_id": "a"}], [rec])
    lyap = pd.DataFrame([{"point_id": "a", "lle_mean": np.nan, "lle_lo": np.nan, "lle_hi": np.nan}])
    row = classify_points(sim, lyap).iloc[0]
    assert row["label"] == "unsettled" and row["reason"].startswith("no verdict: the energy W"), row["reason"]
    # the Lyapunov stage does not call it labelled by the theorem either
    assert long_record_exemption(sim.iloc[0], p).startswith("not measured: the record is not a motion")
    # the default continuation check's runs are watched too; an unloaded point at rest (W = 0,
    # a zero locked orbit) stays at rest: no growth, no division by zero
    monkeypatch.setattr(beamsim.shakedown, "difference_energy", spy)
    seen.clear()
    checked = replace(nm, continuation_check=True, n_record=128, n_transient_max=600)
    rec = simulate_runs([{"point_id": "c", "params": p}], checked, 1)[0]
    w = seen[1:]
    assert rec["shakedown_trouble"] == "" and rec["stick_fraction"] == 1.0
    assert len(w) > 2 + (rec["n_transient_used"] - 20) // (20 + 128)  # a check run after the transients
    assert np.all(np.diff(w) <= 1e-9 * np.asarray(w[:-1])), w
    rest = simulate_runs([{"point_id": "r", "params": base | {"f0_rel": 0.0}}], nm, 1)[0]
    assert rest["shakedown_trouble"] == "" and locked_ratios(base | {"f0_rel": 0.0})[1] == 0.0

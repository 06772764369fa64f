"""analysis.pipeline.chaos_lifetime: copies of a cell below its lock-up limit run until they
lock; against the shakedown theorem (below the shakedown limit every motion locks), the
selection of cells, the seeded copies and the settings' checks."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from kicked_start import kicked_locked_orbit

from analysis.lifetimes import exponential_lifetime
from analysis.pipeline.chaos_lifetime import (
    LifetimeSettings,
    chaos_lifetimes,
    copy_outcome,
    copy_starts,
    decorrelation_periods,
    lifetime_cells,
    summary_line,
)
from beamsim.point import prepare_point
from beamsim.shakedown import locked_orbit, shakedown_ratio

ROOT = Path(__file__).resolve().parents[2]

#: the one-mode point of tests/beamsim/test_shakedown.py (the default grid's friction)
POINT = {"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "interface_viscosity": 0.0939, "Omega": 2.5}
NUMERICS = {"method": "expo"}


def _row(target: float, index: int, label: str = "chaotic",
         lle_lo_T: float = 14.0) -> tuple[dict, np.ndarray]:
    """A map row at ``target`` times the shakedown load of ``POINT``, its end state a start far
    off the locked orbit (a velocity kick of 30 times the orbit's scale in the slowest stuck
    mode: it slips for many periods); the lower end of its exponent interval ``lle_lo_T`` per
    forcing period (by default copies perturbed by 1e-6 decorrelate within one period)."""
    pp0 = prepare_point(**POINT, f0_rel=0.8)
    params = POINT | {"f0_rel": 0.8 * target / shakedown_ratio(pp0)}
    pp = prepare_point(**params)
    orbit = locked_orbit(pp)
    x = kicked_locked_orbit(pp)
    row = {"point_id": f"p{index}", "Omega": params["Omega"], "f0_rel": params["f0_rel"], "index_0": index,
           "label": label, "lle_mean": 0.01, "lle_lo": lle_lo_T * pp.omega / (2 * np.pi),
           "omega": pp.omega, "lock_ratio": float(orbit.ratio.max()),
           "shakedown_ratio": shakedown_ratio(pp), "stick_fraction": 0.9, "diverged": False,
           "params_json": json.dumps(params)}
    return row, x


def test_below_the_shakedown_limit_every_copy_locks_and_is_proven_to_stay():
    """At half the shakedown limit the theorem says every motion stops slipping: every copy
    escapes (to a locked orbit whose stuck state the bound proves), after a slipping start of
    tens of periods, and the estimate is that of its escape times."""
    row, x = _row(0.5, 0)
    sim = pd.DataFrame({"point_id": ["p0"], "final_state": [x]})
    st = LifetimeSettings.from_dict({"copies": 3, "periods": 300})
    out = chaos_lifetimes(pd.DataFrame([row]), sim, NUMERICS, st, ["Omega", "f0_rel"])
    r = out.iloc[0]
    assert r["n_escaped"] == 3 and r["n_unproven"] == 0 and r["n_failed"] == 0
    assert all(20 < t < 300 for t in r["escape_periods"])
    assert r["decorrelation"] == 1.0 and r["n_counted"] == 3  # the others count after one period
    est = exponential_lifetime(r["escape_periods"], [True] * 3, entries=[0.0, 1.0, 1.0])
    assert r["lifetime"] == pytest.approx(est.lifetime) and r["exposure"] == sum(r["escape_periods"]) - 2
    assert (f"1 with copies proven to end locked (a transient, mean lifetimes {r['lifetime']:.0f} periods)"
            in summary_line(out))


def test_a_stuck_end_the_bound_does_not_prove_is_censored_where_the_stuck_stretch_starts():
    """At 0.9 of the shakedown limit the same start slips for about 200 periods and then stays
    stuck to the run's end, but the bound on its future tractions (a sum over the stuck modes'
    free vibration, which the kick left large) stays above 1: no escape is counted; each copy
    is censored where its stuck stretch starts (known on the slipping set until then)."""
    row, x = _row(0.9, 0)
    sim = pd.DataFrame({"point_id": ["p0"], "final_state": [x]})
    st = LifetimeSettings.from_dict({"copies": 2, "periods": 300})
    r = chaos_lifetimes(pd.DataFrame([row]), sim, NUMERICS, st, ["Omega", "f0_rel"]).iloc[0]
    assert r["n_escaped"] == 0 and r["n_unproven"] == 2
    assert all(100 < t < 300 for t in r["censor_periods"]) and r["exposure"] == sum(r["censor_periods"]) - 1


def test_the_table_does_not_depend_on_the_thread_count():
    rows = [_row(0.9, 0), _row(0.5, 1)]
    table = pd.DataFrame([r for r, _ in rows])
    sim = pd.DataFrame({"point_id": ["p0", "p1"], "final_state": [x for _, x in rows]})
    st = LifetimeSettings.from_dict({"copies": 3, "periods": 120})
    one, two = (chaos_lifetimes(table, sim, NUMERICS, st, ["Omega", "f0_rel"], threads=k) for k in (1, 2))
    pd.testing.assert_frame_equal(one, two, check_exact=True)


def test_a_copy_that_still_slips_is_censored_at_the_horizon():
    """The same start at 0.9 of the shakedown limit run for fewer periods than it slips: no
    escape, every copy censored at the horizon, and the mean lifetime bounded from below."""
    row, x = _row(0.9, 0)
    sim = pd.DataFrame({"point_id": ["p0"], "final_state": [x]})
    st = LifetimeSettings.from_dict({"copies": 2, "periods": 10})
    r = chaos_lifetimes(pd.DataFrame([row]), sim, NUMERICS, st, ["Omega", "f0_rel"]).iloc[0]
    assert r["n_escaped"] == 0 and list(r["censor_periods"]) == [10, 10]
    assert r["lifetime"] == np.inf and r["lifetime_lo"] == pytest.approx((10 + 9) / 3.6889, rel=1e-4)
    assert summary_line(pd.DataFrame([r])).endswith(": 1 without (mean lifetime > 5 periods)")


def test_copies_of_a_motion_without_exponential_divergence_count_as_one():
    """Where the lower end of the map's exponent interval is not above zero (a torus, an
    undetermined record) the copies need not decorrelate: one trajectory, so only the first counts (its own
    escape time is the exposure), whatever the others did; they are still reported."""
    row, x = _row(0.5, 0, lle_lo_T=-0.01)
    sim = pd.DataFrame({"point_id": ["p0"], "final_state": [x]})
    st = LifetimeSettings.from_dict({"copies": 3, "periods": 300})
    r = chaos_lifetimes(pd.DataFrame([row]), sim, NUMERICS, st, ["Omega", "f0_rel"]).iloc[0]
    assert r["n_escaped"] == 3 and r["decorrelation"] == np.inf and r["n_counted"] == 1
    assert r["exposure"] in set(r["escape_periods"]) and r["lifetime"] == pytest.approx(r["exposure"])
    assert r["lifetime_hi"] > 30 * r["lifetime"]  # one escape: a wide interval


def test_the_decorrelation_time_is_the_growth_of_the_perturbation_to_the_attractors_size():
    assert decorrelation_periods(0.5, 1e-6) == np.ceil(np.log(1e6) / 0.5) == 28.0
    assert decorrelation_periods(14.0, 1e-6) == 1.0
    for lam in (0.0, -0.2, np.nan):
        assert decorrelation_periods(lam, 1e-6) == np.inf


def test_cells_are_those_below_the_lock_up_limit_that_slip_with_the_labels_set():
    rows = [_row(0.9, i)[0] for i in range(6)]
    rows[1]["lock_ratio"] = 1.02          # above the lock-up limit: no locked orbit to escape to
    rows[2]["stick_fraction"] = 1.0       # the map's run is locked itself
    rows[3]["label"] = "quasi-periodic"   # a torus may approach the locked orbit: run by default
    rows[4]["diverged"] = True
    rows[5]["label"] = "undetermined"     # looks chaotic: run by default (since 2026-11-29)
    table = pd.DataFrame(rows)
    assert list(lifetime_cells(table, LifetimeSettings())["point_id"]) == ["p0", "p3", "p5"]
    periodic = table.assign(label="periodic")  # slipping periodic orbits keep their copies: not run
    assert lifetime_cells(periodic, LifetimeSettings()).empty
    shipped = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["lifetimes"]
    assert LifetimeSettings.from_dict(shipped) == LifetimeSettings()  # the config's are the defaults
    both = LifetimeSettings.from_dict({"labels": ["chaotic", "quasi-periodic"]})
    assert list(lifetime_cells(table, both)["point_id"]) == ["p0", "p3"]
    first = LifetimeSettings.from_dict({"max_cells": 1, "labels": ["quasi-periodic", "chaotic"]})
    assert list(lifetime_cells(table, first)["point_id"]) == ["p0"]  # the first in grid order


def test_copies_are_seeded_by_the_cell_and_perturb_only_coordinates_and_velocities():
    row, x = _row(0.9, 0)
    params = json.loads(row["params_json"])
    st = LifetimeSettings.from_dict({"copies": 3, "perturbation": 1e-6})
    a, b = copy_starts(params, x, [4, 7], st), copy_starts(params, x, [4, 7], st)
    c = copy_starts(params, x, [4, 8], st)
    n = prepare_point(**params).model.n
    for s, t in zip(a, b):
        assert np.array_equal(s["q0"], t["q0"]) and np.array_equal(s["v0"], t["v0"])
    assert not np.array_equal(a[0]["q0"], c[0]["q0"]) and not np.array_equal(a[0]["q0"], a[1]["q0"])
    rel = np.abs(a[0]["q0"] - x[:n]).max() / np.abs(x[:n]).max()
    assert 1e-8 < rel < 1e-5
    nq = (x.size - 2 * n) // 2
    assert np.array_equal(a[0]["z0"], x[2 * n:2 * n + nq]) and np.array_equal(a[0]["mode0"], x[2 * n + nq:])


@pytest.mark.parametrize("bad, match", [
    ({"copies": -1}, "lifetimes.copies"), ({"periods": 0}, "lifetimes.periods"),
    ({"perturbation": 0.5}, "lifetimes.perturbation"), ({"labels": ["chaos"]}, "lifetimes.labels"),
    ({"labels": []}, "lifetimes.labels"), ({"sample": 3}, "unknown key"),
    ({"copies": True}, "lifetimes.copies"),
])
def test_settings_refuse_bad_values_naming_the_key(bad, match):
    with pytest.raises(ValueError, match=match):
        LifetimeSettings.from_dict(bad)
    assert LifetimeSettings.from_dict({"copies": 0}).active is False
    assert LifetimeSettings.from_dict(LifetimeSettings().as_dict()) == LifetimeSettings()


def _fake_run(diss, flags=0.0, diverged=False, n_zeno=0):
    """A stand-in for a copy's :class:`beamsim.results.SimResult`: friction work per period
    ``diss``, end state of the one-mode model with every element's flag ``flags``."""
    from types import SimpleNamespace

    pp = prepare_point(**POINT, f0_rel=0.8)
    n, nq = pp.model.n, pp.model.n_quad
    final = np.concatenate([np.zeros(2 * n + nq), np.full(nq, flags)])
    energy = np.zeros((len(diss) + 1, 5))
    energy[1:, 1] = np.cumsum(diss)
    return pp, SimpleNamespace(diverged=diverged, n_zeno=n_zeno, energy=energy,
                               diss_per_cycle=np.diff(energy[:, 1]), final_state=final)


def test_a_copys_escape_time_is_the_count_of_periods_up_to_its_last_slip(monkeypatch):
    """The escape time is the number of periods up to and including the last one with friction
    work (0 when there is none); the end must be stuck at every element and proven to stay so,
    else the copy is censored at that time; a run that slips in its last period is censored at
    its length; a diverged run or one that met the Zeno guard is left out."""
    import analysis.pipeline.stages as stages

    bound = {"value": 0.5}
    monkeypatch.setattr(stages, "stuck_bound", lambda pp, x: bound["value"])
    pp, run = _fake_run([1.0, 2.0, 0.5, 0.0, 0.0, 0.0])
    assert copy_outcome(run, pp) == ("escaped", 3.0)
    pp, run = _fake_run([0.0] * 4)
    assert copy_outcome(run, pp) == ("escaped", 0.0)
    pp, run = _fake_run([1.0, 0.0, 0.0, 0.5])
    assert copy_outcome(run, pp) == ("slipping", 4.0)
    pp, run = _fake_run([1.0, 0.0, 0.0], flags=1.0)  # an element still flagged slipping at the end
    assert copy_outcome(run, pp) == ("unproven", 1.0)
    bound["value"] = 1.2
    pp, run = _fake_run([1.0, 0.0, 0.0])
    assert copy_outcome(run, pp) == ("unproven", 1.0)
    for kw in ({"diverged": True}, {"n_zeno": 3}):
        pp, run = _fake_run([1.0, 0.0], **kw)
        kind, t = copy_outcome(run, pp)
        assert kind == "failed" and np.isnan(t)
    pp, run = _fake_run([1.0, np.nan])
    assert copy_outcome(run, pp)[0] == "failed"


def test_a_cell_with_no_time_observed_is_unmeasured_not_a_bound():
    rows = pd.DataFrame({"n_escaped": [2, 0, 0], "n_unproven": [0, 1, 0],
                         "exposure": [900.0, 15000.0, 0.0], "lifetime": [450.0, np.inf, np.nan],
                         "lifetime_lo": [200.0, 4066.0, np.nan]})
    assert summary_line(rows) == (
        "lifetimes of 3 cells below the lock-up limit: 1 with copies proven to end locked (a transient, "
        "mean lifetimes 450 periods), 1 without (mean lifetime > 4066 periods; 1 with copies stuck at "
        "the end, not proven), 1 not measured (no time observed)")
    early = rows.iloc[:1].assign(lifetime=np.inf)  # escapes only of copies that do not count
    assert summary_line(pd.concat([rows.iloc[:1], early])) == (
        "lifetimes of 2 cells below the lock-up limit: 2 with copies proven to end locked (a transient, "
        "mean lifetimes 450 periods; 1 with no escape among the copies counted)")
    # a torus (its copies never part) beside a chaotic cell: its bound, one copy's, given apart
    torus = rows.iloc[1:2].assign(decorrelation=np.inf, periods=2000, lifetime_lo=542.0, n_unproven=0)
    chaos = rows.iloc[1:2].assign(decorrelation=40.0, periods=2000, n_unproven=0)
    assert summary_line(pd.concat([chaos, torus])).endswith(
        "2 without (mean lifetime > 4066 periods; 1 whose copies do not decorrelate within the run: > 542)")
    assert summary_line(torus).endswith(
        "1 without (mean lifetime > 542 periods; copies that do not decorrelate within the run)")


def test_copies_run_on_the_integrator_of_the_maps_run():
    """A cell whose map run fell back to RK4 (``expo`` met its Zeno guard) gets RK4 copies; the
    others the configured integrator."""
    from analysis.pipeline.chaos_lifetime import _map_integrator
    from analysis.pipeline.config import as_numerics
    from beamsim.results import ZENO_FALLBACK

    row, _ = _row(0.9, 0)
    params = json.loads(row["params_json"])
    nm = as_numerics(NUMERICS)
    assert _map_integrator(pd.Series(row | {"method": ZENO_FALLBACK}), nm, params) == "rk4"
    assert _map_integrator(pd.Series(row | {"method": "expo"}), nm, params) == "expo"

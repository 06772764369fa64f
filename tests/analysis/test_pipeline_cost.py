"""The run-cost estimate (analysis.pipeline.cost) and the checks before a run
(analysis.pipeline.preflight): what counts as new work, how the estimate scales, the opt-in for
long runs; and through the workflow, a 10,000-point grid planned by a dry run but refused by a
real run without ``allow_long``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from snakemake.exceptions import WorkflowError
from workflow_run import setup_workdir, snakemake

from analysis.pipeline.chaos_lifetime import LifetimeSettings
from analysis.pipeline.config import LyapunovNumerics, Numerics
from analysis.pipeline.convergence import K_T_STEPS, refine
from analysis.pipeline.cost import (
    EXTENDED_SHARE,
    LABEL_SHARE,
    LONG_RUN_SECONDS,
    LONG_TRANSIENT_SHARE,
    MOVED_SHARE,
    Estimate,
    convergence_cells,
    estimate_run,
    lifetime_seconds,
    load_cost_model,
    point_seconds,
    rk4_stiffness,
)
from analysis.pipeline.grid import expand_grid
from analysis.pipeline.preflight import check_results_dir, check_run_length
from analysis.pipeline.store import PointStore
from beamsim.point import period_steps, prepare_point

MODEL = {"n_modes": 2, "mu_s": 0.45, "mu_k": 0.3, "f0_rel": 2.0}


def _points(omegas, numerics=Numerics()):
    return expand_grid("g", {"axes": {"Omega": list(omegas)}}, MODEL, numerics.result_dict())


def test_the_shipped_cost_model_covers_every_method_and_is_positive():
    model = load_cost_model()
    for table in (model["simulate"]["expo"], model["simulate"]["rk4"], model["lyapunov"]["expo"],
                  model["lyapunov"]["rk4"], model["bytes_per_point"]):
        assert sorted(table) == [1, 2, 3] and all(v > 0 for v in table.values())
    # a fixed-length RK4 run and the store's records: more modes, more state, never cheaper.
    # The other coefficients average a regime-dependent workload over the 8-point sample (expo's
    # events, adaptive transients, the Stefanski ladder at the points it runs), which the mode
    # count changes too, so they need not be monotone (docs/reliability.md)
    for table in (model["simulate"]["rk4"], model["bytes_per_point"]):
        assert table[1] <= table[2] <= table[3]


def test_only_points_without_a_store_record_count_as_new(tmp_path):
    pts = _points([1.5, 2.0, 3.0])
    full = estimate_run(pts, Numerics(), tmp_path)
    assert (full.points, full.new_simulate, full.new_lyapunov) == (3, 3, 3)
    PointStore(tmp_path, "simulate").save(pts[0].point_id, {"x": np.zeros(2)})
    part = estimate_run(pts, Numerics(), tmp_path)
    assert (part.new_simulate, part.new_lyapunov) == (2, 3) and part.cpu_seconds < full.cpu_seconds
    PointStore(tmp_path, "lyapunov").save(pts[0].point_id, {"x": np.zeros(2)})
    assert estimate_run(pts, Numerics(), tmp_path).cpu_seconds == pytest.approx(
        estimate_run(pts[1:], Numerics(), tmp_path).cpu_seconds)


def test_the_estimate_scales_with_simulated_time(tmp_path):
    one = estimate_run(_points([2.0]), Numerics(), tmp_path).cpu_seconds
    assert estimate_run(_points([4.0]), Numerics(), tmp_path).cpu_seconds == pytest.approx(one / 2)
    # twice the periods of every run: the reference run (its expected continuation, its
    # continuation check and its expected long run), the Stefanski window and the expected long
    # record
    longer = Numerics(n_transient=2 * 200, n_record=2 * 256, n_transient_max=2400, n_long_transient=2 * 4000,
                      lyapunov=LyapunovNumerics(n_periods=50, block_periods=50, burn_in=50))
    assert estimate_run(_points([2.0], longer), longer, tmp_path).cpu_seconds == pytest.approx(2 * one)


def test_the_long_run_is_in_the_estimate(tmp_path):
    """The long run adds its periods to the expected share of the points: the estimate grows
    linearly with ``n_long_transient``, by ``LONG_TRANSIENT_SHARE`` of a point's cost per period."""
    pts = _points([2.0, 3.0])
    cost = {n: estimate_run(pts, replace(Numerics(), n_long_transient=n), tmp_path).cpu_seconds
            for n in (0, 4000, 8000, 12000)}
    assert cost[4000] > cost[0] and 0 < cost[8000] - cost[4000] == pytest.approx(cost[12000] - cost[8000])
    # a point's reference run: the cost of one period from its estimate without a long run (the
    # fixed transient, the record, the check and the expected continuations)
    nm = replace(Numerics(), n_long_transient=0)
    run = nm.n_transient + nm.n_record
    periods = run * (1.0 + EXTENDED_SHARE) + nm.n_record
    for p in pts:
        per_period = point_seconds(p.params, nm, load_cost_model(), ("simulate",)) / periods
        assert point_seconds(p.params, Numerics(), load_cost_model(), ("simulate",)) == pytest.approx(
            (periods + LONG_TRANSIENT_SHARE * (4000 + 2 * nm.n_record)) * per_period)


def test_the_convergence_runs_are_in_the_estimate(tmp_path):
    """Each refinement adds ``sample`` refined point runs: the windows' doubled periods cost
    twice a map point, the halved Lyapunov step twice its Lyapunov part, one more mode a point
    at that mode count (the measured coefficients decide whether that is more: per nominal
    period they carry the sample's adaptive transients)."""
    pts = _points([2.0, 3.0, 4.0])
    base = estimate_run(pts, Numerics(), tmp_path)
    mean = base.cpu_seconds / len(pts)
    windows = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, ["windows"], 2)])
    assert windows.convergence_runs == 2
    # every window doubled but the long run, which the row keeps (the long_run row refines it)
    doubled = [refine("windows", p.params, Numerics()) for p in pts]
    assert {n.n_long_transient for _, n in doubled} == {Numerics().n_long_transient}
    per_run = sum(point_seconds(q, n, load_cost_model(), ("simulate", "lyapunov"))
                  for q, n in doubled) / len(pts)
    assert windows.cpu_seconds - base.cpu_seconds == pytest.approx(2 * per_run)
    assert mean < per_run < 2 * mean
    # a tenth of the separation: the map's reference runs are read, the Lyapunov stage runs
    sep = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, ["separation"], 2)])
    lyap = sum(point_seconds(p.params, Numerics(), load_cost_model(), ("lyapunov",)) for p in pts)
    assert sep.convergence_runs == 2 and 0 < lyap < base.cpu_seconds
    assert sep.cpu_seconds - base.cpu_seconds == pytest.approx(2 * lyap / len(pts))
    modes = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, ["modes"], 2)])
    more = expand_grid("g", {"axes": {"Omega": [2.0, 3.0, 4.0]}}, MODEL | {"n_modes": 3},
                       Numerics().result_dict())
    # at one mode more, and MOVED_SHARE of the sample followed from the map's attractor (one
    # carried step: a simulate and a Lyapunov run, a point's cost again)
    assert modes.cpu_seconds - base.cpu_seconds == pytest.approx(
        (1 + MOVED_SHARE) * 2 * estimate_run(more, Numerics(), tmp_path).cpu_seconds / len(more))
    assert modes.convergence_runs == 2 + round(MOVED_SHARE * 2)
    # k_t x 3: the refined points, then the moved share's path, K_T_STEPS simulate runs each
    kt = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, ["k_t"], 2)])
    refined = [refine("k_t", p.params, Numerics()) for p in pts]
    sim, lyap = ([point_seconds(q, n, load_cost_model(), (stage,)) for q, n in refined]
                 for stage in ("simulate", "lyapunov"))
    assert kt.cpu_seconds - base.cpu_seconds == pytest.approx(
        2 * (sum(sim) + sum(lyap)) / len(pts)
        + MOVED_SHARE * 2 * (K_T_STEPS * sum(sim) + sum(lyap)) / len(pts))
    none = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, [], 2), (pts, ["k_t"], 0)])
    assert none.cpu_seconds == base.cpu_seconds and none.convergence_runs == 0
    many = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, ["k_t"], 50)])
    assert many.convergence_runs == 3 + round(MOVED_SHARE * 3)  # the sample is at most the grid
    line = estimate_run(pts, Numerics(), tmp_path, lines=[pts[:2]])  # two points, up and down
    assert line.convergence_runs == 4
    assert line.cpu_seconds - base.cpu_seconds == pytest.approx(
        2 * estimate_run(pts[:2], Numerics(), tmp_path).cpu_seconds)
    multi = estimate_run(pts, Numerics(), tmp_path, multistability=[(pts, 2, 5)])  # 2 cells, 5 starts
    assert multi.convergence_runs == 10
    # 10 runs, each at most a mean point's both stages (the Lyapunov stage for half of them)
    assert base.cpu_seconds < multi.cpu_seconds < base.cpu_seconds + 10 * mean
    off = estimate_run(pts, Numerics(), tmp_path, multistability=[(pts, 0, 5)])
    assert off.cpu_seconds == base.cpu_seconds and off.convergence_runs == 0
    assert "4 convergence / continuation / multistability / lifetime runs" in many.summary(2)
    one = estimate_run(pts, Numerics(), tmp_path, convergence=[(pts, ["k_t"], 1)])
    assert "1 convergence / continuation / multistability / lifetime run;" in one.summary(2)


def test_a_census_adds_the_expected_cells_of_its_labels():
    """A census (``convergence.census``) adds each label's expected share of the grid's cells
    to the sample, never more than the grid; the shares are a map's composition."""
    assert convergence_cells(20, (), 400) == 20
    assert convergence_cells(20, ["chaotic"], 400) == 20 + round(LABEL_SHARE["chaotic"] * 400)
    assert convergence_cells(0, ["chaotic", "quasi-periodic"], 400) == 26 + 24
    assert convergence_cells(20, list(LABEL_SHARE), 30) == 30
    assert sum(LABEL_SHARE.values()) == pytest.approx(1.0)


def test_an_rk4_run_costs_its_steps():
    """RK4's step is ``step_factor / omega_max``, so a stiffer point costs more steps per
    period: the regularised laws' velocity band (a stiff dashpot, slope ``F_s / eps_v``), a
    stiffer stick (``k_t x 3``); the rigid stick, without penalty springs, fewer.  The cost
    model's RK4 coefficients were measured on stick-slip points at the default ``k_t``, whose
    ratio is exactly 1.  ``expo``'s cost does not follow the step."""
    model, nm = load_cost_model(), Numerics()
    dry = MODEL | {"Omega": 1.5}
    assert rk4_stiffness(dry) == 1.0
    wet = dry | {"law": "stribeck", "mu_s": 0.3, "v_s": 4e-4}
    ratio = rk4_stiffness(wet)
    assert ratio > 2  # the band's rate is several times the stuck beam's fastest mode
    rk4 = Numerics(method="rk4")
    assert point_seconds(wet, nm, model, ("simulate",)) == pytest.approx(
        ratio * point_seconds(wet | {"law": "stick-slip"}, rk4, model, ("simulate",)))
    # its Lyapunov pair is RK4 (the regularised laws have no expo): the same factor
    pair = Numerics(lyapunov=LyapunovNumerics(method="rk4"))
    assert point_seconds(wet, nm, model, ("lyapunov",)) == pytest.approx(
        ratio * point_seconds(wet | {"law": "stick-slip"}, pair, model, ("lyapunov",)))
    # halving the band doubles its rate, not the free beam's: between 1.5x and 2x the steps
    narrow, _ = refine("band", wet, nm)
    assert 1.5 < rk4_stiffness(narrow) / ratio < 2.0
    # a stiffer stick: more RK4 steps, the same expo estimate
    stiff, _ = refine("k_t", dry, nm)
    assert rk4_stiffness(stiff) > 1.2
    assert point_seconds(stiff, nm, model, ("simulate",)) == point_seconds(dry, nm, model, ("simulate",))
    assert point_seconds(stiff, rk4, model, ("simulate",)) == pytest.approx(
        rk4_stiffness(stiff) * point_seconds(dry, rk4, model, ("simulate",)))
    assert rk4_stiffness(dry | {"law": "rigid-stick", "mu_s": 0.3}) < 1.0
    # the ratio is the kernels' own: RK4's steps per unit time (beamsim.point.period_steps)
    for p in (wet, narrow, stiff):
        steps = period_steps(prepare_point(**p), step_factor=1.0) / period_steps(prepare_point(**dry),
                                                                                    step_factor=1.0)
        assert rk4_stiffness(p) == pytest.approx(steps, rel=2e-3)
    # a point the simulator refuses is its job's error, not the estimate's
    assert rk4_stiffness(wet | {"mu_s": 0.0, "mu_k": 0.0}) == 1.0


def test_a_regularised_grids_band_runs_cost_their_steps(tmp_path):
    """Through the estimate of a run: the ``band`` runs of a Stribeck grid cost 1.5-2x its map's
    points (the band's rate doubles); the lifetime runs' RK4 copies follow the stiffness too."""
    nm = Numerics()
    wet = expand_grid("g", {"axes": {"Omega": [1.5, 2.0]}}, MODEL | {"law": "stribeck", "mu_s": 0.3,
                                                                     "v_s": 4e-4}, nm.result_dict())
    base = estimate_run(wet, nm, tmp_path)
    band = estimate_run(wet, nm, tmp_path, convergence=[(wet, ["band"], 2)])
    extra = band.cpu_seconds - base.cpu_seconds
    assert 1.5 * base.cpu_seconds < extra < 2.0 * base.cpu_seconds
    dry = expand_grid("g", {"axes": {"Omega": [1.5, 2.0]}}, MODEL, nm.result_dict())
    rk4 = Numerics(method="rk4")
    settings = LifetimeSettings(labels=("periodic",), copies=2, periods=10)
    stiff = [replace(p, params=p.params | {"k_t": 30.0}) for p in dry]
    assert lifetime_seconds(stiff, rk4, settings)[0] == pytest.approx(
        np.mean([rk4_stiffness(p.params) for p in stiff]) * lifetime_seconds(dry, rk4, settings)[0],
        rel=0.05)


def test_a_long_run_needs_the_opt_in():
    est = Estimate(points=10, new_simulate=10, new_lyapunov=10, cpu_seconds=4 * LONG_RUN_SECONDS)
    check_run_length(est, cores=8, allow_long=False)  # half an hour on 8 cores
    with pytest.raises(WorkflowError, match=r"^long run: .*allow_long=True"):
        check_run_length(est, cores=2, allow_long=False)
    check_run_length(est, cores=2, allow_long=True)


def test_results_dir_check_wants_room_for_twice_the_new_records(tmp_path):
    check_results_dir(tmp_path / "results" / "nested", need_bytes=1000)  # created later, parent writable
    assert not (tmp_path / "results").exists()
    with pytest.raises(WorkflowError, match=r"^cannot run: .* free, the new results need about"):
        check_results_dir(tmp_path, need_bytes=1e18)


def test_a_ten_thousand_point_grid_is_planned_by_a_dry_run_and_refused_without_opt_in(tmp_path):
    grid = {"grids": {"huge": {"axes": {"Omega": {"range": [1.25, 8.0], "num": 100},
                                        "f0_rel": {"range": [0.8, 3.0], "num": 100}},
                               "fixed": {"mu_s": 0.45, "mu_k": 0.3}}}}
    # 1000 transient periods per point: estimated at 1.6 h on 2 cores at results version 15 (2.2 h
    # at version 14; with 200, 4.3 h at version 13's cost model but 58 min at version 14's faster
    # expo: under the gate, so the run that should be refused started computing the 10,000 points)
    work = setup_workdir(tmp_path / "huge", grid=grid, n_transient=1000, chunk_size=100)
    dry = snakemake(work, "-n", "regimes")
    assert dry.returncode == 0, dry.stderr[-2000:]
    # the test workflows' convergence step (one sampled point, one refinement) and lifetime runs
    # (two copies of the expected cells: 4 % of 10,000, capped at max_cells, 40)
    words = ("regimes: 10000 points; to compute: 10000 simulate, 10000 lyapunov, "
             "81 convergence / continuation / multistability / lifetime runs; estimated")
    assert words in dry.stdout + dry.stderr
    res = snakemake(work, "regimes")
    lines = [ln for ln in (res.stdout + res.stderr).splitlines() if ln.startswith("long run:")]
    assert res.returncode != 0 and len(lines) == 1 and "allow_long=True" in lines[0], res.stderr[-2000:]
    assert not (work / "results").exists()
    # the opt-in as the message spells it passes the config schema (Snakemake reads True as a bool)
    opted = snakemake(work, "-n", "regimes", "--config", "allow_long=True")
    assert opted.returncode == 0, opted.stderr[-2000:]


def test_extrapolation_above_the_measured_modes_never_falls():
    """Above the largest measured mode count the coefficient grows by its last step's factor,
    but never falls (a per-step cost grows with the state; a workload coefficient can come out
    lower at the next mode count through its sample's transients)."""
    from analysis.pipeline.cost import _coefficient

    assert _coefficient({1: 1.0, 2: 2.0, 3: 4.0}, 4) == pytest.approx(8.0)
    assert _coefficient({1: 1.0, 2: 2.0, 3: 1.5}, 5) == pytest.approx(1.5)
    assert _coefficient({1: 1.0, 2: 2.0, 3: 1.5}, 2) == 2.0


def test_the_lifetime_runs_are_in_the_estimate(tmp_path):
    """The lifetime runs add the expected cells times the copies, each its periods at the
    points' mean simulate cost per period (twice the periods, twice the cost; none when off)."""
    from analysis.pipeline.chaos_lifetime import LifetimeSettings
    from analysis.pipeline.cost import LIFETIME_CELL_SHARE

    pts = _points(np.linspace(1.0, 4.0, 100))
    base = estimate_run(pts, Numerics(), tmp_path)
    st = LifetimeSettings.from_dict({"copies": 4, "periods": 500})
    one = estimate_run(pts, Numerics(), tmp_path, lifetimes=[(pts, st)])
    assert one.convergence_runs == round(LIFETIME_CELL_SHARE * 100) * 4
    two = estimate_run(pts, Numerics(), tmp_path,
                       lifetimes=[(pts, LifetimeSettings.from_dict({"copies": 4, "periods": 1000}))])
    assert two.cpu_seconds - base.cpu_seconds == pytest.approx(2 * (one.cpu_seconds - base.cpu_seconds))
    capped = estimate_run(pts, Numerics(), tmp_path, lifetimes=[(pts, LifetimeSettings.from_dict(
        {"copies": 4, "periods": 500, "max_cells": 1}))])
    assert capped.convergence_runs == 4
    none = LifetimeSettings.from_dict({"copies": 0})
    off = estimate_run(pts, Numerics(), tmp_path, lifetimes=[(pts, none)])
    assert off.cpu_seconds == base.cpu_seconds and off.convergence_runs == 0

"""What a run will cost, before it starts: new points and an estimated wall time.

The estimate is a cost model, ``seconds = c * periods / Omega``, per stage and point:

* simulate: ``c_sim(method, n_modes) * (n_transient + n_record) / Omega`` (RK4 also scaled by
  ``1 / step_factor`` and by the point's stiffness, :func:`rk4_stiffness`): the integrators'
  cost is proportional to the simulated time, and a forcing period is ``2 pi / (Omega
  omega_1)`` long;
* lyapunov: ``c_lyap(free copy's method, n_modes) * periods / Omega`` (the RK4 pair's also
  scaled by ``0.5 / step_factor`` and by the stiffness) with ``periods`` the
  Stefanski window ``n_periods`` plus, for the expected share :data:`LONG_RECORD_SHARE` of the
  points that need the label's long Benettin record, the periods its expected length (the first
  run plus the share :data:`LONG_RECORD_REACH` of its boundary of the way from it to the
  cap) adds;
* the adaptive transient adds one continuation (``n_transient + n_record`` periods) to the
  expected share :data:`EXTENDED_SHARE` of the points;
* the continuation check (``numerics.continuation_check``) adds ``n_record`` periods to every
  point (the checks that fail and run again are not in the estimate);
* the long run (``numerics.n_long_transient``) adds ``n_long_transient + n_record`` periods (and
  a check's ``n_record``) to the expected share :data:`LONG_TRANSIENT_SHARE` of the points;
* the convergence runs (:mod:`analysis.pipeline.convergence`; :func:`convergence_seconds`):
  per grid and pending refinement, the sample size (with a census, :func:`convergence_cells`,
  the expected cells of its labels, :data:`LABEL_SHARE`, added) times the mean estimate of the
  grid's points with that refinement applied (the sample is drawn from the finished map, so its
  points are not known before; the store is not consulted; a refinement that stiffens the model,
  ``k_t`` or ``band``, costs its RK4 runs' shorter step through :func:`rk4_stiffness`);
* the continuation lines (:mod:`analysis.continuation`): both stages for every point of a
  pending line, twice (up- and down-sweep);
* the multistability runs (:mod:`analysis.pipeline.cell_attractors`;
  :func:`multistability_seconds`): per grid, the cells run from other starts times the starts
  per cell times the mean simulate estimate of the grid's points, plus the Lyapunov stage for the
  expected share :data:`NEW_ATTRACTOR_SHARE` of the starts that end on an attractor of their own;
* the lifetime runs (:mod:`analysis.pipeline.chaos_lifetime`; :func:`lifetime_seconds`): per
  grid, the expected share :data:`LIFETIME_CELL_SHARE` of its points (at most ``max_cells``)
  times the copies times their periods at the grid's mean simulate coefficient per period.

The two shares are measured on the default grid (docs/pipeline.md, results version 6: 26 % of
the points ran a long record, 29 % were continued, 3.5 % twice; version 8: about 32 % continued,
and about 8 % failed a continuation check and ran one more record, which the estimate leaves
out); other grids differ.

The coefficients ``c`` (seconds per forcing period at ``Omega = 1``, one thread, after
compilation) are measured, not typed: ``benchmarks/cost_model.py --write`` runs the stages on a
few points and writes ``cost_model.yaml`` next to this module.  How close the estimate comes to
measured runs is in docs/reliability.md.  A point counts as new for a stage when the
content-addressed store (:mod:`analysis.pipeline.store`) holds no record of it.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from analysis.pipeline.config import Numerics
from analysis.pipeline.grid import canonical_json
from analysis.pipeline.stages import free_copy_integrator, integrator
from analysis.pipeline.store import PointStore

if TYPE_CHECKING:
    from analysis.pipeline.chaos_lifetime import LifetimeSettings

__all__ = ["COST_MODEL_FILE", "Estimate", "LONG_RUN_SECONDS", "MOVED_SHARE", "convergence_cells",
           "convergence_seconds",
           "estimate_run", "lifetime_seconds", "load_cost_model", "multistability_seconds", "rk4_stiffness"]

COST_MODEL_FILE = Path(__file__).with_name("cost_model.yaml")
#: a run estimated longer than this on the current cores needs ``--config allow_long=True``
LONG_RUN_SECONDS = 3600
#: expected share of points whose label needs the long Benettin record (default grid: 0.26)
LONG_RECORD_SHARE = 1.0 / 3.0
#: how far a long Benettin record runs on average, as a share of the way from the plan's first
#: run to its cap, per sequential boundary (``numerics.lyapunov.boundary``).  The default map:
#: with every look at 95 % (``none``) 207 periods between 100 and 425 at results version 22,
#: 0.33 (180 at version 21, 0.25); on the O'Brien-Fleming boundary 298 at version 23, 0.61;
#: Pocock not measured on the map, taken as O'Brien-Fleming's (on synthetic records its
#: records are 2-22 % shorter: docs/lyapunov.md, section 10)
LONG_RECORD_REACH = {"obrien-fleming": 0.61, "pocock": 0.61, "none": 0.33}
#: expected share of points the adaptive transient continues (default grid: 0.29)
EXTENDED_SHARE = 0.3
#: expected share of points that have the long run, weighted by their cost per period (results
#: version 28's znver3 default map: 108 of 400 cells had it, 0.27, slipping records 1.2 times
#: dearer per period than the map's mean; with 0.3 the run's estimate is 28 min against 33:53
#: measured, with 0.2 it was 24 min: docs/reliability.md)
LONG_TRANSIENT_SHARE = 0.3
#: expected share of a cell's extra starts that reach an attractor of their own (each then
#: needs a Lyapunov run; default grid: 100 of 192, docs/pipeline.md)
NEW_ATTRACTOR_SHARE = 0.5
#: expected share of a grid's cells that the lifetime runs take (the labels set, below the
#: lock-up limit, slipping; default grid, chaotic, undetermined and quasi-periodic: 27 of 400
#: on results version 26's znver3 map, 16 + 6 + 5; chaotic alone 13-16, docs/pipeline.md)
LIFETIME_CELL_SHARE = 0.0675
#: expected share of a model refinement's sampled labels that move and are followed from the
#: map's attractor (:func:`analysis.pipeline.convergence.continuation_path`; results version
#: 27's znver3 default map: 8 of 20 under k_t x 3 and under modes + 1)
MOVED_SHARE = 0.4
#: expected share of a grid's cells per label, for a census of the convergence runs
#: (``convergence.census``: every cell of a label; results version 26's znver3 default map:
#: periodic 292, quasi-periodic 24, chaotic 26, undetermined 53, unsettled 5 of 400)
LABEL_SHARE = {"periodic": 0.73, "quasi-periodic": 0.06, "chaotic": 0.065, "undetermined": 0.1325,
               "unsettled": 0.0125}


@dataclass(frozen=True)
class Estimate:
    """The work a run still has to do.

    points : grid points of the run (distinct ids).
    new_simulate, new_lyapunov : points without a store record for that stage.
    cpu_seconds : estimated single-thread time of the new work [s], the convergence runs'
        included.
    disk_bytes : estimated size of the new store records [bytes].
    convergence_runs : point runs of the convergence step, the continuation lines and the
        multistability runs still to do.
    """

    points: int
    new_simulate: int
    new_lyapunov: int
    cpu_seconds: float
    disk_bytes: float = 0.0
    convergence_runs: int = 0

    def wall_seconds(self, cores: int) -> float:
        """Estimated wall time on ``cores`` cores (points are spread over threads and jobs)."""
        parallel = max(self.new_simulate, self.new_lyapunov, self.convergence_runs, 1)
        return self.cpu_seconds / max(1, min(cores, parallel))

    def summary(self, cores: int) -> str:
        """One line: points, new points per stage, estimated time on ``cores`` cores."""
        n = self.convergence_runs
        runs = "convergence / continuation / multistability / lifetime run" + ("s" if n != 1 else "")
        conv = f", {n} {runs}" if n else ""
        return (f"{self.points} points; to compute: {self.new_simulate} simulate, "
                f"{self.new_lyapunov} lyapunov{conv}; estimated {_duration(self.wall_seconds(cores))} "
                f"on {cores} core{'s' if cores != 1 else ''}")


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def load_cost_model(path: Path = COST_MODEL_FILE) -> dict:
    """The measured coefficients: ``{"simulate": {method: {n_modes: c}}, "lyapunov": {free copy's
    method: {n_modes: c}}, "bytes_per_point": {n_modes: bytes}}``."""
    return yaml.safe_load(Path(path).read_text())


def _coefficient(table: Mapping, n_modes: int) -> float:
    """``c`` at ``n_modes``; above the largest measured mode count, extrapolated with the growth
    factor of its last step, at least 1 (the cost per step grows with the state size; a
    coefficient measured on a workload also carries its sample's adaptive transients, so two
    neighbouring mode counts can come out in either order).  The table holds consecutive mode
    counts from 1 (``benchmarks/cost_model.py``)."""
    top = max(int(k) for k in table)
    if n_modes <= top:
        return float(table[n_modes])
    growth = max(1.0, float(table[top]) / float(table[top - 1])) if top > 1 else 1.0
    return float(table[top]) * growth ** (n_modes - top)


def rk4_stiffness(params: Mapping) -> float:
    """A point's RK4 steps per unit time relative to those the cost model's RK4 coefficients
    were measured with: its largest rate ``omega_max`` (:func:`beamsim.point.prepare_point`:
    the stuck beam's for stick-slip, the free beam's plus the velocity band's viscous rate for
    the regularised laws, the free beam's for the rigid stick), over that of the stuck
    stick-slip beam of its geometry at the default ``k_t`` (the default grid's, on which
    ``benchmarks/cost_model.py`` measures).  The RK4 step is ``step_factor / omega_max``, so the
    steps per period follow this ratio; a step of a regularised law costs somewhat more (its
    traction's ``tanh`` and ``exp``), which the estimate does not carry (measured:
    docs/reliability.md, "RK4's step follows the point's stiffness").
    ``1`` for a stick-slip point at the default ``k_t`` (without building its model), and for a
    point that :func:`~beamsim.point.prepare_point` refuses (its job will say why; the estimate
    does not).  Memoised by the point's parameters: the estimate asks once per stage and
    refinement."""
    from beamsim.two_layer import Geometry

    default_k_t = float(params.get("k_t", Geometry.k_t)) == Geometry.k_t
    if params.get("law", "stick-slip") == "stick-slip" and default_k_t:
        return 1.0
    return _stiffness(canonical_json(dict(params)))


@functools.lru_cache(maxsize=65536)
def _stiffness(params_json: str) -> float:
    """:func:`rk4_stiffness` of the point ``params_json`` (canonical JSON)."""
    from dataclasses import replace

    from beamsim.point import prepare_point
    from beamsim.two_layer import Geometry, build_model

    try:
        pp = prepare_point(**json.loads(params_json))
    except ValueError:
        return 1.0
    return pp.omega_max / build_model(replace(pp.model.geom, k_t=Geometry.k_t)).omega_max_stuck


def point_seconds(params: Mapping, numerics: Numerics, model: Mapping, stages: Iterable[str]) -> float:
    """Estimated single-thread seconds of one point's ``stages`` (``simulate``, ``lyapunov``)."""
    n_modes = int(params.get("n_modes", 1))
    omega = float(params.get("Omega", 1.0))
    seconds = 0.0
    if "simulate" in stages:
        method = integrator(numerics.method, params)
        c = _coefficient(model["simulate"][method], n_modes)
        scale = rk4_stiffness(params) / numerics.step_factor if method == "rk4" else 1.0
        run = numerics.n_transient + numerics.n_record
        if numerics.n_transient_max >= numerics.n_transient + run:
            run *= 1.0 + EXTENDED_SHARE
        if numerics.continuation_check:  # every settled record is continued once
            run += numerics.n_record
        if numerics.n_long_transient:
            check = numerics.n_record if numerics.continuation_check else 0
            run += LONG_TRANSIENT_SHARE * (numerics.n_long_transient + numerics.n_record + check)
        seconds += c * run * scale / omega
    if "lyapunov" in stages:
        ly = numerics.lyapunov
        free = free_copy_integrator(ly.method, params)
        c = _coefficient(model["lyapunov"][free], n_modes)
        plan = ly.block_plan()
        share = LONG_RECORD_REACH[plan.boundary]
        reach = plan.first_periods + share * (plan.max_periods - plan.first_periods)
        extra = max(0.0, reach - ly.n_periods)
        scale = 0.5 * rk4_stiffness(params) / ly.step_factor if free == "rk4" else 1.0
        seconds += c * (ly.n_periods + LONG_RECORD_SHARE * extra) * scale / omega
    return seconds


def convergence_cells(sample: int, census: Iterable[str], n_points: int) -> int:
    """Expected cells of one grid's convergence runs: the sample plus the expected cells of the
    census labels (:data:`LABEL_SHARE` of ``n_points`` each; the census replaces their strata's
    draw, so this overestimates by those draws), at most ``n_points``."""
    extra = sum(round(LABEL_SHARE[lab] * n_points) for lab in census)
    return min(int(sample) + extra, int(n_points))


def convergence_seconds(points: Sequence, numerics: Numerics, refinements: Iterable[str], sample: int,
                        model: Mapping | None = None) -> tuple[float, int]:
    """Estimated single-thread seconds and the number of point runs of one grid's convergence
    runs: for each of ``refinements``, ``min(sample, len(points))`` times the mean of
    :func:`point_seconds` over ``points`` refined: both stages, or the Lyapunov stage alone
    where the refined point reads the map's reference runs
    (:func:`analysis.pipeline.convergence.reuses_reference_runs`: ``separation``); for a model
    refinement (:data:`analysis.pipeline.convergence.CONTINUED`) also :data:`MOVED_SHARE` of
    the sample followed from the map's attractor, each a simulate run per point of its path
    (``K_T_STEPS`` for ``k_t``, one for ``modes``, at the refined point's cost) and one
    Lyapunov run (counted as runs too)."""
    from analysis.pipeline.convergence import CONTINUED, K_T_STEPS, refine, reuses_reference_runs

    model = load_cost_model() if model is None else model
    n = min(int(sample), len(points))
    seconds, runs = 0.0, 0
    for ref in refinements:
        costs, followed = [], []
        for p in points:
            params, nm = refine(ref, p.params, numerics)
            stages = (("lyapunov",) if reuses_reference_runs(p.params, numerics, params, nm)
                      else ("simulate", "lyapunov"))
            costs.append(point_seconds(params, nm, model, stages))
            if ref in CONTINUED:
                steps = K_T_STEPS if ref == "k_t" else 1
                followed.append(steps * point_seconds(params, nm, model, ("simulate",))
                                + point_seconds(params, nm, model, ("lyapunov",)))
        if costs and n:
            seconds += n * sum(costs) / len(costs)
            runs += n
        if followed and n:
            seconds += MOVED_SHARE * n * sum(followed) / len(followed)
            runs += round(MOVED_SHARE * n)
    return seconds, runs


def multistability_seconds(points: Sequence, numerics: Numerics, n_cells: int, starts_per_cell: int,
                           model: Mapping | None = None) -> tuple[float, int]:
    """Estimated single-thread seconds and the number of point runs of one grid's multistability
    runs: ``n_cells * starts_per_cell`` simulate runs at the mean estimate of the grid's points,
    plus Lyapunov runs for :data:`NEW_ATTRACTOR_SHARE` of them."""
    model = load_cost_model() if model is None else model
    runs = int(n_cells) * int(starts_per_cell)
    if not runs or not points:
        return 0.0, 0
    sim = sum(point_seconds(p.params, numerics, model, ("simulate",)) for p in points) / len(points)
    lyap = sum(point_seconds(p.params, numerics, model, ("lyapunov",)) for p in points) / len(points)
    return runs * (sim + NEW_ATTRACTOR_SHARE * lyap), runs


def lifetime_seconds(points: Sequence, numerics: Numerics, settings: LifetimeSettings,
                     model: Mapping | None = None) -> tuple[float, int]:
    """Estimated single-thread seconds and the number of copy runs of one grid's lifetime runs
    (``settings``: :class:`analysis.pipeline.chaos_lifetime.LifetimeSettings`): the expected
    cells (:data:`LIFETIME_CELL_SHARE` of ``points``, at most ``settings.max_cells``, at least
    one) times ``settings.copies`` runs of ``settings.periods`` periods, at the mean over the
    points of the simulate coefficient per period."""
    model = load_cost_model() if model is None else model
    if not settings.active or not points:
        return 0.0, 0
    cells = min(settings.max_cells, max(1, round(LIFETIME_CELL_SHARE * len(points))))
    def per_period(params: Mapping) -> float:  # point_seconds' simulate cost of one period
        method = integrator(numerics.method, params)
        scale = rk4_stiffness(params) / numerics.step_factor if method == "rk4" else 1.0
        c = _coefficient(model["simulate"][method], int(params.get("n_modes", 1)))
        return c * scale / float(params.get("Omega", 1.0))

    mean = sum(per_period(p.params) for p in points) / len(points)
    runs = cells * settings.copies
    return runs * settings.periods * mean, runs


def estimate_run(points: Iterable, numerics: Numerics, store_root: str | Path,
                 model: Mapping | None = None,
                 convergence: Iterable[tuple[Sequence, Iterable[str], int]] = (),
                 lines: Iterable[Sequence] = (),
                 multistability: Iterable[tuple[Sequence, int, int]] = (),
                 lifetimes: Iterable[tuple[Sequence, LifetimeSettings]] = ()) -> Estimate:
    """Estimate of the work for ``points`` (objects with ``point_id`` and ``params``; the same
    point in two grids counts once) given what ``store_root`` already holds, plus the
    convergence runs still to do: ``(grid's points, pending refinements, sample)`` per grid
    (:func:`convergence_seconds`), plus the pending continuation ``lines`` (each a sequence of
    points, run up and down; they count as convergence-like re-runs), plus the pending
    multistability runs: ``(grid's points, cells, starts per cell)`` per grid
    (:func:`multistability_seconds`; counted with the convergence-like re-runs), plus the pending
    lifetime runs: ``(grid's points, settings)`` per grid (:func:`lifetime_seconds`; counted
    likewise)."""
    model = load_cost_model() if model is None else model
    stores = {s: PointStore(store_root, s) for s in ("simulate", "lyapunov")}
    unique = {p.point_id: p.params for p in points}
    seconds, disk, new = 0.0, 0.0, {"simulate": 0, "lyapunov": 0}
    for pid, params in unique.items():
        todo = [s for s, store in stores.items() if not store.has(pid)]
        for s in todo:
            new[s] += 1
        if todo:
            seconds += point_seconds(params, numerics, model, todo)
            disk += _coefficient(model["bytes_per_point"], int(params.get("n_modes", 1)))
    conv_runs = 0
    for grid_points, refinements, sample in convergence:
        s, r = convergence_seconds(grid_points, numerics, refinements, sample, model)
        seconds += s
        conv_runs += r
    for line in lines:
        for p in line:
            seconds += 2 * point_seconds(p.params, numerics, model, ("simulate", "lyapunov"))
            conv_runs += 2
    for grid_points, n_cells, starts in multistability:
        s, r = multistability_seconds(grid_points, numerics, n_cells, starts, model)
        seconds += s
        conv_runs += r
    for grid_points, settings in lifetimes:
        s, r = lifetime_seconds(grid_points, numerics, settings, model)
        seconds += s
        conv_runs += r
    return Estimate(len(unique), new["simulate"], new["lyapunov"], seconds, disk, conv_runs)

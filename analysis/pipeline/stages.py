"""The stages of the regime pipeline, one function per Snakemake rule (rules stay thin).

Every stage takes a chunk of grid points (``[{"point_id": ..., "params": {...}}, ...]``),
looks each point up in the content-addressed :class:`analysis.pipeline.store.PointStore`,
computes only the missing ones (batched, threads inside), and returns one table row per
point in the chunk's order.  Progress (points done / total) goes to the ``logging`` log.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import replace
from typing import TypeVar

import numpy as np
import pandas as pd

from analysis.pipeline.config import Numerics, as_numerics
from analysis.pipeline.store import PointStore
from beamsim.results import ZENO_FALLBACK

log = logging.getLogger("regimes")
Item = TypeVar("Item")
Result = TypeVar("Result")


def _cached_stage(points: Sequence[dict], store: PointStore,
                  compute: Callable[[list[dict]], Iterable[tuple[dict, dict]]], stage: str) -> list[dict]:
    """Records for ``points``: from the store where present (and loadable: a damaged record is
    recomputed), else from ``compute(todo)``, which yields ``(point, record)`` pairs in any
    order as they are done; each is stored at once (an interrupted job keeps what it finished).
    Progress is logged every 25 points."""
    records = {}
    for p in points:
        rec = store.find(p["point_id"])
        if rec is not None:
            records[p["point_id"]] = rec
        elif store.has(p["point_id"]):
            log.info("%s: point %s: stored record does not load, recomputing", stage, p["point_id"])
    todo = [p for p in points if p["point_id"] not in records]
    n, done = len(points), len(points) - len(todo)
    log.info("%s: %d points, %d cached, %d to compute", stage, n, done, len(todo))
    t0 = time.perf_counter()
    for k, (p, rec) in enumerate(compute(todo), start=1):
        store.save(p["point_id"], rec)
        records[p["point_id"]] = store.load(p["point_id"])  # as a later run reads it
        if k % 25 == 0 or k == len(todo):
            log.info("%s: %d / %d points done (%.1f s)", stage, done + k, n, time.perf_counter() - t0)
    return [records[p["point_id"]] for p in points]


# ----------------------------------------------------------------------------- kernels
def compile_kernels(stage: str, methods: Sequence[str] = ("expo",), threads: int = 1,
                    rigid: bool = False) -> float:
    """Compile (or load from numba's on-disk cache) the kernels of one pipeline stage by running
    them once on a one-mode point for a few forcing periods: ``"simulate"`` compiles the reference
    integrators in ``methods``, ``"lyapunov"`` the RK4 drive/copy kernel
    (:func:`beamsim.coupled_copies.run_copies`; the fallback, and the Stefanski ladder's with
    ``numerics.lyapunov.ladder: rk4``) first, then the free copies' and the ladder's integrators
    in ``methods`` (``expo``: :mod:`beamsim.kernels.expo_copies`); with ``rigid`` also the rigid
    stick's kernels (RK4 and copies).  Compilation is single-threaded (its time on a fresh
    install: docs/performance.md, "Compilation").  The workflow runs the simulate stage's job
    first and the Lyapunov stage's after it, which loads the callees the first has compiled
    (``expo``'s, RK4's) from numba's cache: side by side, which callees each job found in the
    cache depended on the jobs' timing, and with them the last bits of the Lyapunov kernels
    (docs/reliability.md, "Compiled kernels").  The chunk jobs load every kernel from the
    cache, so none of them runs a kernel compiled in its own process; the simulate chunks need
    only the first job's, so they run while the second compiles.  Returns the wall time [s]."""
    from beamsim.simulate import prepare_point, simulate_batch

    t0 = time.perf_counter()
    point = {"n_modes": 1, "Omega": 2.5, "f0_rel": 2.0, "mu_s": 0.45, "mu_k": 0.3}
    runs = [(point, methods)]
    if rigid:
        runs.append((point | {"law": "rigid-stick", "mu_s": 0.3}, ("rk4",)))
    for pt, meths in runs:
        if stage == "simulate":
            for method in meths:
                simulate_batch([pt], n_transient=0, n_record=1, method=method, n_threads=threads)
        elif stage == "lyapunov":
            from analysis.lyapunov.beam import attractor_scale, beam_lle, response_scale

            pp = prepare_point(**pt)
            n, nq = pp.model.n, pp.model.n_quad
            start = np.zeros((1, 2 * n + 2 * nq))  # at rest, every element stuck
            # the forced response's scale
            scale = attractor_scale(np.zeros((2, 2 * n)), response_scale(pp), pp.omega)
            # the RK4 copies first, then the ``expo`` copies (each with its own ladder); their
            # callees in common with the reference runs come from the simulate stage's job
            frees = ["rk4"] if pt.get("law") == "rigid-stick" else ["rk4", *sorted(set(meths) - {"rk4"})]
            for free in frees:
                beam_lle([pp], start, scale[None], n_periods=4, n_threads=threads, free_method=free,
                         ladder_method=free)
        else:
            raise ValueError(f"stage must be 'simulate' or 'lyapunov', got {stage!r}")
    return time.perf_counter() - t0


# ----------------------------------------------------------------------------- simulate
def integrator(method: str, params: dict) -> str:
    """Integrator of a point's reference run.  ``auto``: ``expo`` for the stick-slip law (exact
    between located switches, so the stiff stuck interface costs no steps; its distance to the
    RK4 reference and its labels and cost on the default grid: docs/model.md, docs/pipeline.md),
    the RK4 reference for the rigid stick and the regularised laws (which ``expo`` does not
    support).  The Lyapunov stage's free copy: :func:`free_copy_integrator`."""
    if method != "auto":
        return method
    return "expo" if params.get("law", "stick-slip") == "stick-slip" else "rk4"


def free_copy_integrator(method: str, params: dict) -> str:
    """Integrator of a point's free Lyapunov copy (``numerics.lyapunov.method``).  ``auto``
    (the default): ``expo`` for the stick-slip law with ``mu_s > mu_k``
    (:mod:`beamsim.kernels.expo_copies`; its exponents against the RK4 pair's and its cost:
    docs/lyapunov.md, section 12), RK4 otherwise: for the rigid stick and the regularised laws,
    and for ``mu_s = mu_k``, where an element sticks at its slip limit and the ``expo`` copy
    can chatter between stick and slip at a grazing reversal (section 12)."""
    if method != "auto":
        return method
    return "expo" if expo_copy_supported(params) else "rk4"


def expo_copy_steps(reference_steps: int | None) -> int | None:
    """Output grid of the Lyapunov stage's ``expo`` copies (where they are measured, coupled
    and rescaled) for a reference run's ``expo`` grid ``reference_steps`` (``None``: the
    default of each, :data:`beamsim.point.DEFAULT_STEPS_PER_PERIOD` and
    :data:`beamsim.coupled_copies.EXPO_COPY_STEPS_PER_PERIOD`).  A set grid is scaled by the
    ratio of the two defaults, so the convergence evidence's ``step / 2``, which doubles the
    reference grid, doubles the copies' grid too."""
    from beamsim.coupled_copies import EXPO_COPY_STEPS_PER_PERIOD
    from beamsim.point import DEFAULT_STEPS_PER_PERIOD

    if reference_steps is None:
        return None
    return reference_steps * EXPO_COPY_STEPS_PER_PERIOD // DEFAULT_STEPS_PER_PERIOD["expo"]


def expo_copy_supported(params: dict) -> bool:
    """Whether the ``expo`` free copy is validated for ``params``: the stick-slip law with
    ``mu_s > mu_k`` (a stuck element then starts below its slip limit)."""
    mu_s, mu_k = params.get("mu_s"), params.get("mu_k")
    return (params.get("law", "stick-slip") == "stick-slip" and mu_s is not None
            and mu_k is not None and float(mu_s) > float(mu_k))


def simulate_runs(points: list[dict], nm: Numerics, threads: int,
                  pattern_store=None) -> list[dict]:
    """Reference trajectory of each point in one batch: ``n_transient`` periods discarded,
    ``n_record`` recorded, and the final state (restart point of the Lyapunov stage).

    Adaptive transient: a point whose record is still a transient
    (:func:`analysis.regimes.is_transient`) is continued from its end state by another
    ``n_transient`` periods and a fresh record of ``n_record`` periods (the old record joins the
    transient) while the transient stays within ``n_transient_max``; the record kept is the
    last one, ``n_transient_used`` says after how many periods it starts.

    Shakedown: a record that slips (``stick_fraction`` below 1) at a point below its shakedown
    limit (:func:`locked_ratios`: every motion there slips a finite total distance) is a
    transient too, continued in the same way; the record carries the point's
    ``shakedown_ratio``.  Where the runs are not motions of the model (:class:`ShakedownWatch`)
    the record is not continued and carries the reason (``shakedown_trouble``: ``unsettled``,
    :func:`unsettled_reason`, instead of labelled by the theorem).

    Continuation check (``nm.continuation_check``): a record that passes those tests and starts
    within ``n_transient_max`` periods is continued by ``n_record`` periods (no transient); the
    continued record is kept, and when it differs from the first one
    (:func:`analysis.regimes.continuation_reason`: another Poincare signature or period-m
    pattern size, or aperiodic records that joined are a transient), it is tested in turn; a
    record kept after a further adaptive transient is checked again; a check run that diverges
    is kept (the point is ``diverged``); the check is :func:`_check_reason`.
    ``continuation_reason`` of the record is the last failed check's reason (``""`` when the
    last check passed or none ran): :func:`unsettled_reason` reads it.  A point's continuation
    depends on its own records only (same result in any batch).

    Long run (``nm.n_long_transient`` periods, 0: none): a point not below its shakedown limit
    that those tests are done with, and whose record :func:`long_run_due` selects, is run on
    once from its end state by that many periods and a fresh record, tested and checked as above
    with the budget of a run from rest (``n_transient_max - n_transient`` more); ``long_run``.

    Zeno fallback: a point whose ``expo`` runs met ``expo``'s Zeno guard (a stick/slip switch
    cascade cut short and the state put on the step end: a jump in time,
    ``SimResult.n_zeno``) is run again, all of it, on RK4 (``step_factor``); its ``method``
    is then :data:`ZENO_FALLBACK`.

    ``pattern_store``: ``expo``'s stick-pattern decompositions
    (:class:`beamsim.pattern_store.PatternStore`; default: one for this call, shared by its
    runs), a cost, not a result."""
    from analysis.regimes import is_transient
    from beamsim.pattern_store import PatternStore
    from beamsim.simulate import restart_params, simulate_batch

    kw = dict(n_record=nm.n_record, method=integrator(nm.method, points[0]["params"]),
              steps_per_period=nm.steps_per_period, step_factor=nm.step_factor, n_threads=threads,
              pattern_store=pattern_store or PatternStore())
    results = list(simulate_batch([p["params"] for p in points], n_transient=nm.n_transient,
                                  **kw).results)
    zeno = [r.n_zeno for r in results]  # steps ended by expo's Zeno guard, over every run
    used = [nm.n_transient] * len(points)
    t_start = [0.0] * len(points)  # time of the kept run's start
    first_slip = [(r.slipped, r.t_first_slip) for r in results]
    watch = ShakedownWatch(points, [None if r.diverged else r.final_state for r in results])
    kinetic = watch.kinetic  # below 1: every motion shakes down
    checked = [not nm.continuation_check] * len(points)  # the record passed a continuation check
    why_continued = [""] * len(points)
    done = [False] * len(points)  # next_run said None: the point's record is final
    cap = [nm.n_transient_max] * len(points)  # moved on by the long run
    long_run = [False] * len(points)

    def next_run(i: int) -> str | None:
        """``"transient"``, ``"check"``, ``"long"`` or ``None`` (the point is done)."""
        r = results[i]
        x = r.poincare_state
        if r.diverged or not np.all(np.isfinite(x)):
            return None
        if watch.trouble[i]:
            return None
        slipping_below = r.stick_fraction < 1.0 and kinetic[i] < 1.0
        transient = slipping_below or is_transient(x)
        if transient and used[i] + nm.n_record + nm.n_transient <= cap[i]:
            return "transient"
        if not transient and not checked[i] and used[i] <= cap[i]:
            return "check"
        if long_run[i] or nm.n_long_transient == 0 or slipping_below:
            return None
        return "long" if long_run_due(r, points[i]["params"], transient, checked[i]) else None

    def pending() -> list[tuple[int, str]]:
        """The points that run again and how; a point found done stays done (its record is
        not touched again, so its transient tests are not repeated)."""
        out = []
        for i in range(len(points)):
            kind = None if done[i] else next_run(i)
            done[i] = kind is None
            if kind is not None:
                out.append((i, kind))
        return out

    while todo := pending():
        for kind, n_tr in (("transient", nm.n_transient), ("check", 0), ("long", nm.n_long_transient)):
            idx = [i for i, k in todo if k == kind]
            if not idx:
                continue
            ext = simulate_batch([restart_params(results[i]) for i in idx], n_transient=n_tr, **kw).results
            for i, r in zip(idx, ext):
                t0 = (used[i] + nm.n_record) * 2.0 * np.pi / r.omega  # time at which ext started
                if not first_slip[i][0] and r.slipped:
                    first_slip[i] = (True, t0 + r.t_first_slip)
                if kind == "check":
                    why = _check_reason(results[i], r, points[i]["params"].get("law", "stick-slip"))
                    why_continued[i], checked[i] = why or "", why is None
                else:  # a new record after a transient: not checked yet
                    why_continued[i], checked[i] = "", not nm.continuation_check
                used[i] += nm.n_record + n_tr
                if kind == "long":  # then the budget of a run from rest's adaptive transient
                    long_run[i] = True
                    cap[i] = used[i] + nm.n_transient_max - nm.n_transient
                t_start[i] = t0
                results[i] = r
                zeno[i] += r.n_zeno
                watch.ran(i, None if r.diverged else r.final_state)
    fallback = _zeno_fallback(points, zeno, nm, threads)
    return [fallback[i] | {"method": ZENO_FALLBACK} if i in fallback else
            _simulate_record(r, n_tr, t_run, first, why, kin, trouble) | {"long_run": ran_long}
            for i, (r, n_tr, t_run, first, why, kin, trouble, ran_long) in enumerate(
                zip(results, used, t_start, first_slip, why_continued, kinetic, watch.trouble, long_run))]


def _zeno_fallback(points: list[dict], zeno: Sequence[int], nm: Numerics, threads: int) -> dict[int, dict]:
    """The records, by position in ``points``, of the points whose ``expo`` runs met the Zeno
    guard (``zeno``: steps it ended, per point) run again, all of it, on RK4 (:func:`simulate_runs`)."""
    redo = [i for i, z in enumerate(zeno) if z > 0]
    if not redo:
        return {}
    log.info("expo met its Zeno guard at %d point(s) (%s steps): run on RK4", len(redo),
             [zeno[i] for i in redo])
    rk4 = replace(nm, method="rk4", steps_per_period=None)
    return dict(zip(redo, simulate_runs([points[i] for i in redo], rk4, threads)))


def long_run_due(r, params: dict, transient: bool, checked: bool) -> bool:
    """Whether the record of run ``r`` (a ``SimResult`` at ``params``), which the adaptive
    transient and the continuation check of :func:`simulate_runs` are done with, is one the
    long run follows: a record still a transient (``transient``: at the cap) or whose last check
    failed (not ``checked``), the map's ``unsettled``, one without a period in its Poincare
    samples (:func:`analysis.regimes.poincare_signature`; a record too short for the period
    test, fewer than :data:`analysis.regimes.MIN_SAMPLES` samples, shows none), or one of a
    period ``m > 1`` within twice the period test's tolerance of a shorter period
    (:func:`analysis.transients.near_shorter_period`: what a slowly decaying remnant around
    that shorter period's orbit looks like); not a record in which every element of a sticking
    law stays stuck, which the linear analysis labels (:func:`classify_points`)."""
    from analysis.regimes import MIN_SAMPLES, PERIODIC, Thresholds, poincare_signature
    from analysis.transients import near_shorter_period
    from beamsim.friction import STICKING_LAWS

    if params.get("law", "stick-slip") in STICKING_LAWS and r.stick_fraction >= 1.0:
        return False
    x = r.poincare_state
    if transient or not checked or len(x) < MIN_SAMPLES:
        return True
    signature = poincare_signature(x)
    if not signature.startswith(PERIODIC):
        return True
    th = Thresholds()  # the classifier's period test, whose reading this is
    return near_shorter_period(x, int(signature.rsplit("-", 1)[1]), rtol=th.period_rtol,
                               scale_floor_rtol=th.scale_floor_rtol) is not None


#: the relative growth of ``W`` (:func:`beamsim.shakedown.difference_energy`) over one run that
#: :class:`ShakedownWatch` reads as trouble (both integrators keep it below 1e-9 per period on
#: a record that slips for 200 periods below the limit: tests/beamsim/test_shakedown.py)
SHAKEDOWN_RTOL = 1e-6


class ShakedownWatch:
    """The shakedown rule's premise, checked on the runs of :func:`simulate_runs`: below its
    shakedown limit (``kinetic`` below 1) a point's energy of the difference from the locked
    orbit, ``W`` (:func:`beamsim.shakedown.difference_energy`), never grows along an exact
    motion of the model, from any state (docs/model.md, section 7).  ``W`` is taken at the
    point's start (``pp.x0``, time 0) and at the end of every run (a period boundary, where the
    locked orbit's state is its state at time 0); a growth by more than
    :data:`SHAKEDOWN_RTOL` of the value before (or, where that is smaller, of the ``W`` of the
    state at rest, the locked orbit's own energy: a start on the locked orbit has ``W = 0`` and
    stays there up to rounding) sets ``trouble[i]``, the reason, and the point
    is not continued: its runs are not motions of the model (an integrator's trouble), so the
    theorem must not label them.  Points above the limit, of other laws, or with a NaN
    ``kinetic`` are not watched (``trouble`` stays ``""``).  ``kinetic`` holds every point's
    shakedown ratio (:func:`locked_ratios`' second), from the same locked orbits."""

    def __init__(self, points: Sequence[dict], first_ends: Sequence):
        from beamsim.shakedown import difference_energy

        self._energy = difference_energy
        orbits = [point_locked_orbit(p["params"]) for p in points]
        self.kinetic = [_ratios(found)[1] for found in orbits]
        self.trouble = [""] * len(points)
        self.locked: dict[int, tuple] = {}
        self.last: dict[int, float] = {}
        self.scale: dict[int, float] = {}  # W at rest: the locked orbit's own energy
        for i, found in enumerate(orbits):
            if found is not None and self.kinetic[i] < 1.0:
                pp, orbit = found
                self.locked[i] = found
                self.scale[i] = difference_energy(pp, np.zeros_like(orbit.state), orbit)
                self.last[i] = difference_energy(pp, pp.x0, orbit)
                self.ran(i, first_ends[i])

    def ran(self, i: int, final_state) -> None:
        """Take ``W`` at the end of point ``i``'s latest run (its ``final_state``; ``None`` for
        a run that diverged, which is labelled as such)."""
        if i not in self.locked or self.trouble[i] or final_state is None:
            return
        pp, orbit = self.locked[i]
        x = np.asarray(final_state, dtype=float)
        if not np.all(np.isfinite(x)):
            return
        w, before = self._energy(pp, x, orbit), self.last[i]
        denom = max(before, self.scale[i])
        growth = 0.0 if w <= before else (w - before) / denom if denom > 0.0 else np.inf
        if growth > SHAKEDOWN_RTOL:
            self.trouble[i] = (
                f"the energy W of the difference from the locked orbit grew from {before:.6g} to "
                f"{w:.6g} over a run (by {growth:.2g} of it), below the shakedown limit "
                f"(ratio {self.kinetic[i]:.3f}), where every motion of the model has W falling: the "
                "run is not a motion of the model (integrator trouble), so the shakedown rule does "
                "not label it (beamsim.shakedown.difference_energy)")
        self.last[i] = w


def _simulate_record(r, n_transient_used: int, t_run: float, first_slip: tuple[bool, float], why: str,
                     shakedown: float, trouble: str = "") -> dict:
    """The simulate stage's record of a point's kept run ``r`` (a ``SimResult``, started at time
    ``t_run``) after ``n_transient_used`` periods (:func:`simulate_runs`)."""
    energy = r.energy
    w_in = float(energy[-1, 0] - energy[0, 0])
    residual = r.energy_residual[-1] - r.energy_residual[0]
    diss = np.diff(energy[:, 1])
    return {
        "poincare_state": r.poincare_state, "poincare_tip": r.poincare_tip,
        "final_state": r.final_state,
        "f0": r.f0, "f_cr": r.f_cr, "omega": r.omega, "Omega": r.Omega, "lam_f": r.lam_f,
        "steps_per_period": r.steps_per_period, "method": r.method,
        "n_transient_used": int(n_transient_used), "continuation_reason": why,
        "diverged": bool(r.diverged), "t_diverged": t_run + r.t_diverged,
        "slipped": bool(first_slip[0]), "t_first_slip": first_slip[1],
        "stick_fraction": r.stick_fraction, "shakedown_ratio": shakedown, "shakedown_trouble": trouble,
        "diss_per_cycle": float(np.mean(diss)) if np.isfinite(diss).all() else np.nan,
        "energy_residual_rel": float(abs(residual) / abs(w_in)) if w_in != 0 else np.nan,
    }


def _check_reason(record, continued, law: str) -> str | None:
    """The continuation check of the run ``continued`` (a ``SimResult``) against the run before
    it (:func:`analysis.regimes.continuation_reason`), ``None`` where it passes or the run
    diverged.  Its joined test is left out where every element of a sticking law stays stuck
    over ``continued``: the classify stage labels that record by the exact linear analysis
    (:func:`classify_points`), and its free vibration decays too slowly for any record."""
    from analysis.regimes import continuation_reason
    from beamsim.friction import STICKING_LAWS

    if continued.diverged or not np.all(np.isfinite(continued.poincare_state)):
        return None
    stuck = continued.stick_fraction >= 1.0 and law in STICKING_LAWS
    return continuation_reason(record.poincare_state, continued.poincare_state, joined=not stuck)


def each_on_threads(fn: Callable[[Item], Result], items: Sequence[Item],
                    threads: int) -> Iterator[tuple[Item, Result]]:
    """``(item, fn(item))`` for every item, ``threads`` items at a time on one pool (in the
    calling thread if ``threads`` is 1), in the order they finish.  One pool for all the items
    and no barrier between batches: an item that runs long holds one thread, not all, and one
    item's Python overlaps another's kernels (which release the GIL).  ``fn`` must give an
    item's result from that item alone (then the results are those of any batching)."""
    from concurrent.futures import ThreadPoolExecutor, as_completed

    if threads <= 1:
        yield from ((p, fn(p)) for p in items)
        return
    pool = ThreadPoolExecutor(max_workers=threads)
    try:
        futures = {pool.submit(fn, p): p for p in items}
        for f in as_completed(futures):
            yield futures[f], f.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def simulate_points(points: Sequence[dict], numerics: Numerics | dict, store_root: str,
                    threads: int = 1) -> pd.DataFrame:
    """Stage 1: time integration; one row per point with its Poincare samples.

    Each point runs all its runs (:func:`simulate_runs`: the adaptive transient, the
    continuation check) on one thread, ``threads`` points at a time (:func:`each_on_threads`),
    so a thread never waits for another point's continuation.  A point's record depends on its
    own runs only, so this is the record of any batching, to the bit."""
    from beamsim.pattern_store import PatternStore

    store = PointStore(store_root, "simulate")
    nm = as_numerics(numerics)
    patterns = PatternStore()  # expo's decompositions, shared by the stage's points

    def one(p: dict) -> dict:
        return simulate_runs([p], nm, 1, patterns)[0]

    recs = _cached_stage(points, store, lambda todo: each_on_threads(one, todo, threads), stage="simulate")
    return records_table(points, recs)


def point_locked_orbit(params: dict):
    """A point's prepared model and locked orbit, ``(pp, orbit)``
    (:func:`beamsim.shakedown.locked_orbit`), or ``None`` for a law without an elastic stick
    (rigid stick, full slip, Stribeck) and where the stuck beam's stiffness or resonance matrix
    is singular."""
    from beamsim.point import prepare_point
    from beamsim.shakedown import locked_orbit

    pp = prepare_point(**params)
    if pp.friction.law != "stick-slip":
        return None
    try:
        return pp, locked_orbit(pp)
    except np.linalg.LinAlgError:
        return None


def locked_ratios(params: dict) -> tuple[float, float]:
    """A point's ``(lock_ratio, shakedown_ratio)`` (:func:`beamsim.shakedown.lock_ratio`,
    :func:`~beamsim.shakedown.shakedown_ratio`): below 1, a locked period-1 motion exists /
    every motion converges to a locked period-1 orbit.  The second is NaN where a stuck mode is
    undamped (``stuck_decay_rate`` 0: the total slip is still finite, but the free vibration
    left is never damped, so the motion is not periodic).  Both NaN where
    :func:`point_locked_orbit` gives none or the stuck decay rate cannot be computed."""
    return _ratios(point_locked_orbit(params))


def _ratios(found) -> tuple[float, float]:
    """:func:`locked_ratios` from a point's :func:`point_locked_orbit` (``None``: none)."""
    if found is None:
        return np.nan, np.nan
    pp, orbit = found
    try:
        damped = pp.model.stuck_decay_rate() > 0.0
    except np.linalg.LinAlgError:
        return np.nan, np.nan
    return float(np.max(orbit.ratio)), float(np.max(orbit.kinetic_ratio)) if damped else np.nan


def shakedown_trouble(sim_row: pd.Series | dict) -> str:
    """The record's ``shakedown_trouble`` (:class:`ShakedownWatch`), ``""`` when it has none
    (also for records stored before the field existed)."""
    trouble = sim_row.get("shakedown_trouble")
    return trouble if isinstance(trouble, str) else ""


def unsettled_reason(sim_row: pd.Series | dict) -> str | None:
    """Why a simulate record (finite, not diverged) is still a transient, or ``None``: first a
    run that is not a motion of the model below the shakedown limit (:func:`shakedown_trouble`:
    no verdict on such a record), then the record's own tests
    (:func:`analysis.regimes.transient_reason`), a record that slips below
    the point's shakedown limit (``shakedown_ratio`` below 1: :func:`simulate_runs`), then the
    last continuation check (``continuation_reason``, :func:`simulate_runs`)."""
    from analysis.regimes import transient_reason

    trouble = shakedown_trouble(sim_row)
    if trouble:
        return trouble
    why = transient_reason(poincare_array(sim_row["poincare_state"]))
    if why is not None:
        return why
    kinetic = float(sim_row.get("shakedown_ratio", np.nan))
    if kinetic < 1.0 and float(sim_row.get("stick_fraction", 1.0)) < 1.0:
        return (f"the record slips below the shakedown limit (shakedown ratio {kinetic:.3f}): every "
                "motion there slips a finite total distance, so a slipping record is a transient "
                "(beamsim.shakedown)")
    why = sim_row.get("continuation_reason")
    return why if isinstance(why, str) and why else None


def records_table(points: Sequence[dict], recs: Sequence[dict]) -> pd.DataFrame:
    """One row per point: its ``point_id`` and its stage record (arrays as lists)."""
    rows = []
    for p, rec in zip(points, recs):
        row = {"point_id": p["point_id"]}
        for k, v in rec.items():
            row[k] = v.tolist() if isinstance(v, np.ndarray) else v
        rows.append(row)
    return pd.DataFrame(rows)


def poincare_array(value) -> np.ndarray:
    """A stored Poincare column (list of lists) back to a 2-D float array."""
    return np.array([np.asarray(r, dtype=float) for r in value], dtype=float)


# ----------------------------------------------------------------------------- lyapunov
def lyapunov_runs(points: list[dict], sim: pd.DataFrame, nm: Numerics, threads: int,
                  pattern_store=None) -> list[dict]:
    """Stefanski and Benettin estimates (analysis.lyapunov.beam), the block statistics of the
    long Benettin record and nolds for one batch; ``sim``: the simulate records indexed by
    ``point_id``; ``pattern_store``: the ``expo`` copies' stick-pattern decompositions
    (:class:`beamsim.pattern_store.PatternStore`; default: one per ``beam_lle`` call), a cost,
    not a result.  A point's record depends on its own runs only (any batch gives it, to the
    bit); :func:`lyapunov_each` runs the points one by one on a pool."""
    from analysis.lyapunov.beam import attractor_scale, beam_lle, response_scale
    from beamsim.simulate import prepare_point

    lopt = nm.lyapunov
    recs: list = [None] * len(points)
    good = []
    for i, p in enumerate(points):
        r = sim.loc[p["point_id"]]
        x = poincare_array(r["poincare_state"])
        fs = np.asarray(r["final_state"], dtype=float)
        if r["diverged"] or not (np.all(np.isfinite(x)) and np.all(np.isfinite(fs))):
            recs[i] = {"lle_stefanski": np.nan, "lle_stefanski_verdict": "not computed: diverged",
                       "lle_stefanski_lo": np.nan, "lle_stefanski_hi": np.nan,
                       "lle_benettin": np.nan, "lle_nolds": np.nan, "lle_free_copy": "not run",
                       "stuck_bound": np.nan, "lle_expo_floor": np.nan, **_screen_columns(None),
                       **_no_statistics("diverged")}
        else:
            good.append(i)
    if good:
        prepared = {i: prepare_point(**points[i]["params"]) for i in good}
        skip = {i: long_record_exemption(sim.loc[points[i]["point_id"]], points[i]["params"]) for i in good}
        # a fixed step count is an RK4 setting only when RK4 was asked for by name, and sets
        # the expo copies' measuring grid (expo_copy_steps) when the reference runs are expo's
        # (so the convergence evidence's "step / 2" reaches the expo pair too)
        rk4_steps = nm.steps_per_period if nm.method == "rk4" else None
        # one beam_lle call per (free copy's integrator, its expo grid, long record or not)
        runs: dict = {}
        # a point whose expo reference run met the Zeno guard gets the RK4 pair as well
        fell_back = {i for i in good if sim.loc[points[i]["point_id"]].get("method") == ZENO_FALLBACK}
        asked = {i: free_copy_integrator(lopt.method, points[i]["params"]) for i in good}
        for i in good:
            free = "rk4" if i in fell_back else asked[i]
            ref = integrator(nm.method, points[i]["params"])
            spp = expo_copy_steps(nm.steps_per_period) if free == "expo" and ref == "expo" else None
            runs.setdefault((free, spp or 0, skip[i] is None), []).append(i)
        for (method, spp, long_record), subset in sorted(runs.items()):
            plan = lopt.block_plan() if long_record else None
            pps = [prepared[i] for i in subset]
            starts = np.stack([np.asarray(sim.loc[points[i]["point_id"], "final_state"], dtype=float)
                               for i in subset])
            records = [poincare_array(sim.loc[points[i]["point_id"], "poincare_state"]) for i in subset]
            scales = np.stack([attractor_scale(x, response_scale(pp), pp.omega)
                               for x, pp in zip(records, pps)])
            res = beam_lle(pps, starts, scales, n_periods=lopt.n_periods, steps_per_period=rk4_steps,
                           step_factor=lopt.step_factor, e0=lopt.rk4_e0, n_threads=threads, plan=plan,
                           free_method=method, free_steps=spp or None,
                           free_e0=lopt.expo_e0 if method == "expo" else None,
                           ladder_method="expo" if lopt.ladder == "expo" and method == "expo" else "rk4",
                           floor_ratio=lopt.expo_floor if method == "expo" else None,
                           pattern_store=pattern_store)
            if method == "expo" and long_record and lopt.confirm != "none":
                _second_opinion(res, pps, starts, scales, records, plan, lopt, rk4_steps, threads)
            for i, est in zip(subset, res):
                if i in fell_back and asked[i] == "expo":
                    est.free_copy = ZENO_FALLBACK
                row = sim.loc[points[i]["point_id"]]
                linear = bound = np.nan
                if skip[i] == LINEAR_VERDICT:
                    linear = stuck_lle(prepared[i].model, points[i]["params"])
                    bound = stuck_bound(prepared[i], row["final_state"])
                recs[i] = _lyapunov_record(row, est, skip[i], lopt, points[i]["point_id"], linear,
                                           bound)
    return recs


def _second_opinion(res: list, prepared: list, starts: np.ndarray, scales: np.ndarray,
                    records: list, plan, lopt, rk4_steps: int | None, threads: int) -> None:
    """Re-measure on the RK4 pair (:func:`analysis.lyapunov.beam.rk4_long_record`), in place,
    the long records of ``res`` that the ``expo`` pair read with an interval not at or below the
    margin (positive, straddling, or a diverged copy) -- with ``lopt.confirm == "contradicted"``
    only those whose Poincare record (``records``) does not say chaos on its own
    (:func:`analysis.regimes.poincare_says_chaotic`), with ``"all"`` every one: their statistics
    become the RK4 pair's, the ``expo`` pair's are kept as ``est.screen`` and ``est.free_copy``
    is :data:`analysis.lyapunov.beam.RK4_SECOND_OPINION`.

    Why (docs/lyapunov.md, section 15): at period-1 orbits near the slip onset (labelled by the
    period test, so not measured here) the ``expo`` pair's long record reads ``lambda_1 T`` up
    to +0.87 with an interval above the margin where the RK4 pair reads non-positive at two
    steps, and the same pair decides the labels of the records measured here.  Where the
    ``expo`` pair reads non-positive the RK4 pair did too at every cell measured, and where the
    Poincare record says chaos too the two pairs' verdicts differ only through intervals that
    straddle the margin.  So the cheap pair screens, and the RK4 pair decides where the screen
    and the record disagree."""
    from analysis.lyapunov.beam import RK4_SECOND_OPINION, rk4_long_record
    from analysis.lyapunov.block_statistics import NON_POSITIVE
    from analysis.regimes import poincare_says_chaotic

    todo = [k for k, est in enumerate(res) if est.free_copy == "expo" and est.statistics is not None
            and est.statistics.verdict != NON_POSITIVE
            and (lopt.confirm == "all" or not poincare_says_chaotic(records[k]))]
    if not todo:
        return
    stats = rk4_long_record([prepared[k] for k in todo], starts[todo], scales[todo], plan=plan,
                            steps_per_period=rk4_steps, step_factor=lopt.step_factor, e0=lopt.rk4_e0,
                            n_threads=threads)
    for k, st in zip(todo, stats):
        res[k].screen, res[k].statistics = res[k].statistics, st
        res[k].free_copy = RK4_SECOND_OPINION


#: ``lle_verdict`` of a point whose dynamics over the record are linear (its ``lle_mean``,
#: ``lle_lo`` and ``lle_hi``: the exact exponent, :func:`stuck_lle`)
LINEAR_VERDICT = ("non-positive: linear (every element stuck over the record), lambda_1 = -(the "
                  "stuck beam's slowest decay rate)")


def long_record_exemption(sim_row: pd.Series, params: dict) -> str | None:
    """Why a point's label does not need the long Benettin record, or ``None`` when it does.

    * the record is still a transient (:func:`unsettled_reason`): the label is
      ``unsettled`` whatever the exponent;
    * the stick-slip or rigid-stick law and every interface point stuck over the record
      (``stick_fraction`` 1): the dynamics there are linear with constant coefficients, so
      ``lambda_1`` is known exactly (:data:`LINEAR_VERDICT`, :func:`stuck_lle`), and the
      classify stage labels the record by it (a periodic-looking record too: a free vibration
      near a rational frequency ratio reads as a long period).  Not for the regularised laws,
      whose "stuck" (``|v| < eps_v``) is still the nonlinear traction law;
    * the record is periodic by the sample-wise period test (:func:`analysis.regimes.classify`
      without an exponent finds a period ``m`` with ``x[i+m]`` matching ``x[i]`` over the whole
      record): that excludes chaos, and the classifier's rule 1 labels it periodic whatever the
      exponent.  A record that only the cluster route calls periodic (tight clusters, "noise
      suspected") is measured: a chaotic set smaller than the cluster tolerance looks the same,
      and its exponent decides (``undetermined`` where it lies above the margin).
    """
    from analysis.regimes import PERIODIC, classify
    from beamsim.friction import STICKING_LAWS

    x = poincare_array(sim_row["poincare_state"])
    if unsettled_reason(sim_row) is not None:
        if shakedown_trouble(sim_row):
            return "not measured: the record is not a motion of the model (unsettled, no verdict)"
        if float(sim_row.get("shakedown_ratio", np.nan)) < 1.0:
            return ("not measured: the record is a transient (labelled periodic-1 by the shakedown "
                    "limit, not reached)")
        return "not measured: the record is a transient (unsettled)"
    if (params.get("law", "stick-slip") in STICKING_LAWS
            and float(sim_row["stick_fraction"]) >= 1.0):
        return LINEAR_VERDICT
    res = classify(x)
    if res.label == PERIODIC and res.indicators["period_test"] is not None:
        return "not measured: periodic record (the period test excludes chaos)"
    return None


def stuck_lle(model, params: dict) -> float:
    """``lambda_1`` [per unit time] of a record in which every element stays stuck: the
    dynamics are linear with constant coefficients, so it is minus the slowest decay rate of
    the stuck beam's free vibration (:meth:`beamsim.two_layer.TwoLayerModel.stuck_decay_rate`;
    the rigid stick's constrained beam for ``law: rigid-stick``), ``0`` when a stuck mode is
    undamped."""
    return -model.stuck_decay_rate(rigid=params.get("law", "stick-slip") == "rigid-stick")


def stuck_bound(pp, final_state) -> float:
    """Of a record in which every element stays stuck, ending at ``final_state`` on a period
    boundary: the largest ratio over the elements of the bound on their future elastic traction
    to their slip limit (:func:`beamsim.shakedown.stuck_traction_bound`); below 1, no element can
    slip again.  ``nan`` for the rigid stick, whose tractions are constraint forces, and only
    for it; ``inf`` (not proven) where the bound cannot be computed: a linear solve LAPACK
    refuses (an exactly singular eigenvector matrix, stuck stiffness or resonance) or a NaN
    in the result, so that such a record is ``undetermined`` rather than a failed batch or an
    unproven periodic-1.  A nearly defective basis gives a large finite bound, which is safe."""
    if pp.friction.law != "stick-slip":
        return np.nan
    from beamsim.shakedown import stuck_traction_bound

    try:
        bound = float(stuck_traction_bound(pp, np.asarray(final_state, dtype=float)).max())
    except np.linalg.LinAlgError as exc:
        log.info("stuck_bound: a singular linear solve (%s): not proven", exc)
        return np.inf
    return np.inf if np.isnan(bound) else bound


def _lyapunov_record(r: pd.Series, est, exemption: str | None, lopt, pid: str,
                     linear_lle: float = np.nan, bound: float = np.nan) -> dict:
    """A point's Lyapunov record: Stefanski, window Benettin, nolds and the label's exponent
    (the block statistics, or the exemption's: ``linear_lle``, :func:`stuck_lle`, for
    :data:`LINEAR_VERDICT`), and for that exemption the record's ``stuck_bound``
    (:func:`stuck_bound`; ``nan`` otherwise)."""
    from analysis.lyapunov.nolds_rosenstein import nolds_lle

    period = 2.0 * np.pi / r["omega"]
    try:
        lle_nolds = float(nolds_lle(poincare_array(r["poincare_tip"])[:, 0], sample_dt=period,
                                    emb_dim=lopt.nolds_emb_dim).value)
    except Exception as exc:  # nolds rejects short or constant series
        log.info("nolds: point %s: %s", pid, exc)
        lle_nolds = np.nan
    st = est.stefanski
    out = {"lle_stefanski": st.value, "lle_stefanski_verdict": st.verdict,
           "lle_stefanski_lo": st.bracket[0], "lle_stefanski_hi": st.bracket[1],
           "lle_benettin": est.benettin.value, "lle_nolds": lle_nolds, "lle_free_copy": est.free_copy,
           "stuck_bound": bound, "lle_expo_floor": est.expo_floor}
    out |= _screen_columns(est.screen)
    bs = est.statistics
    if bs is not None:
        return out | {"lle_mean": bs.mean, "lle_se": bs.se, "lle_lo": bs.lo, "lle_hi": bs.hi,
                      "lle_periods": int(bs.n_periods), "lle_blocks": np.asarray(bs.blocks),
                      "lle_verdict": bs.verdict}
    stats = _no_statistics(exemption) | {"lle_mean": est.benettin.value,
                                         "lle_periods": int(lopt.n_periods)}
    if exemption == LINEAR_VERDICT:
        # the exact value, not the window's (a 25-period Benettin value on a stuck torus reads
        # the slowly decaying free vibration's finite-time growth, up to +-0.1 per period)
        stats |= {"lle_mean": linear_lle, "lle_lo": linear_lle, "lle_hi": linear_lle}
    return out | stats


def _screen_columns(screen) -> dict:
    """``lle_expo_mean``, ``lle_expo_lo``, ``lle_expo_hi``: the ``expo`` pair's statistics where
    the RK4 pair re-measured the record (:func:`_second_opinion`), NaN otherwise."""
    return {f"lle_expo_{k}": np.nan if screen is None else getattr(screen, k) for k in ("mean", "lo", "hi")}


def _no_statistics(verdict: str) -> dict:
    return {"lle_mean": np.nan, "lle_se": np.nan, "lle_lo": np.nan, "lle_hi": np.nan,
            "lle_periods": 0, "lle_blocks": np.zeros(0), "lle_verdict": verdict}


def lyapunov_points(points: Sequence[dict], simulated: pd.DataFrame, numerics: Numerics | dict,
                    store_root: str, threads: int = 1) -> pd.DataFrame:
    """Stage 2: ``lambda_1`` (per unit dimensionless time) of every point, on its attractor
    (restarted from the reference run's final state):

    * ``lle_stefanski``: synchronisation method on the beam's full state
      (:func:`analysis.lyapunov.beam.beam_lle`), with its verdict and bracket on ``d_s``;
    * ``lle_benettin``: two trajectories, renormalised every period (same integrator);
    * ``lle_nolds``: Rosenstein's estimate (``nolds.lyap_r``) on the stroboscopic series of the
      tip radial displacement (NaN when the record is too short for the embedding).
    """
    store = PointStore(store_root, "lyapunov")
    sim = simulated.set_index("point_id")
    nm = as_numerics(numerics)
    recs = _cached_stage(points, store, lambda todo: lyapunov_each(todo, sim, nm, threads), stage="lyapunov")
    return records_table(points, recs)


def lyapunov_each(points: Sequence[dict], sim: pd.DataFrame, nm: Numerics,
                  threads: int) -> Iterator[tuple[dict, dict]]:
    """:func:`lyapunov_runs` of every point on its own, ``threads`` points at a time
    (:func:`each_on_threads`), yielding ``(point, record)`` as each is done; ``sim``: the
    simulate records indexed by ``point_id``.  A point's Stefanski ladder runs its coupled
    copies as one kernel task, so a batch of points on several threads left all but one idle
    while each point searched (and during the batch's Python: exemption tests, nolds); one
    point per task keeps every thread busy.  The ``expo`` copies share one pattern store."""
    from beamsim.pattern_store import PatternStore

    patterns = PatternStore()

    def one(p: dict) -> dict:
        return lyapunov_runs([p], sim, nm, 1, pattern_store=patterns)[0]

    return each_on_threads(one, points, threads)


def lyapunov_records(points: Sequence[dict], sim: pd.DataFrame, nm: Numerics, threads: int) -> list[dict]:
    """:func:`lyapunov_each`'s records in the order of ``points`` (whose ids must differ)."""
    done = {p["point_id"]: rec for p, rec in lyapunov_each(points, sim, nm, threads)}
    return [done[p["point_id"]] for p in points]


# ----------------------------------------------------------------------------- classify
def lle_resolution(numerics: Numerics | dict) -> float:
    """The margin ``lambda_1 T`` (per forcing period) the exponent's confidence interval must
    clear (``numerics.lyapunov.margin``): above it chaotic, at or below it regular, across it
    undetermined (:func:`analysis.lyapunov.block_statistics.decide`)."""
    return float(as_numerics(numerics).lyapunov.margin)


def classify_points(simulated: pd.DataFrame, lyapunov: pd.DataFrame,
                    lle_threshold: float = 0.05) -> pd.DataFrame:
    """Stage 3: a label per point from its Poincare samples and its largest Lyapunov exponent.

    Non-results first: ``diverged`` (the integrator flagged the point), ``unsettled``
    (:func:`unsettled_reason` finds the record still a transient after the adaptive
    transient's cap, by its own tests or by the continuation check; the reason says which),
    except below the shakedown limit (the record's ``shakedown_ratio`` below 1), where the
    attractor is known, a locked period-1 orbit (:func:`shakedown_reason`), unless the runs
    were not motions of the model there (:func:`shakedown_trouble`: ``unsettled``, "no
    verdict"); otherwise
    :func:`analysis.regimes.classify` on the stroboscopic samples of all generalised
    coordinates and velocities, with ``lambda_1 T`` and its confidence interval from the block
    statistics of the long Benettin record (``lle_mean``, ``lle_lo``, ``lle_hi``); the interval
    is compared with ``lle_threshold`` (:func:`lle_resolution`), and a point whose interval
    straddles it, or whose exponent the Poincare data contradict, is ``undetermined``.
    Where the statistics are missing (diverged copies) the other indicators decide alone.
    A record in which every element stays stuck (:data:`LINEAR_VERDICT`) with a negative
    exponent (every stuck mode damped) is periodic of period 1 whatever its Poincare samples
    show: the motion is the forced response plus a free vibration that decays onto it
    (:func:`stuck_record_reason`), provided no element can slip again (``stuck_bound`` below 1,
    or not available, or the point below its shakedown limit: ``shakedown_ratio`` below 1, where
    every motion's total slip is finite); where a later slip is not excluded (``stuck_bound >= 1``
    above the shakedown limit) it is ``undetermined`` (:func:`stuck_unproven_reason`).
    """
    from analysis.regimes import DIVERGED, PERIODIC, UNDETERMINED, UNSETTLED, classify

    lle = lyapunov.set_index("point_id")
    rows = []
    for _, sim in simulated.iterrows():
        pid = sim["point_id"]
        period_t = 2.0 * np.pi / sim["omega"]
        have = pid in lle.index
        lam, lo, hi = ((float(lle.loc[pid, k]) * period_t for k in ("lle_mean", "lle_lo", "lle_hi"))
                       if have else (np.nan, np.nan, np.nan))
        row = {"point_id": pid, "label": None, "period": None, "reason": "", "K": np.nan,
               "spectral_growth": np.nan, "n_clusters": np.nan, "settled": False}
        x = poincare_array(sim["poincare_state"])
        why_transient = None if (sim["diverged"] or not np.all(np.isfinite(x))) else unsettled_reason(sim)
        if sim["diverged"] or not np.all(np.isfinite(x)):
            row.update(label=DIVERGED, reason="integration diverged")
        elif (why_transient is not None and float(sim.get("shakedown_ratio", np.nan)) < 1.0
              and not shakedown_trouble(sim)):
            row.update(label=PERIODIC, period=1, reason=shakedown_reason(
                float(sim["shakedown_ratio"]), int(sim["n_transient_used"]), why_transient))
        elif why_transient is not None:
            row.update(label=UNSETTLED, reason=(
                f"no verdict: {why_transient}" if shakedown_trouble(sim) else
                f"transient not over after {int(sim['n_transient_used'])} periods: {why_transient}"))
        else:
            known = not (np.isnan(lam) or np.isnan(lo) or np.isnan(hi))
            res = classify(x, lle_per_period=lam if known else None,
                           lle_interval=(lo, hi) if known else None, lle_threshold=lle_threshold)
            ind = dict(res.indicators)
            row.update(label=res.label, period=res.period, reason=res.reason, settled=True,
                       K=ind.get("K", np.nan), spectral_growth=ind.get("spectral_growth", np.nan),
                       n_clusters=ind.get("n_clusters", np.nan))
            if have and lle.loc[pid].get("lle_verdict") == LINEAR_VERDICT and lam < 0.0:
                bound = float(lle.loc[pid].get("stuck_bound", np.nan))
                kinetic = float(sim.get("shakedown_ratio", np.nan))
                if bound >= 1.0 and not kinetic < 1.0:
                    row.update(label=UNDETERMINED, period=None,
                               reason=stuck_unproven_reason(bound, res.reason))
                else:
                    row.update(label=PERIODIC, period=1,
                               reason=stuck_record_reason(lam, res.reason, bound, kinetic))
        rows.append(row)
    out = pd.DataFrame(rows)
    out["period"] = out["period"].astype("Int64")
    return out


def stuck_record_reason(lle_per_period: float, record_reason: str, bound: float = np.nan,
                        shakedown: float = np.nan) -> str:
    """Reason of the label periodic-1 for a record in which every element stays stuck, with
    ``lambda_1 T = lle_per_period < 0`` (:func:`stuck_lle`), the record's :func:`stuck_bound`
    (below 1; ``nan``: not available, the rigid stick; 1 or more where the point is below its
    shakedown limit, ``shakedown`` below 1: a later slip is not excluded, but every motion's
    total slip is finite, so the motion still ends on a locked orbit) and the classifier's
    reading of the record itself (``record_reason``)."""
    if bound >= 1.0:
        proof = (f"; a later slip is not excluded (bound {bound:.3f} of the slip limit), but the point is "
                 f"below its shakedown limit (ratio {shakedown:.3f}): every motion's total slip is "
                 f"finite, so the motion ends on a locked orbit (beamsim.shakedown)")
    else:
        proof = ("" if np.isnan(bound) else
                 f"; no element can slip again: its traction stays below {bound:.3f} of its slip "
                 f"limit for ever (beamsim.shakedown)")
    return (f"period 1: every element stuck over the record, so the motion is linear: the forced "
            f"response of the forcing period plus a free vibration that decays onto it at the "
            f"stuck beam's rates (lambda_1 = {lle_per_period:.3g}/period exactly, the slowest "
            f"falling by e in {-1.0 / lle_per_period:.3g} periods){proof}; the record itself: "
            f"{record_reason}")


#: the first words of the reason of a label given by the shakedown limit alone (the record is
#: still a transient: :func:`shakedown_reason`)
BY_SHAKEDOWN = "period 1 by the shakedown limit"


def shakedown_reason(shakedown: float, n_transient_used: int, why_transient: str) -> str:
    """Reason of the label periodic-1 for a record that is still a transient at the adaptive
    transient's cap at a point below its shakedown limit (``shakedown`` below 1,
    :func:`locked_ratios`): the record is not the attractor, but the attractor is known."""
    return (f"{BY_SHAKEDOWN}: below it (ratio {shakedown:.3f}) every motion slips a "
            f"finite total distance and the stuck beam is damped, so the motion converges to a locked "
            f"period-1 orbit (beamsim.shakedown); the record after {n_transient_used} periods is still "
            f"a transient: {why_transient}")


def stuck_unproven_reason(bound: float, record_reason: str) -> str:
    """Reason of the label ``undetermined`` for a record in which every element stays stuck
    but whose free vibration can still bring an element to its slip limit (:func:`stuck_bound`
    ``= bound >= 1``): the record is not yet the attractor."""
    return (f"every element stuck over the record, but the free vibration left can still bring "
            f"an element to its slip limit (bound {bound:.3f} of it, beamsim.shakedown): a later "
            f"slip is not excluded, so the record is not shown to be the attractor; the record "
            f"itself: {record_reason}")


# ----------------------------------------------------------------------------- portraits
def reference_run(params: dict, nm: Numerics, **kw):
    """``beamsim.simulate.simulate(**kw, **params)`` on the point's reference integrator
    (:func:`integrator`) at ``nm.step_factor``; an ``expo`` run that meets the Zeno guard is run
    again on RK4 (``steps_per_period`` dropped), as :func:`simulate_runs` does, so a figure
    drawn from it shows the trajectory the table's row was measured on."""
    from beamsim.simulate import simulate

    r = simulate(method=integrator(nm.method, params), step_factor=nm.step_factor, **kw, **params)
    if r.n_zeno > 0:
        r = simulate(method="rk4", step_factor=nm.step_factor, **(kw | {"steps_per_period": None}), **params)
    return r


def portrait_case(row: pd.Series, axes: list[str], numerics: Numerics | dict,
                  samples_per_period: int = 64, n_show: int = 40) -> dict:
    """Dense tip history of one grid point for its phase portrait and Poincare map.

    Re-simulates the point (same parameters and numerics as the table) with a dense output of
    ``samples_per_period`` per period; the velocity is the central difference of the dense
    tip displacement.  Returns the data :func:`analysis.figures.regimes.plot_portraits` draws.
    """
    import json

    params = json.loads(row["params_json"])
    nm = as_numerics(numerics)
    spp = nm.steps_per_period
    if spp is not None:
        spp = max(samples_per_period, int(np.ceil(spp / samples_per_period) * samples_per_period))
    # the adaptive transient's length (one run instead of the chained ones: the same trajectory
    # up to round-off, which a chaotic record amplifies: the same attractor, not the same samples)
    n_tr = int(row["n_transient_used"]) if pd.notna(row.get("n_transient_used")) else nm.n_transient
    r = reference_run(params, nm, n_transient=n_tr, n_record=nm.n_record, steps_per_period=spp,
                      dense_per_period=samples_per_period)
    t, w = r.dense_t, r.dense[:, 0]
    w_dot = np.gradient(w, t)
    tail = slice(len(t) - n_show * samples_per_period - 1, len(t))
    start = n_tr * samples_per_period
    pidx = np.arange(start, len(t), samples_per_period)
    where = ", ".join(f"{a}={row[a]:g}" for a in axes)
    period = f" (period {int(row['period'])})" if pd.notna(row["period"]) else ""
    return {"title": f"{where}: {row['label']}{period}", "t": t[tail], "w": w[tail],
            "w_dot": w_dot[tail], "pw": w[pidx], "pw_dot": w_dot[pidx]}


def register_cached_modes(files: Sequence[str]) -> None:
    """Hand the workflow's cached arch modes (one Parquet file per geometry) to the model."""
    from beamsim.mode_cache import read_modes
    from beamsim.two_layer import register_modes

    for f in files:
        register_modes(read_modes(f))

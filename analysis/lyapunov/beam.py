r"""Largest Lyapunov exponent of the beam: Stefanski synchronisation and Benettin, batched.

Both estimators run on the simulator's full state -- generalised coordinates ``q``,
velocities ``v``, the Jenkins elements' slips ``z`` and their stick/slip states -- with the
RK4 reference scheme (:mod:`beamsim.coupled_copies`), starting from the state a reference run
ended in (``SimResult.final_state``, i.e. on the attractor after the transient).  Only
trajectories are integrated (no Jacobian, no saltation matrices), so both are valid for the
discontinuous stick/slip dynamics.

* **Stefanski** (:func:`analysis.lyapunov.sync_search.sync_search` and
  :func:`analysis.lyapunov.sync_rule.sync_test`, the same bracket search and windowed,
  scale-aware synchronisation test as the generic
  :func:`analysis.lyapunov.generic.stefanski_lle`):
  responses ``y' = f(t, y) + d (x - y)`` on every continuous state variable; the smallest
  synchronising ``d`` estimates ``lambda_1``.  ``d = 0`` is tested first, alone: where it
  synchronises, or its windowed error rate (the free pair's finite-time exponent) is within
  the resolution ``5 / n_periods`` per period, the value is that measured rate and nothing else
  is integrated (the usual case for a beam with friction); otherwise a geometric ladder of
  couplings around the Benettin estimate (0.5-4 times it; without it, up to the forcing
  frequency ``omega``) and multisection rounds follow (``batch`` couplings per round,
  integrated together).
* **Benettin**: the same free copy (``d = 0``), also renormalised to the initial separation
  ``e0`` at every period end; ``lambda_1`` is the mean log growth per unit time after
  ``k_align`` periods of alignment with the most unstable direction.  The recorded error carries
  every rescaling factor, so it is the error of the linearised, unbounded dynamics whether the
  copy is rescaled at period ends or only when it leaves the band: one copy serves both (where
  the attractor is not chaotic the two values are two readings of one record; where it is, the
  Stefanski value comes from the coupled copies).

The error is the RMS over ``(q, v)`` of the difference scaled by the attractor size per
component (:func:`attractor_scale`: the spread of the reference's Poincare samples or the
forced-response scale, whichever is larger).  The
initial separation has RMS ``e0`` in a fixed pseudo-random direction (seeded).  Exponents are in
the beam's dimensionless time unit; ``lambda_1 T`` (``T = 2 pi / omega``) is the growth per
forcing period.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from analysis.lyapunov.block_statistics import BlockPlan, LLEStatistics
from analysis.lyapunov.result import LLEResult
from analysis.lyapunov.sync_rule import coupling_cap, exp_clip, perturbation, sync_test, zero_tolerance
from analysis.lyapunov.sync_search import sync_search
from beamsim.results import ZENO_FALLBACK

__all__ = ["BeamLLE", "attractor_scale", "beam_benettin", "beam_lle", "initial_offset",
           "response_scale", "rk4_long_record", "EXPO_FLOOR_FALLBACK", "RK4_SECOND_OPINION"]


#: :attr:`BeamLLE.free_copy` of a point whose long record the RK4 pair measured again because
#: the ``expo`` pair's interval was not at or below the margin
#: (:func:`analysis.pipeline.stages.lyapunov_runs`, ``numerics.lyapunov.confirm``)
RK4_SECOND_OPINION = "rk4 (the expo pair's interval was not at or below the margin)"
#: :attr:`BeamLLE.free_copy` of a point that ``beam_lle`` ran on the RK4 pair because ``expo``'s
#: noise floor there (:func:`analysis.lyapunov.noise_floor.expo_noise_floor`) exceeds
#: ``floor_ratio`` times the ``expo`` copy's separation
EXPO_FLOOR_FALLBACK = "rk4 (expo's noise floor reaches its separation)"


@dataclass
class BeamLLE:
    """The estimates of one grid point.  ``stefanski`` and ``benettin`` are
    :class:`analysis.lyapunov.result.LLEResult` (value per unit dimensionless time) over the
    ``n_periods`` window; ``statistics`` the block statistics of the long Benettin record
    (:mod:`analysis.lyapunov.block_statistics`; ``None`` without a :class:`BlockPlan`);
    ``period`` is the forcing period ``T``."""

    stefanski: LLEResult
    benettin: LLEResult
    period: float
    statistics: LLEStatistics | None = None
    #: integrator of the free copy: ``"expo"``, ``"rk4"``, :data:`ZENO_FALLBACK` (``expo``
    #: asked for, the point run on RK4 because an ``expo`` trajectory met the Zeno guard),
    #: :data:`EXPO_FLOOR_FALLBACK` (``expo`` asked for, the point run on RK4 because ``expo``'s
    #: noise floor reaches its separation) or :data:`RK4_SECOND_OPINION` (``statistics`` from
    #: the RK4 pair, ``screen`` the ``expo`` pair's)
    free_copy: str = "rk4"
    #: the ``expo`` pair's block statistics where the RK4 pair re-measured the long record
    #: (:func:`rk4_long_record`), else ``None``
    screen: LLEStatistics | None = None
    #: ``expo``'s noise floor at the point (:func:`analysis.lyapunov.noise_floor.expo_noise_floor`,
    #: scaled like the separation), where ``beam_lle`` measured it, else ``nan``
    expo_floor: float = float("nan")


def attractor_scale(poincare_state: np.ndarray, q_ref: np.ndarray, omega: float) -> np.ndarray:
    """Per-component size of the attractor, ``(2 n,)`` for ``(q, v)``: the larger of the
    spread (standard deviation) of the Poincare samples (rows = periods) and the forced
    response scale -- ``|q_ref|`` for coordinates, ``omega |q_ref|`` for velocities, with
    ``q_ref`` the frictionless static response to the peak load
    (:func:`response_scale`) -- each group floored at ``1e-3`` of its largest entry.

    The response scale matters on periodic orbits: their Poincare samples do not spread, and a
    separation measured against a zero spread would sit at round-off."""
    x = np.asarray(poincare_state, dtype=float)
    n = x.shape[1] // 2
    s = x.std(axis=0)
    ref = np.abs(np.asarray(q_ref, dtype=float))
    out = np.empty(2 * n)
    for sl, r in ((slice(0, n), ref), (slice(n, 2 * n), omega * ref)):
        g = np.maximum(s[sl], r)
        out[sl] = np.maximum(g, 1e-3 * max(float(g.max()), 1e-300))
    return out


def response_scale(prepared) -> np.ndarray:
    """Frictionless static response to the peak load ``2 f0`` (``(n,)``, generalised
    coordinates): the natural size of the forced motion (unit load if ``f0 = 0``)."""
    u = np.asarray(prepared.model.static_unit_frictionless, dtype=float)
    return 2.0 * prepared.f0 * u if prepared.f0 > 0 else u


#: the slowest modes of the stuck structure that perturbations are drawn in (:func:`initial_offset`,
#: :func:`analysis.multistability.perturbed_starts`)
SLOW_MODES = 4


def slow_modes(model, n_slow: int = SLOW_MODES) -> np.ndarray:
    """The ``min(n_slow, n)`` slowest mode shapes of the stuck structure, ``(n, k)`` columns
    (``model.eig_stuck``), each with its largest entry positive: LAPACK's eigenvector signs
    depend on the threading, and a perturbation built from them must be the same on any
    machine setting."""
    _, phi = model.eig_stuck
    k = max(1, min(int(n_slow), model.n))
    return phi[:, :k] * np.sign(phi[np.argmax(np.abs(phi[:, :k]), axis=0), np.arange(k)])


def initial_offset(prepared, scale: np.ndarray, e0: float, seed: int = 0,
                   n_slow: int = SLOW_MODES) -> np.ndarray:
    """Offset ``y - x`` on ``(q, v, z)`` with scaled RMS ``e0`` in a fixed pseudo-random
    direction within the ``n_slow`` slowest modes of the stuck structure (coordinates and
    velocities), so that the perturbation does not start in the stiff interface (penalty)
    modes, whose transient would dominate the first periods; the Jenkins slips ``z`` are not
    perturbed."""
    model = prepared.model
    n, nq = model.n, model.n_quad
    lam = model.eig_stuck[0]
    phi = slow_modes(model, n_slow)
    k = phi.shape[1]
    u = perturbation(2 * k, seed)
    om = np.sqrt(np.maximum(lam[:k], 0.0))
    dq = phi @ u[:k]
    dv = phi @ (om * u[k:])
    x = np.concatenate([dq, dv])
    rms = math.sqrt(np.mean((x / scale) ** 2))
    off = np.zeros(2 * n + nq)
    off[:2 * n] = x * (e0 / rms)
    return off


def _benettin(log_err: np.ndarray, t: np.ndarray, k_align: int) -> LLEResult:
    ok = np.isfinite(log_err)
    if not ok.all():
        return LLEResult(value=float("nan"), method="benettin",
                         verdict="copy or drive diverged", chaotic=False)
    k0 = min(k_align, log_err.size - 2)
    value = float((log_err[-1] - log_err[k0]) / (t[-1] - t[k0]))
    return LLEResult(value=value, method="benettin", chaotic=value > 0,
                     verdict=f"mean log growth per unit time over periods {k0}-{log_err.size - 1} "
                             "(renormalised every period)",
                     sync_error=exp_clip(log_err[None, :]), sync_time=t)


def beam_lle(prepared: list, x_start: np.ndarray, scales: np.ndarray, *, n_periods: int = 50,
             e0: float = 1e-6, batch: int = 8, rtol: float = 0.05, max_rounds: int = 6,
             window: float = 0.25, k_align: int = 5, seed: int = 0,
             band: tuple[float, float] = (1e-2, 1e2), with_benettin: bool = True,
             zero_first: bool = True, seed_ladder: bool = True,
             steps_per_period: int | None = None, step_factor: float = 0.5,
             n_threads: int | None = None, plan: BlockPlan | None = None,
             free_method: str = "rk4", free_e0: float | None = None,
             free_steps: int | None = None, ladder_method: str = "rk4",
             floor_ratio: float | None = None, pattern_store=None) -> list[BeamLLE]:
    """Stefanski and Benettin estimates of ``lambda_1`` for each point, and with ``plan`` the
    block statistics of a long Benettin record.

    prepared : points from :func:`beamsim.simulate.prepare_point` (same ``n``, ``n_quad``).
    x_start : ``(P, 2 n + 2 n_quad)`` restart states (``SimResult.final_state``).
    scales : ``(P, 2 n)`` attractor sizes (:func:`attractor_scale`).
    n_periods : length of every synchronisation test and of the Benettin run, in forcing
        periods.  ``|lambda_1| T`` below about ``5 / n_periods`` is reported as zero.
    batch, rtol, max_rounds, window : the bracket search (see
        :func:`analysis.lyapunov.generic.stefanski_lle`).
    with_benettin : also give the Benettin estimate (the free copy of the first batch is then
        rescaled to ``e0`` at every period end as well; see the module docstring).
    seed_ladder : start the Stefanski ladder at the Benettin estimate (``ladder_hint`` of
        :func:`analysis.lyapunov.sync_search.sync_search`: couplings 0.5-4 times it, steps of
        ``sqrt 2``) instead of the factor-2 ladder below ``omega``: fewer bracket rounds at a
        chaotic point (measured in docs/lyapunov.md).  Needs ``with_benettin``.
    zero_first : test ``d = 0`` alone first (see the module docstring); ``False`` runs the
        generic search (``d = 0`` with the ladder, then multisection) -- the cost at a point
        where the shortcut does not apply.
    e0, band : initial scaled separation and the band ``[e0 band[0], e0 band[1]]`` outside which
        a copy is moved back to ``e0`` (narrower than the generic estimator's: a stick/slip
        switch that one copy makes and the other does not is a nonlinear event, so the
        separation must stay far below the attractor size).
    plan : the long record (:class:`analysis.lyapunov.block_statistics.BlockPlan`): the free
        copy of round 0 runs ``plan.first_periods`` (at least ``n_periods``; the Stefanski test
        and the window Benettin value read its first ``n_periods``), and points whose interval
        straddles the margin are continued one block at a time from the end states, up to
        ``plan.max_periods``.  Needs ``with_benettin``.  The continuation is exact (same steps as
        one long run), so the statistics do not depend on the batch.
    free_method, free_e0, free_steps : integrator of the free copy (round 0 and the long record:
        the Benettin values, the block statistics and Stefanski's ``d = 0`` test), its initial
        separation (default ``e0``) and, for ``"expo"``, its steps per period (the grid at
        which the copy is measured and renormalised; default
        :data:`beamsim.coupled_copies.EXPO_COPY_STEPS_PER_PERIOD`).  ``"rk4"``: the RK4 pair of
        the coupled copies; ``"expo"``: drive and copy each exact between their own located
        switches (:mod:`beamsim.kernels.expo_copies`; stick-slip law; ``expo``'s rounding
        opens separations in one period that ``free_e0`` must stay well above, largest near the
        slip onset: ``floor_ratio`` below, docs/lyapunov.md, sections 12 and 16).
    ladder_method : integrator of the Stefanski ladder's coupled copies: ``"rk4"`` (the RK4
        pair: ``e0``, ``steps_per_period``, ``step_factor``) or ``"expo"`` (the free copy's
        settings ``free_e0``, ``free_steps``, the coupling applied as its own flow at the
        output grid's step ends: :mod:`beamsim.kernels.expo_copies`; needs
        ``free_method="expo"``, whose guard and fallback then cover the ladder too).  A point
        whose ``expo`` drive or copy meets ``expo``'s Zeno guard (a switch cascade cut short
        at a step end, which leaves that trajectory behind in time) is run again as with
        ``free_method="rk4"`` (``free_e0 = e0``); its :attr:`BeamLLE.free_copy` says so
        (:data:`ZENO_FALLBACK`).
    floor_ratio : with ``free_method="expo"``, first measure ``expo``'s noise floor ``N`` at
        every point (:func:`analysis.lyapunov.noise_floor.expo_noise_floor` on its fixed
        grids, whatever ``free_steps``: the separation that rounding alone opens in one
        period) and run the points where ``N > floor_ratio *
        free_e0`` as with ``free_method="rk4"`` from the start (:data:`EXPO_FLOOR_FALLBACK`):
        there the ``expo`` copy would measure the noise (docs/lyapunov.md, section 16).
        ``None``: no floor is measured.  :attr:`BeamLLE.expo_floor` carries ``N``.
    pattern_store : the ``expo`` copies' stick-pattern decompositions
        (:class:`beamsim.pattern_store.PatternStore`; default: one for this call), a cost, not
        a result: hand one store to the calls of one model's points.
    """
    x_start = np.asarray(x_start, dtype=float)
    scales = np.asarray(scales, dtype=float)
    kw = dict(n_periods=n_periods, e0=e0, batch=batch, rtol=rtol, max_rounds=max_rounds,
              window=window, k_align=k_align, seed=seed, band=band, with_benettin=with_benettin,
              zero_first=zero_first, seed_ladder=seed_ladder, steps_per_period=steps_per_period,
              step_factor=step_factor, n_threads=n_threads, plan=plan)
    if ladder_method not in ("rk4", "expo") or (ladder_method == "expo" and free_method != "expo"):
        raise ValueError(f"beam_lle: ladder_method must be 'rk4', or 'expo' with free_method='expo'; "
                         f"got {ladder_method!r} with {free_method!r}")
    P = len(prepared)
    floors = np.full(P, np.nan)
    noisy = np.zeros(P, np.bool_)
    if free_method == "expo" and floor_ratio is not None:
        from analysis.lyapunov.noise_floor import expo_noise_floor

        floors = expo_noise_floor(prepared, x_start, scales, n_threads=n_threads,
                                  pattern_store=pattern_store)
        noisy = floors > float(floor_ratio) * (e0 if free_e0 is None else float(free_e0))
    out: list = [None] * P
    guarded = np.zeros(P, np.bool_)
    keep = np.flatnonzero(~noisy)
    if keep.size:
        est, met = _estimates([prepared[i] for i in keep], x_start[keep], scales[keep],
                              free_method=free_method, free_e0=free_e0, free_steps=free_steps,
                              ladder_method=ladder_method, pattern_store=pattern_store, **kw)
        for i, e in zip(keep, est):
            out[i] = e
        guarded[keep] = met
    if (guarded | noisy).any():  # only expo has the guards: these points as with free_method="rk4"
        idx = np.flatnonzero(guarded | noisy)
        rerun, _ = _estimates([prepared[i] for i in idx], x_start[idx], scales[idx], free_method="rk4",
                              free_e0=None, free_steps=None, ladder_method="rk4", **kw,
                              pattern_store=None)
        for i, est in zip(idx, rerun):
            est.free_copy = EXPO_FLOOR_FALLBACK if noisy[i] else ZENO_FALLBACK
            out[i] = est
    for i in range(P):
        out[i].expo_floor = float(floors[i])
    return out


def _estimates(prepared: list, x_start: np.ndarray, scales: np.ndarray, *, n_periods: int, e0: float,
               batch: int, rtol: float, max_rounds: int, window: float, k_align: int, seed: int,
               band: tuple[float, float], with_benettin: bool, zero_first: bool, seed_ladder: bool,
               steps_per_period: int | None, step_factor: float, n_threads: int | None,
               plan: BlockPlan | None, free_method: str, free_e0: float | None,
               free_steps: int | None, ladder_method: str, pattern_store) -> tuple[list, np.ndarray]:
    """:func:`beam_lle` with the free copy on ``free_method`` and the ladder on
    ``ladder_method`` whatever happens: the estimates (``None`` for a point whose ``expo`` pair
    or ``expo`` ladder met the Zeno guard) and which points did."""
    from beamsim.coupled_copies import run_copies
    from beamsim.pattern_store import PatternStore
    from beamsim.point import period_steps

    P = len(prepared)
    inv = 1.0 / scales
    offs = [initial_offset(prepared[i], scales[i], e0, seed) for i in range(P)]
    periods = [2 * math.pi / pp.omega for pp in prepared]
    t_all = [np.arange(n_periods + 1) * T for T in periods]
    run_kw = dict(n_periods=n_periods, e0=e0, band=band, steps_per_period=steps_per_period,
                  step_factor=step_factor, n_threads=n_threads)
    free_e0 = e0 if free_e0 is None else float(free_e0)
    free_kw = dict(run_kw, e0=free_e0, method=free_method)
    if free_method == "expo":
        # one store for every free run of the call (or the caller's): the points' drives and
        # copies share their stick-pattern decompositions (a cost, not a result)
        free_kw.update(steps_per_period=free_steps,
                       pattern_store=PatternStore() if pattern_store is None else pattern_store)
    free_offs = offs if free_e0 == e0 else [initial_offset(prepared[i], scales[i], free_e0, seed)
                                              for i in range(P)]
    ladder_kw, ladder_offs = (free_kw, free_offs) if ladder_method == "expo" else (run_kw, offs)

    # round 0 for every point at once: one free copy (d = 0) per point.  Its recorded ln eps is
    # the error of the linearised, unbounded dynamics (the rescaling factors are carried), so
    # rescaling it at every period end as well (Benettin) changes nothing in the linear regime:
    # the same record serves the Benettin estimate and Stefanski's d = 0 test.  Every copy of a
    # point follows the same drive trajectory (beamsim.coupled_copies), so the Stefanski
    # candidates and the Benettin copy measure the same stretch of the attractor
    if plan is not None and not with_benettin:
        raise ValueError("beam_lle: plan needs with_benettin")
    t_run = time.perf_counter()
    off0 = np.stack([o[None, :] for o in free_offs])
    first = n_periods if plan is None else max(n_periods, plan.first_periods)
    zeno = np.zeros((P, 2), np.int64)
    le0, fin = run_copies(prepared, x_start, off0, np.zeros((P, 1)), inv,
                          renorm_period=np.full((P, 1), with_benettin), return_final=True,
                          zeno_out=zeno, **dict(free_kw, n_periods=first))
    t_round0 = time.perf_counter() - t_run
    guarded = zeno.sum(axis=1) > 0
    stats = (_long_records(prepared, le0[:, 0], fin, inv, periods, plan, free_kw, guarded) if plan
             else [None] * P)
    le0 = le0[:, :, :n_periods + 1]

    out = []
    for i, pp in enumerate(prepared):
        if guarded[i]:
            out.append(None)
            continue
        T, t = periods[i], t_all[i]
        t_s = t[1:]
        h = T / period_steps(pp, "rk4", steps_per_period, step_factor)
        n_runs = [0]
        met_guard = [False]  # an expo ladder copy met expo's Zeno guard: the point falls back

        def run_batch(ds: np.ndarray, i=i, pp=pp):
            ds = np.asarray(ds, dtype=float)
            if zero_first and n_runs[0] == 0 and ds.size == 1 and ds[0] == 0.0:
                n_runs[0] += 1
                return sync_test(le0[i, :1, 1:], t_s, window)
            n_runs[0] += 1
            zeno = np.zeros((1, ds.size + 1), np.int64)
            le = run_copies([pp], x_start[i:i + 1], np.repeat(ladder_offs[i][None, None, :], ds.size, axis=1),
                            ds[None, :], inv[i:i + 1], zeno_out=zeno, **ladder_kw)
            met_guard[0] = met_guard[0] or bool(zeno.any())
            return sync_test(le[0, :, 1:], t_s, window)

        ben = (_benettin(le0[i, 0], t, k_align) if with_benettin
               else LLEResult(value=float("nan"), method="benettin", verdict="not run", chaotic=False))
        t_pt = time.perf_counter()
        st = sync_search(run_batch, t_s=t_s, batch=batch, rtol=rtol, atol=1e-3 / T,
                         omega_c=pp.omega, d_cap=coupling_cap(h), zero_tol=zero_tolerance(n_periods * T),
                         e0=free_e0 if zero_first or ladder_method == "expo" else e0, bounded=True,
                         max_rounds=max_rounds,
                         zero_first=zero_first,
                         ladder_hint=ben.value if seed_ladder else None)
        if met_guard[0]:
            guarded[i] = True
            out.append(None)
            continue
        st.runtime = time.perf_counter() - t_pt + t_round0 / P
        st.extras["n_batches"] = n_runs[0]
        out.append(BeamLLE(stefanski=st, benettin=ben, period=T, statistics=stats[i],
                           free_copy=free_method))
    return out, guarded


def _long_records(prepared: list, first: np.ndarray, fin: np.ndarray, inv: np.ndarray,
                  periods: list[float], plan: BlockPlan, run_kw: dict,
                  guarded: np.ndarray) -> list[LLEStatistics]:
    """Block statistics of every point's renormalised record ``first`` (``(P, K + 1)``),
    continuing the undetermined ones one block at a time from the end states ``fin``.
    ``guarded`` (``(P,)`` bool, updated in place): points whose ``expo`` pair met the Zeno
    guard, in ``first`` or in a continuation; they are not continued (their statistics are
    not used)."""
    from beamsim.coupled_copies import run_copies

    n, nq = prepared[0].model.n, prepared[0].model.n_quad
    cont = 2 * n + nq  # continuous part of a state: (q, v, z)
    records = [first[i] for i in range(len(prepared))]
    stats = [plan.statistics(r, T) for r, T in zip(records, periods)]
    fin = fin.copy()
    while True:
        todo = [i for i, st in enumerate(stats) if plan.continues(st) and not guarded[i]
                and np.all(np.isfinite(fin[i]))]
        if not todo:
            return stats
        off = fin[todo, 1:2, :cont] - fin[todo, 0:1, :cont]
        zeno = np.zeros((len(todo), 2), np.int64)
        le, f = run_copies([prepared[i] for i in todo], fin[todo, 0], off, np.zeros((len(todo), 1)),
                           inv[todo], renorm_period=np.ones((len(todo), 1), np.bool_),
                           return_final=True, zeno_out=zeno, **dict(run_kw, n_periods=plan.block))
        guarded[np.asarray(todo)[zeno.sum(axis=1) > 0]] = True
        for k, i in enumerate(todo):
            rec = le[k, 0]
            records[i] = np.concatenate([records[i], records[i][-1] + (rec[1:] - rec[0])])
            fin[i] = f[k]
            stats[i] = plan.statistics(records[i], periods[i])


def rk4_long_record(prepared: list, x_start: np.ndarray, scales: np.ndarray, *, plan: BlockPlan,
                    e0: float = 1e-6, seed: int = 0, band: tuple[float, float] = (1e-2, 1e2),
                    steps_per_period: int | None = None, step_factor: float = 0.5,
                    n_threads: int | None = None) -> list[LLEStatistics]:
    """Block statistics of the RK4 pair's long Benettin record alone (no Stefanski ladder, no
    window value): the record :func:`beam_lle` with ``free_method="rk4"`` and the same ``e0``,
    ``seed``, ``band``, step and ``plan`` measures (to the bit, when its ``n_periods`` is at most
    ``plan.first_periods``), run ``plan.first_periods`` and then one block at a time while the
    interval straddles the margin.

    The pipeline's second opinion on an ``expo`` pair's record whose interval is not at or below
    the margin (``numerics.lyapunov.confirm``, :func:`analysis.pipeline.stages.lyapunov_runs`):
    at period-1 orbits near the slip onset the ``expo`` pair reads chaos the RK4 pair does not,
    at two RK4 steps (docs/lyapunov.md, section 15).  Arguments as :func:`beam_lle`'s.
    """
    from beamsim.coupled_copies import run_copies

    P = len(prepared)
    scales = np.asarray(scales, dtype=float)
    inv = 1.0 / scales
    offs = np.stack([initial_offset(prepared[i], scales[i], e0, seed)[None] for i in range(P)])
    run_kw = dict(e0=e0, band=band, steps_per_period=steps_per_period, step_factor=step_factor,
                  n_threads=n_threads, method="rk4")
    le, fin = run_copies(prepared, np.asarray(x_start, dtype=float), offs, np.zeros((P, 1)), inv,
                         renorm_period=np.ones((P, 1), np.bool_), return_final=True,
                         **dict(run_kw, n_periods=plan.first_periods))
    periods = [2 * math.pi / pp.omega for pp in prepared]
    return _long_records(prepared, le[:, 0], fin, inv, periods, plan, run_kw, np.zeros(P, np.bool_))


def beam_benettin(prepared: list, x_start: np.ndarray, scales: np.ndarray, *, n_periods: int = 30,
                  e0: float = 1e-6, k_align: int = 5, seed: int = 0, step_factor: float = 0.5,
                  steps_per_period: int | None = None, n_threads: int | None = None) -> list[LLEResult]:
    """Benettin estimate alone (one free copy renormalised every period), same set-up as
    :func:`beam_lle`; for cost comparisons."""
    from beamsim.coupled_copies import run_copies

    P = len(prepared)
    scales = np.asarray(scales, dtype=float)
    offs = np.stack([initial_offset(prepared[i], scales[i], e0, seed)[None] for i in range(P)])
    le = run_copies(prepared, np.asarray(x_start, dtype=float), offs, np.zeros((P, 1)), 1.0 / scales,
                    renorm_period=np.ones((P, 1), np.bool_), n_periods=n_periods, e0=e0,
                    band=(1e-2, 1e2), steps_per_period=steps_per_period, step_factor=step_factor,
                    n_threads=n_threads)
    return [_benettin(le[i, 0], np.arange(n_periods + 1) * 2 * math.pi / pp.omega, k_align)
            for i, pp in enumerate(prepared)]

"""The free Lyapunov copies on ``expo`` (beamsim.kernels.expo_copies via run_copies(method="expo")).

Independent checks: the drive is ``expo``'s own reference run; a copy without an offset is the
drive; above ``expo``'s event-location noise the separation is linear in the offset; the
exponents agree with the RK4 pair's (a different integrator, whose copies follow the drive's
steps) on a periodic orbit with slip, on the stuck torus and on a chaotic two-mode point; a
restart from the end states continues the run; threads do not change anything."""

from __future__ import annotations

import math

import numpy as np
import pytest
from beam_copies import CHAOTIC_2MODES, check_coupling_closed_form, stretches

from analysis.lyapunov.beam import attractor_scale, beam_lle, initial_offset, response_scale
from beamsim.coupled_copies import run_copies
from beamsim.simulate import prepare_point, restart_params, simulate, simulate_batch

# the one-mode points of tests/analysis/test_lyapunov_beam.py (10 coordinates, 8 elements)
BASE = dict(n_modes=1, mu_k=0.3, interface_viscosity=0.0939)
SLIPPING = dict(BASE, Omega=2.5, f0_rel=2.5, mu_s=0.6)      # period-1 orbit with slip
STUCK = dict(BASE, Omega=2.5, f0_rel=0.5, mu_s=0.45)        # below onset: undamped, torus
#: a chaotic point of the default grid's band (two modes, mu_s / mu_k = 1.5)
BAND = dict(n_modes=2, mu_s=0.45, mu_k=0.3, interface_viscosity=0.0939, Omega=1.676,
            f0_rel=2.798)


@pytest.fixture(scope="module")
def settled():
    """expo reference runs of the two one-mode points, their restart states and scales."""
    pts = [SLIPPING, STUCK]
    res = simulate_batch(pts, n_transient=60, n_record=30, method="expo", n_threads=2)
    prepared = [prepare_point(**p) for p in pts]
    scales = np.stack([attractor_scale(r.poincare_state, response_scale(pp), pp.omega)
                       for r, pp in zip(res, prepared)])
    return res, prepared, scales


def _offsets(pp, scale, e0s):
    return np.stack([initial_offset(pp, scale, e0) for e0 in e0s])[None]


def _free(pp, start, off, scale, n_periods, e0, **kw):
    M = off.shape[1]
    return run_copies([pp], start[None], off, np.zeros((1, M)), 1 / scale[None],
                      n_periods=n_periods, e0=e0, method="expo", **kw)


def test_the_drive_is_expos_reference_run(settled):
    """The drive of the pair follows ``simulate(method="expo")`` from the same start (the pair
    keeps the time within the period and projects the modal state afresh at period ends, so the
    two agree to round-off, not bitwise)."""
    res, prepared, scales = settled
    for r, pp, sc in zip(res, prepared, scales):
        off = _offsets(pp, sc, (1e-4,))
        _, fin = _free(pp, r.final_state, off, sc, 6, 1e-4, return_final=True)
        ref = simulate(method="expo", n_transient=0, n_record=6, **(pp.params | restart_params(r)))
        n = pp.model.n
        size = np.abs(ref.final_state[:2 * n]).max()
        assert np.abs(fin[0, 0, :2 * n] - ref.final_state[:2 * n]).max() < 1e-9 * size
        assert np.array_equal(fin[0, 0, -pp.model.n_quad:], ref.final_state[-pp.model.n_quad:])


def test_a_copy_without_offset_is_the_drive(settled):
    """A copy without offset stays on the drive, with either adoption rule, to within 1e-4 of
    the copies' separation ``e0 = 1e-4``, so it adds less than 1e-4 to a measured ``ln eps``.
    Not to round-off: the drive and the copies are stepped by two kernels, whose compiled
    arithmetic may differ in the last bits (with the adoption window the copy's intervals are
    also split at the drive's switches), and ``expo``'s switch times carry a noise that grows
    such differences (docs/lyapunov.md, sections 12 and 14).  Measured after 3 periods: 8.6e-10
    (grid) and 6.5e-10 (window) on the 16-step grid, 3.0e-12 on 64 steps (1.4e-12 with the
    kernels of results version 9); at the two-mode chaotic point of the test below (from its
    state after 90 periods) 1.2e-7 with the window on 16 steps and 2.1e-7 on 64."""
    res, prepared, scales = settled
    pp = prepared[0]
    off = np.zeros((1, 2, 2 * pp.model.n + pp.model.n_quad))
    kw = dict(n_periods=3, e0=1e-4, renorm_period=np.array([[False, True]]), method="expo")
    args = ([pp], res[0].final_state[None], off, np.zeros((1, 2)), 1 / scales[:1])
    for adoption in ("grid", "window"):
        assert np.all(run_copies(*args, adoption=adoption, **kw)[0, :, 1:] < math.log(1e-8))
        # the bound of results versions 9-15, on their 64-step grid, where this orbit stays
        # on the drive to round-off
        on64 = run_copies(*args, adoption=adoption, steps_per_period=64, **kw)
        assert np.all(on64[0, :, 1:] < math.log(1e-10))


def test_separation_is_linear_in_the_offset_above_the_event_noise(settled):
    """On the slipping orbit a 10x smaller offset (1e-4 -> 1e-5) gives a 10x smaller separation,
    period by period: the copies' switches are located as the drive's are."""
    res, prepared, scales = settled
    pp = prepared[0]
    le = _free(pp, res[0].final_state, _offsets(pp, scales[0], (1e-4, 1e-5)), scales[0], 8, 1e-4,
               band=(1e-12, 1e12))
    ratio = np.exp(le[0, 0] - le[0, 1])
    assert np.all(np.abs(ratio - 10.0) < 0.05 * 10.0), ratio


@pytest.mark.parametrize("which", [0, 1])
def test_exponent_agrees_with_the_rk4_pair(settled, which):
    """Mean log growth per period over 30 renormalised periods (after 5): the expo pair at its
    separation 1e-4 and the RK4 pair at the pipeline's 1e-6 and step factor 0.5, on the
    periodic orbit with slip (0) and the stuck torus (1).  Measured: docs/lyapunov.md,
    section 12 (agreement within 0.01 per period on 49 default-grid points)."""
    res, prepared, scales = settled
    pp, sc, x = prepared[which], scales[which], res[which].final_state
    kw = dict(renorm_period=np.ones((1, 1), np.bool_), band=(1e-2, 1e2))
    le_e = _free(pp, x, _offsets(pp, sc, (1e-4,)), sc, 35, 1e-4, **kw)[0, 0]
    le_r = run_copies([pp], x[None], _offsets(pp, sc, (1e-6,)), np.zeros((1, 1)), 1 / sc[None],
                      n_periods=35, e0=1e-6, step_factor=0.5, **kw)[0, 0]
    rate_e = (le_e[-1] - le_e[5]) / 30
    rate_r = (le_r[-1] - le_r[5]) / 30
    print(f"\nlambda_1 T: expo pair {rate_e:+.4f}, RK4 pair {rate_r:+.4f}")
    assert abs(rate_e - rate_r) < 0.01, (rate_e, rate_r)


@pytest.mark.slow
def test_exponent_agrees_with_the_rk4_pair_at_a_chaotic_point():
    """At a chaotic point of the default grid's band the block statistics of the expo pair and
    of the RK4 pair (eight blocks of 25 periods after 25) are both positive well above the
    margin and agree within three combined standard errors (on a chaotic attractor the two
    integrators' drives follow different stretches, so only the statistics can agree).  Eight
    blocks, not the pipeline's three: a standard error from three block means has two degrees
    of freedom and can be a third of the spread between stretches (results version 14: 0.426 +-
    0.015 against 0.569 +- 0.025 over three blocks; over eight 0.454 +- 0.021 against 0.526 +-
    0.043, RK4 at half the step 0.509 +- 0.046; results version 16, the copies on 16 steps per
    period: 0.479 +- 0.044 against 0.489 +- 0.051; docs/lyapunov.md, sections 12 and 14)."""
    from analysis.lyapunov.block_statistics import BlockPlan

    pp = prepare_point(**BAND)
    r = simulate_batch([BAND], n_transient=600, n_record=64, method="expo", n_threads=1)[0]
    scale = attractor_scale(r.poincare_state, response_scale(pp), pp.omega)[None]
    plan = BlockPlan(min_blocks=8, max_blocks=8)
    kw = dict(n_periods=25, n_threads=2, plan=plan)
    st_e = beam_lle([pp], r.final_state[None], scale, free_method="expo", free_e0=1e-4, **kw)[0]
    st_r = beam_lle([pp], r.final_state[None], scale, **kw)[0]
    T = st_e.period
    a, b = st_e.statistics, st_r.statistics
    print(f"\nexpo {a.mean * T:.3f} +- {a.se * T:.3f}, RK4 {b.mean * T:.3f} +- {b.se * T:.3f}")
    assert a.verdict == b.verdict == "positive", (a.verdict, b.verdict)
    assert abs(a.mean - b.mean) * T <= 3.0 * math.hypot(a.se * T, b.se * T), (a.mean * T, b.mean * T)


@pytest.mark.parametrize("which", [0, 1])
def test_coupled_copies_obey_the_closed_form(settled, which):
    """A coupled ``expo`` copy (the coupling applied as its own flow at the output grid's step
    ends) obeys ``e_d(t) = e^{-d t} e_0(t)`` of the linearised dynamics, the check of the RK4
    pair (tests/analysis/test_lyapunov_beam.py) with its tolerance, on the slipping orbit and
    the stuck torus, without rescaling.  A coupling carried as a rescaling, or applied once a
    period instead of every step, misses by ``d t`` or by the factor 64."""
    res, prepared, scales = settled
    check_coupling_closed_form(prepared[which], res[which].final_state, scales[which], 1e-4,
                               method="expo")


def test_coupled_copies_do_not_depend_on_threads_or_other_copies(settled):
    """Coupled ``expo`` copies, like free ones: the same record whatever the thread count and
    whichever other copies run in the task (bitwise)."""
    res, prepared, scales = settled
    pp = prepared[0]
    off = np.concatenate([_offsets(pp, scales[0], (1e-4, 1e-4)),
                          initial_offset(pp, scales[0], 1e-3, seed=1)[None, None]], axis=1)
    d = np.array([[0.0, 0.05, 0.2]])
    args = ([pp], res[0].final_state[None], off, d, 1 / scales[:1])
    kw = dict(n_periods=3, e0=1e-4, method="expo")
    a = run_copies(*args, n_threads=1, split=1, **kw)
    b = run_copies(*args, n_threads=2, **kw)
    c = run_copies([pp], res[0].final_state[None], off[:, 2:], d[:, 2:], 1 / scales[:1], **kw)
    assert np.array_equal(a, b)
    assert np.array_equal(a[:, 2:], c)
    assert np.all(np.isfinite(a)) and not np.array_equal(a[0, 1], a[0, 2])  # the couplings act


def test_expo_ladder_agrees_with_benettin_at_a_chaotic_point():
    """Stefanski on the ``expo`` ladder (``ladder_method="expo"``) against the ``expo`` free
    copy's Benettin value at the two-mode chaotic point of tests/analysis/test_lyapunov_beam.py,
    on four 100-period stretches 40 periods apart: chaotic by both on every stretch, median
    ratio within 10 % (issue 4's check; measured 0.96, 0.92, 0.94, 1.04 with the copies on 64
    steps per period, 1.16, 0.925, 1.00, 0.958 on 16 since results version 16, and over eight
    stretches a median of 0.95 against the RK4 ladder's 1.10: docs/lyapunov.md, sections 13 and
    14)."""
    pp, starts, scale = stretches(CHAOTIC_2MODES, (40, 40, 40))
    ests = beam_lle([pp] * 4, starts, np.stack([scale] * 4), n_periods=100, n_threads=2,
                    free_method="expo", free_e0=1e-4, ladder_method="expo")
    T = 2 * math.pi / pp.omega
    ratios = []
    for est in ests:
        st, be = est.stefanski.value * T, est.benettin.value * T
        assert est.free_copy == "expo" and est.stefanski.chaotic, est.stefanski.verdict
        assert be > 2 * 5.0 / 100, be
        ratios.append(st / be)
    print("\nStefanski / Benettin on the expo ladder:", np.round(ratios, 3))
    assert abs(float(np.median(ratios)) - 1.0) <= 0.10, ratios


def test_continued_record_equals_one_long_run(settled):
    """A run continued from the end states (analysis.lyapunov.beam._long_records) gives the
    record of one long run: the drive bitwise, the renormalised copy to round-off."""
    res, prepared, scales = settled
    pp = prepared[0]
    n, nq = pp.model.n, pp.model.n_quad
    off = _offsets(pp, scales[0], (1e-4,))
    kw = dict(renorm_period=np.ones((1, 1), np.bool_), return_final=True)
    x0 = res[0].final_state
    whole, fin = _free(pp, x0, off, scales[0], 6, 1e-4, **kw)
    first, f1 = _free(pp, x0, off, scales[0], 3, 1e-4, **kw)
    cont = 2 * n + nq
    second, f2 = _free(pp, f1[0, 0], f1[:, 1:2, :cont] - f1[:, 0:1, :cont], scales[0], 3, 1e-4,
                       **kw)
    assert np.array_equal(f2[0, 0], fin[0, 0])
    joined = np.concatenate([first[0, 0], first[0, 0, -1] + second[0, 0, 1:] - second[0, 0, 0]])
    assert np.allclose(joined, whole[0, 0], rtol=0, atol=1e-6)


def test_results_do_not_depend_on_threads_or_other_copies(settled):
    res, prepared, scales = settled
    pp = prepared[0]
    off = np.concatenate([_offsets(pp, scales[0], (1e-4,)),
                          initial_offset(pp, scales[0], 1e-3, seed=1)[None, None]], axis=1)
    args = ([pp], res[0].final_state[None], off, np.zeros((1, 2)), 1 / scales[:1])
    kw = dict(n_periods=3, e0=1e-4, method="expo")
    a = run_copies(*args, n_threads=1, **kw)
    b = run_copies(*args, n_threads=2, **kw)
    c = run_copies([pp], res[0].final_state[None], off[:, :1], np.zeros((1, 1)), 1 / scales[:1],
                   **kw)
    assert np.array_equal(a, b)
    assert np.array_equal(a[:, :1], c)


def test_copies_sharing_a_full_pattern_cache_keep_their_decompositions(settled):
    """The copies of a task share a pattern cache; when it is full, one copy's decomposition
    takes the slot another copy is using, which must then look its pattern up again rather
    than run on the other's modes.  A two-slot cache (full at once) gives the result of the
    default one, to the bit."""
    res, prepared, scales = settled
    pp = prepared[0]
    off = np.concatenate([_offsets(pp, scales[0], (1e-4, 1e-3)),
                          initial_offset(pp, scales[0], 1e-3, seed=1)[None, None]], axis=1)
    args = ([pp], res[0].final_state[None], off, np.zeros((1, 3)), 1 / scales[:1])
    kw = dict(n_periods=3, e0=1e-4, method="expo", n_threads=1, split=1, return_final=True)
    a = run_copies(*args, **kw)
    b = run_copies(*args, pattern_cache=2, **kw)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])


def test_expo_copies_are_stick_slip_only(settled):
    res, prepared, scales = settled
    pp = prepared[0]
    off = _offsets(pp, scales[0], (1e-4,))
    slip = prepare_point(**(SLIPPING | {"law": "full-slip"}))
    with pytest.raises(ValueError, match="law"):
        run_copies([slip], res[0].final_state[None], off, np.zeros((1, 1)), 1 / scales[:1],
                   n_periods=1, e0=1e-4, method="expo")
    with pytest.raises(ValueError, match="method"):
        run_copies([pp], res[0].final_state[None], off, np.zeros((1, 1)), 1 / scales[:1],
                   n_periods=1, e0=1e-4, method="euler")


def _logged_intervals(switches, window, limit):
    """The drive's logged intervals in one output step (every switch begins one more) until the
    step ends or the Zeno guard fires, by the guard's rule; one more than the drive logs when
    the guard fires (it stops before the next interval), so an upper bound."""
    from beamsim.kernels.expo import zeno_count

    t_win, guard, k = 0.0, 0, 1
    for t in switches:
        k += 1
        t_win, guard = zeno_count(t, t_win, guard, window)
        if guard > limit:
            break
    return k


def test_zeno_guard_counts_per_window_and_the_drives_log_holds_a_step():
    """One Zeno-guard rule for ``expo``'s runs, its drive and its copies: a switch a window or
    more after the window's start begins a new one, and the guard fires on the count's
    ``10 nq + 10 + 1``-th switch in a window.  The drive's log (``log_size``) holds every
    interval of an output step before the guard fires, on 16 and 4 steps per period and the
    densest switch sequences the rule lets through (each window filled to the limit, the next
    one begun as early as the rule allows)."""
    from beamsim.kernels.expo import zeno_count, zeno_limit, zeno_window
    from beamsim.kernels.expo_copies import log_size

    assert zeno_count(0.5, 0.0, 3, 1.0) == (0.0, 4)
    assert zeno_count(1.0, 0.0, 3, 1.0) == (1.0, 1)
    om, nq = 1.85, 8
    window, limit = zeno_window(om), zeno_limit(nq)
    assert window == pytest.approx(2 * math.pi / om / 64, rel=1e-15) and limit == 90
    for n_per in (16, 4):
        h = 2 * math.pi / om / n_per
        worst = 0
        for offset in (0.0, 1e-9 * window, 0.5 * window):
            # limit switches from the window's start, then the next window's first switch a
            # window later (and a rounding more)
            starts = offset + np.arange(int(h / window) + 2) * window * (1.0 + 1e-12)
            dense = np.concatenate([s + np.linspace(0.0, 0.999 * window, limit) for s in starts])
            dense = dense[dense < h]
            assert _logged_intervals(dense, window, limit) == dense.size + 1  # no guard fired
            worst = max(worst, dense.size + 1)
        rng = np.random.default_rng(0)
        for _ in range(200):
            ts = np.sort(rng.uniform(0.0, h, rng.integers(1, 6 * limit)))
            worst = max(worst, _logged_intervals(ts, window, limit))
        assert worst <= log_size(h, om, nq)
        # and one switch more in a filled window fires the guard
        over = np.linspace(0.0, 0.5 * window, limit + 1)
        assert _logged_intervals(over, window, limit) == limit + 2

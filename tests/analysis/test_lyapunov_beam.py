"""Lyapunov estimates on the beam: the drive/copy integrator (beamsim.coupled_copies) and the
Stefanski / Benettin estimates built on it (analysis.lyapunov.beam).

Independent checks: a copy with zero offset and zero coupling is the drive (bitwise); the
linear limit (the separation scales with the initial offset); the closed form of the coupling
(``e_d(t) = e^{-d t} e_0(t)`` for the linearised dynamics with the same switching sequence);
a restart reproduces an uninterrupted run; Stefanski vs Benettin on attractors of each kind,
and the verdict when the measuring time doubles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from beam_copies import CHAOTIC_2MODES, check_coupling_closed_form, stretches

from analysis.lyapunov.beam import attractor_scale, beam_benettin, beam_lle, initial_offset, response_scale
from beamsim.coupled_copies import run_copies
from beamsim.simulate import prepare_point, restart_params, simulate_batch

# one arch mode keeps these runs short; the state still has 10 coordinates, 8 Jenkins elements
BASE = dict(n_modes=1, mu_k=0.3, interface_damping=0.5)
SLIPPING = dict(BASE, Omega=2.5, f0_rel=2.5, mu_s=0.6)      # period-1 orbit with slip
STUCK = dict(BASE, Omega=2.5, f0_rel=0.5, mu_s=0.45)        # below onset: undamped, torus
# chaotic: three modes and static friction three times the kinetic one (docs/lyapunov.md s.7:
# lambda_1 T = 1.67 per forcing period over 400 periods, converged in the step)
CHAOTIC = dict(n_modes=3, mu_s=0.9, mu_k=0.3, interface_damping=0.5, Omega=1.5, f0_rel=2.2)


@pytest.fixture(scope="module")
def settled():
    """Reference runs (60 periods) of the test points, their restart states and scales."""
    pts = [SLIPPING, STUCK]
    res = simulate_batch(pts, n_transient=30, n_record=30, method="rk4", n_threads=2)
    prepared = [prepare_point(**p) for p in pts]
    scales = np.stack([attractor_scale(r.poincare_state, response_scale(pp), pp.omega)
                       for r, pp in zip(res, prepared)])
    return pts, res, prepared, scales


def _offsets(pp, scale, e0s):
    return np.stack([initial_offset(pp, scale, e0) for e0 in e0s])[None]


def test_restart_continues_the_run():
    a = simulate_batch([SLIPPING], n_transient=0, n_record=6, method="rk4")[0]
    b = simulate_batch([SLIPPING], n_transient=0, n_record=3, method="rk4")[0]
    c = simulate_batch([restart_params(b)], n_transient=0, n_record=3, method="rk4")[0]
    size = np.abs(a.poincare_state).max()
    assert np.abs(c.poincare_state[-1] - a.poincare_state[-1]).max() < 1e-9 * size
    assert set(np.unique(a.final_state[-8:])) <= {-1.0, 0.0, 1.0}


def test_unperturbed_uncoupled_copy_is_the_drive(settled):
    pts, res, prepared, scales = settled
    pp = prepared[0]
    off = np.zeros((1, 2, 2 * pp.model.n + pp.model.n_quad))
    le = run_copies([pp], res[0].final_state[None], off, np.array([[0.0, 0.0]]), 1 / scales[:1],
                    n_periods=3, e0=1e-6, renorm_period=np.array([[False, True]]))
    # the copy switches one split later than the drive when both hit an event at the same
    # instant (switches are applied one at a time): round-off-level differences only
    assert np.all(le[0, :, 1:] < math.log(1e-11))


def test_rescaling_at_period_ends_does_not_change_the_recorded_error(settled):
    """One free copy serves Stefanski's d = 0 test and Benettin (analysis.lyapunov.beam): the
    recorded ln eps carries every rescaling factor, so a copy rescaled only when it leaves the
    band and one rescaled at every period end as well record the same linearised error up to the
    nonlinear remainder (separations differ by up to the band; switch times move with them).
    Checked on the slipping periodic orbit and the stuck torus over 20 periods (measured 2.1e-3
    and 8.5e-5): the records agree to 0.01 in ln eps, 1/500 of what the estimators resolve over
    a window (5 in ln eps, the resolution 5 / n_periods per period); a wrong carry of the
    rescaling factor would differ by ln(e / e0), i.e. O(1)."""
    pts, res, prepared, scales = settled
    for k in (0, 1):
        pp = prepared[k]
        off = _offsets(pp, scales[k], [1e-6, 1e-6])
        le = run_copies([pp], res[k].final_state[None], off, np.zeros((1, 2)), 1 / scales[k:k + 1],
                        n_periods=20, e0=1e-6, band=(1e-2, 1e2), renorm_period=np.array([[False, True]]))
        assert np.all(np.isfinite(le))
        assert np.max(np.abs(le[0, 0] - le[0, 1])) < 0.01, (k, np.max(np.abs(le[0, 0] - le[0, 1])))
        # the records move: the test compares something (the errors change by more than 1e-3)
        assert np.ptp(le[0, 0]) > 1e-3


def test_separation_is_linear_in_the_offset(settled):
    """On a slipping orbit a 10x smaller offset gives a 10x smaller separation, period by period
    (the stick/slip switching of the copies is resolved; a missed or spurious switch would
    break this)."""
    pts, res, prepared, scales = settled
    pp = prepared[0]
    e0s = (1e-6, 1e-7)
    le = run_copies([pp], res[0].final_state[None], _offsets(pp, scales[0], e0s),
                    np.zeros((1, 2)), 1 / scales[:1], n_periods=8, e0=1e-6, band=(1e-12, 1e12))
    ratio = np.exp(le[0, 0] - le[0, 1])
    assert np.all(np.abs(ratio - 10.0) < 0.05 * 10.0), ratio


def test_coupling_obeys_the_closed_form(settled):
    """e_d(t) = exp(-d t) e_0(t) for the linearised dynamics (the coupling adds -d I to the
    variational equation), measured without rescaling."""
    pts, res, prepared, scales = settled
    check_coupling_closed_form(prepared[0], res[0].final_state, scales[0], 1e-6)


def test_results_do_not_depend_on_threads_or_other_copies(settled):
    pts, res, prepared, scales = settled
    pp = prepared[0]
    off = _offsets(pp, scales[0], (1e-6,) * 3)
    d = np.array([[0.0, 1e-3, 2e-3]])
    args = ([pp], res[0].final_state[None])
    a = run_copies(*args, off, d, 1 / scales[:1], n_periods=3, e0=1e-6, n_threads=1)
    b = run_copies(*args, off, d, 1 / scales[:1], n_periods=3, e0=1e-6, n_threads=2)
    c = run_copies(*args, off[:, 1:2], d[:, 1:2], 1 / scales[:1], n_periods=3, e0=1e-6)
    assert np.array_equal(a, b)
    assert np.array_equal(a[:, 1:2], c)
    # all copies in one task, far enough apart (1e-3) that they switch in other steps than the
    # drive: a coupled copy after other coupled copies (which split their steps at their own
    # switches) must see the same drive as alone (this caught a scratch-array clash)
    far = np.stack([initial_offset(pp, scales[0], 1e-3, seed=s) for s in range(3)])[None]
    dc = np.array([[1e-3, 2e-3, 3e-3]])
    e = run_copies(*args, far, dc, 1 / scales[:1], n_periods=3, e0=1e-3, split=1)
    f = run_copies(*args, far[:, 2:3], dc[:, 2:3], 1 / scales[:1], n_periods=3, e0=1e-3)
    assert np.array_equal(e[:, 2:3], f)


@pytest.mark.parametrize("which", [0, 1])
def test_non_chaotic_points_give_non_positive_exponents(settled, which):
    """Periodic orbit with slip (0) and the stuck, undamped beam (1, a torus): Stefanski and
    Benettin both give lambda_1 T <= ~0 (|lambda_1 T| below the resolution 5 / n_periods), and
    doubling the measuring time keeps the verdict."""
    pts, res, prepared, scales = settled
    for n_periods in (20, 40):
        est = beam_lle([prepared[which]], res[which].final_state[None], scales[which:which + 1],
                       n_periods=n_periods)[0]
        T = est.period
        tol = 5.0 / n_periods
        assert est.stefanski.value * T <= tol, est.stefanski.verdict
        assert est.benettin.value * T <= tol
        assert not est.stefanski.chaotic, est.stefanski.verdict
        assert est.stefanski.verdict.startswith(("zero exponent", "non-chaotic")), est.stefanski.verdict
        assert abs(est.stefanski.value - est.benettin.value) * T <= tol


@pytest.mark.slow
def test_chaotic_point_is_chaotic_for_both_estimators():
    """At a chaotic beam point (three modes, mu_s = 3 mu_k; lambda_1 T = 1.65 +- 0.1 per forcing
    period from 400-period Benettin runs at three step sizes, docs/lyapunov.md s.7) Benettin's
    exponent (RK4 pair) is far above the resolution and stays so when the measuring time
    doubles, and on the pipeline's path (``expo`` free copy and ``expo`` ladder) Stefanski's
    verdict is chaotic in each of six consecutive, non-overlapping 40-period windows, with its
    threshold d_s summed over the six at or above 0.9 of Benettin's values summed over the same
    windows (for a non-smooth flow d_s bounds lambda_1 from above, Baumann & Leine 2016; 0.9:
    the windows' noise).  Until results version 25 the test read the first window alone (over
    20 periods: 2.00 against 2.10 in version 14, 1.68 against 1.94 in version 15; over 40 1.47
    against 1.50, over 60 1.67 against 1.67), and one window does not decide it: in version 26
    the first window read 1.86 against 1.82, and windows 16 periods apart (overlapping) read
    ratios 0.81-1.02 (version 25's code: 0.72-1.10).  The six windows of this test in version
    26: 1.02, 0.93, 0.98, 0.97, 0.90, 0.98 (the sums' ratio 0.96).  The RK4 ladder at the
    pipeline's step did not synchronise below its cap there (d_s T = 492 against Benettin's
    2.42), at half that step it read 1.93 against 1.78 (docs/lyapunov.md, section 13)."""
    pp = prepare_point(**CHAOTIC)
    r = simulate_batch([CHAOTIC], n_transient=60, n_record=16, method="rk4", n_threads=2)[0]
    scale = attractor_scale(r.poincare_state, response_scale(pp), pp.omega)[None]
    T = 2 * math.pi / pp.omega
    for n_periods in (30, 60):
        be = beam_benettin([pp], r.final_state[None], scale, n_periods=n_periods,
                           n_threads=2)[0].value * T
        assert be > 3 * 5.0 / n_periods, (n_periods, be)
    windows = []
    for _ in range(6):
        scale = attractor_scale(r.poincare_state, response_scale(pp), pp.omega)[None]
        est = beam_lle([pp], r.final_state[None], scale, n_periods=40, n_threads=2,
                       free_method="expo", free_e0=1e-4, ladder_method="expo")[0]
        assert est.free_copy == "expo"
        assert est.stefanski.chaotic and est.stefanski.verdict.startswith("chaotic"), \
            est.stefanski.verdict
        assert est.benettin.value * T > 5.0 / 40
        windows.append((est.stefanski.value * T, est.benettin.value * T))
        # the next window starts where this one ends: 24 + 16 = 40 periods on
        r = simulate_batch([CHAOTIC | restart_params(r)], n_transient=24, n_record=16,
                           method="rk4", n_threads=2)[0]
    st, be = np.sum(windows, axis=0)
    print(f"\nStefanski / Benettin per 40-period window: {np.round(windows, 3).tolist()}")
    assert st >= 0.9 * be, windows


@pytest.mark.slow
def test_rk4_ladder_bounds_benettin_at_a_two_mode_chaotic_point():
    """The RK4 ladder (the Stefanski column where the free copy is RK4's: the regularised laws,
    ``mu_s = mu_k``, a point that met expo's Zeno guard) at the two-mode chaotic point
    (mu_s / mu_k = 1.5) on a 100-period stretch from where the pipeline starts (after 60 + 128
    periods at step factor 1.0): chaotic by both estimators, and Stefanski an upper bound of
    Benettin (>= 0.95 of it: Benettin's window noise) that stays within 1.5 of it.  Issue 4's
    "within 10 %" is checked on the pipeline's default, the ``expo`` ladder
    (tests/beamsim/test_expo_copies.py), over four stretches.  The RK4 ladder's ratio on
    eight stretches of this point: 1.04-1.16, median 1.10; at a two-mode band point
    1.32-1.45 (docs/lyapunov.md, section 13)."""
    pp, starts, scale = stretches(CHAOTIC_2MODES, ())
    T = 2 * math.pi / pp.omega
    est = beam_lle([pp], starts, scale[None], n_periods=100, n_threads=2)[0]
    st, be = est.stefanski.value * T, est.benettin.value * T
    assert est.stefanski.chaotic and est.stefanski.verdict.startswith("chaotic"), est.stefanski.verdict
    assert be > 2 * 5.0 / 100, be  # chaotic by Benettin too, well above the resolution
    assert 0.95 * be <= st <= 1.5 * be, (st, be)


def test_continued_record_equals_one_long_run(settled):
    """The long Benettin record is run in pieces (analysis.lyapunov.beam._long_records): a run
    continued from the end states of the first piece gives the same record as one long run
    (the drive bitwise; the renormalised copy to round-off)."""
    pts, res, prepared, scales = settled
    pp = prepared[0]
    n, nq = pp.model.n, pp.model.n_quad
    off = _offsets(pp, scales[0], (1e-6,))
    kw = dict(e0=1e-6, renorm_period=np.ones((1, 1), np.bool_))
    whole, fin = run_copies([pp], res[0].final_state[None], off, np.zeros((1, 1)), 1 / scales[:1],
                            n_periods=6, return_final=True, **kw)
    first, f1 = run_copies([pp], res[0].final_state[None], off, np.zeros((1, 1)), 1 / scales[:1],
                           n_periods=3, return_final=True, **kw)
    cont = 2 * n + nq
    second, f2 = run_copies([pp], f1[:, 0], f1[:, 1:2, :cont] - f1[:, 0:1, :cont], np.zeros((1, 1)),
                            1 / scales[:1], n_periods=3, return_final=True, **kw)
    assert np.array_equal(f2[0, 0], fin[0, 0])  # the drive
    joined = np.concatenate([first[0, 0], first[0, 0, -1] + second[0, 0, 1:] - second[0, 0, 0]])
    assert np.allclose(joined, whole[0, 0], rtol=0, atol=1e-6)
    # and beam_lle's statistics follow the plan: an undetermined point is continued
    from analysis.lyapunov.block_statistics import BlockPlan

    plan = BlockPlan(block=2, burn_in=1, min_blocks=2, max_blocks=3, margin=0.05)
    est = beam_lle([pp], res[0].final_state[None], scales[:1], n_periods=3, plan=plan)[0]
    st = est.statistics
    assert st.n_periods in (4, 6) and st.blocks.size == st.n_periods // 2
    first_verdict = plan.statistics(whole[0, 0][:6], est.period).verdict
    assert (st.n_periods == 6) == (first_verdict == "undetermined")

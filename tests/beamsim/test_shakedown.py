"""beamsim.shakedown: the bound on a stuck beam's future interface tractions, against the exact
linear flow (matrix exponential, scipy) and against the integrator (whether elements slip)."""

import numpy as np
import pytest
from kicked_start import kicked_locked_orbit
from scipy.linalg import expm

from beamsim.point import prepare_point
from beamsim.shakedown import difference_energy, lock_ratio, locked_orbit, stuck_traction_bound
from beamsim.simulate import simulate, state_params

#: one mode, the default grid's friction, below the static slip onset: the start-up slips, the
#: record is stuck (tests/analysis/test_pipeline_stages.py uses the same point)
POINT = {"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "interface_viscosity": 0.0939, "Omega": 2.5,
         "f0_rel": 0.8}


@pytest.fixture(scope="module")
def stuck_end():
    pp = prepare_point(**POINT)
    r = simulate(**POINT, n_transient=60, n_record=128, method="expo")
    assert r.slipped and r.stick_fraction == 1.0
    return pp, np.asarray(r.final_state, dtype=float)


def _parts(pp, x):
    m = pp.model
    n, nq = m.n, m.n_quad
    return m, n, nq, x[:n], x[n:2 * n], x[2 * n:2 * n + nq]


def _stuck_flow(pp, x, n_periods, per_period=64):
    """Elastic tractions / slip limit of the everywhere-stuck beam from ``x`` at t = 0, by the
    exact propagator of the linear system with the forcing as two oscillator states; yields the
    ratio per element at every ``T / per_period`` and the state."""
    m, n, nq, q, v, z = _parts(pp, x)
    kt, S, w = m.geom.k_t, m.S, pp.omega
    Mi = np.linalg.inv(m.M)
    A = np.zeros((2 * n + 2, 2 * n + 2))
    A[:n, n:2 * n] = np.eye(n)
    A[n:2 * n, :n] = -Mi @ m.K_stuck
    A[n:2 * n, n:2 * n] = -Mi @ m.C
    A[n:2 * n, 2 * n] = pp.f0 * (Mi @ m.g)
    A[2 * n, 2 * n + 1], A[2 * n + 1, 2 * n] = -w, w
    # the constant part of the load and the frozen sliders: a static shift
    shift = np.linalg.solve(m.K_stuck, -pp.f0 * m.g + kt * (S.T @ (m.wq * z)))
    E = expm(A * (2 * np.pi / w / per_period))
    y = np.concatenate([q - shift, v, [1.0, 0.0]])
    for _ in range(n_periods * per_period):
        y = E @ y
        yield np.abs(kt * (S @ (y[:n] + shift) - z)) / pp.tau_s, y, shift


def test_the_bound_holds_over_a_long_run_and_is_nearly_reached(stuck_end):
    """Over 2000 periods of the exact stuck flow every element's traction stays below its bound,
    and the largest comes within 2 % of it (the phases of the forced response and the stuck
    modes come close to alignment: the bound is not loose)."""
    pp, x = stuck_end
    m, n, nq, q, v, z = _parts(pp, x)
    bound = stuck_traction_bound(pp, x)
    now = np.abs(m.geom.k_t * (m.S @ q - z)) / pp.tau_s
    assert np.all(now <= bound)
    seen = np.zeros_like(bound)
    for ratio, _, _ in _stuck_flow(pp, x, 2000):
        seen = np.maximum(seen, ratio)
    assert np.all(seen <= bound * (1 + 1e-9)), (seen, bound)
    k = int(np.argmax(bound))
    assert seen[k] >= 0.98 * bound[k], (seen[k], bound[k])
    assert bound.max() < 1.0


def test_the_bound_does_not_grow_along_the_flow_at_any_phase(stuck_end):
    """The bound from a later state of the same stuck motion, at a time that is no period
    boundary (so the forcing's phase enters through ``t0``), is the bound from the first state
    up to the free vibration's decay: the forced response is separated correctly at any phase."""
    pp, x = stuck_end
    m, n, nq, q, v, z = _parts(pp, x)
    b0 = stuck_traction_bound(pp, x).max()
    per = 64
    for k, (_, y, shift) in enumerate(_stuck_flow(pp, x, 3, per), start=1):
        if k % 23:
            continue
        later = np.concatenate([y[:n] + shift, y[n:2 * n], z, np.zeros(nq)])
        b = stuck_traction_bound(pp, later, t0=k * 2 * np.pi / pp.omega / per).max()
        assert b <= b0 * (1 + 1e-9) and b >= b0 * (1 - 1e-3), (k, b, b0)


@pytest.mark.parametrize("Omega", [0.98, 1.0, 1.02])
def test_the_forced_part_is_its_full_amplitude_at_any_phase_lag(Omega):
    """Near a damped resonance of the stuck beam (5 % modal damping, forcing at 0.98-1.02 of its
    first natural frequency) the forced response lags the load by 50-130 degrees.  From a state
    on the forced response (no free vibration) the exact flow's largest traction over a period
    is the bound itself (to the sampling's 1e-5): the bound takes the whole amplitude of the
    cos and sin parts and the static part with it, not the in-phase part alone."""
    point = POINT | {"damping": 0.05, "Omega": Omega, "f0_rel": 0.05}
    pp = prepare_point(**point)
    m = pp.model
    nq = m.n_quad
    S, w = m.S, pp.omega
    z = np.zeros(nq)
    q_c = np.linalg.solve(m.K_stuck, -pp.f0 * m.g)
    Q = np.linalg.solve(m.K_stuck - w * w * m.M + 1j * w * m.C, pp.f0 * m.g.astype(complex))
    SQ = S @ Q
    k = int(np.argmax(np.abs(SQ)))
    assert abs(SQ[k].imag) > 0.7 * abs(SQ[k])  # the out-of-phase part dominates
    x = np.concatenate([q_c + Q.real, (1j * w * Q).real, z, np.zeros(nq)])
    bound = stuck_traction_bound(pp, x)
    seen = np.zeros_like(bound)
    for ratio, _, _ in _stuck_flow(pp, x, 2, per_period=2048):
        seen = np.maximum(seen, ratio)
    assert np.all(seen <= bound * (1 + 1e-9)), (seen, bound)
    assert np.all(seen >= bound * (1 - 1e-5)), (seen, bound)


@pytest.mark.parametrize("scale", [1.5, 3.0])
def test_below_the_bound_nothing_slips_above_it_an_element_does(stuck_end, scale):
    """The integrator (``expo``) from the certified end state: 2000 more periods without a slip.
    From the same state with its free vibration enlarged (the forced response kept) so that the
    bound exceeds 1 while every element is still below its limit: an element slips."""
    pp, x = stuck_end
    m, n, nq, q, v, z = _parts(pp, x)
    mode = x[2 * n + nq:]
    r = simulate(**POINT, q0=q, v0=v, z0=z, mode0=mode, n_transient=0, n_record=2000, method="expo")
    assert not r.slipped and r.stick_fraction == 1.0
    kt, S, w = m.geom.k_t, m.S, pp.omega
    q_c = np.linalg.solve(m.K_stuck, -pp.f0 * m.g + kt * (S.T @ (m.wq * z)))
    Q = np.linalg.solve(m.K_stuck - w * w * m.M + 1j * w * m.C, pp.f0 * m.g.astype(complex))
    forced = np.concatenate([q_c + Q.real, (1j * w * Q).real, z, mode])
    xs = forced + scale * (x - forced)
    assert stuck_traction_bound(pp, xs).max() > 1.0
    assert np.all(np.abs(kt * (S @ xs[:n] - z)) < pp.tau_s)
    r = simulate(**POINT, q0=xs[:n], v0=xs[n:2 * n], z0=z, mode0=mode, n_transient=0, n_record=200,
                 method="expo")
    assert r.slipped and r.stick_fraction < 1.0


def test_an_undamped_stuck_record_above_the_bound_slips_much_later():
    """Without the interface dashpot the same point's record is stuck over its 128 periods too,
    but the free vibration never decays and its bound exceeds 1: the integrator finds a slip
    thousands of periods later, where a record could not have shown it."""
    point = POINT | {"interface_viscosity": 0.0}
    pp = prepare_point(**point)
    n, nq = pp.model.n, pp.model.n_quad
    r = simulate(**point, n_transient=60, n_record=128, method="expo")
    assert r.stick_fraction == 1.0
    x = np.asarray(r.final_state, dtype=float)
    assert stuck_traction_bound(pp, x).max() > 1.0
    r = simulate(**point, q0=x[:n], v0=x[n:2 * n], z0=x[2 * n:2 * n + nq], mode0=x[2 * n + nq:],
                 n_transient=0, n_record=6000, method="expo")
    assert r.slipped and r.t_first_slip > 1000 * 2 * np.pi / pp.omega


def test_the_locked_orbit_is_a_stuck_period_one_motion_whose_peak_traction_is_its_ratio():
    """The locked orbit's state under the exact stuck flow (matrix exponential, not the formula
    that built it): after one period it is back where it started (period 1, no free vibration
    to the rounding), its largest traction over the period is its ratio (to the sampling's
    1e-5) and never above it, and its mean traction is zero (sliders at the structure's
    mean deflection).  ``stuck_traction_bound`` of the state is the ratio; the ratio is linear
    in the load."""
    pp = prepare_point(**POINT)
    orbit = locked_orbit(pp)
    x = orbit.state
    n, nq = pp.model.n, pp.model.n_quad
    assert np.all(x[2 * n + nq:] == 0.0)
    np.testing.assert_allclose(stuck_traction_bound(pp, x), orbit.ratio, rtol=1e-7)
    seen = np.zeros(nq)
    mean = np.zeros(nq)
    per = 4096
    m = pp.model
    for k, (ratio, y, shift) in enumerate(_stuck_flow(pp, x, 1, per_period=per)):
        seen = np.maximum(seen, ratio)
        mean += m.geom.k_t * (m.S @ (y[:n] + shift) - x[2 * n:2 * n + nq]) / pp.tau_s / per
    np.testing.assert_allclose(y[:n] + shift, x[:n], rtol=0, atol=1e-9 * np.abs(x[:n]).max())
    assert np.all(seen <= orbit.ratio * (1 + 1e-9)) and np.all(seen >= orbit.ratio * (1 - 1e-5))
    assert np.abs(mean).max() < 1e-9 * orbit.ratio.max()
    assert lock_ratio(prepare_point(**(POINT | {"f0_rel": 2 * POINT["f0_rel"]}))) == \
        pytest.approx(2 * lock_ratio(pp), rel=1e-12)


@pytest.mark.parametrize("method", ["expo", "rk4"])
def test_the_lock_up_limit_is_sharp_for_the_integrators(method):
    """The integrators (their own stick/slip logic) from the locked orbit at 0.97 and 1.03 of
    the lock-up load: below it, 100 periods without a slip on one period-1 orbit; above it, an
    element slips in the first period (the locked orbit is the everywhere-stuck motion with the
    smallest tractions, so above the limit no stuck motion is left)."""
    r1 = lock_ratio(prepare_point(**POINT))
    for target, stays in ((0.97, True), (1.03, False)):
        point = POINT | {"f0_rel": POINT["f0_rel"] * target / r1}
        pp = prepare_point(**point)
        orbit = locked_orbit(pp)
        assert orbit.ratio.max() == pytest.approx(target, rel=1e-12)
        r = simulate(**state_params(point, orbit.state, pp.model.n), n_transient=0,
                     n_record=100 if stays else 2, method=method)
        if stays:
            assert not r.slipped and r.stick_fraction == 1.0
            xs = r.poincare_state
            assert np.ptp(xs, axis=0).max() < 1e-8 * np.abs(xs).max()
        else:
            assert r.slipped and r.t_first_slip < 2 * np.pi / pp.omega


def test_refuses_other_laws_and_wrong_states(stuck_end):
    pp, x = stuck_end
    with pytest.raises(ValueError, match="state must have"):
        stuck_traction_bound(pp, x[:-1])
    rigid = prepare_point(**(POINT | {"law": "rigid-stick", "mu_s": 0.3}))
    with pytest.raises(ValueError, match="elastic stick"):
        stuck_traction_bound(rigid, x)
    with pytest.raises(ValueError, match="elastic stick"):
        lock_ratio(rigid)


def test_the_pipeline_reads_a_failed_decomposition_as_not_proven(stuck_end, monkeypatch):
    """``analysis.pipeline.stages.stuck_bound``: where the stuck beam's modes give no basis (a
    singular eigenvector matrix) or a NaN, the record is not proven (``inf``: its label becomes
    undetermined) and the batch goes on; the rigid stick has no bound (``nan``)."""
    import beamsim.shakedown as sd
    from analysis.pipeline.stages import stuck_bound

    pp, x = stuck_end
    assert stuck_bound(pp, x) == stuck_traction_bound(pp, x).max()
    eig = np.linalg.eig

    def degenerate(column):
        def fake(a):
            lam, psi = eig(a)
            psi[:, 1] = column(psi)
            return lam, psi
        return fake

    # two eigenvectors equal to rounding: the coefficients blow up, the bound is far above 1
    monkeypatch.setattr(sd.np.linalg, "eig", degenerate(lambda psi: psi[:, 0]))
    assert stuck_bound(pp, x) > 1.0
    # no basis at all (LAPACK refuses the solve): not proven
    monkeypatch.setattr(sd.np.linalg, "eig", degenerate(lambda psi: 0.0))
    assert stuck_bound(pp, x) == np.inf
    # a NaN in the bound proves nothing either (NaN is the rigid stick's "no bound" alone)
    monkeypatch.setattr(sd.np.linalg, "eig", degenerate(lambda psi: np.nan))
    assert stuck_bound(pp, x) == np.inf
    monkeypatch.undo()
    rigid = prepare_point(**(POINT | {"law": "rigid-stick", "mu_s": 0.3}))
    assert np.isnan(stuck_bound(rigid, x))


@pytest.mark.parametrize("method", ["expo", "rk4"])
def test_below_the_shakedown_limit_every_motion_stops_slipping(method):
    """The shakedown limit against the integrators' own stick/slip logic.  At 0.9 of it
    (kinetic ratio 0.9; static 0.6) a start far off the locked orbit (a velocity kick of 30
    times the orbit's scale in the slowest stuck mode) slips for many periods, yet the energy
    of its difference from the locked orbit falls in every period, as the theorem says
    (``dW/dt <= -(1 - ratio) tau_k |z'|`` per element, plus the dashpot's loss), and the
    slipping stops.  At 1.3 of it (static ratio 0.87, so a locked orbit still exists) the same
    start is still slipping after 250 periods and that energy grows in some period: the
    theorem's hypothesis is what makes it fall."""
    rk = locked_orbit(prepare_point(**POINT)).kinetic_ratio.max()
    for target in (0.9, 1.3):
        point = POINT | {"f0_rel": POINT["f0_rel"] * target / rk}
        pp = prepare_point(**point)
        orbit = locked_orbit(pp)
        n = pp.model.n
        x = kicked_locked_orbit(pp)
        energy, slipping = [difference_energy(pp, x, orbit)], []
        for _ in range(250):
            r = simulate(**state_params(point, x, n), n_transient=0, n_record=1, method=method)
            x = np.asarray(r.final_state, dtype=float)
            energy.append(difference_energy(pp, x, orbit))
            slipping.append(r.stick_fraction < 1.0)
        grows = np.max(np.diff(energy) / np.asarray(energy[:-1]))
        if target < 1.0:
            assert sum(slipping) > 20 and not any(slipping[-40:])
            assert grows < 1e-9
        else:
            assert slipping[-1] and grows > 1e-3

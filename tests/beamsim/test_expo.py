"""expo: the real eigen-decomposition and its conjugate-pair ordering (the damped system's modes
are evaluated half as often), the check ladder and the closed form in the interval's
coefficients (against the divided-difference form), the response to an anchor shift (against
RK4), and the pattern cache (its size, and its sharing across points and runs, change the cost,
not the result)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from beamsim.kernels import expo
from beamsim.kernels.bundles import State, point_at
from beamsim.kernels.real_eig import real_eig
from beamsim.pattern_store import PatternStore, model_keys
from beamsim.point import stack_points
from beamsim.simulate import prepare_point, simulate, simulate_batch, state_params


def _oscillators(*pairs):
    """First-order matrix of uncoupled oscillators ``x'' + c x' + k x = 0`` for ``(k, c)``
    pairs, coupled afterwards by a random similarity (a real matrix of the same spectrum)."""
    n = len(pairs)
    A = np.zeros((2 * n, 2 * n))
    for i, (k, c) in enumerate(pairs):
        A[i, n + i] = 1.0
        A[n + i, i] = -k
        A[n + i, n + i] = -c
    T = np.random.default_rng(1).normal(size=(2 * n, 2 * n)) + 3 * np.eye(2 * n)
    return T @ A @ np.linalg.inv(T)


@pytest.mark.parametrize("pairs, nc_expected", [
    (((1.0, 0.1), (9.0, 0.5), (100.0, 2.0)), 3),    # all underdamped: three conjugate pairs
    (((1.0, 0.1), (1.0, 3.0)), 1),                   # one underdamped, one overdamped (2 real)
    (((1.0, 3.0), (4.0, 5.0)), 0),                   # all overdamped: four real modes
])
def test_pairs_reproduce_the_real_system(pairs, nc_expected):
    A = _oscillators(*pairs)
    lam2, V2, nh, nc = real_eig(A)
    n2 = A.shape[0]
    assert nc == nc_expected and nh == n2 - nc
    # the spectrum numpy's complex eigensolver finds (an independent LAPACK driver), and the
    # oscillators' own roots -c/2 +- sqrt(c^2/4 - k)
    ref = np.linalg.eigvals(A.astype(np.complex128))
    roots = np.concatenate([np.roots([1.0, c, k]) for k, c in pairs])
    for other in (ref, roots):
        d = np.abs(lam2[:, None] - other[None, :]).min(axis=1)
        assert d.max() < 1e-9 * np.abs(other).max()
    # a decomposition of the same matrix
    Vi = np.linalg.inv(V2)
    assert np.abs(V2 @ np.diag(lam2) @ Vi - A).max() < 1e-10 * np.abs(A).max()
    # positive imaginary parts first, then real ones, then the exact conjugates
    assert np.all(lam2[:nc].imag > 0) and np.all(lam2[nc:nh].imag == 0)
    assert np.array_equal(lam2[nh:], np.conj(lam2[:nc]))
    assert np.array_equal(V2[:, nh:], np.conj(V2[:, :nc]))
    # a real state from the first nh modal coordinates, weight 2 on each pair
    x = np.random.default_rng(2).normal(size=n2)
    zeta = Vi @ x
    wt = np.where(np.arange(nh) < nc, 2.0, 1.0)
    back = (V2[:, :nh] * (wt * zeta[:nh])).real.sum(axis=1)
    assert np.abs(back - x).max() < 1e-10 * np.abs(x).max()


def _interval_start(viscosity=0.0939):
    """A three-mode point (the pipeline's interface dashpot by default) in a mixed stick
    pattern, projected onto its modes at ``t0 = 0.1``: ``(md, wk, x, pt, t0)``."""
    pp = prepare_point(n_modes=3, mu_s=0.45, mu_k=0.3, Omega=1.52, f0_rel=2.61,
                       interface_viscosity=viscosity)
    pt = point_at(stack_points([pp]), 0, False)
    n, nq = pp.model.n, pp.model.n_quad
    rng = np.random.default_rng(3)
    x = State(1e-3 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n),
              1e-4 * rng.standard_normal(nq), np.array([0, 1, 0, -1] * (nq // 4), np.int64))
    cache = expo.new_cache(n, nq, 4)
    wk = expo.new_scratch(pt, 4, np.zeros(expo.N_COUNTERS, np.int64))
    slot = expo._pattern_slot(cache, wk, x, pt)
    md = expo._modes(cache, slot, wk)
    expo.project(cache, slot, wk, x, pt)
    return md, wk, x, pt, 0.1


def test_ladder_and_closed_form_follow_the_divided_differences():
    """The check ladder (exponentials advanced rung by rung) and the closed form in the
    interval's coefficients give the modal state of the divided-difference form
    (:func:`expo._zeta_at`, series near its removable singularities) to rounding."""
    md, wk, x, pt, t0 = _interval_start()
    lmax, sep = expo._rate_bounds(t0, md, wk, x, pt)
    d_min = 0.1 / lmax
    assert md.ladder.shape[0] == expo.LADDER_RUNGS
    ref = np.empty_like(wk.zeta)
    got = np.empty_like(wk.zeta)
    e_ref = np.empty_like(wk.zeta)
    e_got = np.empty_like(wk.zeta)
    nh = md.nh
    wk.el[:] = 1.0
    tau = 0.0
    for m in [0, 5, 29, 3, 12, 12, 1, 29, 29, 7] * 3:
        tau += expo._rung(d_min, m)
        expo._ladder_check(m, tau, md, wk, pt)
        expo._zeta_at(tau, md, wk, t0, pt, ref, e_ref)
        scale = np.abs(ref[:nh]).max()
        assert np.abs(wk.zeta[:nh] - ref[:nh]).max() < 1e-12 * scale
        expo._closed_form(tau, md, wk, pt, got, e_got)
        assert np.abs(got[:nh] - ref[:nh]).max() < 1e-12 * scale
        # both hand out the exponentials e^{lam_k tau} (the work integral takes them)
        assert np.array_equal(e_got[:nh], e_ref[:nh])
        assert np.abs(e_got[:nh] - np.exp(md.lam[:nh] * tau)).max() < 1e-15
    # longer than an output step at 64 per period (the longest interval): the recurrence was
    # checked over more rungs than one interval ever takes
    assert tau > 2 * np.pi / pt.om / 64


def test_a_guarded_point_checks_without_the_ladder():
    """The ladder is made from the slot's own eigenvalues; a point whose resonance guard
    shifts them (undamped: a natural frequency on the forcing's) gets no rungs (every check
    evaluates the exponentials)."""
    md, wk, x, pt, t0 = _interval_start(viscosity=0.0)
    cache_lam = md.lam.copy()
    k = int(np.argmax(cache_lam.imag))
    pt2 = pt._replace(om=float(cache_lam[k].imag))
    cache = expo.new_cache(pt.Mm.shape[0], pt.S.shape[0], 4)
    wk2 = expo.new_scratch(pt2, 4, np.zeros(expo.N_COUNTERS, np.int64))
    slot = expo._pattern_slot(cache, wk2, x, pt2)
    assert wk2.gslot[0] == slot and expo._modes(cache, slot, wk2).ladder.shape[0] == 0
    wk1 = expo.new_scratch(pt, 4, np.zeros(expo.N_COUNTERS, np.int64))
    assert expo._modes(cache, expo._pattern_slot(cache, wk1, x, pt), wk1).ladder.shape[0] \
        == expo.LADDER_RUNGS


def test_expo_with_the_interface_dashpot_follows_rk4():
    """The pipeline's damped model (interface dashpot, conjugate pairs evaluated once) against
    the RK4 reference at a small step: expo's difference stays at the level of its
    event-location error (docs/performance.md), not at the size of a dropped or doubled mode."""
    base = dict(n_modes=2, mu_s=0.3, mu_k=0.3, f0_rel=2.0, Omega=1.85, interface_damping=0.5,
                n_transient=2, n_record=4)
    ex = simulate(method="expo", **base)
    rk = [simulate(step_factor=sf, **base).poincare_state for sf in (0.5, 0.125)]
    size = np.abs(rk[1]).max()
    d = np.abs(ex.poincare_state - rk[1]).max() / size
    d_rk = np.abs(rk[0] - rk[1]).max() / size
    print(f"\nexpo vs RK4 (step factor 0.125): {d:.1e}; RK4 0.5 vs 0.125: {d_rk:.1e}; "
          f"{ex.n_events} events")
    assert ex.slipped and ex.n_events > 0
    assert d < 5e-6


@pytest.mark.parametrize("viscosity, step_factor", [(0.0939, 0.5), (0.0, 0.0625)])
def test_an_anchor_shift_moves_expo_as_it_moves_rk4(viscosity, step_factor):
    """The response of a stuck beam to a shift ``dz`` of one stuck spring's anchor is linear in
    ``dz`` and integrator-independent: expo's traction response over one forcing period, per unit
    anchor force, equals RK4's (itself linear to 3e-4) within 1e-3 from ``dz = 1e-12`` to
    ``1e-9``, with the interface dashpot (LAPACK's decomposition; RK4 at step factor 0.5) and
    without damping (the closed-form modes; RK4 at 0.0625, because the undamped penalty modes
    keep the anchor shift's fast response for the whole period: docs/lyapunov.md, section 17).
    The anchors' loads are large and balanced by the elastic forces; expo forms their modal load
    from per-pattern unit loads (``gS``), where ``V^-1 M^-1`` of the load vector, with the
    ill-conditioned mass matrix, left a rounding error in the slow modes that made the response
    at 1e-12 wrong (section 17).  No load, static friction too high to slip, so no switch
    happens."""
    point = dict(n_modes=3, mu_s=100.0, mu_k=99.0, interface_viscosity=viscosity, Omega=1.25,
                 f0_rel=0.0)
    pp = prepare_point(**point)
    md = pp.model
    n, nq, S = md.n, md.n_quad, md.S
    kt = stack_points([pp]).kt[0]
    q = np.linalg.solve(md.K, md.g)
    q *= 2e-3 / np.abs(S @ q).max()          # interface slips of the grazing orbit's size
    x = np.concatenate([q, np.zeros(n), S @ q, np.zeros(nq)])   # all stuck, no traction

    def traction(method, dz, **kw):
        y = x.copy()
        y[2 * n + 2] += dz
        r = simulate_batch([point | state_params(point, y, n)], n_transient=0, n_record=1,
                           method=method, n_threads=1, **kw)[0]
        assert r.n_events == 0
        return kt * (S[2] @ r.final_state[:n] - y[2 * n + 2])

    dzs = (1e-12, 1e-11, 1e-10, 1e-9)
    resp = {}
    for method, kw in (("expo", {}), ("rk4", dict(step_factor=step_factor))):
        base = traction(method, 0.0, **kw)
        resp[method] = np.array([(traction(method, dz, **kw) - base) / (kt * dz) for dz in dzs])
    print(f"\ntraction response per unit anchor force at dz = {dzs}: {resp}")
    ref = resp["rk4"][-1]
    assert np.abs(resp["rk4"] / ref - 1).max() < 3e-4      # RK4's own rounding at dz = 1e-12
    assert np.abs(resp["expo"] / ref - 1).max() < 1e-3


@functools.lru_cache(maxsize=1)
def _stuck_beam():
    """Every element stuck, no load: the motion is linear, ``M q'' + C q' + K_P q = k_t S^T W
    z``, and one forcing period of it is propagated exactly by SciPy's ``expm`` in
    mass-normalised coordinates ``y = L^T q`` (``M = L L^T``: the first-order matrix holds
    ``L^-1 K_P L^-T`` and ``L^-1 C L^-T``, no ``M^-1``).  The start is the two slowest stuck
    modes about the equilibrium, so RK4's step error is far below the rounding at the step
    factors used.  Returns the point with that start state, the exact state after one period,
    and that state's own rounding floor: the largest change of it, over the largest ``|(q,
    v)|``, when ``M``, ``K_P`` and ``C`` are perturbed by one rounding each (relative
    ``+-eps``, six seeded draws; cond(M) ~ 1.6e7, cond(K_P) ~ 1.4e9 at three modes).  A
    backward-stable computation of the same state (any integrator's, from its own roundings
    of the same matrices) is not expected closer than that."""
    import scipy.linalg as sla

    point = dict(n_modes=3, mu_s=100.0, mu_k=99.0, interface_viscosity=0.0939, Omega=1.25,
                 f0_rel=0.0)
    pp = prepare_point(**point)
    md = pp.model
    n, nq, S = md.n, md.n_quad, md.S
    KW = stack_points([pp]).kt[0] * (S.T * md.wq)
    KP = md.K + KW @ S
    z = np.linalg.solve(md.K, md.g)
    z = S @ z * (2e-3 / np.abs(S @ z).max())    # anchors at slips of the grazing orbit's size
    q_eq = np.linalg.solve(KP, KW @ z)           # the static equilibrium
    _, phi = sla.eigh(KP, md.M, subset_by_index=[0, 1])
    q = q_eq + phi @ np.array([1.0, 0.5]) * (1e-3 / np.abs(S @ phi).max())   # the slow modes

    def exact(M, K, C):
        L = np.linalg.cholesky(M)

        def normalised(X):
            return sla.solve_triangular(L, sla.solve_triangular(L, X.T, lower=True).T, lower=True)

        A = np.block([[np.zeros((n, n)), np.eye(n)], [-normalised(K), -normalised(C)]])
        y1 = sla.expm(A * 2 * np.pi / pp.omega) @ np.concatenate([L.T @ (q - q_eq), np.zeros(n)])
        return np.concatenate([q_eq + sla.solve_triangular(L.T, y1[:n]),
                               sla.solve_triangular(L.T, y1[n:])])

    rng = np.random.default_rng(0)

    def rounded(X):
        P = X * (1.0 + np.finfo(float).eps * rng.uniform(-1.0, 1.0, X.shape))
        return (P + P.T) / 2

    ref = exact(md.M, KP, md.C)
    floor = max(np.abs(exact(rounded(md.M), rounded(KP), rounded(md.C)) - ref).max()
                for _ in range(6)) / np.abs(ref).max()
    x = np.concatenate([q, np.zeros(n), z, np.zeros(nq)])
    return point | state_params(point, x, n), ref, floor


def _stuck_beam_error(method, **kw):
    """The largest error of ``(q, v)`` after one period of :func:`_stuck_beam` over the
    largest ``|(q, v)|`` of the exact solution, and the exact solution's own floor."""
    point, ref, floor = _stuck_beam()
    r = simulate_batch([point], n_transient=0, n_record=1, method=method, n_threads=1, **kw)[0]
    assert r.n_events == 0
    return np.abs(r.final_state[:ref.size] - ref).max() / np.abs(ref).max(), floor


def test_rk4_follows_a_stuck_beams_exact_solution_at_every_step():
    """RK4 lands within the exact solution's own rounding floor (:func:`_stuck_beam`), which is
    below 1e-8: measured 1.2e-10, 1.4e-10, 1.5e-10 at step factors 0.25, 0.125 and 0.0625 on
    a znver5 host, 1.01e-9 at all three on an AVX-512 rocketlake host (floor 3.4e-9 there: the
    error is rounding, not step).  Its first-order matrices are Cholesky solves
    (``beamsim.point._first_order``); with the explicit ``M^-1`` (before results version 26) it
    was 3.0e-7 away at every step factor: a floor no step reached (docs/performance.md, "The
    first-order matrices without the explicit inverse")."""
    runs = [_stuck_beam_error("rk4", step_factor=sf) for sf in (0.25, 0.125, 0.0625)]
    errors, floor = [e for e, _ in runs], runs[0][1]
    print(f"\nRK4 from the exact solution at step factors 0.25, 0.125, 0.0625: {errors}; "
          f"the exact solution's floor {floor:.1e}")
    assert floor < 1e-8
    assert max(errors) < floor


def test_expo_follows_a_stuck_beams_exact_solution():
    """``expo`` is exact between switches, and its damped decomposition
    (:func:`beamsim.kernels.expo._pattern`) is formed in mass-normalised coordinates: it lands
    within the exact solution's own rounding floor (:func:`_stuck_beam`, below 1e-8) after one
    period (measured 1.7e-10 on znver5, 1.3e-9 on rocketlake against the floor 3.4e-9;
    1.3e-9 without symmetrising the two blocks on znver5).  Decomposing ``[[0, I], [-M^-1 K_P,
    -M^-1 C]]`` with the explicit inverse instead (before results version 26) landed 1.2e-6
    from it (docs/performance.md, "The first-order matrices without the explicit inverse")."""
    error, floor = _stuck_beam_error("expo")
    print(f"\nexpo from the exact solution: {error:.1e}; the exact solution's floor {floor:.1e}")
    assert floor < 1e-8
    assert error < floor


def test_expo_stick_fractions_are_time_averages_on_any_output_grid():
    """expo tallies its stick statistics per interval between switches: its stick fractions are
    the time averages that RK4, sampling them at each of its thousands of steps per period,
    converges to, on one output step per period as on 64 (sampled at the step ends, as up to
    results version 17, they were 0.422 / 0.645 / 0.701 at 1 / 4 / 16 steps per period here,
    against 0.7134); below the slip onset they are 1 exactly (the Lyapunov stage's linear
    verdict reads ``stick_fraction >= 1``)."""
    base = dict(n_modes=2, mu_s=0.3, mu_k=0.3, f0_rel=2.0, Omega=1.85, n_transient=2, n_record=4)
    rk = [simulate(step_factor=sf, **base) for sf in (0.25, 0.125)]
    # the reference: RK4's sampled averages converge (1.5e-6 apart at these two steps)
    assert abs(rk[0].stick_fraction - rk[1].stick_fraction) < 1e-5
    assert 0.1 < rk[1].stick_fraction < 0.9
    for spp in (1, 4, 64):
        ex = simulate(method="expo", steps_per_period=spp, **base)
        # the trajectories agree to expo's event-location error (about 1e-5 of the state)
        assert abs(ex.stick_fraction - rk[1].stick_fraction) < 1e-4, spp
        assert abs(ex.stick_fraction_all - rk[1].stick_fraction_all) < 1e-4, spp
    stuck = simulate(method="expo", **dict(base, f0_rel=0.3))
    assert not stuck.slipped
    assert stuck.stick_fraction == 1.0 and stuck.stick_fraction_all == 1.0


def test_the_pattern_cache_size_changes_the_cost_not_the_result():
    """A decomposition evicted from the pattern cache and computed again is the same
    computation: a two-slot cache (nearly every switch a miss) and the default cache give the
    same trajectory to the bit, with many more decompositions."""
    point = dict(n_modes=2, Omega=1.85, f0_rel=2.0, mu_s=0.45, mu_k=0.3)
    small = simulate(n_transient=2, n_record=6, method="expo", pattern_cache=2, **point)
    default = simulate(n_transient=2, n_record=6, method="expo", **point)
    assert small.n_patterns > 2 * default.n_patterns  # the small cache did evict and recompute
    assert np.array_equal(small.poincare_state, default.poincare_state)
    assert np.array_equal(small.final_state, default.final_state)


#: default-grid points (two modes) and one of another model (a stiffer stick)
_SHARED = [dict(n_modes=2, mu_s=0.45, mu_k=0.3, Omega=om, f0_rel=f, **kw)
           for om, f, kw in ((1.85, 2.0, {}), (1.85, 2.2, {}), (2.5, 1.4, {}), (1.85, 2.0, {"k_t": 30.0}),
                             (1.7, 2.6, {}))]


def _same(a, b):
    for name in ("poincare_state", "final_state", "energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name


@pytest.mark.parametrize("threads", [1, 2])
def test_a_shared_pattern_store_changes_the_cost_not_the_result(threads):
    """Points of one model share decompositions (within a batch and, through a store, across
    batches); a point of another model (k_t 30) in the same batch must not be served them.
    Every result is the one of the point run alone, to the bit."""
    kw = dict(n_transient=3, n_record=5, method="expo")
    alone = [simulate(**kw, **p) for p in _SHARED]
    store = PatternStore()
    mixed = simulate_batch(_SHARED, n_threads=threads, pattern_store=store, **kw).results
    one_model = [p for p in _SHARED if "k_t" not in p]
    first = simulate_batch(one_model, n_threads=threads, pattern_store=store, **kw).results
    again = simulate_batch(one_model, n_threads=threads, pattern_store=store, **kw).results
    for a, b in zip(alone, mixed):
        _same(a, b)
    for a, b, c in zip([r for r, p in zip(alone, _SHARED) if "k_t" not in p], first, again):
        _same(a, b)
        _same(a, c)
    n_alone, n_mixed, n_first, n_again = (sum(r.n_patterns for r in rs)
                                          for rs in (alone, mixed, first, again))
    print(f"\ndecompositions: {n_alone} alone, {n_mixed} in a batch, {n_first} and {n_again} "
          "in two batches of one model")
    n_alone_one = sum(r.n_patterns for r, p in zip(alone, _SHARED) if "k_t" not in p)
    # with two threads the counts depend on which thread ran which point (not the results)
    assert n_mixed < n_alone and n_first < n_alone_one and n_again < n_alone_one
    if threads == 1:
        assert n_again == 0   # the thread's cache holds every pattern of the model


def test_the_model_key_separates_models_and_only_them():
    pts = [prepare_point(**p) for p in _SHARED]
    keys = model_keys(stack_points(pts))
    assert len(set(keys[[0, 1, 2, 4]])) == 1      # load and frequency are not the model
    assert keys[3] != keys[0]                       # the stick stiffness is


def test_the_resonance_guard_is_the_points_own():
    """A decomposition cached by one point, looked up by a point whose forcing frequency is a
    natural frequency of that pattern: the second point gets the guard's shifted eigenvalue
    (as if it had decomposed the pattern itself), the cache keeps the unshifted one."""
    pp = prepare_point(**_SHARED[0])
    pt = point_at(stack_points([pp]), 0, False)
    cache = expo.new_cache(pp.model.n, pp.model.n_quad, 4)
    wk = expo.new_scratch(pt, 4, np.zeros(expo.N_COUNTERS, np.int64))
    x = State(np.zeros(pp.model.n), np.zeros(pp.model.n), np.zeros(pp.model.n_quad),
                   np.zeros(pp.model.n_quad, np.int64))
    slot = expo._pattern_slot(cache, wk, x, pt)
    assert wk.gslot[0] == -1                       # the point's own frequency is not resonant
    lam = cache.lam[slot].copy()
    k = int(np.argmax(lam.imag))
    om = float(lam[k].imag)
    pt2 = pt._replace(om=om)
    wk2 = expo.new_scratch(pt2, 4, np.zeros(expo.N_COUNTERS, np.int64))
    assert expo._pattern_slot(cache, wk2, x, pt2) == slot and wk2.gslot[0] == slot
    seen = expo._modes(cache, slot, wk2).lam
    tol = 1e-9 * (np.abs(lam) + om)
    hit = (np.abs(lam - 1j * om) < tol) | (np.abs(lam + 1j * om) < tol)
    assert hit.sum() == 2                          # +-i om: the mode and its conjugate
    assert np.array_equal(seen, np.where(hit, lam - tol, lam))
    assert np.array_equal(cache.lam[slot], lam)    # the cache is not touched
    assert np.array_equal(expo._modes(cache, slot, wk).lam, lam)

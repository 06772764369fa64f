"""Linear limits of the two-layer Galerkin model (docs/model.md, "Checks")."""

import math

import numpy as np
import pytest

from beamsim.friction import Friction
from beamsim.two_layer import Geometry, build_model, single_layer_modes, static_tip_shape

ALPHA, BETA = 0.005, 0.4


@pytest.mark.parametrize("N", [1, 3, 5])
def test_frictionless_equal_layers_is_single_layer_arch(N):
    """mu = 0: equal layers behave as one arch of a single layer's alpha (exactly: the exact
    modes lie in the Galerkin space)."""
    m = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=N))
    lam = m.eig_frictionless[0][:N]
    ref = single_layer_modes(ALPHA, BETA, N).lam
    np.testing.assert_allclose(lam, ref, rtol=1e-8)


def test_frictionless_unequal_layers_stiffness_adds():
    """Unequal layers sliding freely: mass and bending stiffness add, membrane strains are
    separate.  The fundamental lies between the single-layer values of the two thicknesses."""
    m = build_model(Geometry(alpha1=0.004, alpha2=0.006, beta=BETA, n_modes=3))
    lam1 = m.eig_frictionless[0][0]
    l4 = single_layer_modes(0.004, BETA, 1).lam[0]
    l6 = single_layer_modes(0.006, BETA, 1).lam[0]
    # bending dominated: lam ~ sum(alpha_i^3) / sum(alpha_i) / 12 * c  ->  between l4 and l6
    assert l4 < lam1 < l6
    pred = l4 * (0.004**3 + 0.006**3) / (0.004 + 0.006) / 0.004**2
    assert abs(lam1 / pred - 1) < 0.01


@pytest.mark.parametrize("N", [1, 3, 5])
def test_bonded_is_double_thickness_arch(N):
    """Rigidly bonded interface (slip = 0 at every interface point): one arch of thickness
    alpha1 + alpha2.  The residual is the O(alpha^2) thin-layer approximation, independent of N
    (converged), and it scales with alpha^2."""
    ref = single_layer_modes(2 * ALPHA, BETA, 3).lam
    m = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=N))
    lam = m.eig_bonded_rigid()
    err = lam[0] / ref[0] - 1
    assert abs(err) < 3e-4
    if N >= 3:
        errs = lam[:3] / ref - 1
        assert np.all(np.abs(errs) < 3.5e-3), errs


def test_bonded_residual_is_thin_beam_order():
    errs = []
    for a in (0.0025, 0.005):
        ref = single_layer_modes(2 * a, BETA, 3).lam
        lam = build_model(Geometry(alpha1=a, beta=BETA, n_modes=3)).eig_bonded_rigid()[:3]
        errs.append(np.abs(lam / ref - 1))
    ratio = errs[1] / errs[0]
    np.testing.assert_allclose(ratio, 4.0, rtol=0.05)   # O(alpha^2)


def test_bonded_frequencies_twice_frictionless():
    m = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=3))
    ratio = np.sqrt(m.eig_bonded_rigid()[:3] / m.eig_frictionless[0][:3])
    np.testing.assert_allclose(ratio, 2.0, rtol=5e-3)


def test_penalty_interface_converges_to_bonded():
    """Elastic-stick interface: the stuck eigenvalues converge to the rigidly bonded ones as
    k_t grows (error ~ 1/sqrt(k_t), shear-lag boundary layers)."""
    rigid = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=3)).eig_bonded_rigid()[:3]
    errs = []
    for kt in (10.0, 100.0, 1000.0, 10000.0):
        lam = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=3, k_t=kt)).eig_stuck[0][:3]
        errs.append(np.abs(lam / rigid - 1))
    errs = np.array(errs)
    assert np.all(np.diff(errs, axis=0) < 0)
    assert errs[0, 0] < 6e-3          # k_t = 10: lam_1 within 0.6 %
    assert errs[-1].max() < 2e-3


def test_static_shape_closed_form():
    """The closed-form static tip-load shape: frictionless equal layers carry half of a
    single layer's load-point compliance, and it is exact in the Galerkin space."""
    m = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=3))
    w, _, _, u, _ = static_tip_shape(np.array([BETA]), ALPHA, BETA)
    single = math.cos(BETA) * w[0] - math.sin(BETA) * u[0]
    # the tangential tip load acts on the upper layer only; split evenly over both layers the
    # load is purely symmetric and the two free layers act as one arch with doubled energy
    g_sym = math.cos(BETA) * m.tip[0] - 0.5 * math.sin(BETA) * (m.tip[1] + m.tip[2])
    got = g_sym @ np.linalg.solve(m.K, g_sym)
    assert abs(got / (0.5 * single) - 1) < 1e-9
    # the upper-layer load adds only a tiny antisymmetric (axial) compliance
    assert 0 < m.g @ m.static_unit_frictionless / (0.5 * single) - 1 < 1e-4


def test_static_shape_satisfies_equilibrium():
    th = np.linspace(0.0, BETA, 2001)
    a = ALPHA
    k2 = a * a / 12
    w, w1, w2, u, u1 = static_tip_shape(th, a, BETA)
    # N* = a (w + u') = -sin(theta);  M* = a k2 (w'' - u') = sin(beta) - sin(theta)
    np.testing.assert_allclose(a * (w + u1), -np.sin(th), atol=1e-9)
    np.testing.assert_allclose(a * k2 * (w2 - u1), np.sin(BETA) - np.sin(th), atol=1e-12)
    assert abs(w[0]) < 1e-14 and abs(w1[0]) < 1e-14 and abs(u[0]) < 1e-14


def test_f_cr_linear_in_mu_p_and_profile():
    m = build_model(Geometry(alpha1=ALPHA, beta=BETA, n_modes=3))
    f1 = m.f_cr(0.3, 1e-4)
    assert f1 > 0
    assert abs(m.f_cr(0.6, 1e-4) / f1 - 2) < 1e-12
    assert abs(m.f_cr(0.3, 5e-5) / f1 - 0.5) < 1e-12
    # zero pressure somewhere -> slip starts at zero load there
    prof = np.ones(m.n_quad)
    prof[m.n_quad // 2] = 0.0
    assert m.f_cr(0.3, 1e-4, prof) == 0.0
    assert m.f_cr(0.3, 0.0) == 0.0


@pytest.mark.parametrize("kwargs, name", [
    (dict(alpha1=-0.01), "alpha1"),
    (dict(alpha2=float("nan")), "alpha2"),
    (dict(beta=0.0), "beta"),
    (dict(n_modes=0), "n_modes"),
    (dict(k_t=float("inf")), "k_t"),
    (dict(damping=-0.1), "damping"),
    (dict(n_quad=0), "n_quad"),
    (dict(interface_viscosity=-0.1), "interface_viscosity"),
    (dict(interface_viscosity=11.0), "interface_viscosity"),
    (dict(interface_damping=0.5, interface_viscosity=0.1), "interface_viscosity"),
])
def test_bad_geometry_raises(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Geometry(**kwargs)


@pytest.mark.parametrize("kwargs, name", [
    (dict(mu_s=-0.1), "mu_s"),
    (dict(mu_s=0.2, mu_k=0.3), "mu_s"),
    (dict(mu_k=-0.3), "mu_k"),
    (dict(p=-1e-4), "p"),
    (dict(p=float("nan")), "p"),
    (dict(p_profile=[1.0, -1.0]), "p_profile"),
    (dict(law="viscous"), "law"),
    (dict(law="stribeck", v_s=0.0), "v_s"),
    (dict(law="stribeck", F_c=2e-5, F_s=1e-5), "F_s"),
    (dict(eps_v=0.0), "eps_v"),
])
def test_bad_friction_raises(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Friction(**kwargs)


def test_registered_modes_are_used_instead_of_recomputed():
    """The workflow hands its cached modes to the model with register_modes."""
    from beamsim.modes import arch_modes
    from beamsim.two_layer import register_modes

    alpha, beta = 0.0061, 0.43  # a geometry no other test uses
    cached = arch_modes(alpha, beta, 3)
    fake = cached.truncated(3)
    object.__setattr__(fake, "lam", cached.lam * 1.5)  # distinguishable from a recomputation
    register_modes(fake)
    got = single_layer_modes(alpha, beta, 3)
    np.testing.assert_array_equal(got.lam, cached.lam * 1.5)


def test_a_larger_registered_set_is_not_used_for_fewer_modes():
    """A point's modes do not depend on which other mode files its process registered: with
    four modes of its geometry registered, a three-mode model gets ``arch_modes(..., 3)`` to
    the bit, not the first three of the registered set (``arch_modes`` brackets its roots on a
    mesh that depends on the count, so those differ from it in the last bits)."""
    from beamsim.modes import arch_modes
    from beamsim.two_layer import register_modes

    alpha, beta = 0.0063, 0.41  # a geometry no other test uses
    four = arch_modes(alpha, beta, 4)
    fake = four.truncated(4)
    object.__setattr__(fake, "lam", four.lam * 1.5)  # what a three-mode model must not see
    register_modes(fake)
    got = single_layer_modes(alpha, beta, 3)
    want = arch_modes(alpha, beta, 3)
    for name in ("lam", "roots", "theta_ref", "coef_w", "coef_u"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name))
    np.testing.assert_array_equal(single_layer_modes(alpha, beta, 4).lam, four.lam * 1.5)


def test_stuck_decay_rate_against_closed_forms_and_perturbation_theory():
    """TwoLayerModel.stuck_decay_rate (the everywhere-stuck beam's slowest decay, from its
    first-order eigenvalues): 0 without damping; with a vanishing stick stiffness and modal
    damping zeta of the frictionless structure, zeta times its first natural frequency (closed
    form); with the shipped interface dashpot, the first-order perturbation estimate
    ``min_k phi_k^T C phi_k / 2`` over the undamped stuck modes (light damping: they agree to
    O(zeta^2)); the rigid stick sees the structural damping only."""
    from beamsim.point import prepare_point

    base = {"n_modes": 3, "Omega": 2.0, "f0_rel": 1.0, "mu_s": 0.45, "mu_k": 0.3}
    undamped = prepare_point(**base).model
    assert undamped.stuck_decay_rate() == 0.0 and undamped.stuck_decay_rate(rigid=True) == 0.0

    soft = prepare_point(**base, damping=0.01, k_t=1e-6).model
    w01 = math.sqrt(soft.eig_frictionless[0][0])
    assert soft.stuck_decay_rate() == pytest.approx(0.01 * w01, rel=1e-8)

    shipped = prepare_point(**base, interface_viscosity=0.0939).model
    phi = shipped.eig_stuck[1]
    modal = np.einsum("ak,ab,bk->k", phi, shipped.C, phi)
    rate = shipped.stuck_decay_rate()
    assert rate > 0.0 and rate == pytest.approx(modal.min() / 2.0, rel=1e-5)
    assert shipped.stuck_decay_rate(rigid=True) == 0.0  # a rigidly stuck dashpot does not move
    damped = prepare_point(**base, damping=0.01).model
    assert damped.stuck_decay_rate(rigid=True) > 0.0

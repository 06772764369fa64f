"""Validation of beamsim.modes against closed forms, published values and the governing equations.

The independent finite-element comparison lives in test_modes_fe.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from beamsim.modes import (
    arch_modes,
    characteristic_determinant,
    end_conditions,
    gauss_legendre,
    ritz_eigenvalues,
    system_matrix,
)


@pytest.fixture(scope="module")
def paper_modes():
    return arch_modes(0.01, 0.4, 4)


def test_paper_table1_frequency_ratios(paper_modes):
    """Paper Table 1 (alpha = 0.01, beta = 0.4): 22.72, 139.19, 393.12."""
    ratios = paper_modes.frequency_ratios
    assert ratios[1] == pytest.approx(139.19 / 22.72, rel=5e-3)
    assert ratios[2] == pytest.approx(393.12 / 22.72, rel=5e-3)


def test_eigenvalues_ascending_and_positive(paper_modes):
    assert np.all(paper_modes.lam > 0)
    assert np.all(np.diff(paper_modes.lam) > 0)


@pytest.mark.parametrize("beta", [0.05, 0.01])
def test_straight_cantilever_limit(beta):
    """beta -> 0 at fixed length L = R beta and thickness h: beta_n L -> 1.8751, 4.6941, 7.8548.

    lam = omega^2 rho R^2 / E and omega = (b_n L)^2 / L^2 sqrt(EI / rho A) give
    b_n L = beta (lam / k^2)^(1/4).
    """
    length, h = 1.0, 0.01
    radius = length / beta
    m = arch_modes(h / radius, beta, 3)
    bl = beta * (m.lam / m.k2) ** 0.25
    tol = 2e-3 if beta == 0.05 else 2e-4  # the curvature correction shrinks with beta
    np.testing.assert_allclose(bl, [1.87510, 4.69409, 7.85476], rtol=tol)


def test_straight_clamped_clamped_limit():
    """Symmetric clamped-clamped modes are stiffened by arch action ~ (rise / h)^2, so the
    approach to the straight beam (4.7300, 7.8532, 10.9956) is checked as a convergence."""
    length, h = 1.0, 0.02
    exact = np.array([4.73004, 7.85320, 10.99561])
    errs = []
    for beta in (0.03, 0.01, 0.003):
        m = arch_modes(h * beta / length, beta, 3, "clamped-clamped")
        errs.append(np.abs(beta * (m.lam / m.k2) ** 0.25 / exact - 1.0).max())
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 2e-4


def test_published_pinned_pinned_97deg_arch():
    """R = 2.438 m, E = 206.8 GPa, rho = 7855, A = 4.071e-3 m^2, I = 6.456e-6 m^4.

    Published (thin-arch FE literature): 396.98, 931.22, 1797.31 rad/s; the extensible
    Euler-Bernoulli theory is known to sit 0.1-0.6 % above.
    """
    radius, e_mod, rho, area, inertia = 2.438, 206.8e9, 7855.0, 4.071e-3, 6.456e-6
    alpha = np.sqrt(12.0 * inertia / area) / radius  # same k^2 = I / (A R^2)
    m = arch_modes(alpha, np.deg2rad(97.0), 3, "pinned-pinned")
    omega = np.sqrt(m.lam * e_mod / rho) / radius
    rel = omega / np.array([396.98, 931.22, 1797.31]) - 1.0
    assert np.all(rel > -1e-3) and np.all(rel < 7e-3), rel


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_system_matrix_reproduces_complete_ring(n):
    """Closed ring: lam^2 - lam (n^2+1)(1+k^2 n^2) + k^2 n^2 (n^2-1)^2 = 0.

    A periodic solution over 2 pi exists iff expm(2 pi A(lam)) has eigenvalue 1, so the
    closed-form ring eigenvalues must make det(expm(2 pi A) - I) vanish, while a value 1 %
    away must not.  NAFEMS free ring (R = 1, d = 0.1 circular, E = 200 GPa, rho = 8000):
    53.38, 151.0, 289.5 Hz for n = 2, 3, 4 checks the closed form itself.
    """
    k2 = 0.1**2 / 16.0  # I / (A R^2) of a circular section d = 0.1 at R = 1
    c = [1.0, -(n * n + 1) * (1 + k2 * n * n), k2 * n * n * (n * n - 1) ** 2]
    lam = min(np.roots(c).real)
    if n <= 4:
        hz = np.sqrt(lam * 200e9 / 8000.0) / (2 * np.pi)
        assert hz == pytest.approx({2: 53.38, 3: 151.0, 4: 289.5}[n], rel=3e-3)

    def distance_to_ring_root(x):  # |s - i n| minimised over the six roots of A(x)
        return np.abs(np.linalg.eigvals(system_matrix(x, k2)) - 1j * n).min() / n

    assert distance_to_ring_root(lam) < 1e-9
    assert distance_to_ring_root(lam * 1.01) > 1e-4


@pytest.mark.parametrize("bc", ["clamped-free", "clamped-clamped", "pinned-pinned"])
@pytest.mark.parametrize("alpha,beta", [(0.01, 0.4), (0.05, 1.5), (0.02, 3.0)])
def test_shapes_satisfy_equations_bcs_and_orthogonality(bc, alpha, beta):
    m = arch_modes(alpha, beta, 4, bc)
    k2 = m.k2
    th = np.linspace(0.0, beta, 101)
    w = [m.W(th, d) for d in range(5)]
    u = [m.U(th, d) for d in range(4)]
    lam = m.lam[:, None]
    # governing equations (7) and (10) for harmonic motion, residual relative to the terms
    r7 = k2 * (u[3] - w[4]) - (u[1] + w[0]) + lam * w[0]
    r10 = k2 * (u[2] - w[3]) + (u[2] + w[1]) + lam * u[0]
    s7 = np.abs(k2 * w[4]).max(axis=1) + np.abs(u[1]).max(axis=1) + np.abs(w[0]).max(axis=1)
    s10 = np.abs(k2 * w[3]).max(axis=1) + np.abs(u[2]).max(axis=1) + np.abs(lam * u[0]).max(axis=1)
    assert np.all(np.abs(r7).max(axis=1) < 1e-8 * s7)
    assert np.all(np.abs(r10).max(axis=1) < 1e-8 * s10)
    # boundary conditions at both ends
    left, right = bc.split("-")
    for kind, theta in ((left, 0.0), (right, beta)):
        for n in range(m.n_modes):
            y = np.array([m.W([theta], d)[n, 0] for d in range(4)]
                         + [m.U([theta], d)[n, 0] for d in range(2)])
            scale = np.abs([m.W(th, d)[n] for d in range(4)]).max()
            res = end_conditions(kind, m.lam[n], k2) @ y
            assert np.abs(res).max() < 1e-8 * scale, (kind, n, res)
    # mass orthonormality and diagonal stiffness (modal orthogonality)
    np.testing.assert_allclose(m.mass_matrix(), np.eye(4), atol=1e-9)
    np.testing.assert_allclose(m.stiffness_matrix(), np.diag(m.lam), atol=1e-8 * m.lam.max())


def test_close_roots_are_both_found():
    """Thick clamped-clamped arch: modes 3 and 4 are 5 % apart; a coarse scan would merge them."""
    m = arch_modes(0.2, 2.0, 5, "clamped-clamped")
    assert m.lam[3] / m.lam[2] < 1.1
    ritz = ritz_eigenvalues(0.2, 2.0, "clamped-clamped", 100, 5)  # conforming Ritz: upper bounds
    assert np.all(m.lam <= ritz * (1 + 1e-12))
    np.testing.assert_allclose(m.lam, ritz, rtol=1e-5)
    # the characteristic function changes sign at every reported root
    d = characteristic_determinant(np.concatenate([m.lam * (1 - 1e-7), m.lam * (1 + 1e-7)]), 0.2, 2.0,
                                   "clamped-clamped")
    assert np.all(np.sign(d[:5]) != np.sign(d[5:]))


def test_complex_root_regime_clamped_free():
    """beta > ~53 deg puts the clamped-free fundamental where eq 16 has a complex pair of s^2."""
    alpha, beta = 0.01, 1.5
    m = arch_modes(alpha, beta, 2)
    k2 = m.k2
    s2 = np.roots([k2, 2 * k2 + k2 * m.lam[0], k2 - k2 * m.lam[0] - m.lam[0], m.lam[0] * (1 - m.lam[0])])
    assert np.any(np.abs(s2.imag) > 1e-6 * np.abs(s2).max())
    ritz = ritz_eigenvalues(alpha, beta, "clamped-free", 30, 2)  # conforming Ritz: upper bounds
    assert np.all(m.lam <= ritz * (1 + 1e-7))  # 1e-7: round-off of the Ritz eigensolver at lam ~ 2e-5
    np.testing.assert_allclose(m.lam, ritz, rtol=1e-5)


def test_gauss_legendre_integrates_polynomials():
    x, w = gauss_legendre(0.0, 2.0, 64)
    assert np.sum(w * x**7) == pytest.approx(2.0**8 / 8, rel=1e-13)


def test_persistence_round_trip(paper_modes):
    from beamsim.modes import ArchModes

    back = ArchModes.from_table(paper_modes.to_table(), paper_modes.alpha, paper_modes.beta, paper_modes.bc)
    th = np.linspace(0, paper_modes.beta, 17)
    np.testing.assert_array_equal(back.lam, paper_modes.lam)
    np.testing.assert_allclose(back.W(th, 2), paper_modes.W(th, 2), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "kwargs,name",
    [
        ({"alpha": 0.0}, "alpha"),
        ({"alpha": -0.01}, "alpha"),
        ({"alpha": float("nan")}, "alpha"),
        ({"beta": 0.0}, "beta"),
        ({"beta": -1.0}, "beta"),
        ({"beta": 2 * np.pi}, "beta"),
        ({"beta": 7.0}, "beta"),
        ({"n_modes": 0}, "n_modes"),
        ({"n_modes": 2.5}, "n_modes"),
        ({"bc": "free-free"}, "bc"),
    ],
)
def test_bad_input_names_argument_and_range(kwargs, name):
    args = {"alpha": 0.01, "beta": 0.4, "n_modes": 3, "bc": "clamped-free"} | kwargs
    with pytest.raises(ValueError, match=name) as info:
        arch_modes(**args)
    msg = str(info.value)
    if name in ("alpha", "beta", "n_modes"):
        assert any(tok in msg for tok in ("<", ">=")), msg  # states the allowed range
    else:
        assert "clamped-free" in msg  # lists the allowed values


def test_shape_evaluation_rejects_outside_arch(paper_modes):
    with pytest.raises(ValueError, match="theta"):
        paper_modes.W([0.5])
    with pytest.raises(ValueError, match="d"):
        paper_modes.U([0.1], d=-1)


def test_truncated_keeps_the_first_modes(paper_modes):
    two = paper_modes.truncated(2)
    np.testing.assert_array_equal(two.lam, paper_modes.lam[:2])
    th = np.linspace(0, paper_modes.beta, 5)
    np.testing.assert_array_equal(two.W(th), paper_modes.W(th)[:2])
    with pytest.raises(ValueError, match="n_modes"):
        paper_modes.truncated(9)

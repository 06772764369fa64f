"""A state carried from one Galerkin model of the beam to another (beamsim.state_transfer).

Independent checks: the displacement fields each model evaluates from its own coordinates
(its own basis and axial orthonormalisation), the kinetic and strain energies from each
model's own assembled ``M`` and ``K``, and the tractions from each model's own ``S`` and
``k_t``.  A basis with more modes contains the smaller one (the arch modes of ``N`` are the
first ``N`` of ``N + 1``), so the fields and energies must be carried to round-off.
"""

from __future__ import annotations

import numpy as np
import pytest

from beamsim.simulate import prepare_point
from beamsim.state_transfer import transfer_state
from beamsim.two_layer import _basis

POINT = {"Omega": 1.378, "f0_rel": 1.133, "mu_s": 0.45, "mu_k": 0.3}
THETA = np.linspace(0.0, 0.4, 101)  # the default beam's opening angle is 0.4


def _model(**over):
    return prepare_point(**(POINT | over)).model


def _state(model, seed=0):
    """A seeded state: coordinates at the scale of a forced response, tractions up to the
    kinetic limit, a mix of stuck and slipping elements."""
    rng = np.random.default_rng(seed)
    n, nq = model.n, model.n_quad
    q = 1e-2 * rng.standard_normal(n)
    v = 1e-3 * rng.standard_normal(n)
    z = model.S @ q - 3e-5 * rng.uniform(-1.0, 1.0, nq) / model.geom.k_t
    mode = rng.integers(-1, 2, nq).astype(float)
    return np.concatenate([q, v, z, mode])


def _parts(model, x):
    n, nq = model.n, model.n_quad
    return x[:n], x[n:2 * n], x[2 * n:2 * n + nq], x[2 * n + nq:]


def test_the_same_model_is_the_identity():
    m = _model(n_modes=3)
    x = _state(m)
    np.testing.assert_allclose(transfer_state(x, m, m), x, rtol=0, atol=1e-13 * np.abs(x).max())


def _span_floor(src, dst, coords):
    """How closely ``dst``'s basis can hold the axial fields of ``src``'s coordinates
    ``coords``, row by row ``(w, u1, u2)`` at ``THETA``.  The two bases are built from the same
    arch modes, computed by separate root searches, so their raw axial functions ``[U_n; W_n';
    hats]`` (``beamsim.two_layer._basis``) differ by ``dB`` (about 1e-13 of their size); the
    axial coordinates are raw combinations ``c = axial_T d``, and where that basis is nearly
    dependent (the four-mode one: scaled Gram eigenvalues 1.8e-12 of the largest) a state with
    weight in every coordinate has ``|c|`` thousands of times the field.  ``sum_r |c_r| |dB_r|``
    then bounds what the target can carry (to first order).  The radial row has no such
    amplification (its coordinates are the arch modes', the same to about 1e-13 in both bases):
    its floor is 0 here, and the caller's allowance of 1e-13 of the field covers it."""
    g = src.geom
    b_src = _basis(src.modes, THETA, g.n_slip, g.static_shape)[3]
    b_dst = _basis(dst.modes, THETA, dst.geom.n_slip, dst.geom.static_shape)[3]
    n_src, n_dst = src.modes.n_modes, dst.modes.n_modes
    extra = b_src.shape[0] - 2 * n_src          # the hat functions (and the static shape's)
    rows = np.r_[np.arange(n_src), n_dst + np.arange(n_src), 2 * n_dst + np.arange(extra)]
    d_b = np.abs(b_src - b_dst[rows])
    m = src.axial_T.shape[1]
    nw = src.n - 2 * m
    layers = [np.abs(src.axial_T @ coords[off:off + m]) @ d_b for off in (nw, nw + m)]
    return np.stack([np.zeros(THETA.size), *layers])


def test_one_more_mode_carries_the_fields_and_energies_exactly():
    """The fields are carried to the floor of :func:`_span_floor`: on an AVX-512 host
    (rocketlake) the axial rows differ by up to 1.45e-9 of the field, 0.9995 of that floor at
    its tightest, which is 5.4e-9 of the field there (the radial row 1.3e-14)."""
    m3, m4 = _model(n_modes=3), _model(n_modes=4)
    x = _state(m3)
    y = transfer_state(x, m3, m4)
    q3, v3, _, _ = _parts(m3, x)
    q4, v4, _, _ = _parts(m4, y)
    assert y.size == 2 * m4.n + 2 * m4.n_quad
    for a, b in ((q3, q4), (v3, v4)):
        f3, f4 = m3.displacements(a, THETA), m4.displacements(b, THETA)
        scale = np.abs(f3).max()
        floor = _span_floor(m3, m4, a)
        assert floor.max() <= 1e-8 * scale      # round-off, not an approximation
        assert np.all(np.abs(f4 - f3) <= floor + 1e-13 * scale)
    # each model's own matrices (assembled on its own grid)
    assert v4 @ m4.M @ v4 == pytest.approx(v3 @ m3.M @ v3, rel=1e-9)
    assert q4 @ m4.K @ q4 == pytest.approx(q3 @ m3.K @ q3, rel=1e-9)
    assert m4.tip[3] @ q4 == pytest.approx(m3.tip[3] @ q3, rel=1e-9)


def test_back_to_fewer_modes_returns_the_coordinates():
    m3, m4 = _model(n_modes=3), _model(n_modes=4)
    x = _state(m3, seed=1)
    back = transfer_state(transfer_state(x, m3, m4), m4, m3)
    q, v, _, _ = _parts(m3, x)
    qb, vb, _, _ = _parts(m3, back)
    np.testing.assert_allclose(qb, q, rtol=0, atol=1e-10 * np.abs(q).max())
    np.testing.assert_allclose(vb, v, rtol=0, atol=1e-10 * np.abs(v).max())


def test_fewer_modes_take_the_best_approximation_in_the_kinetic_metric():
    """Down to three modes the velocity field is the kinetic-energy projection: no more
    kinetic energy than the source, and the part left out is orthogonal to the target basis."""
    m3, m4 = _model(n_modes=3), _model(n_modes=4)
    x = _state(m4, seed=2)
    y = transfer_state(x, m4, m3)
    _, v4, _, _ = _parts(m4, x)
    _, v3, _, _ = _parts(m3, y)
    e4, e3 = v4 @ m4.M @ v4, v3 @ m3.M @ v3
    assert e3 < e4
    # the difference of the two fields has no component along a target coordinate: the
    # target's mass matrix applied to its own velocity equals the cross inner products
    up = transfer_state(y, m3, m4)  # the projected field, exactly, in the four-mode basis
    _, v3_in_4, _, _ = _parts(m4, up)
    assert (v4 - v3_in_4) @ m4.M @ v3_in_4 == pytest.approx(0.0, abs=1e-9 * e4)


def test_a_stiffer_stick_keeps_every_traction():
    m10, m30 = _model(n_modes=3), _model(n_modes=3, k_t=30.0)
    x = _state(m10, seed=3)
    y = transfer_state(x, m10, m30)
    q, _, z, mode = _parts(m10, x)
    qy, _, zy, mode_y = _parts(m30, y)
    np.testing.assert_allclose(qy, q, rtol=0, atol=1e-12 * np.abs(q).max())
    t10, t30 = 10.0 * (m10.S @ q - z), 30.0 * (m30.S @ qy - zy)
    np.testing.assert_allclose(t30, t10, rtol=0, atol=1e-10 * np.abs(t10).max())
    np.testing.assert_array_equal(mode_y, mode)


def test_other_interface_points_carry_a_linear_traction_profile():
    """With 16 points instead of 12, a traction linear in ``theta`` is carried exactly at the
    new points inside the old points' span, and each element's mode is its nearest old point's."""
    m12, m16 = _model(n_modes=3), _model(n_modes=3, n_quad=16)
    x = _state(m12, seed=4)
    q, v, _, _ = _parts(m12, x)
    tr = 1e-5 * (1.0 - 4.0 * m12.theta_q)
    mode = np.where(m12.theta_q < 0.2, 0.0, -1.0)
    x = np.concatenate([q, v, m12.S @ q - tr / m12.geom.k_t, mode])
    y = transfer_state(x, m12, m16)
    qy, _, zy, mode_y = _parts(m16, y)
    t16 = m16.geom.k_t * (m16.S @ qy - zy)
    inside = (m16.theta_q >= m12.theta_q[0]) & (m16.theta_q <= m12.theta_q[-1])
    assert inside.sum() >= 12
    # to the round-off of k_t (s - z), s and z each far larger than their difference
    roundoff = 1e-15 * m16.geom.k_t * np.abs(m16.S @ qy).max()
    np.testing.assert_allclose(t16[inside], 1e-5 * (1.0 - 4.0 * m16.theta_q[inside]), rtol=0, atol=roundoff)
    nearest = np.abs(m16.theta_q[:, None] - m12.theta_q[None, :]).argmin(axis=1)
    np.testing.assert_array_equal(mode_y, mode[nearest])


def test_another_beam_a_wrong_size_or_another_law_is_refused():
    m = _model(n_modes=3)
    with pytest.raises(ValueError, match="beta"):
        transfer_state(_state(m), m, _model(n_modes=3, beta=0.3))
    with pytest.raises(ValueError, match="entries"):
        transfer_state(_state(m)[:-1], m, m)
    with pytest.raises(ValueError, match="stick-slip only"):  # z is a traction there
        transfer_state(_state(m), m, m, law="rigid-stick")

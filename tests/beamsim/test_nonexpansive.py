"""With one friction coefficient (``mu_s = mu_k``, the paper's eq. 33) or the regularised
full-slip law, two solutions of the beam never move apart in the energy norm.

Why (docs/lyapunov.md, section 8): the structure is linear elastic, the interlayer pressure is
fixed, and each Jenkins element with ``tau_s = tau_k`` is an elastic-perfectly-plastic element,
whose flow rule is monotone: ``(sigma_a - sigma_b)(z'_a - z'_b) >= 0``; the regularised
full-slip traction is a non-decreasing function of the slip rate, and the dashpots and modal
damping only dissipate.  The energy of the *difference* of two solutions,
``D = 1/2 dv' M dv + 1/2 dq' K dq + 1/2 k_t sum_j w_j (S dq - dz)_j^2``, therefore never grows:
``dD/dt = -dv' C dv - sum_j w_j (dsigma_j dz'_j) <= 0``.  Hence ``lambda_1 <= 0`` at every
forcing: such a beam cannot be chaotic. The rigid stick is the limit ``k_t -> inf``: its
interface term vanishes (``|dtau|^2 / (2 k_t)``) and Coulomb's set-valued law is monotone. This
is a property of the equations, independent of the code; a kernel that created energy at a
switch (a wrong ``z`` update, a wrong slip direction, a wrong traction) would break it.
"""
import numpy as np
import pytest

from beamsim.simulate import prepare_point, restart_params, simulate_batch


def _period(params):
    return simulate_batch([params], n_transient=0, n_record=1, method="rk4", step_factor=1.0,
                          n_threads=1).results[0]


def _distance(model, a, b, with_interface):
    n, nq = model.n, model.n_quad
    d = np.asarray(a.final_state) - np.asarray(b.final_state)
    return model.mechanical_energy(d[:n], d[n:2 * n], d[2 * n:2 * n + nq] if with_interface
                                   else None)


@pytest.mark.parametrize("case", [
    dict(law="stick-slip", interface_damping=0.5),
    dict(law="stick-slip", interface_damping=0.0),
    dict(law="full-slip", interface_damping=0.5),
    dict(law="rigid-stick", interface_viscosity=0.0939),
], ids=["stick-slip", "stick-slip-undamped-interface", "full-slip", "rigid-stick"])
def test_energy_distance_of_two_solutions_never_grows(case):
    base = dict(case, mu_s=0.3, mu_k=0.3, n_modes=1, Omega=2.0, f0_rel=2.5)
    model = prepare_point(**base).model
    n = model.n
    # B starts far from A (from rest): half the size of A's forced response, random direction
    r = _period(base)
    amp = np.abs(np.asarray(r.poincare_state)).max(axis=0) + 1e-30
    rng = np.random.default_rng(3)
    pb = dict(base, q0=0.5 * amp[:n] * rng.standard_normal(n),
              v0=0.5 * amp[n:] * rng.standard_normal(n))
    a, b = _period(base), _period(pb)  # one period: both past their start-up projection
    with_interface = case["law"] == "stick-slip"
    dist = [_distance(model, a, b, with_interface)]
    e_a = model.mechanical_energy(np.asarray(a.final_state)[:n], np.asarray(a.final_state)[n:2 * n])
    for _ in range(10):
        a, b = _period(restart_params(a)), _period(restart_params(b))
        dist.append(_distance(model, a, b, with_interface))
    dist = np.array(dist)
    # the pair is far apart (nonlinear regime), not a trivially small difference
    assert dist[0] > 1e-3 * e_a
    # D never grows from one period end to the next (integration error allowance 1e-6 D_0)
    assert np.all(np.diff(dist) <= 1e-6 * dist[0]), dist
    # and it shrinks over the ten periods: slip dissipates the difference too
    assert dist[-1] < dist[0]

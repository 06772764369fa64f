"""Can a stuck interface slip again?  A bound on the future tractions of the everywhere-stuck
beam (elastic shakedown of the Jenkins interface).

While every Jenkins element sticks, the beam is linear with constant coefficients (docs/model.md):

    M q'' + C q' + K_stuck q = g F(t) + k_t S^T W z,   F(t) = f0 (cos(omega t) - 1),

with the sliders ``z`` frozen, ``K_stuck = K + k_t S^T W S`` and ``C`` the structural damping
plus the interface dashpot.  Its solution from a state ``(q, v)`` at time ``t0`` is the forced
periodic response ``q_p(t) = q_c + Re(Q e^{i omega t})`` plus a free vibration
``e(t) = sum_k c_k e^{lambda_k (t - t0)} psi_k`` over the eigenpairs of the first-order matrix
``[[0, I], [-M^-1 K_stuck, -M^-1 C]]``.  The elastic traction of element ``j`` is
``tau_j = k_t (S_j q - z_j)``, and since every ``Re lambda_k <= 0``,

    sup_{t >= t0} |tau_j(t)| <= |k_t (S_j q_c - z_j)| + k_t |S_j Q| + sum_k |k_t c_k S_j psi_k|.

If that bound is below the static limit ``tau_s,j = mu_s p_j`` at every element, no element can
start to slip, ever: the record stays stuck and its motion converges onto the forced response
(the stuck beam's attractor, period 1, when every mode is damped).  The bound can also be
approached when it is not below the limit: with the forcing and the stuck natural frequencies
rationally independent, the phases of the oscillating terms come arbitrarily close to alignment
(Kronecker), so an element may slip again unless the free vibration decays first (its slowest
modes decay by e only in ``1 / stuck_decay_rate`` time units, docs/classification.md, rule 3).
An overdamped (real) mode's term only shrinks from ``t0`` on and never comes back, so there the
bound is a bound, not a value the motion returns to.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from beamsim.point import PreparedPoint
from beamsim.two_layer import first_order_matrix

__all__ = ["LockedOrbit", "difference_energy", "lock_ratio", "locked_orbit", "shakedown_ratio",
           "stuck_traction_bound"]


def _check_elastic_stick(pp: PreparedPoint, what: str) -> None:
    if pp.friction.law != "stick-slip":
        raise ValueError(f"{what} needs the elastic stick (law stick-slip), got {pp.friction.law!r}")


def _harmonic(pp: PreparedPoint) -> np.ndarray:
    """``Q``: the complex amplitude of the stuck beam's forced response to ``f0 cos(omega t)``,
    ``(K_stuck - omega^2 M + i omega C) Q = f0 g``."""
    m, w = pp.model, pp.omega
    return np.linalg.solve(m.K_stuck - w * w * m.M + 1j * w * m.C, pp.f0 * m.g.astype(complex))


def stuck_traction_bound(pp: PreparedPoint, state: np.ndarray, t0: float = 0.0) -> np.ndarray:
    """Per interface point, the bound above on ``sup_{t >= t0} |tau_j(t)|`` divided by the static
    limit ``tau_s,j`` for the everywhere-stuck beam started at time ``t0`` from ``state``.

    Parameters
    ----------
    pp : a prepared point of the elastic stick-slip law (``law: stick-slip``).
    state : the kernels' state vector ``(q, v, z, mode)``, length ``2 n + 2 n_quad``; only
        ``q``, ``v`` and ``z`` enter (the bound assumes every element stuck from ``t0`` on).
    t0 : the time of ``state`` in the forcing's clock (dimensionless time; a multiple of the
        forcing period ``2 pi / omega`` at a record's end).

    Returns
    -------
    ratio : array of ``n_quad``; below 1 at every element means that no element can slip again.
        ``inf`` where ``tau_s,j = 0`` (no stick possible there).
    """
    _check_elastic_stick(pp, "stuck_traction_bound")
    m = pp.model
    n, nq = m.n, m.n_quad
    x = np.asarray(state, dtype=float)
    if x.size != 2 * n + 2 * nq:
        raise ValueError(f"state must have {2 * n + 2 * nq} entries, got {x.size}")
    q, v, z = x[:n], x[n:2 * n], x[2 * n:2 * n + nq]
    kt, S, w = m.geom.k_t, m.S, pp.omega
    # forced response: q_c (mean load and the frozen sliders), Q (the harmonic)
    q_c = np.linalg.solve(m.K_stuck, -pp.f0 * m.g + kt * (S.T @ (m.wq * z)))
    Q = _harmonic(pp)
    rot = Q * np.exp(1j * w * t0)
    e0 = np.concatenate([q - (q_c + rot.real), v - (1j * w * rot).real])
    # free vibration in the eigenvectors of the first-order stuck matrix
    lam, psi = np.linalg.eig(first_order_matrix(m.M, m.K_stuck, m.C))
    c = np.linalg.solve(psi, e0.astype(complex))
    free = kt * np.abs((S @ psi[:n, :]) * c[None, :]).sum(axis=1)
    forced = np.abs(kt * (S @ q_c - z)) + kt * np.abs(S @ Q)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(pp.tau_s > 0, (forced + free) / np.where(pp.tau_s > 0, pp.tau_s, 1.0), np.inf)


class LockedOrbit(NamedTuple):
    """The locked orbit of a point (:func:`locked_orbit`).

    state : its state at ``t = 0`` (a period boundary) in the kernels' layout
        ``(q, v, z, mode)``, every ``mode`` 0 (stuck): a start for the integrators
        (:func:`beamsim.simulate.state_params`).
    ratio : per interface point, its traction amplitude over the static limit,
        ``k_t |S_j Q| / tau_s,j`` (``inf`` where ``tau_s,j = 0``).
    kinetic_ratio : the same amplitude over the kinetic limit, ``k_t |S_j Q| / tau_k,j``
        (``inf`` where ``tau_k,j = 0``).
    """

    state: np.ndarray
    ratio: np.ndarray
    kinetic_ratio: np.ndarray


def _over(amp: np.ndarray, limit: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(limit > 0, amp / np.where(limit > 0, limit, 1.0), np.inf)


def locked_orbit(pp: PreparedPoint) -> LockedOrbit:
    """The everywhere-stuck period-1 motion with the smallest tractions, and their ratios to the
    static and kinetic slip limits (docs/model.md, section 7).

    With every element stuck and the sliders ``z`` frozen, the motion's tail is the forced
    response ``q_c + Re(Q e^{i omega t})``, plus free vibration in the modes that no damping
    reaches (with the interface dashpot, ``c_t > 0``, those load no element: ``C psi = 0``
    needs ``S psi = 0``).  Its traction at element ``j`` is
    ``k_t (S_j q_c - z_j) + k_t Re(S_j Q e^{i omega t})``: the harmonic part is fixed by the
    load, the mean part by the locked slips.  Sliders at ``z = S q_c`` with ``K q_c = -f0 g``
    (the structure without the interface carries the mean load, so ``K_stuck q_c = -f0 g +
    k_t S^T W z`` holds) make every mean traction zero, so every element's peak traction is its
    harmonic amplitude ``k_t |S_j Q|``, the least any everywhere-stuck motion can have.

    Hence two limits.  **Lock-up** (``ratio`` below 1 at every element): this motion never
    slips (:func:`stuck_traction_bound` of its state is ``ratio``: no free vibration), so a
    locked period-1 motion exists.  Locked orbits form a family, one per set of locked slips;
    with damping the stuck states near one converge to the family at the stuck beam's slowest
    decay, and along the slips they are neutral.  Above 1 at some element, no motion stays
    stuck at every element for ever once every mode is damped (its tail is the forced response,
    whose traction there swings by more than the limit).  **Shakedown** (``kinetic_ratio``
    below 1 at every element): every motion, from any state, slips a finite total distance
    (an energy argument of Melan-Koiter-Ceradini type: the energy of the difference from the
    locked orbit falls by at least ``(1 - kinetic_ratio) tau_k,j`` per unit slip of element
    ``j``), so no attractor slips.

    Parameters
    ----------
    pp : a prepared point of the elastic stick-slip law.
    """
    _check_elastic_stick(pp, "locked_orbit")
    m, w = pp.model, pp.omega
    Q = _harmonic(pp)
    q_c = np.linalg.solve(m.K, -pp.f0 * m.g)
    z = m.S @ q_c
    state = np.concatenate([q_c + Q.real, (1j * w * Q).real, z, np.zeros(m.n_quad)])
    amp = m.geom.k_t * np.abs(m.S @ Q)
    return LockedOrbit(state=state, ratio=_over(amp, pp.tau_s), kinetic_ratio=_over(amp, pp.tau_k))


def difference_energy(pp: PreparedPoint, state: np.ndarray, orbit: LockedOrbit) -> float:
    """``W``: the energy of the difference between ``state`` and the locked orbit ``orbit``
    (:func:`locked_orbit`), both at a period boundary (``t`` a multiple of ``2 pi / omega``):

        W = 1/2 e'^T M e' + 1/2 e^T K e + 1/2 k_t sum_j wq_j (S_j e - zeta_j)^2,

    ``e = q - q*``, ``zeta = z - z*``: kinetic, structural and interface-spring energy.  Below
    the shakedown limit (:func:`shakedown_ratio` below 1) every exact motion of the model has
    ``dW/dt <= -(1 - kinetic ratio) tau_k,j |z_j'|`` per element, minus the dampers' loss
    (docs/model.md, section 7): ``W`` never grows, from any state.  A run whose ``W`` grows
    there is not a motion of the model (the integrator's trouble), which is what the pipeline's
    shakedown rule checks before it continues a slipping record
    (:func:`analysis.pipeline.stages.simulate_runs`).

    Parameters
    ----------
    pp : a prepared point of the elastic stick-slip law.
    state : the kernels' state ``(q, v, z, mode)``, length ``2 n + 2 n_quad`` (``mode`` unused).
    orbit : the point's :func:`locked_orbit`.
    """
    _check_elastic_stick(pp, "difference_energy")
    m = pp.model
    n, nq = m.n, m.n_quad
    x, o = np.asarray(state, dtype=float), np.asarray(orbit.state, dtype=float)
    if x.size != 2 * n + 2 * nq:
        raise ValueError(f"state must have {2 * n + 2 * nq} entries, got {x.size}")
    e, ev = x[:n] - o[:n], x[n:2 * n] - o[n:2 * n]
    r = m.S @ e - (x[2 * n:2 * n + nq] - o[2 * n:2 * n + nq])
    return float(0.5 * ev @ m.M @ ev + 0.5 * e @ m.K @ e + 0.5 * m.geom.k_t * np.sum(m.wq * r * r))


def lock_ratio(pp: PreparedPoint) -> float:
    """The largest ratio of :func:`locked_orbit`: below 1, a locked (everywhere-stuck)
    period-1 motion exists at this point; above 1, none does.  It is proportional to the load
    amplitude ``f0``, so ``f0 / lock_ratio`` is the point's lock-up load."""
    return float(np.max(locked_orbit(pp).ratio))


def shakedown_ratio(pp: PreparedPoint) -> float:
    """The largest kinetic ratio of :func:`locked_orbit` (``lock_ratio * mu_s / mu_k``): below
    1, every motion of this point shakes down (its total slip is finite, from any state), so no
    record that slips is on an attractor."""
    return float(np.max(locked_orbit(pp).kinetic_ratio))

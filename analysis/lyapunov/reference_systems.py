r"""Reference systems for validating the Lyapunov estimators.

Each system is a ``numba.njit`` right-hand side ``rhs(t, x, params) -> ndarray``
plus a :class:`ReferenceSystem` record with its parameters, a start state, a
step size, run lengths and the reference value of lambda_1 *with its source*.
Where no published value is known to us, ``reference`` is ``None`` and the
validation is Stefanski vs Benettin (and a closed form where one exists).

Time units: each system's own (dimensionless) time; exponents are per unit time.

Sources
-------
* [Sprott2003] J. C. Sprott, *Chaos and Time-Series Analysis*, Oxford University
  Press (2003), Appendix A "Common chaotic systems": Lorenz (10, 28, 8/3):
  0.9056, 0, -14.5723; Rossler (0.2, 0.2, 5.7): 0.0714, 0, -5.3943.
  The project brief quotes 0.906 for Lorenz.
* [LS-web] "Lyapunov spectrum" collection, duffing_eqs page
  (https://sites.google.com/view/lyapunov-spectrum/home/duffing_eqs): Ueda's
  Duffing equation x'' + 0.05 x' + x^3 = 7.5 cos t, exponents 0.0999, 0.0000,
  -0.1499 (RK4, h = 0.001, Gram-Schmidt), citing Ueda, J. Stat. Phys. 20 (1979)
  181-196 and Sprott (2003) pp. 182, 183, 429.  This is a web computation that
  cites the book, not a table we could check in the book itself: treat it as a
  secondary source.
* Closed forms: the autonomous van der Pol limit cycle has lambda_1 = 0 exactly
  (the phase direction is neutral); the damped linear oscillator
  x'' + 2 zeta omega x' + omega^2 x = 0 (zeta < 1) has lambda_1 = lambda_2 =
  -zeta omega.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

__all__ = [
    "ReferenceSystem",
    "lorenz",
    "rossler",
    "ueda_duffing",
    "duffing_dry_friction",
    "van_der_pol",
    "damped_oscillator",
    "REFERENCE_SYSTEMS",
    "get_system",
]


@njit(cache=True)
def lorenz(t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    r"""Lorenz (1963): x' = s(y - x), y' = x(r - z) - y, z' = x y - b z.

    ``p = [sigma, rho, beta]``.  Autonomous (t unused).
    """
    out = np.empty(3)
    out[0] = p[0] * (x[1] - x[0])
    out[1] = x[0] * (p[1] - x[2]) - x[1]
    out[2] = x[0] * x[1] - p[2] * x[2]
    return out


@njit(cache=True)
def rossler(t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    r"""Rossler (1976): x' = -y - z, y' = x + a y, z' = b + z (x - c).

    ``p = [a, b, c]``.  Autonomous.
    """
    out = np.empty(3)
    out[0] = -x[1] - x[2]
    out[1] = x[0] + p[0] * x[1]
    out[2] = p[1] + x[2] * (x[0] - p[2])
    return out


@njit(cache=True)
def ueda_duffing(t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    r"""Ueda's forced Duffing oscillator x'' + k x' + x^3 = B cos(Omega t).

    State ``[x, x']``, ``p = [k, B, Omega]``.  Non-autonomous (forced); the
    forcing period is 2 pi / Omega.
    """
    out = np.empty(2)
    out[0] = x[1]
    out[1] = -p[0] * x[1] - x[0] ** 3 + p[1] * math.cos(p[2] * t)
    return out


@njit(cache=True)
def duffing_dry_friction(t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    r"""Forced Duffing oscillator with Coulomb (dry) friction.

    .. math:: x'' + k x' + x^3 + \mu\,\mathrm{sgn}(x') = B\cos(\Omega t)

    State ``[x, x']``, ``p = [k, B, Omega, mu]``.  The friction force is
    discontinuous in the velocity (``sgn(0) = 0``, no regularisation): the
    right-hand side jumps by 2 mu across x' = 0.  This is the class of system of
    Stefanski & Kapitaniak (2000, "Duffing oscillator with added dry friction");
    their exact parameters are not reproduced here, so there is no published
    lambda_1 for these parameters: validation is Stefanski vs Benettin.
    """
    out = np.empty(2)
    v = x[1]
    s = 0.0
    if v > 0.0:
        s = 1.0
    elif v < 0.0:
        s = -1.0
    out[0] = v
    out[1] = -p[0] * v - x[0] ** 3 - p[3] * s + p[1] * math.cos(p[2] * t)
    return out


@njit(cache=True)
def van_der_pol(t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    r"""Autonomous van der Pol oscillator x'' - mu (1 - x^2) x' + x = 0.

    ``p = [mu]``.  Stable limit cycle: lambda_1 = 0 (neutral phase direction),
    lambda_2 < 0.
    """
    out = np.empty(2)
    out[0] = x[1]
    out[1] = p[0] * (1.0 - x[0] * x[0]) * x[1] - x[0]
    return out


@njit(cache=True)
def damped_oscillator(t: float, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    r"""Damped linear oscillator x'' + 2 zeta omega x' + omega^2 x = 0.

    ``p = [zeta, omega]``.  Stable focus at the origin for 0 < zeta < 1;
    both exponents equal the real part of the eigenvalues, -zeta*omega.
    """
    out = np.empty(2)
    out[0] = x[1]
    out[1] = -2.0 * p[0] * p[1] * x[1] - p[1] * p[1] * x[0]
    return out


@dataclass(frozen=True)
class ReferenceSystem:
    """A validation case.

    Attributes
    ----------
    name, rhs, params, x0
        The system and where to start it.
    dt
        RK4 step used in the validation (time unit of the system).
    t_transient, t_measure
        Run lengths used in the validation; ``t_measure`` is the length of each
        Stefanski test and of the Benettin average.
    reference
        Published / closed-form lambda_1, or ``None`` when there is none.
    source
        Where ``reference`` comes from (or why there is none).
    kind
        ``"chaotic"``, ``"limit-cycle"`` or ``"fixed-point"``.
    forcing_period
        For forced systems, the period (for stroboscopic sampling); else None.
    smooth
        False for discontinuous right-hand sides.
    """

    name: str
    rhs: object
    params: np.ndarray
    x0: np.ndarray
    dt: float
    t_transient: float
    t_measure: float
    reference: float | None
    source: str
    kind: str
    forcing_period: float | None = None
    smooth: bool = True


def _arr(*v: float) -> np.ndarray:
    return np.array(v, dtype=np.float64)


REFERENCE_SYSTEMS: dict[str, ReferenceSystem] = {
    "lorenz": ReferenceSystem(
        name="lorenz", rhs=lorenz, params=_arr(10.0, 28.0, 8.0 / 3.0), x0=_arr(1.0, 1.0, 1.0),
        dt=0.01, t_transient=100.0, t_measure=400.0, reference=0.9056,
        source="Sprott (2003) Appendix A: 0.9056 (brief: 0.906)", kind="chaotic"),
    "rossler": ReferenceSystem(
        name="rossler", rhs=rossler, params=_arr(0.2, 0.2, 5.7), x0=_arr(1.0, 1.0, 0.0),
        dt=0.02, t_transient=500.0, t_measure=5000.0, reference=0.0714,
        source="Sprott (2003) Appendix A: 0.0714", kind="chaotic"),
    "ueda_duffing": ReferenceSystem(
        name="ueda_duffing", rhs=ueda_duffing, params=_arr(0.05, 7.5, 1.0), x0=_arr(2.5, 0.0),
        dt=2.0 * math.pi / 400, t_transient=100 * 2.0 * math.pi, t_measure=2400 * 2.0 * math.pi,
        reference=0.0999,
        source="lyapunov-spectrum web collection (duffing_eqs), citing Ueda (1979) and "
               "Sprott (2003): 0.0999 (secondary source)",
        kind="chaotic", forcing_period=2.0 * math.pi),
    "duffing_dry_friction": ReferenceSystem(
        name="duffing_dry_friction", rhs=duffing_dry_friction, params=_arr(0.05, 7.5, 1.0, 0.05),
        x0=_arr(2.5, 0.0), dt=2.0 * math.pi / 400, t_transient=100 * 2.0 * math.pi,
        t_measure=2400 * 2.0 * math.pi, reference=None,
        source="no published value for these parameters: Stefanski vs Benettin",
        kind="chaotic", forcing_period=2.0 * math.pi, smooth=False),
    "van_der_pol": ReferenceSystem(
        name="van_der_pol", rhs=van_der_pol, params=_arr(1.0), x0=_arr(0.5, 0.0),
        dt=0.01, t_transient=100.0, t_measure=1000.0, reference=0.0,
        source="closed form: limit cycle of an autonomous flow, lambda_1 = 0",
        kind="limit-cycle"),
    "damped_oscillator": ReferenceSystem(
        name="damped_oscillator", rhs=damped_oscillator, params=_arr(0.1, 2.0), x0=_arr(1.0, 0.0),
        dt=0.01, t_transient=10.0, t_measure=100.0, reference=-0.2,
        source="closed form: -zeta*omega = -0.1*2.0", kind="fixed-point"),
}


def get_system(name: str) -> ReferenceSystem:
    """Look a reference system up by name (raises ``KeyError`` listing the names)."""
    try:
        return REFERENCE_SYSTEMS[name]
    except KeyError:
        raise KeyError(f"unknown reference system {name!r}; known: {sorted(REFERENCE_SYSTEMS)}") from None

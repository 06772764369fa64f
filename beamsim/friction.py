r"""Interlayer friction laws (paper eqs 33, 34), chosen per run.

All tractions and pressures are in units of E, slip velocities in units of
``R / sqrt(rho R^2 / E)`` (see docs/model.md).  The interface traction ``tau_j`` at interface
point ``j`` resists the slip ``s_j`` (it enters the equations as ``- S^T diag(wq) tau``).

``stick-slip`` (paper eq 33, the paper's model)
    Elastic-stick (Jenkins) element at each interface point: ``tau_j = k_t (s_j - z_j)`` with the
    internal slip ``z_j``.  Stuck (``z_j`` frozen) while ``|tau_j| <= mu_s p_j``; when the
    limit is exceeded the point slips with ``tau_j = mu_k p_j sgn(slip velocity)`` and ``z_j``
    follows ``s_j``; it sticks again when the slip velocity reverses.  ``mu_s >= mu_k``.
    Stick and slip are local (partial slip).  As ``k_t -> inf`` this is the rigid-stick
    Coulomb law of eq 33.
``rigid-stick`` (that limit, eq 33 itself)
    A stuck point does not slip at all (``s_j' = 0``; the traction is the constraint force,
    whatever it takes up to ``mu_s p_j``), a sliding one carries ``mu_k p_j sgn(slip
    velocity)``; no ``k_t``, no stuck-interface modes.  Tractions that the interface carries
    without a generalised force (the Galerkin basis has fewer slip shapes than interface
    points) are locked in while a pattern sticks, as in the penalty model
    (:mod:`beamsim.kernels.rigid_stick`).  Integrated by ``rk4`` only.
``full-slip`` (the simplified model of the paper's fig 9)
    ``tau_j = mu_k p_j tanh(v_j / eps_v)``: always sliding, the sign function regularised over
    the velocity band ``eps_v``.
``stribeck`` (paper eq 34)
    ``tau_j = g_j [F_c + (F_s - F_c) exp(-|v_j| / v_s)] tanh(v_j / eps_v) + k_v v_j`` with
    ``g_j = p(theta_j) / p`` the pressure profile shape (1 for uniform pressure).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from beamsim.two_layer import check_nonnegative, check_positive, set_fields

__all__ = ["LAWS", "STICK_SLIP", "FULL_SLIP", "STRIBECK", "RIGID_STICK", "Friction", "smooth_traction",
           "law_code"]

STICK_SLIP = 0
FULL_SLIP = 1
STRIBECK = 2
RIGID_STICK = 3
LAWS = {"stick-slip": STICK_SLIP, "full-slip": FULL_SLIP, "stribeck": STRIBECK,
        "rigid-stick": RIGID_STICK}
#: the laws with a stick phase (static and kinetic coefficients, located switches)
STICKING_LAWS = ("stick-slip", "rigid-stick")


def law_code(law: str) -> int:
    try:
        return LAWS[law]
    except KeyError:
        raise ValueError(f"law must be one of {tuple(LAWS)}, got {law!r}") from None


@njit(cache=True, inline="always")
def smooth_traction(v, fc, fs, vs, kv, eps):
    """Regularised Stribeck / Coulomb traction at slip velocity ``v`` (full-slip: fc = fs, kv = 0)."""
    return (fc + (fs - fc) * math.exp(-abs(v) / vs)) * math.tanh(v / eps) + kv * v


@dataclass(frozen=True)
class Friction:
    """Friction law and its constants for one run.

    law : "stick-slip" | "rigid-stick" | "full-slip" | "stribeck".
    mu_s, mu_k : static and kinetic coefficients (``mu_k=None`` -> ``mu_s``); ``mu_s >= mu_k``.
        full-slip uses ``mu_k``.
    p : mean interlayer pressure p* = p / E (>= 0);  ``p_profile`` optional shape (see
        :func:`beamsim.two_layer.pressure_at`).
    F_c, F_s, v_s, k_v : Stribeck constants (tractions in units of E, ``F_s >= F_c``; ``v_s`` > 0;
        ``k_v`` >= 0 viscous coefficient, traction per unit slip velocity).
        ``F_c=None`` -> ``mu_k p``; ``F_s=None`` -> ``mu_s p``.
    eps_v : velocity band of the tanh regularisation (full-slip, stribeck).  ``None`` -> chosen
        by the simulator as ``eps_rel`` times a characteristic slip velocity (docs/model.md).
    eps_rel : see ``eps_v``.
    """

    law: str = "stick-slip"
    mu_s: float = 0.3
    mu_k: float | None = None
    p: float = 1e-4
    p_profile: object = None
    F_c: float | None = None
    F_s: float | None = None
    v_s: float = 1e-6
    k_v: float = 0.0
    eps_v: float | None = None
    eps_rel: float = 5e-2

    def __post_init__(self):
        law_code(self.law)
        mu_s = check_nonnegative("mu_s", self.mu_s)
        mu_k = mu_s if self.mu_k is None else check_nonnegative("mu_k", self.mu_k)
        if mu_s < mu_k:
            raise ValueError(f"mu_s must be >= mu_k, got mu_s={mu_s!r} < mu_k={mu_k!r}")
        p = check_nonnegative("p", self.p)
        fc = mu_k * p if self.F_c is None else check_nonnegative("F_c", self.F_c)
        fs = mu_s * p if self.F_s is None else check_nonnegative("F_s", self.F_s)
        if fs < fc:
            raise ValueError(f"F_s must be >= F_c, got F_s={fs!r} < F_c={fc!r}")
        vs = check_positive("v_s", self.v_s)
        kv = check_nonnegative("k_v", self.k_v)
        if self.eps_v is not None:
            check_positive("eps_v", self.eps_v)
        check_positive("eps_rel", self.eps_rel)
        if self.p_profile is not None and not callable(self.p_profile):
            arr = np.asarray(self.p_profile, dtype=float)
            if not np.all(np.isfinite(arr)):
                raise ValueError("p_profile must be finite")
            if np.any(arr < 0):
                raise ValueError("p_profile must be >= 0 (interlayer pressure cannot be negative)")
        set_fields(self, mu_s=mu_s, mu_k=mu_k, p=p, F_c=fc, F_s=fs, v_s=vs, k_v=kv)

    @property
    def code(self) -> int:
        return LAWS[self.law]

    def limits(self, theta_q, pj):
        """Per-point arrays (tau_s, tau_k, fc, fs) for the kernel; ``pj`` = pressure at points."""
        p = self.p
        shape = pj / p if p > 0 else np.zeros_like(pj)
        tau_s = self.mu_s * pj
        tau_k = self.mu_k * pj
        if self.law == "full-slip":
            fc = fs = tau_k
        else:
            fc = self.F_c * shape
            fs = self.F_s * shape
        return tau_s, tau_k, fc, fs

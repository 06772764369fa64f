"""One parameter point made ready for the kernels: validation, derived load and frequency,
friction limits at the quadrature points, initial state, the fastest rate of the linear part,
steps per period, and the stacked kernel inputs of a batch."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np
import scipy.linalg as sla

from beamsim.friction import RIGID_STICK, Friction
from beamsim.kernels.bundles import PointStack
from beamsim.two_layer import (
    Geometry,
    TwoLayerModel,
    build_model,
    check_nonnegative,
    check_positive,
    pressure_at,
)

__all__ = ["PreparedPoint", "check_point", "prepare_point", "period_steps", "stack_points", "POINT_KEYS"]

#: steps per forcing period of the fixed-grid integrators (RK4's follows from its stability).
#: ``expo``'s steps are its output grid (Poincare samples at period ends, the divergence test
#: at step ends) and the longest spacing of its checks, not a discretisation: 4 since results
#: version 18 (16 since version 14, 64 before; the measurements: docs/model.md and
#: docs/performance.md, "Four output steps per period"); its stick statistics are tallied per
#: interval, not at the step ends
DEFAULT_STEPS_PER_PERIOD = {"expo": 4, "newmark": 256}

#: the load of a point that gives neither ``f0`` nor ``f0_rel`` (f0 / f_cr)
DEFAULT_F0_REL = 2.0

_GEOM_KEYS = tuple(f.name for f in fields(Geometry))
_FRIC_KEYS = tuple(f.name for f in fields(Friction))
_LOAD_KEYS = ("f0", "f0_rel", "omega", "lam_f", "Omega")
_INIT_KEYS = ("q0", "v0", "z0", "mode0")
POINT_KEYS = set(_GEOM_KEYS) | set(_FRIC_KEYS) | set(_LOAD_KEYS) | set(_INIT_KEYS)


@dataclass
class PreparedPoint:
    """Everything the kernel needs for one parameter point (see :func:`prepare_point`)."""

    model: TwoLayerModel
    friction: Friction
    f0: float
    omega: float
    f_cr: float
    eps_v: float
    tau_s: np.ndarray
    tau_k: np.ndarray
    fc: np.ndarray
    fs: np.ndarray
    x0: np.ndarray
    omega_max: float
    params: dict = field(repr=False)

    @property
    def Omega(self) -> float:
        return self.omega / omega1_stuck(self.model, self.friction.law)

    @property
    def lam_f(self) -> float:
        return self.omega**2


#: integrators that support only some friction laws (the others, e.g. ``rk4``, support all)
METHOD_LAWS = {"expo": ("stick-slip",), "newmark": ("stick-slip",)}


def check_method_law(method: str, law: str) -> None:
    """Raise ValueError if the integrator ``method`` does not support the friction ``law``."""
    laws = METHOD_LAWS.get(method)
    if laws is not None and law not in laws:
        raise ValueError(f"method={method!r} supports law={' or '.join(map(repr, laws))} only, "
                         f"got law={law!r}")


def omega1_stuck(model: TwoLayerModel, law: str) -> float:
    """First natural angular frequency of the stuck beam, the unit of ``Omega``: bonded by the
    penalty springs (every law but one) or rigidly (``rigid-stick``)."""
    if law == "rigid-stick":
        return model.omega1_bonded_rigid
    return model.omega1_stuck


def _split(point: dict):
    unknown = set(point) - POINT_KEYS
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; allowed: {sorted(POINT_KEYS)}")
    geom = Geometry(**{k: point[k] for k in _GEOM_KEYS if k in point})
    fric = Friction(**{k: point[k] for k in _FRIC_KEYS if k in point})
    return geom, fric


def check_point(point: dict) -> tuple[Geometry, Friction]:
    """Every rule a parameter point must satisfy that needs no model to be built: known keys;
    the geometry's and the friction law's values and cross rules (:class:`Geometry`,
    :class:`Friction`: e.g. ``mu_k <= mu_s``, ``F_c <= F_s``, finite values); at most one load
    (``f0`` or ``f0_rel``, finite, ``>= 0``) and at most one frequency (``omega``, ``lam_f`` or
    ``Omega``, finite, ``> 0``).  Raises ValueError naming the parameter; returns the checked
    geometry and friction law.  :func:`prepare_point` starts with it, and the workflow runs it
    on every grid point before any job (:mod:`analysis.pipeline.validation`)."""
    geom, fric = _split(point)
    if point.get("f0") is not None and point.get("f0_rel") is not None:
        raise ValueError("give only one of f0 and f0_rel")
    for key in ("f0", "f0_rel"):
        if point.get(key) is not None:
            check_nonnegative(key, point[key])
    given = [k for k in ("omega", "lam_f", "Omega") if point.get(k) is not None]
    if len(given) > 1:
        raise ValueError(f"give only one of omega, lam_f, Omega (got {given})")
    for key in given:
        check_positive(key, point[key])
    return geom, fric


def prepare_point(**point) -> PreparedPoint:
    """Validate one parameter point and derive the kernel inputs.

    Load: exactly one of ``f0`` (amplitude, units E b R) and ``f0_rel`` (= f0 / f_cr, default 2);
    exactly one of ``omega`` (angular frequency, units sqrt(E / rho R^2)), ``lam_f``
    (= omega^2, the paper's lambda) and ``Omega`` (= omega / omega_1 of the stuck beam,
    default 1).  Initial state ``q0``, ``v0`` (generalised coordinates, default 0), ``z0``
    (Jenkins internal slips, default 0), ``mode0`` (stick/slip state of each Jenkins element:
    0 stuck, +-1 slipping in that direction; default 0; stick-slip and rigid-stick laws only;
    for rigid-stick ``z0`` is a stuck element's locked-in traction).  A point can be
    restarted from ``SimResult.final_state`` with :func:`restart_params`.
    """
    geom, fric = check_point(point)
    model = build_model(geom)
    pj = pressure_at(model.theta_q, fric.p, fric.p_profile)
    f_cr = model.f_cr(fric.mu_s, fric.p, fric.p_profile, rigid=fric.law == "rigid-stick")
    # load amplitude
    if point.get("f0") is not None:
        f0 = check_nonnegative("f0", point["f0"])
    else:
        rel = check_nonnegative("f0_rel", point.get("f0_rel", DEFAULT_F0_REL))
        if not (math.isfinite(f_cr) and f_cr > 0):
            if rel != 0:
                raise ValueError("f0_rel needs a positive slip-onset load f_cr (mu_s * p > 0); "
                                 "give f0 instead")
            f0 = 0.0
        else:
            f0 = rel * f_cr
    # frequency
    given = [k for k in ("omega", "lam_f", "Omega") if point.get(k) is not None]
    key = given[0] if given else "Omega"
    if key == "omega":
        omega = check_positive("omega", point["omega"])
    elif key == "lam_f":
        omega = math.sqrt(check_positive("lam_f", point["lam_f"]))
    else:
        omega = check_positive("Omega", point.get("Omega", 1.0)) * omega1_stuck(model, fric.law)
    # initial state
    n, nq = model.n, model.n_quad
    x0 = np.zeros(2 * n + 2 * nq)
    for name, sl, size in (("q0", slice(0, n), n), ("v0", slice(n, 2 * n), n),
                           ("z0", slice(2 * n, 2 * n + nq), nq),
                           ("mode0", slice(2 * n + nq, 2 * n + 2 * nq), nq)):
        val = point.get(name)
        if val is not None:
            arr = np.asarray(val, dtype=float).ravel()
            if arr.size != size:
                raise ValueError(f"{name} must have {size} entries, got {arr.size}")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be finite")
            if name == "mode0" and not np.all(np.isin(arr, (-1.0, 0.0, 1.0))):
                raise ValueError("mode0 entries must be -1, 0 (stuck) or +1 (slipping direction)")
            x0[sl] = arr
    tau_s, tau_k, fc, fs = fric.limits(model.theta_q, pj)
    # regularisation band and stiffness of the regularised laws
    if fric.law == "stick-slip":
        eps_v = 1.0
        has_stick = bool(np.any(tau_s > 0))
        omega_max = model.omega_max_stuck if has_stick else model.omega_max_frictionless
    elif fric.law == "rigid-stick":
        # a constraint can only lower the largest natural frequency (Rayleigh quotient over a
        # subspace): the free (frictionless) beam bounds every stick pattern
        eps_v = 1.0
        omega_max = model.omega_max_frictionless
    else:
        if fric.eps_v is not None:
            eps_v = float(fric.eps_v)
        else:
            s_unit = np.abs(model.S @ model.static_unit_frictionless).max()
            v_ref = omega * 2.0 * f0 * s_unit
            if v_ref <= 0:
                v_ref = omega * np.abs(model.S @ x0[:n]).max() + np.abs(model.S @ x0[n:2 * n]).max()
            eps_v = fric.eps_rel * v_ref if v_ref > 0 else 1e-12
        slope = np.maximum(fs, fc) / eps_v + fric.k_v
        Cv = (model.S.T * (model.wq * slope)) @ model.S
        c_max = float(sla.eigh(Cv, model.M, eigvals_only=True)[-1])
        omega_max = model.omega_max_frictionless + max(c_max, 0.0)
    return PreparedPoint(model=model, friction=fric, f0=f0, omega=omega, f_cr=f_cr, eps_v=eps_v,
                         tau_s=tau_s, tau_k=tau_k, fc=fc, fs=fs, x0=x0, omega_max=omega_max,
                         params=dict(point))


def period_steps(pp: PreparedPoint, method: str = "rk4", steps_per_period: int | None = None,
                 step_factor: float = 0.5) -> int:
    """Fixed steps per forcing period ``T = 2 pi / omega``: ``steps_per_period`` if given, else
    RK4 ``max(64, ceil(T omega_max / step_factor))`` (``omega_max``: fastest rate of the
    point's linear part), otherwise :data:`DEFAULT_STEPS_PER_PERIOD` (``expo`` is exact between
    located switches: its steps only set the output grid and the largest spacing of the event
    checks; the choice of 64 is measured in docs/model.md)."""
    if steps_per_period is not None:
        return int(steps_per_period)
    if method in DEFAULT_STEPS_PER_PERIOD:
        return DEFAULT_STEPS_PER_PERIOD[method]
    T = 2 * math.pi / pp.omega
    return max(64, int(math.ceil(T * pp.omega_max / step_factor)))


def _first_order(md: TwoLayerModel, explicit_inverse: bool = False) -> tuple:
    """``(-M^-1 K, -M^-1 C_struct, -M^-1 S^T W, M^-1 g, M^-1, L^-1)`` of a model (L: Cholesky
    factor of M).  The products with ``M^-1`` are Cholesky solves, not products with the
    explicit inverse: the mass matrix is ill-conditioned (cond ~ 1e7 at three modes), and the
    explicit inverse's rounding, ``eps cond(M)``, left RK4 a floor of ~3e-7 of the state per
    period below which no step size reached (docs/performance.md, "The first-order matrices
    without the explicit inverse").  ``explicit_inverse``: the products with ``M^-1`` itself,
    for the rigid stick, whose constraint tractions project with ``S M^-1 S^T`` and must see
    the same ``M^-1`` as its free acceleration (with the solves its drive left the reference
    run by 2e-8 and a monotone law's Benettin exponent came out positive)."""
    Cst = md.C if md.C_struct is None else md.C_struct
    Minv = np.linalg.inv(md.M)
    Linv = np.linalg.inv(np.linalg.cholesky(md.M))
    if explicit_inverse:
        return -Minv @ md.K, -Minv @ Cst, -Minv @ (md.S.T * md.wq), Minv @ md.g, Minv, Linv
    chol = sla.cho_factor(md.M, lower=True)
    return (-sla.cho_solve(chol, md.K), -sla.cho_solve(chol, Cst),
            -sla.cho_solve(chol, md.S.T * md.wq), sla.cho_solve(chol, md.g), Minv, Linv)


def stack_points(prepared: list, div_limit: float = 1e3) -> PointStack:
    """Stack the kernel inputs of prepared points (same ``n`` and ``n_quad``) into a
    :data:`~beamsim.kernels.bundles.PointStack`: matrices of the first-order form, friction
    limits, initial states ``x0 = (q, v, z, mode)`` and divergence limits
    ``div_limit * q_ref`` (``q_ref``: the largest of the frictionless static response to the
    peak load ``2 f0``, ``|q0|`` and ``|v0| / omega``)."""
    P = len(prepared)
    n = prepared[0].model.n
    nq = prepared[0].model.n_quad

    def mats(*shape):
        return np.empty((P, *shape))

    a = dict(law=np.empty(P, np.int64), Aq=mats(n, n), Av=mats(n, n), Bt=mats(n, nq), gv=mats(n),
             S=mats(nq, n), wq=mats(nq), kt=mats(), ct=np.zeros(P), Mm=mats(n, n), Km=mats(n, n),
             Cm=mats(n, n), damp=np.zeros(P, np.bool_), g=mats(n), tip=mats(4, n), f0=mats(),
             om=mats(), tau_s=mats(nq), tau_k=mats(nq), fc=mats(nq), fs=mats(nq), vs=mats(),
             kv=mats(), eps=mats(), Minv=mats(n, n), Linv=mats(n, n), Cs=mats(n, n),
             damp_s=np.zeros(P, np.bool_), x0=mats(2 * n + 2 * nq), divl=mats())
    cache = {}
    for i, pp in enumerate(prepared):
        md = pp.model
        key = (id(md), pp.friction.code == RIGID_STICK)
        if key not in cache:
            cache[key] = _first_order(md, explicit_inverse=key[1])
        a["Aq"][i], a["Av"][i], a["Bt"][i], a["gv"][i], a["Minv"][i], a["Linv"][i] = cache[key]
        a["S"][i], a["wq"][i], a["kt"][i] = md.S, md.wq, md.geom.k_t
        a["Mm"][i], a["Km"][i], a["Cm"][i], a["g"][i], a["tip"][i] = md.M, md.K, md.C, md.g, md.tip
        a["f0"][i], a["om"][i] = pp.f0, pp.omega
        a["tau_s"][i], a["tau_k"][i], a["fc"][i], a["fs"][i] = pp.tau_s, pp.tau_k, pp.fc, pp.fs
        a["vs"][i], a["kv"][i], a["eps"][i] = pp.friction.v_s, pp.friction.k_v, pp.eps_v
        a["damp"][i] = bool(np.any(md.C != 0.0))
        a["Cs"][i] = md.C if md.C_struct is None else md.C_struct
        a["damp_s"][i] = bool(np.any(a["Cs"][i] != 0.0))
        a["ct"][i] = md.c_t
        a["law"][i] = pp.friction.code
        a["x0"][i] = pp.x0
        qref = max(2.0 * pp.f0 * np.abs(md.static_unit_frictionless).max(),
                   np.abs(pp.x0[:n]).max(), np.abs(pp.x0[n:2 * n]).max() / pp.omega)
        a["divl"][i] = div_limit * (qref if qref > 0 else 1.0)
    return PointStack(**a)

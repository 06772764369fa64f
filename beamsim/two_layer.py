r"""Two-layer curved beam with an interlayer shear interface: parameters and Galerkin matrices.

The derivation is in ``docs/model.md``; this module implements its section "Galerkin
reduction".  Summary (all quantities dimensionless: lengths / R, time / sqrt(rho R^2 / E),
energies / (E b R^2), forces / (E b R), tractions and pressures / E):

* generalised coordinates ``q = [a, b1, c1, b2, c2]`` (each block ``N`` long):
  ``w = sum a_n W_n``, ``u_i = sum b_in U_n + c_in W_n'`` (layer i centroid),
  with ``W_n, U_n`` the single-layer arch modes of :func:`beamsim.modes.arch_modes`.
  The ``W_n'`` enrichment of the axial basis removes shear locking of the stuck interface.
* kinetic energy ``T = sum_i alpha_i/2 int (w_t^2 + u_i,t^2)``,
  strain energy ``V = sum_i alpha_i/2 int [(w + u_i')^2 + k_i^2 (w'' - u_i')^2]``,
  ``k_i^2 = alpha_i^2 / 12`` -> ``M``, ``K``.
* interface slip at the interface fibre (layer 1 = outer/upper layer, layer 2 = inner):
  ``s = (1 - alpha1/2) u1 - (1 + alpha2/2) u2 + (alpha1 + alpha2)/2 w'``, sampled at the
  ``n_quad`` Gauss-Legendre points ``theta_j`` (weights ``wq_j``): ``s_j = S[j] @ q``.
* interface traction ``tau_j`` (resisting slip) enters as ``- S.T @ (wq * tau)``.
* tip force ``F(t) = f0 (cos(omega t) - 1)`` in the fixed direction
  ``cos(beta) e_r - sin(beta) e_theta`` applied at theta = beta to w and to the upper layer:
  generalised force ``F(t) * g``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

__all__ = [
    "Geometry",
    "TwoLayerModel",
    "build_model",
    "single_layer_modes",
    "check_finite",
    "check_positive",
    "check_nonnegative",
    "pressure_at",
]

AXIAL_RTOL = 1e-13

BCS = ("clamped-free", "clamped-clamped", "pinned-pinned")


# --------------------------------------------------------------------------- validation helpers
def check_finite(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return v


def check_positive(name: str, value) -> float:
    v = check_finite(name, value)
    if v <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return v


def check_nonnegative(name: str, value) -> float:
    v = check_finite(name, value)
    if v < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return v


def set_fields(obj, **values) -> None:
    """Store normalised values on a frozen dataclass instance (from its ``__post_init__``)."""
    for name, value in values.items():
        object.__setattr__(obj, name, value)


def check_int(name: str, value, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        else:
            raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


# --------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class Geometry:
    """Parameters that define the linear model (the matrices).

    alpha1, alpha2 : layer thicknesses over R (upper = outer layer 1, lower = inner layer 2);
        ``alpha2=None`` means equal layers.
    beta : opening angle (rad).
    n_modes : number N of arch modes (the model has 5 N generalised coordinates).
    k_t : dimensionless interface (Jenkins / penalty) shear stiffness ``k_t_dim R / E``
        (``k_t_dim`` = shear traction per unit tangential slip, Pa/m).
    static_shape : add the static tip-load shape of the single-layer arch (w_s to the radial
        basis, u_s and w_s' to the axial basis): modal truncation augmentation, makes the
        interface traction near a concentrated tip load converge (clamped-free only).
    n_slip : number of extra piecewise-linear axial ("slip") functions per layer on a uniform
        mesh of ``n_slip`` elements over [0, beta] (0 = pure modal basis).  They let the
        interface traction converge pointwise (shear-lag boundary layers, Goodman-Klumpp limit).
    n_quad : number of interface points (``None`` -> ``max(8, 4 N)`` Gauss-Legendre points when
        ``n_slip == 0``, else 2 Gauss points per slip element).
    damping : modal damping ratio zeta applied to every mode of the *frictionless* structure
        (material damping of the layers, independent of the interface state).
    interface_damping : ``zeta_t``, the damping of the interface (penalty) modes, from a
        dashpot in parallel with every Jenkins element (stick and slip): ``T_visc = c_t s'``
        with ``c_t = 2 zeta_t k_t / omega_max_stuck`` (stiffness-proportional on the
        interface springs).  A stuck mode n gets ``zeta_n ~ zeta_t (omega_n / omega_max) e_n``
        (``e_n``: its share of strain energy in the interface springs), so the structural
        modes are left almost undamped and the fastest (penalty) modes are damped.  It removes
        the undamped ringing of the penalty springs' own modes (an artefact of the
        elastic-stick model: the real stuck interface is rigid), which every stick/slip switch
        excites.  Why parallel and not stick-only, and the measured modal damping:
        docs/model.md.  0 = none (the paper).
    interface_viscosity : ``c_t`` itself (interface traction per unit slip rate, in the
        model's units: tractions / E, lengths / R, time / sqrt(rho R^2 / E)), a dashpot
        coefficient independent of ``k_t`` and ``omega_max``, in place of the rule of
        ``interface_damping`` (give one of the two: ``interface_damping`` must then be 0).
        With the rule, ``c_t = 2 zeta_t k_t / omega_max`` grows with ``k_t`` (``omega_max``
        grows more slowly), and so does the viscous traction in slip; with a fixed ``c_t`` a
        stiffer stick changes only the stick (docs/pipeline.md, the k_t study).  ``None`` =
        use ``interface_damping``.
    bc : end conditions of the arch modes (the paper: clamped-free).
    alpha_modes : thickness of the single layer whose modes are the basis
        (``None`` -> ``(alpha1 + alpha2) / 2``).
    """

    alpha1: float = 0.005
    alpha2: float | None = None
    beta: float = 0.4
    n_modes: int = 3
    k_t: float = 10.0
    static_shape: bool = True
    n_slip: int = 0
    n_quad: int | None = None
    damping: float = 0.0
    interface_damping: float = 0.0
    interface_viscosity: float | None = None
    bc: str = "clamped-free"
    alpha_modes: float | None = None

    def __post_init__(self):
        a1 = check_positive("alpha1", self.alpha1)
        a2 = a1 if self.alpha2 is None else check_positive("alpha2", self.alpha2)
        if a1 >= 0.5 or a2 >= 0.5:
            raise ValueError("alpha1, alpha2 must be < 0.5 (thin layers)")
        beta = check_positive("beta", self.beta)
        if beta >= 2 * math.pi:
            raise ValueError(f"beta must be < 2 pi, got {self.beta!r}")
        n = check_int("n_modes", self.n_modes, 1)
        kt = check_positive("k_t", self.k_t)
        ns = check_int("n_slip", self.n_slip, 0)
        if not isinstance(self.static_shape, (bool, np.bool_)):
            raise ValueError(f"static_shape must be True or False, got {self.static_shape!r}")
        if self.static_shape and self.bc != "clamped-free":
            object.__setattr__(self, "static_shape", False)
        if self.n_quad is None:
            nq = max(8, 4 * n) if ns == 0 else 2 * ns
        else:
            nq = check_int("n_quad", self.n_quad, 1)
        object.__setattr__(self, "n_slip", ns)
        zeta = check_nonnegative("damping", self.damping)
        if zeta >= 1.0:
            raise ValueError(f"damping must be < 1 (modal damping ratio), got {self.damping!r}")
        zt = check_nonnegative("interface_damping", self.interface_damping)
        if zt > 10.0:
            raise ValueError("interface_damping must be <= 10 (damping ratio of the stiffest "
                             f"stuck-interface mode), got {self.interface_damping!r}")
        object.__setattr__(self, "interface_damping", zt)
        if self.interface_viscosity is not None:
            ct = check_nonnegative("interface_viscosity", self.interface_viscosity)
            if ct > 10.0:
                raise ValueError("interface_viscosity must be <= 10 (c_t, interface traction per "
                                 f"unit slip rate), got {self.interface_viscosity!r}")
            if zt > 0:
                raise ValueError("give only one of interface_damping (> 0) and interface_viscosity "
                                 f"(got interface_damping={zt!r}, interface_viscosity={ct!r}); set "
                                 "interface_viscosity: null to use interface_damping, or "
                                 "interface_damping: 0 to use interface_viscosity")
            object.__setattr__(self, "interface_viscosity", ct)
        if self.bc not in BCS:
            raise ValueError(f"bc must be one of {BCS}, got {self.bc!r}")
        am = basis_thickness(a1, a2, None if self.alpha_modes is None
                             else check_positive("alpha_modes", self.alpha_modes))
        set_fields(self, alpha1=a1, alpha2=a2, beta=beta, n_modes=n, k_t=kt, n_quad=nq,
                   damping=zeta, alpha_modes=am)


def basis_thickness(alpha1: float, alpha2: float, alpha_modes: float | None = None) -> float:
    """Thickness / R of the single-layer arch whose modes are the Galerkin basis:
    ``alpha_modes`` if given, else the mean layer ``(alpha1 + alpha2) / 2``."""
    return 0.5 * (alpha1 + alpha2) if alpha_modes is None else alpha_modes


#: modes supplied from outside (the workflow's per-geometry cache), keyed by
#: (alpha, beta, bc); a set with more modes than asked for is sliced
_REGISTERED_MODES: dict = {}


def register_modes(modes) -> None:
    """Make :func:`single_layer_modes` use ``modes`` (an :class:`beamsim.modes.ArchModes`, e.g.
    read from the workflow's cache ``results/modes/<key>/modes.parquet``) instead of computing
    the same ``n_modes`` modes of the same geometry."""
    key = (float(modes.alpha), float(modes.beta), modes.bc, int(modes.n_modes))
    if key not in _REGISTERED_MODES:
        _REGISTERED_MODES[key] = modes
        single_layer_modes.cache_clear()


@functools.lru_cache(maxsize=64)
def single_layer_modes(alpha: float, beta: float, n_modes: int, bc: str = "clamped-free"):
    """:func:`beamsim.modes.arch_modes` for a single layer of thickness ``alpha R``, memoised;
    modes registered with :func:`register_modes` for the same geometry and the same ``n_modes``
    are used instead of computing them.  Never a larger registered set's first ``n_modes``:
    :func:`~beamsim.modes.arch_modes` brackets its roots with a Ritz mesh that depends on the
    number of modes asked for, so those agree with the ``n_modes`` set to rounding only, and a
    point's result would depend on which other mode files its process had registered (a grid
    with ``n_modes`` on an axis: on the chunk's other points; docs/reliability.md, "Arch
    modes by their count")."""
    from beamsim.modes import arch_modes

    reg = _REGISTERED_MODES.get((float(alpha), float(beta), bc, int(n_modes)))
    if reg is not None:
        return reg
    return arch_modes(alpha, beta, n_modes, bc=bc)


def pressure_at(theta: np.ndarray, p: float, p_profile=None) -> np.ndarray:
    """Interlayer pressure ``p(theta_j) = p * profile(theta_j)`` at the interface points.

    ``p_profile`` is ``None`` (uniform), a callable of theta (array -> array) or an array of
    values at the interface points.  The result must be finite and >= 0.
    """
    p = check_nonnegative("p", p)
    if p_profile is None:
        shape = np.ones_like(theta)
    elif callable(p_profile):
        shape = np.asarray(p_profile(np.asarray(theta)), dtype=float) * np.ones_like(theta)
    else:
        shape = np.asarray(p_profile, dtype=float)
        if shape.shape != theta.shape:
            raise ValueError(f"p_profile must have one value per interface point ({theta.size}), "
                             f"got shape {shape.shape}")
    if not np.all(np.isfinite(shape)):
        raise ValueError("p_profile must be finite")
    if np.any(shape < 0):
        raise ValueError("p_profile must be >= 0 (interlayer pressure cannot be negative)")
    return p * shape


# --------------------------------------------------------------------------- model
@dataclass
class TwoLayerModel:
    """Galerkin matrices of the two-layer curved beam (see module docstring and docs/model.md)."""

    geom: Geometry
    modes: object = field(repr=False)
    M: np.ndarray = field(repr=False)
    K: np.ndarray = field(repr=False)
    C: np.ndarray = field(repr=False)
    S: np.ndarray = field(repr=False)
    theta_q: np.ndarray = field(repr=False)
    wq: np.ndarray = field(repr=False)
    g: np.ndarray = field(repr=False)
    tip: np.ndarray = field(repr=False)
    #: viscous interface traction per unit slip rate (``interface_viscosity``, or the dashpot
    #: rule of ``interface_damping``);
    #: ``C = C_struct + c_t S^T diag(wq) S``
    c_t: float = 0.0
    C_struct: np.ndarray | None = field(default=None, repr=False)
    #: the axial coordinates' basis: ``u_i = (axial_T^T B(theta))^T d_i``, ``B`` the enriched
    #: axial shapes of :func:`_basis` (orthonormalised in :func:`build_model`)
    axial_T: np.ndarray | None = field(default=None, repr=False)

    # ---- sizes / names
    @property
    def n(self) -> int:
        return self.M.shape[0]

    @property
    def n_quad(self) -> int:
        return self.S.shape[0]

    @property
    def coord_names(self) -> list[str]:
        N = self.geom.n_modes
        names = [f"a{i+1}" for i in range(N)] + (["a_static"] if self.geom.static_shape else [])
        m = (self.n - len(names)) // 2
        for lay in (1, 2):
            names += [f"d{lay}_{i+1}" for i in range(m)]
        return names

    # ---- derived matrices
    @property
    def K_interface(self) -> np.ndarray:
        """``k_t S^T diag(wq) S``: stiffness of the stuck (elastic) interface."""
        return self.geom.k_t * (self.S.T * self.wq) @ self.S

    @property
    def K_stuck(self) -> np.ndarray:
        return self.K + self.K_interface

    @functools.cached_property
    def eig_frictionless(self) -> tuple[np.ndarray, np.ndarray]:
        """(lam, Phi) of ``K Phi = lam M Phi`` (free sliding, no interface traction)."""
        return sla.eigh(self.K, self.M)

    @functools.cached_property
    def eig_stuck(self) -> tuple[np.ndarray, np.ndarray]:
        """(lam, Phi) with the elastic interface everywhere stuck (penalty ``k_t``)."""
        return sla.eigh(self.K_stuck, self.M)

    def stuck_decay_rate(self, rigid: bool = False) -> float:
        """Slowest decay rate [1 / time unit] of the free vibration of the everywhere-stuck beam:
        ``-max_k Re lambda_k`` over the eigenvalues of ``[[0, I], [-M^-1 K_P, -M^-1 C_P]]``, with
        the elastic stick ``K_P = K_stuck``, ``C_P = C`` (structural damping and the interface
        dashpot), or with ``rigid`` the slip constrained to zero (the rigid stick: ``K``, ``M``
        and the structural damping on the null space of ``S``; a rigidly stuck dashpot does not
        move).  ``0`` when a mode is undamped: no damping at all, or a stuck mode's modal
        damping ``phi_k^T C_P phi_k`` at or below ``1e-13`` of the largest (a mode that deforms
        no damped element, whose eigenvalue's real part is then rounding; a safeguard, not a
        proof: the form's rounding and the dashpot's smallest share, which falls as ``1 /
        k_t^2``, are in docs/classification.md, rule 3).

        While every element stays stuck the beam is linear with constant coefficients, so its
        largest Lyapunov exponent is ``-stuck_decay_rate`` exactly, and when that is negative
        the free vibration left by the transient decays onto the forced response: the record's
        attractor is that response, of the forcing period."""
        if rigid:
            Z = sla.null_space(self.S)
            Mp, Kp = Z.T @ self.M @ Z, Z.T @ self.K @ Z
            Cs = self.C_struct if self.C_struct is not None else np.zeros_like(self.M)
            Cp = Z.T @ Cs @ Z
        else:
            Mp, Kp, Cp = self.M, self.K_stuck, self.C
        if not np.any(Cp):
            return 0.0
        # M-orthonormal undamped stuck modes
        phi = sla.eigh(Kp, Mp)[1] if rigid else self.eig_stuck[1]
        modal = np.einsum("ak,ab,bk->k", phi, Cp, phi)
        if modal.min() <= 1e-13 * modal.max():
            return 0.0
        return max(0.0, -float(np.linalg.eigvals(first_order_matrix(Mp, Kp, Cp)).real.max()))

    def eig_bonded_rigid(self) -> np.ndarray:
        """Eigenvalues with the slip constrained to zero at every interface point (k_t -> inf)."""
        Z = sla.null_space(self.S)
        return sla.eigh(Z.T @ self.K @ Z, Z.T @ self.M @ Z, eigvals_only=True)

    @property
    def omega1_stuck(self) -> float:
        """First natural angular frequency of the stuck (bonded, penalty) beam."""
        return float(math.sqrt(self.eig_stuck[0][0]))

    @functools.cached_property
    def omega1_bonded_rigid(self) -> float:
        """First natural angular frequency with the slip constrained to zero everywhere."""
        return float(math.sqrt(self.eig_bonded_rigid()[0]))

    @property
    def omega_max_stuck(self) -> float:
        """Largest natural angular frequency of the stuck system (sets the explicit RK4 step)."""
        return float(math.sqrt(self.eig_stuck[0][-1]))

    @property
    def omega_max_frictionless(self) -> float:
        return float(math.sqrt(self.eig_frictionless[0][-1]))

    @functools.cached_property
    def static_unit(self) -> tuple[np.ndarray, np.ndarray]:
        """Static stuck response to a unit tip force F = +1: (q, interface tractions tau_j)."""
        q = np.linalg.solve(self.K_stuck, self.g)
        return q, self.geom.k_t * (self.S @ q)

    @functools.cached_property
    def static_unit_frictionless(self) -> np.ndarray:
        return np.linalg.solve(self.K, self.g)

    @functools.cached_property
    def static_unit_rigid(self) -> tuple[np.ndarray, np.ndarray]:
        """Static response to a unit tip force with the interface rigidly stuck (``S q = 0``)
        from an unloaded interface: (q, tractions tau_j).  The tractions lie in
        ``range(S)`` (no locked-in part: the limit ``k_t -> inf`` of :attr:`static_unit`)."""
        Z = sla.null_space(self.S)
        q = Z @ np.linalg.solve(Z.T @ self.K @ Z, Z.T @ self.g)
        # S^T W tau = g - K q with tau = S xi
        xi = np.linalg.lstsq((self.S.T * self.wq) @ self.S, self.g - self.K @ q, rcond=None)[0]
        return q, self.S @ xi

    def f_cr(self, mu_s: float, p: float, p_profile=None, rigid: bool = False) -> float:
        """Static initial-slip amplitude: the smallest ``f0`` for which the peak load ``2 f0`` of
        ``F = f0 (cos tau - 1)`` makes the bonded (stuck) interface traction reach
        ``mu_s p(theta)`` somewhere.  Linear in ``mu_s p``.  ``rigid``: the rigid stick's
        tractions (:attr:`static_unit_rigid`) instead of the penalty's.
        """
        mu_s = check_nonnegative("mu_s", mu_s)
        pj = pressure_at(self.theta_q, p, p_profile)
        tau = np.abs((self.static_unit_rigid if rigid else self.static_unit)[1])
        with np.errstate(divide="ignore"):
            ratio = np.where(tau > 0, mu_s * pj / np.where(tau > 0, tau, 1.0), np.inf)
        return float(0.5 * ratio.min())

    def displacements(self, q, theta) -> np.ndarray:
        """The displacement fields of generalised coordinates ``q`` at angles ``theta`` [rad]:
        rows ``w`` (radial, shared), ``u1``, ``u2`` (the layers' centroid axial displacements),
        units R; shape ``(3, len(theta))``, or ``(3, len(theta), k)`` for ``q`` of shape
        ``(n, k)`` (one field per column).  (The interface slip is ``S @ q`` at ``theta_q``.)"""
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        W0, _, _, B0, _ = _basis(self.modes, th, self.geom.n_slip, self.geom.static_shape)
        B0 = self.axial_T.T @ B0
        q = np.asarray(q, dtype=float)
        nw, m = W0.shape[0], B0.shape[0]
        return np.stack([W0.T @ q[:nw], B0.T @ q[nw:nw + m], B0.T @ q[nw + m:nw + 2 * m]])

    def mechanical_energy(self, q, v, z=None) -> float:
        e = 0.5 * v @ self.M @ v + 0.5 * q @ self.K @ q
        if z is not None:
            r = self.S @ q - z
            e += 0.5 * self.geom.k_t * np.sum(self.wq * r * r)
        return float(e)


def first_order_matrix(M: np.ndarray, K: np.ndarray, C: np.ndarray) -> np.ndarray:
    """``[[0, I], [-M^-1 K, -M^-1 C]]``: ``M q'' + C q' + K q = 0`` as ``x' = A x`` with
    ``x = (q, q')``."""
    m = M.shape[0]
    A = np.zeros((2 * m, 2 * m))
    A[:m, m:] = np.eye(m)
    A[m:, :m] = -np.linalg.solve(M, K)
    A[m:, m:] = -np.linalg.solve(M, C)
    return A


def _hats(theta, beta, ns):
    """Piecewise-linear functions on ns uniform elements, nodes k beta/ns, k = 1..ns
    (zero at the clamped end), and their derivatives."""
    if ns == 0:
        return np.zeros((0, theta.size)), np.zeros((0, theta.size))
    d = beta / ns
    x = theta[None, :] / d - np.arange(1, ns + 1)[:, None]     # 0 at node k
    h0 = np.clip(1.0 - np.abs(x), 0.0, None)
    h1 = np.where((x > -1.0) & (x <= 0.0), 1.0 / d, np.where((x > 0.0) & (x < 1.0), -1.0 / d, 0.0))
    return h0, h1


def static_tip_shape(theta, alpha, beta):
    """Static response (w, w', w'', u, u') of a clamped-free single-layer arch (thickness
    alpha R) to a unit tip force in the load direction ``cos(beta) e_r - sin(beta) e_theta``
    (closed form of the equilibrium equations of the energy V; docs/model.md)."""
    th = np.asarray(theta, dtype=float)
    k2 = alpha * alpha / 12.0
    c1 = math.sin(beta) / k2
    c2 = 0.5 * (1.0 / k2 + 1.0)
    s, c = np.sin(th), np.cos(th)
    w = (c1 * (1.0 - c) - c2 * (s - th * c)) / alpha
    w1 = (c1 * s - c2 * th * s) / alpha
    w2 = (c1 * c - c2 * (s + th * c)) / alpha
    e = -s / alpha                                   # membrane strain w + u'
    iw = (c1 * (th - s) - c2 * (2.0 - 2.0 * c - th * s)) / alpha
    u = -(1.0 - c) / alpha - iw
    u1 = e - w
    return w, w1, w2, u, u1


def _basis(modes, theta, ns=0, static=False):
    """Shapes at theta: radial basis [W_n; w_s] with derivatives 0..2, and the axial basis
    B = [U_n; W_n'; u_s; w_s'; hats] with its derivative B'."""
    W0, W1, W2 = modes.W(theta, 0), modes.W(theta, 1), modes.W(theta, 2)
    U0, U1 = modes.U(theta, 0), modes.U(theta, 1)
    h0, h1 = _hats(theta, modes.beta, ns)
    if static:
        if modes.bc != "clamped-free":
            raise ValueError("static_shape=True needs bc='clamped-free'")
        ws, ws1, ws2, us, us1 = static_tip_shape(theta, modes.alpha, modes.beta)
        sc = 1.0 / abs(static_tip_shape(np.array([modes.beta]), modes.alpha, modes.beta)[0][0])
        ws, ws1, ws2, us, us1 = (x * sc for x in (ws, ws1, ws2, us, us1))
        W0, W1, W2 = np.vstack([W0, ws]), np.vstack([W1, ws1]), np.vstack([W2, ws2])
        return (W0, W1, W2, np.vstack([U0, W1, us[None, :], h0]),
                np.vstack([U1, W2, us1[None, :], h1]))
    return W0, W1, W2, np.vstack([U0, W1, h0]), np.vstack([U1, W2, h1])


@functools.lru_cache(maxsize=64)
def build_model(geom: Geometry) -> TwoLayerModel:
    """Assemble M, K, C, S, g and the tip rows for ``geom`` (cached)."""
    from beamsim.modes import gauss_legendre

    N = geom.n_modes
    a1, a2, beta = geom.alpha1, geom.alpha2, geom.beta
    modes = single_layer_modes(geom.alpha_modes, beta, N, geom.bc)

    ns = geom.n_slip
    panels = max(8, 2 * N) if ns == 0 else ns * max(1, -(-16 // ns))
    th, w = gauss_legendre(0.0, beta, max(400, 40 * N, 6 * panels), panels=panels)
    st = geom.static_shape
    W0, W1, W2, B0, B1 = _basis(modes, th, ns, st)
    Nw = W0.shape[0]
    # orthonormalise the enriched axial basis span{U_n, W_n'} (it is nearly linearly
    # dependent for larger N); directions whose eigenvalue of the diagonally scaled Gram matrix
    # is < AXIAL_RTOL are dropped (none for N <= 6)
    G = (B0 * w) @ B0.T + beta**2 * (B1 * w) @ B1.T
    dsc = 1.0 / np.sqrt(np.diag(G))
    lg, Vg = np.linalg.eigh(G * dsc[:, None] * dsc[None, :])
    keep = lg > AXIAL_RTOL * lg.max()
    T = (dsc[:, None] * Vg[:, keep]) / np.sqrt(lg[keep])
    B0, B1 = T.T @ B0, T.T @ B1
    m = B0.shape[0]
    n = Nw + 2 * m
    ia = slice(0, Nw)
    iu1 = slice(Nw, Nw + m)
    iu2 = slice(Nw + m, Nw + 2 * m)

    M = np.zeros((n, n))
    M[ia, ia] = (a1 + a2) * (W0 * w) @ W0.T
    Bm = (B0 * w) @ B0.T
    M[iu1, iu1] = a1 * Bm
    M[iu2, iu2] = a2 * Bm

    K = np.zeros((n, n))
    for alpha_i, iu in ((a1, iu1), (a2, iu2)):
        k2 = alpha_i**2 / 12.0
        idx = np.r_[np.arange(Nw), np.arange(n)[iu]]
        eps = np.vstack([W0, B1])           # d(w + u')/dq on [a, d_i]
        kap = np.vstack([W2, -B1])          # d(w'' - u')/dq
        Ki = alpha_i * ((eps * w) @ eps.T + k2 * (kap * w) @ kap.T)
        K[np.ix_(idx, idx)] += Ki
    M = 0.5 * (M + M.T)
    K = 0.5 * (K + K.T)

    # interface points
    if ns == 0:
        xg, wg = np.polynomial.legendre.leggauss(geom.n_quad)
        theta_q = 0.5 * beta * (xg + 1.0)
        wq = 0.5 * beta * wg
    else:
        theta_q, wq = gauss_legendre(0.0, beta, geom.n_quad, panels=ns)
        if theta_q.size != geom.n_quad:
            raise ValueError(f"n_quad must be a multiple of n_slip ({ns}), got {geom.n_quad}")
    Wq0, Wq1, _, Bq0, _ = _basis(modes, theta_q, ns, st)
    Bq0 = T.T @ Bq0
    S = np.zeros((geom.n_quad, n))
    S[:, ia] = 0.5 * (a1 + a2) * Wq1.T
    S[:, iu1] = (1.0 - 0.5 * a1) * Bq0.T
    S[:, iu2] = -(1.0 + 0.5 * a2) * Bq0.T

    # tip
    tb = np.array([beta])
    Wt0, _, _, Bt0, _ = _basis(modes, tb, ns, st)
    Bt0 = T.T @ Bt0
    tip = np.zeros((4, n))
    tip[0, ia] = Wt0[:, 0]
    tip[1, iu1] = Bt0[:, 0]
    tip[2, iu2] = Bt0[:, 0]
    g = math.cos(beta) * tip[0] - math.sin(beta) * tip[1]
    tip[3] = g

    # modal damping on the frictionless structure
    if geom.damping > 0:
        lam0, Phi0 = sla.eigh(K, M)
        om0 = np.sqrt(np.maximum(lam0, 0.0))
        MP = M @ Phi0
        C = (MP * (2.0 * geom.damping * om0)) @ MP.T
        C = 0.5 * (C + C.T)
    else:
        C = np.zeros((n, n))
    C_struct = C
    c_t = 0.0
    if geom.interface_viscosity is not None:
        c_t = geom.interface_viscosity
    elif geom.interface_damping > 0:
        KI = (S.T * (geom.k_t * wq)) @ S
        om_max = math.sqrt(max(sla.eigh(K + KI, M, eigvals_only=True)[-1], 0.0))
        c_t = 2.0 * geom.interface_damping * geom.k_t / om_max
    if c_t > 0:
        CI = (S.T * (c_t * wq)) @ S
        C = C_struct + 0.5 * (CI + CI.T)
    return TwoLayerModel(geom=geom, modes=modes, M=M, K=K, C=C, S=S, theta_q=theta_q, wq=wq,
                         g=g, tip=tip, c_t=c_t, C_struct=C_struct, axial_T=T)

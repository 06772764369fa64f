r"""In-plane free vibration modes of a thin circular arch (paper eqs 1-18).

Model
-----
A circular arch of radius ``R``, opening angle ``beta`` (rad), thickness ``h``
(rectangular section), Young's modulus ``E`` and density ``rho`` is described by
the radial displacement ``w(theta)`` and the tangential displacement
``u(theta)``, both scaled by ``R``.  With ``alpha = h/R`` and
``k^2 = alpha^2/12`` (``= I/(A R^2)``) the strain and kinetic energies are

.. math::

    V = \frac{EA}{2R}\int_0^\beta \left[(w + u')^2 + k^2 (w'' - u')^2\right] d\theta,
    \qquad
    T = \frac{\rho A R^3}{2}\int_0^\beta (\dot w^2 + \dot u^2)\, d\theta ,

(primes are ``d/dtheta``; ``w + u'`` is the membrane strain, ``(w'' - u')/R``
the change of curvature).  Hamilton's principle gives the paper's eqs (7) and
(10); for harmonic motion at angular frequency ``omega`` with the dimensionless
eigenvalue

.. math::  \lambda = \omega^2 \rho R^2 / E

they read

.. math::

    k^2 (u''' - w'''') - (u' + w) + \lambda w = 0, \qquad
    k^2 (u'' - w''') + (u'' + w') + \lambda u = 0 .

The boundary terms give the end conditions: clamped ``w = w' = u = 0``;
pinned ``w = u = 0`` and zero moment ``w'' - u' = 0``; free (natural)
``w'' - u' = 0``, ``w''' - u'' = 0`` and ``(w + u') - k^2 (w'' - u') = 0``.

How the eigenvalues are found
-----------------------------
Written as a first-order system on the state ``y = (w, w', w'', w''', u, u')``,
``y' = A(lambda) y`` with constant ``A``; the transfer matrix over the arch is
``expm(A beta)``.  The characteristic function is the 3x3 determinant
``det(B1 expm(A beta) N0)`` (``N0`` spans the states allowed at ``theta = 0``,
``B1`` are the three conditions at ``theta = beta``).  It is evaluated with the
compound-matrix method (the third exterior power of ``expm(A beta)``, i.e.
``expm(beta A^[3])`` on the 20 Pluecker coordinates), which avoids the
cancellation that ruins the naive 3x3 determinant when ``|s| beta`` is large,
and it is divided by ``exp(beta * (sum of the three largest Re s))`` -- a
positive factor, so roots and signs are unchanged.  This formulation does not
care which kind of roots the sextic (paper eq 16) has (the paper's
sin/cos/sinh/cosh form of eqs 17-18 is wrong when the cubic in ``s^2`` has a
complex pair, e.g. the clamped-free fundamental for beta > ~53 deg).

A root search over a scan can miss two roots that fall into one scan cell.  To
make a skipped mode impossible to miss silently, the eigenvalues are first
bracketed with a Rayleigh-Ritz model (conforming Hermite-cubic elements in
``theta`` for ``w`` and ``u``; Ritz eigenvalues are upper bounds and give the
mode count), then each root is refined with Brent's method on the exact
characteristic function inside its own bracket, and finally the number of sign
changes of the characteristic function on a fine grid below the last bracket is
checked against the number of modes found.  Any disagreement raises
``RuntimeError``.

Mode shapes
-----------
At an eigenvalue the six roots ``s_j`` and eigenvectors ``v_j`` of ``A`` give
``y(theta) = sum_j c_j v_j exp(s_j (theta - theta_j))`` with ``theta_j = beta``
for ``Re s_j > 0`` and ``0`` otherwise, so every exponential is bounded by 1 on
the arch and the 6x6 boundary matrix is well conditioned.  ``c`` is its null
vector (SVD).  Any derivative is then exact:
``w^(d) = Re sum_j c_j v_j[0] s_j^d exp(...)``.  Shapes are normalised so that
``int_0^beta (W_m W_n + U_m U_n) dtheta = delta_mn`` (mass normalisation in
units of ``rho A R^3``), with the sign chosen so that the largest-magnitude
radial value is positive.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import scipy.linalg as sla

BoundaryCondition = Literal["clamped-free", "clamped-clamped", "pinned-pinned"]
BOUNDARY_CONDITIONS: tuple[str, ...] = ("clamped-free", "clamped-clamped", "pinned-pinned")

_TRIPLES: list[tuple[int, int, int]] = list(itertools.combinations(range(6), 3))
_TRIPLE_INDEX = {t: i for i, t in enumerate(_TRIPLES)}


# --------------------------------------------------------------------------- input checks
def _check_geometry(alpha: float, beta: float) -> tuple[float, float]:
    try:
        alpha = float(alpha)
        beta = float(beta)
    except (TypeError, ValueError) as exc:  # pragma: no cover - message only
        raise ValueError(f"alpha and beta must be real numbers: {exc}") from None
    if not math.isfinite(alpha) or not (0.0 < alpha < 1.0):
        raise ValueError(f"alpha must satisfy 0 < alpha < 1 (alpha = h/R), got {alpha!r}")
    if not math.isfinite(beta) or not (0.0 < beta < 2.0 * math.pi):
        raise ValueError(f"beta must satisfy 0 < beta < 2*pi (opening angle in rad), got {beta!r}")
    return alpha, beta


def _check_n_modes(n_modes: int) -> int:
    if isinstance(n_modes, bool) or not isinstance(n_modes, (int, np.integer)):
        raise ValueError(f"n_modes must be an integer >= 1, got {n_modes!r}")
    if n_modes < 1:
        raise ValueError(f"n_modes must be an integer >= 1, got {n_modes!r}")
    return int(n_modes)


def _check_bc(bc: str) -> tuple[str, str]:
    if bc not in BOUNDARY_CONDITIONS:
        raise ValueError(f"bc must be one of {', '.join(BOUNDARY_CONDITIONS)}; got {bc!r}")
    left, right = bc.split("-")
    return left, right


# --------------------------------------------------------------------------- the ODE system
def system_matrix(lam: float, k2: float) -> np.ndarray:
    """First-order system matrix ``A`` with ``y' = A y``, ``y = (w, w', w'', w''', u, u')``.

    From eq (10): ``u'' = (k^2 w''' - w' - lam u) / (1 + k^2)``;
    from eq (7):  ``w'''' = -(w'' + lam u') - (1 + k^2) (u' + (1 - lam) w) / k^2``.
    """
    a = np.zeros((6, 6))
    a[0, 1] = a[1, 2] = a[2, 3] = 1.0
    a[3, 0] = -(1.0 + k2) * (1.0 - lam) / k2
    a[3, 2] = -1.0
    a[3, 5] = -lam - (1.0 + k2) / k2
    a[4, 5] = 1.0
    a[5, 1] = -1.0 / (1.0 + k2)
    a[5, 3] = k2 / (1.0 + k2)
    a[5, 4] = -lam / (1.0 + k2)
    return a


def system_matrix_strain(lam: float, k2: float) -> np.ndarray:
    """System matrix on the well-scaled state ``z = (w, w', w'', w''', u, e)``, ``e = (u' + w) / k^2``.

    The membrane strain ``u' + w`` is ``O(k^2)`` in bending-dominated motion, and on the
    state ``y`` of :func:`system_matrix` the matrix has entries ``~1/k^2`` although its
    eigenvalues are ``O(1)``: a strongly non-normal matrix whose exponential loses
    accuracy.  With ``e`` as a state the entries are ``O(1 + lam/k^2)``, the size of the
    roots.  From eqs (7), (10):
    ``e' = (w''' + w' - (lam/k^2) u) / (1 + k^2)``,
    ``w'''' = (lam + (1+k^2) lam/k^2) w - w'' - (lam k^2 + 1 + k^2) e`` and ``u' = k^2 e - w``.
    """
    a = np.zeros((6, 6))
    a[0, 1] = a[1, 2] = a[2, 3] = 1.0
    a[3, 0] = lam + (1.0 + k2) * lam / k2
    a[3, 2] = -1.0
    a[3, 5] = -(lam * k2 + 1.0 + k2)
    a[4, 0], a[4, 5] = -1.0, k2
    a[5, 1] = a[5, 3] = 1.0 / (1.0 + k2)
    a[5, 4] = -lam / k2 / (1.0 + k2)
    return a


def strain_state_inverse(k2: float) -> np.ndarray:
    """``P^-1`` with ``y = P^-1 z``: maps ``(w, w', w'', w''', u, e)`` to ``(w, ..., u, u')``."""
    p_inv = np.eye(6)
    p_inv[5, 5], p_inv[5, 0] = k2, -1.0
    return p_inv


def end_conditions(kind: str, lam: float, k2: float) -> np.ndarray:
    """Rows ``B`` (3x6) with ``B y = 0`` at an end of the given kind (clamped, pinned, free)."""
    b = np.zeros((3, 6))
    if kind == "clamped":  # w = w' = u = 0
        b[0, 0] = b[1, 1] = b[2, 4] = 1.0
    elif kind == "pinned":  # w = u = 0, moment ~ w'' - u' = 0
        b[0, 0] = b[1, 4] = 1.0
        b[2, 2], b[2, 5] = 1.0, -1.0
    elif kind == "free":
        b[0, 2], b[0, 5] = 1.0, -1.0  # moment: w'' - u' = 0
        # shear: w''' - u'' = 0 with u'' from eq (10)
        b[1, 1], b[1, 3], b[1, 4] = 1.0, 1.0, lam
        b[1] /= 1.0 + k2
        # N - M/R-type condition: (w + u') - k^2 (w'' - u') = 0
        b[2, 0], b[2, 2], b[2, 5] = 1.0, -k2, 1.0 + k2
    else:  # pragma: no cover - guarded by _check_bc
        raise ValueError(f"unknown end condition {kind!r}")
    return b


def _compound_basis() -> np.ndarray:
    """Tensor ``G`` (36, 20, 20) with ``A^[3] = sum_rc A[r, c] G[6 r + c]`` (A^[3] is linear in A)."""
    g = np.zeros((36, 20, 20))
    for col, (i, j, k) in enumerate(_TRIPLES):
        base = (i, j, k)
        for pos in range(3):
            for r in range(6):
                idx = list(base)
                idx[pos] = r
                if len(set(idx)) < 3:
                    continue
                # sign of the permutation that sorts idx (count inversions)
                inv = sum(1 for p in range(3) for q in range(p + 1, 3) if idx[p] > idx[q])
                g[6 * r + base[pos], _TRIPLE_INDEX[tuple(sorted(idx))], col] += (-1.0) ** inv
    return g


_COMPOUND_G = _compound_basis()


def _compound3(a: np.ndarray) -> np.ndarray:
    """Additive third compound ``A^[3]`` (20x20): the generator of ``Lambda^3 expm(A t)``."""
    return np.tensordot(a.ravel(), _COMPOUND_G, axes=1)


def _minors3(m: np.ndarray, rows: bool) -> np.ndarray:
    """All 20 3x3 minors of a 6x3 (rows=True) or 3x6 (rows=False) matrix, in ``_TRIPLES`` order."""
    if rows:
        return np.array([np.linalg.det(m[list(t), :]) for t in _TRIPLES])
    return np.array([np.linalg.det(m[:, list(t)]) for t in _TRIPLES])


def _null_space(b: np.ndarray) -> np.ndarray:
    return sla.null_space(b)


def characteristic_determinant(lam, alpha: float, beta: float,
                               bc: BoundaryCondition = "clamped-free") -> np.ndarray | float:
    """Scaled characteristic function ``D(lam)`` of the arch; zero exactly at eigenvalues.

    ``D(lam) = det(B1 expm(A beta) N0) * exp(-beta * sigma(lam))`` evaluated with the
    compound-matrix method, ``sigma`` the sum of the three largest real parts of the
    roots of eq (16).  Real and continuous in ``lam``; simple eigenvalues are sign changes.
    Accepts a scalar or an array of ``lam`` (dimensionless, ``omega^2 rho R^2 / E``).
    """
    alpha, beta = _check_geometry(alpha, beta)
    left, right = _check_bc(bc)
    k2 = alpha * alpha / 12.0
    lam_arr = np.atleast_1d(np.asarray(lam, dtype=float))
    out = np.array([_char_det(float(x), k2, beta, left, right) for x in lam_arr])
    return out if np.ndim(lam) else float(out[0])


def _char_det(lam: float, k2: float, beta: float, left: str, right: str) -> float:
    a = system_matrix_strain(lam, k2)
    p_inv = strain_state_inverse(k2)
    n0 = _null_space(end_conditions(left, lam, k2) @ p_inv)  # 6x3
    # fix the orientation of the null-space basis so D is continuous in lam
    p0 = _minors3(n0, rows=True)
    ref = int(np.argmax(np.abs(p0)))
    p0 = p0 / p0[ref] * np.abs(p0).max()
    sigma = np.sort(np.linalg.eigvals(a).real)[-3:].sum()
    # subtracting sigma*I from the 20x20 generator multiplies by exp(-beta*sigma) > 0
    prop = sla.expm(beta * (_compound3(a) - sigma * np.eye(20)))
    b1 = end_conditions(right, lam, k2) @ p_inv
    return float(_minors3(b1, rows=False) @ (prop @ p0))


# --------------------------------------------------------------------------- Ritz brackets
def _hermite(xi: np.ndarray, he: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cubic Hermite shape functions on [0, 1] scaled to an element of length ``he``.

    Returns N, dN/dtheta, d2N/dtheta2, each (4, len(xi)); dofs (f0, f0', f1, f1').
    """
    n = np.array([1 - 3 * xi**2 + 2 * xi**3, he * (xi - 2 * xi**2 + xi**3),
                  3 * xi**2 - 2 * xi**3, he * (-xi**2 + xi**3)])
    d1 = np.array([-6 * xi + 6 * xi**2, he * (1 - 4 * xi + 3 * xi**2),
                   6 * xi - 6 * xi**2, he * (-2 * xi + 3 * xi**2)]) / he
    d2 = np.array([-6 + 12 * xi, he * (-4 + 6 * xi), 6 - 12 * xi, he * (-2 + 6 * xi)]) / he**2
    return n, d1, d2


def ritz_eigenvalues(alpha: float, beta: float, bc: BoundaryCondition, n_elements: int,
                     n_values: int) -> np.ndarray:
    """Rayleigh-Ritz (conforming Hermite-cubic FE in theta) upper bounds on the eigenvalues.

    Used only to bracket and count the exact roots; the reported eigenvalues come from
    the characteristic function.
    """
    alpha, beta = _check_geometry(alpha, beta)
    left, right = _check_bc(bc)
    k2 = alpha * alpha / 12.0
    he = beta / n_elements
    xg, wg = np.polynomial.legendre.leggauss(6)
    xi, wq = 0.5 * (xg + 1.0), 0.5 * wg * he
    n, d1, d2 = _hermite(xi, he)
    z = np.zeros_like(n)
    # element dofs: (w0, w0', u0, u0', w1, w1', u1, u1')
    wmap = [0, 1, 4, 5]
    umap = [2, 3, 6, 7]
    bw, bu = np.zeros((8, xi.size)), np.zeros((8, xi.size))
    bw[wmap], bu[umap] = n, n
    bup, bwpp = z.repeat(2, 0), z.repeat(2, 0)
    bup[umap], bwpp[wmap] = d1, d2
    eps = bw + bup  # membrane strain w + u'
    kap = bwpp - bup  # curvature w'' - u'
    ke = (eps * wq) @ eps.T + k2 * (kap * wq) @ kap.T
    me = (bw * wq) @ bw.T + (bu * wq) @ bu.T
    ndof = 4 * (n_elements + 1)
    kg = np.zeros((ndof, ndof))
    mg = np.zeros((ndof, ndof))
    for e in range(n_elements):
        sl = slice(4 * e, 4 * e + 8)
        kg[sl, sl] += ke
        mg[sl, sl] += me
    fixed: list[int] = []
    for kind, node in ((left, 0), (right, n_elements)):
        if kind == "clamped":
            fixed += [4 * node, 4 * node + 1, 4 * node + 2]
        elif kind == "pinned":
            fixed += [4 * node, 4 * node + 2]
    keep = np.setdiff1d(np.arange(ndof), fixed)
    vals = sla.eigh(kg[np.ix_(keep, keep)], mg[np.ix_(keep, keep)], eigvals_only=True,
                    subset_by_index=[0, min(n_values, keep.size) - 1])
    return vals


# --------------------------------------------------------------------------- result object
@dataclass(frozen=True)
class ArchModes:
    """Mass-normalised in-plane modes of a circular arch.

    Attributes
    ----------
    alpha, beta, bc : geometry (``alpha = h/R``, ``beta`` opening angle in rad) and end conditions.
    lam : (n,) ascending dimensionless eigenvalues ``lam_n = omega_n^2 rho R^2 / E``.
    roots, theta_ref, coef_w, coef_u : (n, 6) spectral representation of each mode:
        ``W^(d)(theta) = Re sum_j coef_w[n, j] roots[n, j]^d exp(roots[n, j] (theta - theta_ref[n, j]))``
        and the same with ``coef_u`` for ``U``.
    """

    alpha: float
    beta: float
    bc: str
    lam: np.ndarray
    roots: np.ndarray = field(repr=False)
    theta_ref: np.ndarray = field(repr=False)
    coef_w: np.ndarray = field(repr=False)
    coef_u: np.ndarray = field(repr=False)

    @property
    def n_modes(self) -> int:
        return int(self.lam.size)

    def truncated(self, n_modes: int) -> "ArchModes":
        """The first ``n_modes`` modes (``1 <= n_modes <= self.n_modes``)."""
        n = _check_n_modes(n_modes)
        if n > self.n_modes:
            raise ValueError(f"n_modes must be <= {self.n_modes} (modes available), got {n}")
        return ArchModes(alpha=self.alpha, beta=self.beta, bc=self.bc, lam=self.lam[:n], roots=self.roots[:n],
                         theta_ref=self.theta_ref[:n], coef_w=self.coef_w[:n], coef_u=self.coef_u[:n])

    @property
    def k2(self) -> float:
        """``k^2 = alpha^2 / 12``."""
        return self.alpha**2 / 12.0

    @property
    def omega(self) -> np.ndarray:
        """Dimensionless angular frequencies ``sqrt(lam)`` (units of ``sqrt(E / (rho R^2))``)."""
        return np.sqrt(self.lam)

    @property
    def frequency_ratios(self) -> np.ndarray:
        """``f_n / f_1 = sqrt(lam_n / lam_1)``."""
        return np.sqrt(self.lam / self.lam[0])

    def _eval(self, coef: np.ndarray, theta, d: int) -> np.ndarray:
        if isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 0:
            raise ValueError(f"d (derivative order) must be an integer >= 0, got {d!r}")
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        if not np.all(np.isfinite(th)) or th.min() < -1e-12 or th.max() > self.beta + 1e-12:
            raise ValueError(f"theta must lie in [0, beta] = [0, {self.beta}]")
        ex = np.exp(self.roots[:, :, None] * (th[None, None, :] - self.theta_ref[:, :, None]))
        return np.einsum("nj,njt->nt", coef * self.roots**d, ex).real

    def W(self, theta, d: int = 0) -> np.ndarray:
        """``d``-th theta-derivative of the radial shapes, shape ``(n_modes, len(theta))``."""
        return self._eval(self.coef_w, theta, d)

    def U(self, theta, d: int = 0) -> np.ndarray:
        """``d``-th theta-derivative of the tangential shapes, shape ``(n_modes, len(theta))``."""
        return self._eval(self.coef_u, theta, d)

    def mass_matrix(self, n_quad: int = 400) -> np.ndarray:
        """``int_0^beta (W_m W_n + U_m U_n) dtheta`` by Gauss-Legendre quadrature (identity)."""
        th, wq = gauss_legendre(0.0, self.beta, n_quad)
        w, u = self.W(th), self.U(th)
        return (w * wq) @ w.T + (u * wq) @ u.T

    def stiffness_matrix(self, n_quad: int = 400) -> np.ndarray:
        """``int_0^beta [(W_m + U_m')(W_n + U_n') + k^2 (W_m'' - U_m')(W_n'' - U_n')] dtheta``."""
        th, wq = gauss_legendre(0.0, self.beta, n_quad)
        eps = self.W(th) + self.U(th, 1)
        kap = self.W(th, 2) - self.U(th, 1)
        return (eps * wq) @ eps.T + self.k2 * (kap * wq) @ kap.T

    # ---- persistence (the workflow's cache) ----
    def to_table(self):
        """One row per mode: eigenvalue, frequency ratio and the spectral coefficients."""
        import pandas as pd

        rows = []
        for n in range(self.n_modes):
            row = {"mode": n + 1, "lam": self.lam[n], "frequency_ratio": self.frequency_ratios[n]}
            for j in range(6):
                row[f"root_re_{j}"] = self.roots[n, j].real
                row[f"root_im_{j}"] = self.roots[n, j].imag
                row[f"theta_ref_{j}"] = self.theta_ref[n, j]
                row[f"coef_w_re_{j}"] = self.coef_w[n, j].real
                row[f"coef_w_im_{j}"] = self.coef_w[n, j].imag
                row[f"coef_u_re_{j}"] = self.coef_u[n, j].real
                row[f"coef_u_im_{j}"] = self.coef_u[n, j].imag
            rows.append(row)
        return pd.DataFrame(rows)

    @classmethod
    def from_table(cls, table, alpha: float, beta: float, bc: str) -> "ArchModes":
        """Inverse of :meth:`to_table`."""
        def cplx(prefix: str) -> np.ndarray:
            return np.stack([table[f"{prefix}_re_{j}"].to_numpy() + 1j * table[f"{prefix}_im_{j}"].to_numpy()
                             for j in range(6)], axis=1)

        return cls(alpha=float(alpha), beta=float(beta), bc=str(bc),
                   lam=table["lam"].to_numpy(dtype=float),
                   roots=cplx("root"),
                   theta_ref=np.stack([table[f"theta_ref_{j}"].to_numpy() for j in range(6)], axis=1),
                   coef_w=cplx("coef_w"), coef_u=cplx("coef_u"))


def gauss_legendre(a: float, b: float, n: int, panels: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss-Legendre nodes and weights on ``[a, b]`` (``panels`` panels, ``n`` nodes total)."""
    per = max(2, int(math.ceil(n / panels)))
    x, w = np.polynomial.legendre.leggauss(per)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    nodes = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    weights = (half[:, None] * w[None, :]).ravel()
    return nodes, weights


# --------------------------------------------------------------------------- mode shape
def _mode_shape(lam: float, k2: float, beta: float, left: str, right: str):
    a = system_matrix(lam, k2)
    s = np.linalg.eigvals(a).astype(complex)
    # polish the roots of the sextic (paper eq 16) with Newton steps
    poly = np.array([k2, 0.0, 2 * k2 + k2 * lam, 0.0, k2 - k2 * lam - lam, 0.0, lam * (1 - lam)])
    dpoly = np.polyder(poly)
    for _ in range(3):
        step = np.polyval(poly, s) / np.polyval(dpoly, s)
        s = s - np.where(np.isfinite(step), step, 0.0)
    # eigenvectors from the 2x2 amplitude relations of eqs (7) and (10): (C, D) with D = r C
    m11, m12 = -k2 * s**4 - 1.0 + lam, k2 * s**3 - s
    m21, m22 = s - k2 * s**3, (1.0 + k2) * s**2 + lam
    use_first = np.abs(m11) + np.abs(m12) >= np.abs(m21) + np.abs(m22)
    cw = np.where(use_first, m12, m22)
    cu = np.where(use_first, -m11, -m21)
    v = np.array([cw, cw * s, cw * s**2, cw * s**3, cu, cu * s])
    # scale the derivative components by powers of the largest root so that the
    # conditioning check sees genuine root coalescence, not a scale disparity
    sig = np.abs(s).max()
    scale = np.array([1.0, sig, sig**2, sig**3, 1.0, sig])
    vs = v / scale[:, None]
    vs = vs / np.linalg.norm(vs, axis=0)
    v = vs * scale[:, None]
    if np.linalg.cond(vs) > 1e10:
        raise RuntimeError(
            f"mode at lam={lam:.6g} sits on a coalescence of characteristic roots "
            "(eigenvector matrix singular); perturb beta or alpha slightly")
    theta_ref = np.where(s.real > 0.0, beta, 0.0)
    e0 = np.exp(s * (0.0 - theta_ref))
    e1 = np.exp(s * (beta - theta_ref))
    bmat = np.vstack([end_conditions(left, lam, k2) @ (v * e0), end_conditions(right, lam, k2) @ (v * e1)])
    bmat = bmat / np.linalg.norm(bmat, axis=1, keepdims=True)
    _, sv, vh = np.linalg.svd(bmat)
    c = vh[-1].conj()
    if sv[-1] > 1e-6 * sv[0]:
        raise RuntimeError(f"boundary matrix is not singular at lam={lam:.6g} "
                           f"(s_min/s_max={sv[-1]/sv[0]:.2e})")
    coef_w = c * v[0]
    coef_u = c * v[4]
    # make the shape real: rotate the global phase so the largest sample is real
    th = np.linspace(0.0, beta, 257)
    ex = np.exp(s[:, None] * (th[None, :] - theta_ref[:, None]))
    wv = coef_w @ ex
    uv = coef_u @ ex
    both = np.concatenate([wv, uv])
    phase = both[np.argmax(np.abs(both))]
    phase /= abs(phase)
    coef_w, coef_u = coef_w / phase, coef_u / phase
    imag = np.abs(np.concatenate([wv, uv]) / phase).max()
    resid = np.abs((np.concatenate([wv, uv]) / phase).imag).max()
    if resid > 1e-6 * imag:
        raise RuntimeError(f"mode shape at lam={lam:.6g} is not real (imag/real = {resid/imag:.1e})")
    return s, theta_ref, coef_w, coef_u


def arch_modes(alpha: float, beta: float, n_modes: int,
               bc: BoundaryCondition = "clamped-free") -> ArchModes:
    """In-plane modes of a circular arch (paper eqs 1-18; see the module docstring).

    Parameters
    ----------
    alpha : ``h/R``, thickness over radius, ``0 < alpha < 1``.
    beta : opening angle in rad, ``0 < beta < 2 pi``.
    n_modes : number of modes, ``>= 1``.
    bc : ``"clamped-free"`` (clamped at theta = 0, free at theta = beta; the paper's),
        ``"clamped-clamped"`` or ``"pinned-pinned"``.

    Returns
    -------
    ArchModes with ascending ``lam = omega^2 rho R^2 / E`` and mass-normalised shapes.
    """
    alpha, beta = _check_geometry(alpha, beta)
    n_modes = _check_n_modes(n_modes)
    left, right = _check_bc(bc)
    k2 = alpha * alpha / 12.0

    # 1. Ritz brackets (upper bounds) on n_modes + 1 eigenvalues, refined until stable.
    n_el = max(24, 6 * (n_modes + 2))
    ritz = ritz_eigenvalues(alpha, beta, bc, n_el, n_modes + 1)
    for _ in range(4):
        finer = ritz_eigenvalues(alpha, beta, bc, 2 * n_el, n_modes + 1)
        done = np.all(np.abs(finer - ritz) < 1e-4 * finer)
        ritz, n_el = finer, 2 * n_el
        if done:
            break
    from scipy.optimize import brentq  # here, not at the top: slow to import, and the
    # pipeline's jobs read their modes from the cache (beamsim.mode_cache) and never solve

    # 2. bracket each root between midpoints of consecutive Ritz values
    gaps = np.concatenate([[ritz[0]], np.diff(ritz)])
    lam = np.empty(n_modes)

    def f(x: float) -> float:
        return _char_det(x, k2, beta, left, right)

    for n in range(n_modes):
        hi = ritz[n] * (1.0 + 1e-9) + 0.02 * gaps[n + 1] if n + 1 < ritz.size else ritz[n] * 1.01
        hi = min(hi, 0.5 * (ritz[n] + ritz[n + 1]))
        lo = ritz[n] - 0.5 * gaps[n] if n > 0 else 0.5 * ritz[0]
        lo = max(lo, lam[n - 1] * (1.0 + 1e-9)) if n > 0 else lo
        grid = np.linspace(lo, hi, 33)
        vals = np.array([f(x) for x in grid])
        changes = np.nonzero(np.sign(vals[:-1]) * np.sign(vals[1:]) < 0)[0]
        if changes.size != 1:
            raise RuntimeError(
                f"mode {n + 1}: expected exactly one root of the characteristic function in "
                f"[{lo:.6g}, {hi:.6g}] (Ritz estimate {ritz[n]:.6g}), found {changes.size}")
        i = int(changes[0])
        lam[n] = brentq(f, grid[i], grid[i + 1], xtol=1e-15 * grid[i + 1], rtol=1e-14, maxiter=200)
    # 3. global count: sign changes on a fine log grid below the last bracket
    top = 0.5 * (lam[-1] + ritz[n_modes]) if ritz.size > n_modes else lam[-1] * 1.001
    scan = np.geomspace(lam[0] * 0.25, top, 60 * (n_modes + 1))
    scan_vals = np.array([f(x) for x in scan])
    n_changes = int(np.count_nonzero(np.sign(scan_vals[:-1]) * np.sign(scan_vals[1:]) < 0))
    if n_changes != n_modes:
        raise RuntimeError(f"root count check failed: {n_changes} sign changes of the characteristic "
                           f"function below {top:.6g}, but {n_modes} modes bracketed")

    roots = np.empty((n_modes, 6), complex)
    theta_ref = np.empty((n_modes, 6))
    coef_w = np.empty((n_modes, 6), complex)
    coef_u = np.empty((n_modes, 6), complex)
    for n in range(n_modes):
        roots[n], theta_ref[n], coef_w[n], coef_u[n] = _mode_shape(lam[n], k2, beta, left, right)
    modes = ArchModes(alpha=alpha, beta=beta, bc=bc, lam=lam, roots=roots, theta_ref=theta_ref,
                      coef_w=coef_w, coef_u=coef_u)
    # 4. mass normalisation and sign
    th, wq = gauss_legendre(0.0, beta, 400)
    w, u = modes.W(th), modes.U(th)
    norm = np.sqrt((w * w * wq).sum(1) + (u * u * wq).sum(1))
    sign = np.sign(w[np.arange(n_modes), np.argmax(np.abs(w), axis=1)])
    scale = sign / norm
    object.__setattr__(modes, "coef_w", coef_w * scale[:, None])
    object.__setattr__(modes, "coef_u", coef_u * scale[:, None])
    return modes

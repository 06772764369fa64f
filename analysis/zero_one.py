"""The 0-1 test for chaos (correlation method).

References
----------
* G. A. Gottwald, I. Melbourne, "A new test for chaos in deterministic systems",
  Proc. R. Soc. Lond. A 460 (2004) 603-611.
* G. A. Gottwald, I. Melbourne, "On the implementation of the 0-1 test for
  chaos", SIAM J. Appl. Dyn. Syst. 8 (2009) 129-145 (correlation method,
  ``c`` drawn in ``(pi/5, 4 pi/5)``, median over ``c``).
* G. A. Gottwald, I. Melbourne, "The 0-1 test for chaos: a review", in
  *Chaos Detection and Predictability*, Lecture Notes in Physics 915 (2016)
  (oversampled data push K towards 0; sample more coarsely).

Definitions
-----------
For a scalar series ``phi_j`` (``j = 1..N``) and a frequency ``c``, the
translation variables are

.. math::

    p_c(n) = \\sum_{j=1}^{n} \\phi_j \\cos(jc), \\qquad
    q_c(n) = \\sum_{j=1}^{n} \\phi_j \\sin(jc),

with mean square displacement (finite-record version, ``n = 1..n_cut``)

.. math::

    M_c(n) = \\frac{1}{N - n_{cut}} \\sum_{j=1}^{N-n_{cut}}
             \\left[(p_c(j+n) - p_c(j))^2 + (q_c(j+n) - q_c(j))^2\\right].

The oscillatory term ``V_osc = (E phi)^2 (1 - cos nc)/(1 - cos c)`` of the
modified displacement ``D_c = M_c - V_osc`` is removed *exactly* by subtracting
the sample mean of ``phi`` first (then ``E phi = 0``), so ``D_c = M_c``.
``K_c = corr(xi, D_c(xi))`` with ``xi = 1..n_cut`` and the test result is
``K = median_c K_c``: ``K ~ 1`` for chaotic (diffusive, ``M_c ~ n``) and
``K ~ 0`` for regular (bounded ``M_c``) dynamics.

Caveats (documented in docs/classification.md): K converges slowly for
quasi-periodic series with several frequencies (short records can give
intermediate or high K); any additive noise makes ``M_c`` grow linearly, so a
noisy *fixed point* gives ``K ~ 1`` (the classifier's period test decides those);
oversampled flows give ``K`` too low (use ``stride``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ZeroOneResult", "oversampling_stride", "zero_one_test"]

C_RANGE: tuple[float, float] = (np.pi / 5.0, 4.0 * np.pi / 5.0)


@dataclass(frozen=True)
class ZeroOneResult:
    """Outcome of :func:`zero_one_test`.

    Attributes
    ----------
    K
        Median of ``K_c`` over the random ``c`` values (in [-1, 1]; ~0 regular, ~1 chaotic).
    K_c
        Correlation coefficient for each ``c``.
    c
        The frequencies used (uniform in ``c_range``, fixed seed).
    stride
        Subsampling stride applied to the input before the test.
    n_used
        Length of the (subsampled) series.
    n_cut
        Largest displacement lag ``n``.
    """

    K: float
    K_c: NDArray[np.float64]
    c: NDArray[np.float64]
    stride: int
    n_used: int
    n_cut: int


def oversampling_stride(phi: ArrayLike, *, min_length: int = 200) -> int:
    """Decorrelation stride: first lag at which the autocorrelation of ``phi`` is <= 0.

    A series whose consecutive samples are strongly correlated (an oversampled
    flow, or a slowly drifting Poincare series) makes ``p_c, q_c`` look
    regular on short scales and biases K towards 0.  Taking every ``tau``-th
    sample, ``tau`` = first zero of the autocorrelation function (a standard
    decorrelation time), removes this.  ``tau`` is capped so that at least
    ``min_length`` samples remain; a series that never decorrelates within that
    cap (periodic with a long period, constant) gets the cap or 1.
    """
    x = np.asarray(phi, dtype=np.float64).ravel()
    x = x - x.mean()
    n = x.size
    cap = max(1, n // max(min_length, 1))
    if cap == 1 or not np.any(x):
        return 1
    f = np.fft.rfft(x, 2 * n)
    acf = np.fft.irfft(f * np.conj(f))[: cap + 1]
    acf = acf / acf[0]
    below = np.nonzero(acf[1:] <= 0.0)[0]
    if below.size == 0:
        return cap
    return int(min(below[0] + 1, cap))


def zero_one_test(
    phi: ArrayLike,
    *,
    n_c: int = 100,
    c_range: tuple[float, float] = C_RANGE,
    n_cut: int | None = None,
    stride: int | str = 1,
    seed: int = 0,
) -> ZeroOneResult:
    """0-1 test for chaos, correlation method (Gottwald & Melbourne 2009).

    Parameters
    ----------
    phi
        Scalar observable, one value per forcing period (1-D, finite, length >= 20).
    n_c
        Number of random frequencies ``c`` (default 100 as in the 2009 paper).
    c_range
        Open interval for ``c``; ``(pi/5, 4 pi/5)`` avoids resonances at ``c = 0, pi``.
    n_cut
        Largest lag of ``M_c(n)``; default ``N // 10`` (the 2009 recommendation).
    stride
        Subsampling stride, or ``"auto"`` for :func:`oversampling_stride`.
    seed
        Seed of the generator drawing ``c`` (deterministic).

    Returns
    -------
    ZeroOneResult
        ``K`` = median of ``K_c``; constant input gives ``K = 0`` (no growth).

    Notes
    -----
    ``M_c(n)`` for all ``n`` and ``c`` is computed in ``O(n_c N log N)`` with
    the identity ``|z_{j+n} - z_j|^2 = |z_{j+n}|^2 + |z_j|^2 - 2 Re(z_{j+n} z_j^*)``,
    ``z = p + i q``, the cross term being a correlation evaluated by FFT.
    """
    x = np.asarray(phi, dtype=np.float64).ravel()
    if x.size < 20 or not np.all(np.isfinite(x)):
        raise ValueError("phi must be a finite 1-D series with at least 20 samples")
    if stride == "auto":
        step = oversampling_stride(x)
    elif isinstance(stride, (int, np.integer)) and stride >= 1:
        step = int(stride)
    else:
        raise ValueError(f"stride must be a positive int or 'auto'; got {stride!r}")
    x = x[::step]
    n = x.size
    ncut = int(n_cut) if n_cut is not None else max(n // 10, 2)
    if not 2 <= ncut < n:
        raise ValueError(f"n_cut must satisfy 2 <= n_cut < N={n}; got {ncut}")
    rng = np.random.default_rng(seed)
    c = rng.uniform(c_range[0], c_range[1], n_c)
    x = x - x.mean()
    if not np.any(x):
        return ZeroOneResult(0.0, np.zeros(n_c), c, step, n, ncut)

    j = np.arange(1, n + 1)
    length = n - ncut
    lags = np.arange(1, ncut + 1)
    nfft = 1 << int(np.ceil(np.log2(n + length)))
    msd = np.empty((n_c, ncut))  # M_c(n)
    for lo in range(0, n_c, 16):  # chunks of c bound the memory to O(16 N)
        cc = c[lo : lo + 16]
        z = np.cumsum(x[None, :] * np.exp(1j * np.outer(cc, j)), axis=1)  # p_c + i q_c
        cs = np.concatenate(
            [np.zeros((cc.size, 1)), np.cumsum(np.abs(z) ** 2, axis=1)], axis=1
        )
        tail = cs[:, lags + length] - cs[:, lags]  # sum_j |z_{j+n}|^2
        head = cs[:, length][:, None]  # sum_j |z_j|^2
        zf = np.fft.fft(z, nfft, axis=1)
        wf = np.fft.fft(z[:, :length], nfft, axis=1)
        cross = np.fft.ifft(zf * np.conj(wf), axis=1)[:, lags].real  # sum_j Re z_{j+n} z_j^*
        msd[lo : lo + 16] = (tail + head - 2.0 * cross) / length

    xi = lags.astype(np.float64)
    xi_c = xi - xi.mean()
    d_c = msd - msd.mean(axis=1, keepdims=True)
    denom = np.sqrt(np.sum(d_c**2, axis=1) * np.sum(xi_c**2))
    with np.errstate(invalid="ignore", divide="ignore"):
        k_c = np.where(denom > 0.0, d_c @ xi_c / denom, 0.0)
    return ZeroOneResult(float(np.median(k_c)), k_c, c, step, n, ncut)

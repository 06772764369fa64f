"""Indicators computed from stroboscopic (Poincare) samples.

A *Poincare sample set* is a 2-D array ``samples[i, j]``: row ``i`` is the state
at the i-th forcing period after the transient (``tau_i = tau_0 + 2*pi*i`` in the
nondimensional time of the design brief), column ``j`` is a state component.

This module provides the data-side indicators used by
:func:`analysis.regimes.classify`:

* :func:`validate_samples` -- shape / finiteness checks (``ValueError`` naming the
  argument);
* :func:`component_scales` -- the per-component scale ``S_j`` that makes every
  tolerance relative to the attractor's spread;
* :func:`detect_period` -- smallest ``m`` with ``x[i+m] ~= x[i]`` for all ``i``;
* :func:`cluster_points` -- number and tightness of point clusters
  (single-linkage hierarchical clustering, a grid-free distance criterion);
* :func:`scalar_observable` -- a scalar series (first principal component);
* :func:`spectral_lines` -- spectral entropy of the windowed periodogram and its
  growth with record length (discrete lines vs broadband spectrum).

All functions are deterministic.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MIN_SAMPLES",
    "ClusterResult",
    "PatternResult",
    "PeriodResult",
    "SpectralResult",
    "blackman_harris",
    "cluster_points",
    "component_scales",
    "detect_period",
    "periodic_pattern",
    "scalar_observable",
    "spectral_lines",
    "validate_samples",
]

#: Smallest number of stroboscopic samples accepted by the classifier.  The
#: spectral-growth indicator compares the spectrum of the full record with
#: records 2 and 4 times shorter, so a quarter record must still hold >= 32
#: samples; the 0-1 test needs ``n_cut = N/10 >= ~10`` displacement lags.
MIN_SAMPLES: int = 128


def validate_samples(
    samples: ArrayLike, *, name: str = "poincare", min_samples: int = 2
) -> NDArray[np.float64]:
    """Return ``samples`` as a C-contiguous float64 2-D array or raise ``ValueError``.

    Parameters
    ----------
    samples
        Candidate sample array, shape ``(n_periods, n_components)``.
    name
        Argument name quoted in error messages.
    min_samples
        Minimum number of rows.

    Raises
    ------
    ValueError
        If the array is not 2-D, has no columns, has fewer than ``min_samples``
        rows, is not numeric, or contains NaN/inf.  The message names ``name``.
    """
    try:
        arr = np.asarray(samples, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric 2-D array: {exc}") from exc
    if arr.ndim != 2:
        raise ValueError(
            f"{name} must be a 2-D array (rows = forcing periods, columns = state "
            f"components); got ndim={arr.ndim}, shape={arr.shape}"
        )
    if arr.shape[1] < 1:
        raise ValueError(f"{name} must have at least one column; got shape={arr.shape}")
    if arr.shape[0] < min_samples:
        raise ValueError(
            f"{name} has {arr.shape[0]} samples (rows); at least {min_samples} are required"
        )
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise ValueError(f"{name} contains {bad} non-finite value(s) (NaN or inf)")
    return np.ascontiguousarray(arr)


def component_scales(
    samples: NDArray[np.float64], *, floor_rtol: float = 0.1
) -> NDArray[np.float64]:
    r"""Per-component scale used to make tolerances scale-aware.

    .. math::

        S_j = \max\bigl(\operatorname{ptp}_i x_{ij},\; \varepsilon_f M,\; \epsilon_{\min}\bigr),
        \qquad M = \max_{i,j} |x_{ij}|,

    where ``ptp`` is the peak-to-peak spread (max - min) of component ``j`` over
    the record, ``eps_f = floor_rtol`` and ``eps_min`` the smallest normal float
    (``S_j = 1`` if the whole array is zero).

    The floor ``eps_f * M`` matters only for components whose spread is tiny
    compared with the state magnitude: a fixed point of the stroboscopic map
    polluted by noise has a spread equal to the noise, so a tolerance relative to
    the spread alone could never call it a point.  The floor assumes comparable
    (nondimensional) units across components and an origin with physical meaning
    (static equilibrium); callers with other conventions pass their own scale.
    """
    spread = np.ptp(samples, axis=0)
    mag = float(np.max(np.abs(samples))) if samples.size else 0.0
    if mag == 0.0:
        return np.ones(samples.shape[1])
    floor = max(floor_rtol * mag, np.finfo(np.float64).tiny)
    return np.maximum(spread, floor)


@dataclass(frozen=True)
class PeriodResult:
    """Outcome of :func:`detect_period`.

    Attributes
    ----------
    period
        Smallest ``m`` passing the test, or ``None``.
    residuals
        ``residuals[m-1] = r_m`` for every tested ``m`` (see :func:`detect_period`);
        ``inf`` where the record was too short to test ``m``.
    rtol
        Tolerance the residuals were compared with.
    """

    period: int | None
    residuals: NDArray[np.float64]
    rtol: float

    @property
    def best_residual(self) -> float:
        """Smallest residual over the tested ``m`` (how close to periodic)."""
        finite = self.residuals[np.isfinite(self.residuals)]
        return float(finite.min()) if finite.size else float("inf")


def detect_period(
    samples: NDArray[np.float64],
    *,
    m_max: int = 32,
    rtol: float = 0.02,
    scales: NDArray[np.float64] | None = None,
    min_repeats: int = 3,
) -> PeriodResult:
    r"""Smallest period ``m`` of the stroboscopic sequence.

    The residual of candidate ``m`` is the largest scaled spread of a residue
    class ``{x_k, x_{k+m}, x_{k+2m}, ...}``:

    .. math::

        r_m = \max_{0 \le k < m}\; \max_j
              \frac{\operatorname{ptp}_{l}\, x_{k+lm,\,j}}{S_j},

    with ``S_j`` from :func:`component_scales`.  ``r_m <= rtol`` means
    ``|x_{i+lm} - x_i| <= rtol S`` for *all* ``i`` and all ``l`` -- every return
    after any number of periods, not only after one, so a slow drift (a torus
    with rotation number close to ``p/m``) accumulates and is rejected.  The
    period is the smallest ``m <= m_max`` with ``r_m <= rtol``; ``m`` is only
    tested if the record holds at least ``min_repeats`` full repetitions.

    Choice of ``rtol = 0.02``: round-off (1e-12) and noise of 1e-4 of the
    signal give ``r_m`` of order 1e-3 at most (about 6 noise standard
    deviations), while any quasi-periodic or chaotic record spreads each residue
    class over ``O(1)`` of the attractor.  Attractor structure finer than
    ``rtol`` of the spread (e.g. banded chaos with bands narrower than 2 % of
    the spread) is not resolved and is called periodic.
    """
    x = np.asarray(samples, dtype=np.float64)
    n = x.shape[0]
    s = component_scales(x) if scales is None else np.asarray(scales, dtype=np.float64)
    xs = x / s
    residuals = np.full(max(m_max, 0), np.inf)
    period: int | None = None
    for m in range(1, m_max + 1):
        if n < min_repeats * m:
            break
        usable = (n // m) * m
        blocks = xs[:usable].reshape(n // m, m, -1)  # blocks[l, k, j] = x_{k+lm, j}
        r = float(np.max(np.ptp(blocks, axis=0)))
        if usable < n:  # the incomplete last block
            tail = xs[usable:]
            ref = blocks[:, : tail.shape[0]]
            lo = np.minimum(ref.min(axis=0), tail)
            hi = np.maximum(ref.max(axis=0), tail)
            r = max(r, float(np.max(hi - lo)))
        residuals[m - 1] = r
        if r <= rtol:
            period = m
            break
    return PeriodResult(period=period, residuals=residuals, rtol=rtol)


@dataclass(frozen=True)
class PatternResult:
    """Outcome of :func:`periodic_pattern`.

    Attributes
    ----------
    period
        Selected pattern period ``m*``, or ``None`` if no ``m`` qualifies.
    explained
        ``explained[m-1] = R^2_m`` for ``m = 1..m_max`` (0 where untested).
    drift
        ``drift[m-1] = D_m``, pattern change between the two record halves
        (``inf`` where untested).
    residual
        ``phi`` minus its period-``m*`` pattern (``phi - mean`` if ``period`` is None).
    """

    period: int | None
    explained: NDArray[np.float64]
    drift: NDArray[np.float64]
    residual: NDArray[np.float64]


def _class_means(x: NDArray[np.float64], m: int, offset: int = 0) -> NDArray[np.float64]:
    """Residue-class means ``P(k) = mean{x_i : (i + offset) = k mod m}``, shape ``(m, d)``."""
    n, d = x.shape
    q, r = divmod(n, m)
    # row i = a m + j (j < m) is in class (j + offset) mod m: sum the whole cycles' rows as a
    # (q, m, d) block, then the r rows left; each class summed in row order, as a running sum
    by_slot = x[:q * m].reshape(q, m, d).sum(axis=0) if q else np.zeros((m, d))
    by_slot[:r] += x[q * m:]
    counts = np.full(m, float(q))
    counts[:r] += 1.0
    order = (np.arange(m) - offset) % m  # the slot j of class k
    return by_slot[order] / counts[order, None]


def periodic_pattern(
    data: ArrayLike,
    *,
    m_max: int = 32,
    min_explained: float = 0.5,
    slack: float = 0.02,
    min_repeats: int = 8,
    max_drift: float = 0.2,
) -> PatternResult:
    r"""Dominant period-``m`` pattern of a series and its residual.

    ``data`` is a scalar series (1-D) or a sample array ``x_{ij}`` (2-D, rows =
    periods).  For each ``m`` the pattern is the residue-class mean
    ``P_m(k) = mean{x_i : i = k mod m}``; its share of the (total) variance is

    .. math::

        R^2_m = 1 - \frac{\sum_j \operatorname{var}_i(x_{ij} - P_{m,j}(i \bmod m))}
                          {\sum_j \operatorname{var}_i(x_{ij})},

    and its drift is the RMS change of the pattern between the first and the
    second half of the record relative to the RMS deviation of the data,
    ``D_m = rms_{k,j}(P^{(1)}_m - P^{(2)}_m) / rms_{i,j}(x - mean x)``.

    ``m*`` is the smallest ``m >= 2`` with (i) ``n >= min_repeats * m``,
    (ii) ``R^2_m >= min_explained``, (iii) ``R^2_m >= max_m R^2_m - slack``
    (multiples of the true period explain as much; any ``m`` explains ``~m/N``
    of a broadband series by over-fitting) and (iv) ``D_m <= max_drift`` (a
    stationary pattern: a torus whose rotation number is close to ``p/m``
    also yields a large ``R^2_m`` on a short record, but its pattern rotates
    slowly, so the halves disagree).

    Why: in *banded* chaos (e.g. the logistic map at r = 3.6, two bands visited
    alternately) and in *period-m x torus* motion (one mode periodic, another
    circling a closed curve) a strong periodic component carries most of the
    power and hides the weak chaotic or quasi-periodic component from the
    spectral test; the residual ``x_i - P_{m*}(i mod m*)`` (same shape as
    ``data``) exposes it.
    """
    arr = np.asarray(data, dtype=np.float64)
    x = arr[:, None] if arr.ndim == 1 else arr
    n = x.shape[0]
    xc = x - x.mean(axis=0)
    total = float(np.sum(xc**2)) / n
    explained = np.zeros(m_max)
    drift = np.full(m_max, np.inf)
    if total <= 0.0:
        return PatternResult(None, explained, drift, xc.reshape(arr.shape))
    rms = np.sqrt(total / x.shape[1])
    h = n // 2
    for m in range(2, min(m_max, n // max(min_repeats, 1)) + 1):  # m = 1 is the mean
        means = _class_means(xc, m)
        explained[m - 1] = 1.0 - float(np.sum((xc - means[np.arange(n) % m]) ** 2)) / n / total
        d = _class_means(xc[:h], m) - _class_means(xc[h:], m, offset=h)
        drift[m - 1] = float(np.sqrt(np.mean(d**2)) / rms)
    best = explained.max()
    ok = np.nonzero(
        (explained >= min_explained) & (explained >= best - slack) & (drift <= max_drift)
    )[0]
    if ok.size == 0:
        return PatternResult(None, explained, drift, xc.reshape(arr.shape))
    m = int(ok[0]) + 1
    resid = xc - _class_means(xc, m)[np.arange(n) % m]
    return PatternResult(m, explained, drift, resid.reshape(arr.shape))


@dataclass(frozen=True)
class ClusterResult:
    """Outcome of :func:`cluster_points`.

    Attributes
    ----------
    n_clusters
        Number of single-linkage clusters at distance ``tol``.
    labels
        Cluster label (0-based, in order of first appearance) of each point used.
    max_diameter
        Largest cluster diameter, scaled Chebyshev norm (max over clusters of
        ``max_j ptp(x_j / S_j)`` within the cluster).
    min_separation
        Smallest scaled Chebyshev distance between two cluster centroids
        (``inf`` for one cluster).
    label_period
        Smallest ``m`` with ``labels[i+m] == labels[i]`` for all ``i`` (the
        itinerary is periodic), or ``None``.
    n_points
        Number of points clustered (the last ``max_points`` of the record).
    tol
        Linkage distance threshold used.
    """

    n_clusters: int
    labels: NDArray[np.int64]
    max_diameter: float
    min_separation: float
    label_period: int | None
    n_points: int
    tol: float


def cluster_points(
    samples: NDArray[np.float64],
    *,
    tol: float = 0.01,
    scales: NDArray[np.float64] | None = None,
    max_points: int = 2000,
    m_max: int = 32,
    min_repeats: int = 3,
) -> ClusterResult:
    r"""Group Poincare points into clusters with a grid-free distance criterion.

    Points are scaled component-wise, ``y_i = x_i / S`` (:func:`component_scales`),
    and merged by single-linkage hierarchical clustering
    (:func:`scipy.cluster.hierarchy.linkage`, Chebyshev metric): two points are
    in the same cluster if a chain of points joins them with every link shorter
    than ``tol``.  A period-``m`` orbit gives ``m`` clusters of diameter ~ noise;
    a closed invariant curve (torus) or a chaotic cloud gives either many
    clusters or clusters of large diameter (chains along the curve).

    Only the last ``max_points`` samples are used (memory ``O(n^2)``).
    """
    # imported here, not at the top: scipy.cluster and scipy.spatial are slow to import, and
    # every `snakemake` call imports this module (the Snakefile's plan uses the label names)
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial.distance import pdist

    x = np.asarray(samples, dtype=np.float64)
    s = component_scales(x) if scales is None else np.asarray(scales, dtype=np.float64)
    y = (x / s)[-max_points:]
    n = y.shape[0]
    if n == 1:
        raw = np.zeros(1, dtype=np.int64)
    else:
        z = linkage(y, method="single", metric="chebyshev")
        raw = fcluster(z, t=tol, criterion="distance").astype(np.int64)
    # relabel in order of first appearance (deterministic, 0-based)
    _, first = np.unique(raw, return_index=True)
    order = np.argsort(first)
    remap = np.empty(raw.max() + 1, dtype=np.int64)
    remap[np.unique(raw)[order]] = np.arange(order.size)
    labels = remap[raw]
    k = int(order.size)

    srt = np.argsort(labels, kind="stable")
    ys = y[srt]
    starts = np.searchsorted(labels[srt], np.arange(k))
    cmax = np.maximum.reduceat(ys, starts, axis=0)
    cmin = np.minimum.reduceat(ys, starts, axis=0)
    counts = np.diff(np.append(starts, n))
    centroids = np.add.reduceat(ys, starts, axis=0) / counts[:, None]
    max_diameter = float(np.max(cmax - cmin))
    min_sep = float(np.min(pdist(centroids, metric="chebyshev"))) if k > 1 else float("inf")

    label_period: int | None = None
    for m in range(1, min(m_max, n // max(min_repeats, 1)) + 1):
        if np.array_equal(labels[m:], labels[:-m]):
            label_period = m
            break
    return ClusterResult(
        n_clusters=k,
        labels=labels,
        max_diameter=max_diameter,
        min_separation=min_sep,
        label_period=label_period,
        n_points=n,
        tol=tol,
    )


def scalar_observable(
    samples: NDArray[np.float64], method: Literal["pca"] | int = "pca"
) -> NDArray[np.float64]:
    r"""Scalar series ``phi_i`` from the state samples.

    ``method="pca"`` (default): projection on the first principal axis,
    ``phi_i = (x_i - \bar x) \cdot v_1`` with ``v_1`` the leading right singular
    vector of the centred data (sign fixed so that the largest entry of ``v_1``
    is positive).  This is the fixed linear projection carrying the largest
    variance; it is a smooth observable on a torus, as the spectral-line and 0-1
    tests require.  An integer selects that column (centred).
    """
    x = np.asarray(samples, dtype=np.float64)
    xc = x - x.mean(axis=0)
    if isinstance(method, (int, np.integer)):
        return xc[:, int(method)].copy()
    if method != "pca":
        raise ValueError(f"observable must be 'pca' or a column index; got {method!r}")
    if x.shape[1] == 1:
        return xc[:, 0].copy()
    _, _, vt = np.linalg.svd(xc, full_matrices=False)
    v = vt[0]
    if v[np.argmax(np.abs(v))] < 0:
        v = -v
    return xc @ v


@dataclass(frozen=True)
class SpectralResult:
    """Outcome of :func:`spectral_lines`.

    Attributes
    ----------
    growth
        Slope ``gamma`` of ``log N_eff`` against ``log L`` over record lengths
        ``L = N, N/2, N/4, ...``: ~0 for a discrete (line) spectrum, ~1 for a
        broadband spectrum.
    entropy
        Normalised spectral entropy of the full record, ``H / log(n_bins)`` in [0, 1].
    n_eff
        Effective number of occupied frequency bins ``exp(H)`` per record length
        (full record first).
    lengths
        Record lengths ``L`` used.
    """

    growth: float
    entropy: float
    n_eff: NDArray[np.float64]
    lengths: NDArray[np.int64]


def _spectral_entropy(seg: NDArray[np.float64], window: NDArray[np.float64]) -> tuple[float, int]:
    """Entropy ``H = -sum p_k log p_k`` of the normalised one-sided periodogram."""
    seg = seg - seg.mean()
    power = np.abs(np.fft.rfft(seg * window)) ** 2
    total = power.sum()
    if not np.isfinite(total) or total <= 0.0:
        return 0.0, power.size
    p = power / total
    p = p[p > 0.0]
    return float(-np.sum(p * np.log(p))), power.size


#: coefficients of the minimum 4-term Blackman-Harris window (Harris 1978; scipy's
#: ``signal.windows.blackmanharris``)
_BLACKMAN_HARRIS = (0.35875, 0.48829, 0.14128, 0.01168)


def blackman_harris(n: int) -> NDArray[np.float64]:
    """The periodic (DFT-even) 4-term Blackman-Harris window of ``n`` samples,
    ``w_i = sum_k a_k cos(k theta_i)`` with ``theta`` the ``n + 1`` points from ``-pi`` to ``pi``,
    the last one dropped: scipy's ``signal.get_window("blackmanharris", n, fftbins=True)`` in
    the same operations, so to the bit (tested), without importing ``scipy.signal``, which is
    slow to import in every process that classifies a record (docs/performance.md)."""
    if n <= 1:
        return np.ones(max(n, 0))
    theta = np.linspace(-np.pi, np.pi, n + 1, dtype=np.float64)
    w = np.zeros(n + 1)
    for k, a in enumerate(_BLACKMAN_HARRIS):
        w += a * np.cos(k * theta)
    return w[:-1]


def spectral_lines(phi: ArrayLike, *, n_scales: int = 3) -> SpectralResult:
    r"""Discrete-line versus broadband test on a scalar Poincare series.

    For a record of length ``L`` the periodogram
    ``P_k = |sum_i w_i (phi_i - bar phi) e^{-2 pi i k i / L}|^2`` (window ``w`` the
    4-term Blackman-Harris, :func:`blackman_harris`: sidelobes below -92 dB, main lobe +-4 bins)
    is normalised to ``p_k = P_k / sum P`` and its entropy
    ``H = -sum_k p_k log p_k`` gives the effective number of occupied bins
    ``N_eff = exp(H)``.

    * A discrete spectrum -- periodic orbit (``m`` lines) or quasi-periodic
      torus (lines at the rotation numbers, their harmonics and combinations) --
      occupies a fixed number of lines, each a main lobe of a fixed number of
      bins, so ``N_eff`` does not depend on ``L``.
    * A broadband (continuous) spectrum spreads over a fixed fraction of all
      ``L/2`` bins, so ``N_eff`` is proportional to ``L``.

    The growth exponent is the least-squares slope
    ``gamma = d log N_eff / d log L`` over ``L = N, N/2, ..., N/2^(n_scales-1)``,
    with ``N_eff`` at each shorter length averaged over the non-overlapping
    segments of the record.  It is scale-free (no threshold on absolute power)
    and insensitive to small additive noise: noise carrying a fraction ``eps``
    of the power changes ``H`` by ``~ eps log(L/eps)`` (``~3e-7`` for noise of
    1e-4 of the signal amplitude).
    """
    x = np.asarray(phi, dtype=np.float64).ravel()
    n = x.size
    lengths = []
    n_effs = []
    entropy_norm = 0.0
    for s in range(n_scales):
        seg_len = n >> s
        if seg_len < 16:
            break
        win = blackman_harris(seg_len)
        hs = []
        for k in range(n // seg_len):
            h, nbins = _spectral_entropy(x[k * seg_len : (k + 1) * seg_len], win)
            hs.append(h)
            if s == 0:
                entropy_norm = h / np.log(nbins) if nbins > 1 else 0.0
        lengths.append(seg_len)
        n_effs.append(float(np.mean(np.exp(hs))))
    ln_l = np.log(np.asarray(lengths, dtype=np.float64))
    ln_n = np.log(np.asarray(n_effs))
    growth = float(np.polyfit(ln_l, ln_n, 1)[0]) if len(lengths) >= 2 else float("nan")
    return SpectralResult(
        growth=growth,
        entropy=float(entropy_norm),
        n_eff=np.asarray(n_effs),
        lengths=np.asarray(lengths, dtype=np.int64),
    )

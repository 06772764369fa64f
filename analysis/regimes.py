"""Regime classification of stroboscopic (Poincare) samples.

:func:`classify` labels a post-transient Poincare sample set as ``"periodic"``
(with its period ``m``), ``"quasi-periodic"`` or ``"chaotic"`` from several
indicators and returns them all, with a sentence saying why, so a reader of the
regime map can check each label.  The decision rule and its thresholds are
described in ``docs/classification.md``.

Indicators
----------
1. Period test (:func:`analysis.poincare.detect_period`): smallest ``m`` with
   ``|x_{i+lm} - x_i| <= rtol * S`` for all ``i`` and ``l`` (``S`` =
   per-component spread).
2. Poincare clusters (:func:`analysis.poincare.cluster_points`): number of
   single-linkage clusters, their diameter and the period of the cluster
   itinerary.
3. 0-1 test for chaos (:func:`analysis.zero_one.zero_one_test`) on a
   scalar observable (first principal component), median ``K`` over 100 random
   ``c``.
4. Spectral line test (:func:`analysis.poincare.spectral_lines`): growth
   exponent ``gamma`` of the effective number of occupied frequency bins with
   record length (~0 discrete lines, ~1 broadband).
   If a stationary periodic pattern dominates (banded chaos, period-m x torus),
   tests 3 and 4 are repeated on the residual after removing it
   (:func:`analysis.poincare.periodic_pattern`).
5. Largest Lyapunov exponent, if given, **per forcing period** (i.e. per
   iteration of the stroboscopic map): ``lle_per_period = lambda_1 * T`` with
   ``lambda_1`` per unit time and ``T`` the forcing period (``T = 2 pi`` in the
   nondimensional time ``tau`` of the design brief); see
   :func:`lle_per_period_from_rate`.

Decision rule
-------------
1. *Periodic* if the period test finds ``m <= m_max``; otherwise, if the
   cluster itinerary is periodic with period ``m`` and every cluster is a
   point (diameter ``<= cluster_diameter_max``), periodic with that ``m``
   (catches noise above ``period_rtol`` but below the cluster separation).
2. Otherwise non-periodic; chaotic vs quasi-periodic.  If a stationary
   period-``m*`` pattern carries most of the variance
   (:func:`analysis.poincare.periodic_pattern`; banded chaos, period-m x
   torus), the spectral growth and ``K`` used below are the larger of the
   values for the series and for its residual after removing the pattern.

   a. ``lle_interval`` given (a confidence interval ``[lo, hi]`` of
      ``lambda_1 T``, :mod:`analysis.lyapunov.block_statistics`): ``lo >
      lle_threshold`` -> chaotic; ``hi <= lle_threshold`` -> quasi-periodic;
      an interval that straddles the threshold -> :data:`UNDETERMINED`.  An
      exponent that the data contradict (positive with a discrete spectrum and a
      regular 0-1 test, or non-positive with a broadband spectrum and a chaotic
      0-1 test) is also :data:`UNDETERMINED`, with the conflict as its reason.
   b. Only ``lle_per_period`` given: ``> lle_threshold`` -> chaotic, unless both
      the spectrum shows lines and ``K <= k_chaotic`` (then quasi-periodic,
      conflict reported); ``<= lle_threshold`` -> quasi-periodic (conflict
      reported if spectrum and ``K`` both say chaotic).
   c. Neither: spectrum ``lines`` -> quasi-periodic; ``broadband`` ->
      chaotic; ``ambiguous`` -> the 0-1 test decides.

Non-results
-----------
:data:`DIVERGED` and :data:`UNSETTLED` are the labels the pipeline uses for grid
points that cannot be classified (solution blew up / transient not over, see
:func:`is_settled`).  :func:`classify` itself never returns them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Literal, Mapping

import numpy as np
from numpy.typing import ArrayLike

from analysis.poincare import (
    MIN_SAMPLES,
    cluster_points,
    component_scales,
    detect_period,
    periodic_pattern,
    scalar_observable,
    spectral_lines,
    validate_samples,
)
from analysis.transients import converging_period, drifting_component
from analysis.zero_one import zero_one_test

__all__ = [
    "CHAOTIC",
    "CLASSIFIER_VERSION",
    "DIVERGED",
    "LABELS",
    "MIN_SAMPLES",
    "PERIODIC",
    "QUASI_PERIODIC",
    "UNDETERMINED",
    "UNSETTLED",
    "RegimeResult",
    "Thresholds",
    "classify",
    "is_settled",
    "is_transient",
    "poincare_says_chaotic",
    "transient_reason",
    "continuation_reason",
    "poincare_signature",
    "lle_per_period_from_rate",
]

PERIODIC: str = "periodic"
QUASI_PERIODIC: str = "quasi-periodic"
CHAOTIC: str = "chaotic"
#: Neither regular nor chaotic established: the exponent's confidence interval straddles the
#: threshold, or the exponent and the Poincare data contradict each other (reason says which).
UNDETERMINED: str = "undetermined"
#: The labels :func:`classify` can return (:data:`UNDETERMINED` only with ``lle_interval``).
LABELS: tuple[str, ...] = (PERIODIC, QUASI_PERIODIC, CHAOTIC, UNDETERMINED)
#: Pipeline non-result: the integration diverged (non-finite or exploding state).
DIVERGED: str = "diverged"
#: Pipeline non-result: the transient is not over (see :func:`is_settled`).
UNSETTLED: str = "unsettled"
#: Bump when a change of :func:`classify` or :func:`is_settled` alters labels for unchanged
#: samples: the pipeline's classify rule takes it as a parameter, so stored tables are
#: relabelled without recomputing the simulations (2: noise-aware :func:`is_settled`; 3: the
#: exponent's confidence interval and :data:`UNDETERMINED`, transient-trend test; 4: the
#: continuation check on the joined records, undetermined for tight clusters with a chaotic
#: interval and for aperiodic samples with an interval below minus the threshold).
CLASSIFIER_VERSION: str = "4"

Label = Literal["periodic", "quasi-periodic", "chaotic", "undetermined"]


@dataclass(frozen=True)
class RegimeResult:
    """Result of :func:`classify`.

    Attributes
    ----------
    label
        ``"periodic"``, ``"quasi-periodic"``, ``"chaotic"`` or ``"undetermined"``.
    period
        ``m`` of a period-``m`` orbit, else ``None``.
    reason
        Human-readable explanation of the decision.
    indicators
        Read-only mapping of indicator values (see ``docs/classification.md``):
        ``n_samples``, ``period_test``, ``period_residual``, ``n_clusters``,
        ``cluster_diameter``, ``cluster_separation``, ``cluster_period``,
        ``K``, ``K_stride``, ``spectral_growth``, ``spectral_entropy``,
        ``pattern_period``, ``pattern_explained``, ``K_residual``,
        ``spectral_growth_residual`` (``None`` when no periodic pattern was
        removed), ``lle_per_period``.
    votes
        Read-only mapping indicator -> verdict (``"periodic"``, ``"regular"``,
        ``"chaotic"``, ``"lines"``, ``"broadband"``, ``"ambiguous"``,
        ``"not given"``...).
    """

    label: Label
    period: int | None
    reason: str
    indicators: Mapping[str, float | int | None] = field(default_factory=dict)
    votes: Mapping[str, str] = field(default_factory=dict)


def lle_per_period_from_rate(lle_per_time: float, forcing_period: float = 2.0 * np.pi) -> float:
    """Convert a largest Lyapunov exponent per unit time to per forcing period.

    ``lambda_per_period = lambda_per_time * T``; ``T = 2 pi`` for the
    nondimensional time of the design brief (``tau = Omega t``).
    """
    return float(lle_per_time) * float(forcing_period)


#: the quantiles :func:`is_settled` compares between the halves of a record
_TAIL_QUANTILES = (0.05, 0.95)


def _half_differences(a: np.ndarray, b: np.ndarray, qa: np.ndarray | None = None,
                      qb: np.ndarray | None = None) -> np.ndarray:
    """``|stat(a) - stat(b)|`` for mean, standard deviation and the 5 % / 95 % quantiles, along
    the sample axis ``-2``: shape ``(4, ..., d)``.  ``qa``, ``qb``: the quantiles if known
    (:func:`_sorted_quantiles`)."""
    qa = np.quantile(a, _TAIL_QUANTILES, axis=-2) if qa is None else qa
    qb = np.quantile(b, _TAIL_QUANTILES, axis=-2) if qb is None else qb
    return np.abs(np.stack([a.mean(axis=-2) - b.mean(axis=-2), a.std(axis=-2) - b.std(axis=-2),
                            qa[0] - qb[0], qa[1] - qb[1]]))


def _sorted_quantiles(s: np.ndarray) -> np.ndarray:
    """``np.quantile`` (method ``"linear"``) at :data:`_TAIL_QUANTILES` of samples ``s`` sorted
    along the last axis, to the bit: numpy's interpolation between the order statistics it
    selects (``b - (b - a)(1 - g)`` where ``g >= 0.5``, else ``a + (b - a) g``), which are
    the same values whether partitioned or sorted.  Shape ``(2, ...)``.  Sorting along a
    contiguous axis is several times faster than numpy's partition along the sample axis of the
    permuted records (docs/performance.md, "The settledness test's permutations")."""
    n = s.shape[-1]
    vi = (n - 1) * np.asarray(_TAIL_QUANTILES)
    lo = np.floor(vi).astype(np.intp)
    hi = np.minimum(lo + 1, n - 1)
    gamma = vi - lo
    out = []
    for k in range(vi.size):
        a, b = s[..., lo[k]], s[..., hi[k]]
        d = b - a
        out.append(b - d * (1 - gamma[k]) if gamma[k] >= 0.5 else a + d * gamma[k])
    return np.stack(out)


def is_settled(
    poincare: ArrayLike,
    *,
    rtol: float = 0.1,
    scale_floor_rtol: float = 0.1,
    alpha: float = 0.01,
    n_perm: int = 1000,
    block: int | None = None,
    seed: int = 0,
) -> bool:
    r"""Heuristic: has the transient died out in this Poincare record?

    Splits the record into its first and second halves ``A`` and ``B`` and
    compares, for every component ``j`` (``S_j`` from
    :func:`analysis.poincare.component_scales` of the whole record), four
    statistics: mean, standard deviation and the 5 % and 95 % quantiles,

    .. math::

        D_{kj} = |T_k(A_j) - T_k(B_j)| / S_j ,\qquad
        \text{settled} \iff \max_j D_{kj} \le \max(r, c_k)\ \text{for every } k ,

    with ``r = rtol`` (default 0.1).  On a settled attractor both halves sample
    the same invariant measure, so mean, spread and extreme quantiles agree; a
    decaying transient (drift of the mean, shrinking or growing amplitude)
    moves at least one.

    ``c_k`` is the sampling noise of the statistic, so that a chaotic record --
    whose halves differ by chance, most in the extreme quantiles of a short,
    intermittent record -- is not mistaken for a transient: the record is cut
    into blocks of ``block`` rows (default ``max(4, n / 16)``; meant to be longer
    than the correlation time of a chaotic record), the block order is permuted
    ``n_perm`` times (seeded: deterministic), and ``c_k`` is the
    ``1 - alpha / 4`` quantile of ``max_j D_kj`` over the permuted records
    (a block-permutation test at family-wise level ``alpha`` over the four
    statistics and all components).  Permuting mixes early and late blocks, so
    a transient's drift does not enter ``c_k`` beyond its share of the
    variance.  Periodic and quasi-periodic records have ``c_k`` near zero and
    the fixed tolerance ``r`` decides, as without the permutation; it runs only
    when some ``D_kj`` exceeds ``r``.

    Limitations: a torus whose slowest rotation takes longer than half the
    record, or intermittent chaos whose laminar phases are longer than a block,
    can fail the test although settled; a transient much slower than
    the record (a drift below ``max(r, c_k) S`` over the whole record) passes it.
    """
    x = validate_samples(poincare, name="poincare", min_samples=8)
    if not (0.0 < alpha < 1.0):
        raise ValueError(f"alpha must be in (0, 1), got {alpha!r}")
    if int(n_perm) < 1 or (block is not None and int(block) < 1):
        raise ValueError(f"n_perm and block must be >= 1, got n_perm={n_perm!r}, block={block!r}")
    s = component_scales(x, floor_rtol=scale_floor_rtol)
    h = x.shape[0] // 2
    y = x[-2 * h:]
    obs = (_half_differences(y[:h], y[h:]) / s).max(axis=-1)
    if np.all(obs <= rtol):
        return True
    n_block = max(4, h // 8) if block is None else int(block)
    nb = h // n_block  # blocks per half
    if nb < 2:
        return False  # too short to estimate the noise: the fixed tolerance decides
    z = x[-2 * nb * n_block:].reshape(2 * nb, n_block, -1)
    zt = np.ascontiguousarray(z.transpose(0, 2, 1))  # blocks, components, rows
    d = z.shape[-1]
    half = nb * n_block
    q = 1.0 - alpha / 4.0
    # the verdict is known once enough permuted values reach the observed ones: c_k is at least
    # the order statistic at the floor lo of numpy's virtual index (n_perm - 1) q, so once
    # n_perm - lo of them are at or above obs_k, obs_k <= c_k whatever the other permutations
    # give (lo taken one lower than that floor: safe against the index's rounding)
    enough = n_perm - (int(np.floor((n_perm - 1) * q)) - 1)
    open_k = obs > rtol
    rng = np.random.default_rng(seed)
    null = np.empty((n_perm, 4))
    for lo in range(0, n_perm, 250):
        k = min(250, n_perm - lo)
        order = np.argsort(rng.random((k, 2 * nb)), axis=1)
        zz = z[order].reshape(k, 2 * nb * n_block, -1)
        # the halves' samples component by component, sorted: their quantiles
        srt = (zt[order].reshape(k, 2, nb, d, n_block).transpose(0, 1, 3, 2, 4)
               .reshape(k, 2, d, half))
        srt.sort(axis=-1)
        diffs = _half_differences(zz[:, :half], zz[:, half:], _sorted_quantiles(srt[:, 0]),
                                  _sorted_quantiles(srt[:, 1]))
        null[lo:lo + k] = (diffs / s).max(axis=-1).T
        if np.all((null[:lo + k, open_k] >= obs[open_k]).sum(axis=0) >= enough):
            return True
    c = np.quantile(null, q, axis=0)
    return bool(np.all(obs <= np.maximum(rtol, c)))


def transient_reason(
    poincare: ArrayLike,
    *,
    m_max: int = 32,
    period_rtol: float = 0.02,
    min_decay: float = 1.25,
    min_drift: float = 0.05,
    scale_floor_rtol: float = 0.1,
    trends_first: bool = False,
    **settle_options,
) -> str | None:
    """Why the record is still a transient, or ``None`` when it looks settled.

    Three tests, in order: the halves test :func:`is_settled` (``settle_options`` are its
    keyword arguments); convergence towards a periodic orbit
    (:func:`analysis.transients.converging_period`: the distance ``|x[i+m] - x[i]|`` of some
    lag ``m <= m_max`` falls at least ``min_decay`` times over the record from above
    ``period_rtol`` of the spread, i.e. the remnant is large enough to change the period test);
    a linear drift of a component by more than ``min_drift`` of its spread
    (:func:`analysis.transients.drifting_component`, on the record and, when a periodic
    pattern dominates it, on the residual after removing the pattern).  The first test that
    fails gives the reason; ``trends_first`` runs the halves test last (the same verdict, the
    reason of another test where several fail: :func:`is_transient`).
    """
    x = validate_samples(poincare, name="poincare", min_samples=8)

    def halves() -> str | None:
        if is_settled(x, scale_floor_rtol=scale_floor_rtol, **settle_options):
            return None
        return ("first and second half of the record differ (mean, spread or 5 % / 95 % "
                "quantiles; is_settled)")

    def trends() -> str | None:
        return _trend_reason(x, m_max=m_max, period_rtol=period_rtol, min_decay=min_decay,
                             min_drift=min_drift, scale_floor_rtol=scale_floor_rtol)

    for test in (trends, halves) if trends_first else (halves, trends):
        if (why := test()) is not None:
            return why
    return None


def is_transient(poincare: ArrayLike, **options) -> bool:
    """``transient_reason(poincare, **options) is not None``, for a caller that needs only the
    verdict: the convergence and drift tests run first and the halves test :func:`is_settled`
    only when they pass, because the halves test is the one that is dear on a record it fails
    (every block permutation is drawn there), and the trend tests flag most such records too
    (docs/performance.md, "The record tests' order").  The three tests are independent, so the
    order changes the cost, not the verdict."""
    return transient_reason(poincare, trends_first=True, **options) is not None


def _trend_reason(x: np.ndarray, *, m_max: int, period_rtol: float, min_decay: float, min_drift: float,
                  scale_floor_rtol: float) -> str | None:
    """The convergence and drift tests of :func:`transient_reason` on validated samples ``x``."""
    s = component_scales(x, floor_rtol=scale_floor_rtol)
    conv = converging_period(x, s, m_max=m_max, min_decay=min_decay)
    if conv is not None:
        m, factor = conv
        head = x[:max(m + 8, x.shape[0] // 8)]
        start = float(np.median(np.max(np.abs(head[m:] - head[:-m]) / s, axis=1)))
        if start > period_rtol:
            return (f"converging towards a period-{m} orbit: |x[i+{m}] - x[i]| falls "
                    f"{factor:.3g}x over the record from {start:.2g} of the spread")
    drift = drifting_component(x, s, min_drift=min_drift)
    if drift is None:  # a drift under a periodic pattern (whose block means alias)
        pat = periodic_pattern(x, m_max=m_max)
        if pat.period is not None and pat.period > 1:
            drift = drifting_component(pat.residual, s, min_drift=min_drift)
    if drift is not None:
        j, amount = drift
        return (f"component {j} drifts by {amount:+.3g} of its spread over the record (least-squares "
                "trend of the block means, significant against their scatter)")
    return None


def poincare_signature(poincare: ArrayLike) -> str:
    """What the Poincare samples say on their own, without an exponent: ``"periodic-m"`` when
    :func:`classify` finds a period ``m``, else ``"aperiodic"`` (quasi-periodic, chaotic or
    undetermined are told apart only with the exponent, which a second record does not have)."""
    res = classify(poincare)
    return f"{PERIODIC}-{res.period}" if res.label == PERIODIC else "aperiodic"


def continuation_reason(record: ArrayLike, continued: ArrayLike, *, max_change: float = 0.05,
                        scale_floor_rtol: float = 0.1, joined: bool = True) -> str | None:
    """Why a record that passed :func:`transient_reason` is still a transient, judged by running
    on (``continued``: the samples of the next periods, same length), or ``None``.

    Three tests, in order: the records' :func:`poincare_signature` differ (a slowly decaying
    period-5 remnant that continuing turns into period 1, a torus that locks); the size of a
    period-``m`` pattern changes (below); two aperiodic records joined (without the
    continuation's first sample, which is the record's last) fail the halves test or the
    convergence test of :func:`transient_reason` at twice the record's baseline (a spiral or
    remnant decaying by 1.12-1.25x per record, which one record's 1.25x threshold misses; the
    drift test is left out here: on the joined records of stationary chaos it raised 3 false
    alarms in 200 logistic pairs, and on the default map it flagged only one chaotic record the
    other two passed, which then passed its next check;
    periodic readings are left out too: a remnant that keeps the period test within its
    tolerance does not change their label: joined, a period-1 record of the default map
    converging onto its fixed point stayed unsettled at the cap).  The pattern
    test: both records are period ``m > 1`` and the size of the pattern (the largest range
    over the cycle of the ``m`` phase means, per component scale of ``record``) changes by more
    than a factor ``1 + max_change`` from one record to the next -- on a periodic orbit it is
    the same to round-off, on a remnant converging to a fixed point or to a shorter period it
    falls geometrically.

    ``joined=False`` leaves the joined test out: the pipeline does so for a continued record in
    which every element of a sticking law stays stuck, whose label the exact linear analysis
    gives (docs/classification.md, rule 3; its free vibration decays onto the forced response
    over 1e5 periods and more, which the joined test would read as a transient to the cap).

    This is what a referee does with a cell (run it longer): it catches transients slower than
    the record, which the record's own trend tests cannot see (they compare parts of one record,
    and a remnant decaying by 20 % per record shows no significant trend inside it)."""
    x, y = np.asarray(record, dtype=float), np.asarray(continued, dtype=float)
    a, b = poincare_signature(x), poincare_signature(y)
    n = y.shape[0] - 1  # periods run on (the samples include both ends)
    if a != b:
        return f"continuing by {n} periods changes the record from {a} to {b}"
    m = int(a.rsplit("-", 1)[1]) if a.startswith(PERIODIC) else 1
    if m > 1:
        s = component_scales(x, floor_rtol=scale_floor_rtol)

        def size(z: np.ndarray) -> float:
            means = np.array([z[k::m].mean(axis=0) for k in range(m)])
            return float(np.max(np.ptp(means, axis=0) / s))

        sx, sy = max(size(x), 1e-300), max(size(y), 1e-300)
        ratio = sx / sy
        if abs(np.log(ratio)) > np.log1p(max_change):
            return (f"continuing by {n} periods, the period-{m} pattern "
                    f"{'shrinks' if ratio > 1 else 'grows'} by a factor {max(ratio, 1 / ratio):.3g}")
    if a != "aperiodic" or not joined:  # a periodic reading's remnant below the period
        return None  # test's tolerance does not change its label; its pattern's size is tested above
    why = transient_reason(np.vstack([x, y[1:]]), scale_floor_rtol=scale_floor_rtol, min_drift=np.inf)
    if why is not None:
        return f"the record and its continuation by {n} periods, joined, are a transient: {why}"
    return None


@dataclass(frozen=True)
class Thresholds:
    """The settings of :func:`classify` (same names and meaning as its keyword arguments)."""

    m_max: int = 32
    period_rtol: float = 0.02
    scale_floor_rtol: float = 0.1
    cluster_tol: float = 0.01
    cluster_diameter_max: float = 0.05
    max_cluster_points: int = 2000
    lle_threshold: float = 0.02
    growth_lines: float = 0.3
    growth_broadband: float = 0.6
    k_chaotic: float = 0.5
    observable: Literal["pca"] | int = "pca"
    zero_one_stride: int | str = "auto"
    seed: int = 0


@dataclass(frozen=True)
class _Evidence:
    """The indicators of one record: period test, clusters, and the spectral growth and 0-1
    ``K`` actually used (the larger of series and pattern residual)."""

    per: object
    clu: object
    pat: object
    growth: float
    k_val: float
    indicators: dict


def classify(
    poincare: ArrayLike,
    lle_per_period: float | None = None,
    *,
    lle_interval: tuple[float, float] | None = None,
    m_max: int = Thresholds.m_max,
    period_rtol: float = Thresholds.period_rtol,
    scale_floor_rtol: float = Thresholds.scale_floor_rtol,
    cluster_tol: float = Thresholds.cluster_tol,
    cluster_diameter_max: float = Thresholds.cluster_diameter_max,
    max_cluster_points: int = Thresholds.max_cluster_points,
    lle_threshold: float = Thresholds.lle_threshold,
    growth_lines: float = Thresholds.growth_lines,
    growth_broadband: float = Thresholds.growth_broadband,
    k_chaotic: float = Thresholds.k_chaotic,
    observable: Literal["pca"] | int = Thresholds.observable,
    zero_one_stride: int | str = Thresholds.zero_one_stride,
    seed: int = Thresholds.seed,
) -> RegimeResult:
    """Classify a post-transient stroboscopic record (decision rule: module docstring).

    Parameters
    ----------
    poincare
        Samples, shape ``(n_periods, n_components)``, one row per forcing period
        after the transient; finite; at least :data:`MIN_SAMPLES` rows.
    lle_per_period
        Largest Lyapunov exponent **per forcing period** (per map iteration),
        or ``None``.  Convert a rate per unit time with
        :func:`lle_per_period_from_rate`.
    lle_interval
        Confidence interval ``(lo, hi)`` of ``lambda_1 T`` (per forcing period), or
        ``None``; when given, the decision between chaos and regular motion is taken
        from it (rule 2a of the module docstring) and ``lle_per_period`` is the point
        estimate reported.
    m_max
        Largest period tested.
    period_rtol
        Tolerance of the period test, relative to the per-component scale.
    scale_floor_rtol
        Floor of the per-component scale relative to the state magnitude
        (:func:`analysis.poincare.component_scales`).
    cluster_tol, cluster_diameter_max, max_cluster_points
        Single-linkage distance (scaled units), largest cluster diameter for
        a cluster to count as a *point*, and number of (last) samples clustered
        (memory O(n^2)).
    lle_threshold
        ``lle_per_period > lle_threshold`` counts as clearly positive (chaos);
        ``lle_per_period <= lle_threshold`` rules chaos out.
    growth_lines, growth_broadband
        Spectral growth exponent below ``growth_lines`` -> discrete lines; above
        ``growth_broadband`` -> broadband; in between -> ambiguous.
    k_chaotic
        0-1 test: ``K > k_chaotic`` votes chaotic, otherwise regular.
    observable
        Scalar observable for the 0-1 and spectral tests (``"pca"`` or column).
    zero_one_stride
        Stride for the 0-1 test (``"auto"``: decorrelation stride).
    seed
        Seed of the 0-1 test's random ``c`` values.

    Returns
    -------
    RegimeResult

    Raises
    ------
    ValueError
        Invalid ``poincare`` (not 2-D, fewer than :data:`MIN_SAMPLES` rows,
        non-finite) or non-finite ``lle_per_period``.
    """
    th = Thresholds(m_max, period_rtol, scale_floor_rtol, cluster_tol, cluster_diameter_max,
                    max_cluster_points, lle_threshold, growth_lines, growth_broadband, k_chaotic,
                    observable, zero_one_stride, seed)
    x = validate_samples(poincare, name="poincare", min_samples=MIN_SAMPLES)
    lle = _checked_lle(lle_per_period)
    interval = _checked_interval(lle_interval, lle)
    ev = _evidence(x, lle, th)
    if interval is not None:
        ev.indicators["lle_lo"], ev.indicators["lle_hi"] = interval
    votes = _votes(ev, lle, th)

    def result(label: Label, period: int | None, reason: str) -> RegimeResult:
        return RegimeResult(label=label, period=period, reason=reason,
                            indicators=MappingProxyType(ev.indicators), votes=MappingProxyType(votes))

    if interval is not None:
        votes["lle"] = ("positive" if interval[0] > th.lle_threshold else
                        "non-positive" if interval[1] <= th.lle_threshold else "undetermined")
    periodic = _periodic(ev, lle if interval is None else interval[0], th)
    if periodic is not None:
        if interval is not None and ev.per.period is None and interval[0] > th.lle_threshold:
            return result(UNDETERMINED, None, _small_chaos_reason(ev, lle, interval, th))
        return result(PERIODIC, *periodic)
    if interval is not None:
        return result(*_aperiodic_interval(ev, votes, lle, interval, th))
    return result(*_aperiodic(ev, votes, lle, th))


def poincare_says_chaotic(poincare: ArrayLike) -> bool:
    """Whether a record says chaos without an exponent: :func:`classify` (no exponent, default
    thresholds) does not call it periodic, its spectrum is broadband (growth above
    ``growth_broadband``) and its 0-1 test reads ``K`` above ``k_chaotic`` (both on the series
    and, where a period-``m`` pattern was found, on its residual: the votes of
    ``RegimeResult.votes``).  The Lyapunov stage asks the RK4 pair's second opinion on an
    ``expo`` pair's positive or straddling interval where this is ``False``
    (:func:`analysis.pipeline.stages.lyapunov_runs`, ``numerics.lyapunov.confirm``)."""
    res = classify(poincare)
    return (res.label != PERIODIC and res.votes["spectrum"] == "broadband"
            and res.votes["zero_one"] == "chaotic")


def _small_chaos_reason(ev: _Evidence, lle: float, interval: tuple[float, float],
                        th: Thresholds) -> str:
    """Reason of ``undetermined`` for a record that only the cluster route calls periodic
    (tight clusters, the sample-wise period test failed) while the exponent's interval lies
    above the threshold: the clusters are a chaotic set of small extent, not a periodic orbit
    with noise, or the reverse; the record does not tell."""
    clu = ev.clu
    return (f"CONFLICT: the points form {clu.n_clusters} tight clusters (diameter "
            f"{clu.max_diameter:.1e} of the spread) visited with period {clu.label_period}, but "
            f"the sample-wise period test failed (residual {ev.per.best_residual:.2g} > "
            f"{th.period_rtol:g}) and lambda_1={lle:.3g}/period, interval [{interval[0]:.3g}, "
            f"{interval[1]:.3g}], lies above {th.lle_threshold:g}: a chaotic set smaller than "
            f"the cluster tolerance or a noisy periodic orbit")


def _checked_interval(interval, lle: float | None) -> tuple[float, float] | None:
    if interval is None:
        return None
    try:
        lo, hi = (float(v) for v in interval)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"lle_interval must be a pair (lo, hi) of floats: {exc}") from exc
    if np.isnan(lo) or np.isnan(hi) or lo > hi or lo == np.inf:
        raise ValueError(f"lle_interval must be an ordered pair (lo <= hi), got {interval!r}")
    if lle is None:
        raise ValueError("lle_interval needs lle_per_period (the point estimate)")
    return lo, hi

def _checked_lle(lle_per_period) -> float | None:
    if lle_per_period is None:
        return None
    try:
        lle = float(lle_per_period)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"lle_per_period must be a float or None: {exc}") from exc
    if not (np.isfinite(lle) or lle == -np.inf):  # -inf: copies coincided (contraction)
        raise ValueError(f"lle_per_period must be finite; got {lle_per_period!r}")
    return lle


def _evidence(x: np.ndarray, lle: float | None, th: Thresholds) -> _Evidence:
    """Every indicator of the record (module docstring, items 1-4)."""
    scales = component_scales(x, floor_rtol=th.scale_floor_rtol)
    per = detect_period(x, m_max=th.m_max, rtol=th.period_rtol, scales=scales)
    clu = cluster_points(x, tol=th.cluster_tol, scales=scales, max_points=th.max_cluster_points,
                         m_max=th.m_max)
    phi = scalar_observable(x, th.observable)
    zo = zero_one_test(phi, stride=th.zero_one_stride, seed=th.seed)
    spec = spectral_lines(phi)
    pat = periodic_pattern(x, m_max=th.m_max)
    if pat.period is not None:
        phi_res = scalar_observable(pat.residual, th.observable)
        spec_res = spectral_lines(phi_res)
        zo_res = zero_one_test(phi_res, stride=th.zero_one_stride, seed=th.seed)
        growth = max(spec.growth, spec_res.growth)
        k_val = max(zo.K, zo_res.K)
    else:
        spec_res = zo_res = None
        growth, k_val = spec.growth, zo.K
    indicators: dict[str, float | int | None] = {
        "n_samples": x.shape[0],
        "period_test": per.period,
        "period_residual": per.best_residual,
        "n_clusters": clu.n_clusters,
        "cluster_diameter": clu.max_diameter,
        "cluster_separation": clu.min_separation,
        "cluster_period": clu.label_period,
        "K": zo.K,
        "K_stride": zo.stride,
        "spectral_growth": spec.growth,
        "spectral_entropy": spec.entropy,
        "pattern_period": pat.period,
        "pattern_explained": None if pat.period is None else float(pat.explained[pat.period - 1]),
        "K_residual": None if zo_res is None else zo_res.K,
        "spectral_growth_residual": None if spec_res is None else spec_res.growth,
        "lle_per_period": lle,
    }
    return _Evidence(per, clu, pat, growth, k_val, indicators)


def _clusters_are_points(ev: _Evidence, th: Thresholds) -> bool:
    return ev.clu.max_diameter <= th.cluster_diameter_max


def _votes(ev: _Evidence, lle: float | None, th: Thresholds) -> dict[str, str]:
    """What each indicator says on its own."""
    per, clu = ev.per, ev.clu
    votes: dict[str, str] = {}
    votes["period_test"] = f"period {per.period}" if per.period else "no period"
    if clu.label_period is not None and _clusters_are_points(ev, th):
        votes["clusters"] = f"{clu.n_clusters} point cluster(s), itinerary period {clu.label_period}"
    else:
        votes["clusters"] = f"{clu.n_clusters} cluster(s), not a finite point set"
    if ev.growth < th.growth_lines:
        votes["spectrum"] = "lines"
    elif ev.growth > th.growth_broadband:
        votes["spectrum"] = "broadband"
    else:
        votes["spectrum"] = "ambiguous"
    votes["zero_one"] = "chaotic" if ev.k_val > th.k_chaotic else "regular"
    if lle is None:
        votes["lle"] = "not given"
    elif lle > th.lle_threshold:
        votes["lle"] = "positive"
    else:
        votes["lle"] = "non-positive"
    return votes


def _periodic(ev: _Evidence, lle: float | None, th: Thresholds) -> tuple[int, str] | None:
    """Rule 1: ``(m, reason)`` of a periodic record, else ``None``."""
    per, clu = ev.per, ev.clu
    if per.period is not None:
        m = per.period
        why = (
            f"x[i+{m}] matches x[i] for all i within {per.best_residual:.1e} of the "
            f"spread (tolerance {th.period_rtol:g}); {clu.n_clusters} Poincare cluster(s)"
        )
    elif clu.label_period is not None and _clusters_are_points(ev, th):
        m = clu.label_period
        why = (
            f"points form {clu.n_clusters} tight clusters (diameter {clu.max_diameter:.1e} "
            f"of the spread) visited with period {m}; sample-wise period test failed "
            f"(residual {per.best_residual:.2g} > {th.period_rtol:g}), noise suspected"
        )
    else:
        return None
    if lle is not None and lle > th.lle_threshold:
        why += (f"; CONFLICT: lambda_1 (with an interval: its lower bound) = {lle:.3g}/period > "
                f"{th.lle_threshold:g} ignored")
    return m, f"period {m}: {why}"


def _aperiodic(ev: _Evidence, votes: dict[str, str], lle: float | None,
               th: Thresholds) -> tuple[Label, None, str]:
    """Rule 2: quasi-periodic or chaotic, ``(label, None, reason)``."""
    facts = f"spectral growth {ev.growth:.2f} ({votes['spectrum']}), 0-1 test K={ev.k_val:.2f}"
    pat = ev.pat
    if pat.period is not None:
        facts += (
            f" (larger of the series and its residual after removing the period-"
            f"{pat.period} pattern, {100 * pat.explained[pat.period - 1]:.1f}% of the variance)"
        )
    if lle is not None:
        facts += f"; lambda_1={lle:.3g}/period"
    nonper = f"no period <= {th.m_max} (best residual {ev.per.best_residual:.2g})"
    thr = th.lle_threshold
    if lle is not None and lle > thr:
        if votes["spectrum"] == "lines" and votes["zero_one"] == "regular":
            return (QUASI_PERIODIC, None,
                    f"{nonper}; CONFLICT: lambda_1={lle:.3g}/period > {thr:g} but "
                    f"discrete spectrum and regular 0-1 test ({facts}); labelled by the data")
        return CHAOTIC, None, f"{nonper}; lambda_1={lle:.3g}/period > {thr:g} ({facts})"
    if lle is not None:
        note = ""
        if votes["spectrum"] == "broadband" and votes["zero_one"] == "chaotic":
            note = "; CONFLICT: broadband spectrum and 0-1 test say chaotic"
        return (QUASI_PERIODIC, None,
                f"{nonper}; lambda_1={lle:.3g}/period <= {thr:g} rules out chaos ({facts}){note}")
    if votes["spectrum"] == "lines":
        return QUASI_PERIODIC, None, f"{nonper}; discrete spectrum ({facts})"
    if votes["spectrum"] == "broadband":
        return CHAOTIC, None, f"{nonper}; broadband spectrum ({facts})"
    label: Label = CHAOTIC if votes["zero_one"] == "chaotic" else QUASI_PERIODIC
    return label, None, f"{nonper}; spectrum ambiguous, 0-1 test decides ({facts})"


def _aperiodic_interval(ev: _Evidence, votes: dict[str, str], lle: float,
                        interval: tuple[float, float], th: Thresholds) -> tuple[Label, None, str]:
    """Rule 2a: chaotic, quasi-periodic or undetermined from the exponent's confidence
    interval, ``(label, None, reason)``."""
    lo, hi = interval
    thr = th.lle_threshold
    facts = f"spectral growth {ev.growth:.2f} ({votes['spectrum']}), 0-1 test K={ev.k_val:.2f}"
    if ev.pat.period is not None:
        facts += f" (and of the residual of the period-{ev.pat.period} pattern)"
    est = f"lambda_1={lle:.3g}/period, interval [{lo:.3g}, {hi:.3g}]"
    nonper = f"no period <= {th.m_max} (best residual {ev.per.best_residual:.2g})"
    data_regular = votes["spectrum"] == "lines" and votes["zero_one"] == "regular"
    data_chaotic = votes["spectrum"] == "broadband" and votes["zero_one"] == "chaotic"
    if lo > thr:
        if data_regular:
            return (UNDETERMINED, None, f"{nonper}; CONFLICT: {est} above {thr:g} but discrete "
                    f"spectrum and regular 0-1 test ({facts})")
        return CHAOTIC, None, f"{nonper}; {est} above {thr:g} ({facts})"
    if hi <= thr:
        if data_chaotic:
            return (UNDETERMINED, None, f"{nonper}; CONFLICT: {est} at or below {thr:g} but "
                    f"broadband spectrum and chaotic 0-1 test ({facts})")
        if hi < -thr:
            return (UNDETERMINED, None, f"{nonper}; {est} below -{thr:g}: the motion contracts, so "
                    f"it is neither a torus (lambda_1 = 0) nor chaos; a periodic orbit of a period "
                    f"above {th.m_max} or a remnant still decaying ({facts})")
        return QUASI_PERIODIC, None, f"{nonper}; {est} at or below {thr:g} rules out chaos ({facts})"
    return (UNDETERMINED, None, f"{nonper}; {est} straddles the threshold {thr:g}: the record "
            f"does not decide between chaos and a torus ({facts})")

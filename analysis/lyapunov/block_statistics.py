r"""Largest Lyapunov exponent as a statistic: block means of a long Benettin record.

A single finite-time window gives one draw of a fluctuating quantity: at a weakly chaotic
attractor of the beam (``lambda_1 T`` 0.1-0.5 per forcing period) 25-period estimates scatter
over 0.0-1.0, and a label decided by one of them is decided by chance.  Here the exponent is
the mean of the growth rates of consecutive blocks of one long renormalised (Benettin) record,
with its standard error and a Student-t confidence interval, and the decision is made only
when the interval is clear of a stated margin:

* the record ``ln eps_k`` (carried rescaling factors included, so it is the log error of the
  linearised dynamics) is sampled at period ends ``k = 0 .. K``;
* the first ``burn_in`` periods are discarded (alignment of the separation with the most
  unstable direction, and the slow start of a neutral direction's linear growth);
* the rest is cut into blocks of ``block`` periods; block ``b``'s rate is
  ``r_b = (ln eps_{end} - ln eps_{start}) / (block T)``;
* ``mean = mean_b r_b`` (which equals the rate over the whole measured stretch),
  ``se = std_b(r_b) / sqrt(B)`` (``ddof = 1``), interval ``mean -+ t_{(1+c)/2, B-1} se``.

Blocks of a chaotic record are treated as independent: a block (25 periods by default) is long
against the decorrelation time of a separation growing at ``lambda_1 T >= 0.05`` per period
(one e-fold in at most 20 periods).  Correlated blocks would make ``se`` too small; the
pipeline's margin (below) and the minimum number of blocks guard against over-reading a short
record.

Decision, in units of the forcing period (``lambda_1 T``), with the margin ``m``:
``positive`` when ``lo > m``, ``non-positive`` when ``hi <= m``, else ``undetermined``.

A record that is run one block further while undetermined (:class:`BlockPlan`) is a
sequential test: looked at after ``min_blocks``, ``min_blocks + 1``, ... ``max_blocks``
blocks, it would call a record whose true rate is the margin positive (or non-positive) more
often than one interval's ``(1 - c) / 2``.  A :class:`BlockPlan` therefore widens the interval
of each look to a group-sequential boundary (:func:`look_errors`; Jennison & Turnbull 2000,
ch. 2 and 11): each look's interval is taken at a nominal two-sided error ``alpha_k = 2
Phi(-C w_k)``, ``w_k = 1`` (Pocock) or ``sqrt(K / k)`` (O'Brien-Fleming, ``K = max_blocks``),
and ``C`` is calibrated so that on independent normal block rates whose mean is the margin
some look decides with probability ``1 - c`` (``(1 - c) / 2`` per side).  The intervals are
then repeated confidence intervals: on such records all looks' intervals hold the true rate
together with probability ``c``, so over records the interval each stops at holds it with at
least that probability (a marginal guarantee, not one conditional on the look that stopped).
A neutral direction (torus, undamped stuck modes, a periodic orbit's phase) has zero exponent
but finite-time growth ``ln(t2/t1) / (t2 - t1)`` when it grows linearly (shear); after a
25-period burn-in that is at most ``ln 2 / 25 = 0.028`` per period in the first block and
falls below ``0.012`` for the mean over 200 periods, under the default margin ``0.05``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

__all__ = ["BlockPlan", "LLEStatistics", "POSITIVE", "NON_POSITIVE", "UNDETERMINED", "DIVERGED",
           "BOUNDARIES", "block_statistics", "boundary_constant", "decide", "look_errors"]

POSITIVE = "positive"
NON_POSITIVE = "non-positive"
UNDETERMINED = "undetermined"
DIVERGED = "diverged"

#: Group-sequential boundaries of :class:`BlockPlan` (:func:`look_errors`); ``none`` takes every
#: look at the stated level (the rule until results version 22).
BOUNDARIES = ("obrien-fleming", "pocock", "none")

#: Simulated sequential tests behind :func:`boundary_constant` (fixed seed: the same constant in
#: every process); the constant is rounded up to :data:`_ROUND`.
_N_SIMULATED, _SEED, _ROUND = 100_000, 20261128, 0.01


def _weights(boundary: str, looks: np.ndarray, max_blocks: int) -> np.ndarray:
    """``w_k`` of the boundary ``C w_k`` on the normal scale at the looks ``k`` (blocks)."""
    if boundary == "pocock":
        return np.ones(looks.size)
    if boundary == "obrien-fleming":
        return np.sqrt(max_blocks / looks)
    raise ValueError(f"boundary must be one of {BOUNDARIES[:2]} here, got {boundary!r}")


@lru_cache(maxsize=32)
def boundary_constant(boundary: str, min_blocks: int, max_blocks: int, confidence: float) -> float:
    """The constant ``C`` of a group-sequential boundary: looks after ``min_blocks ..
    max_blocks`` blocks, each taking the Student-t interval at the nominal two-sided level
    ``1 - alpha_k``, ``alpha_k = 2 Phi(-C w_k)`` (:func:`look_errors`), decide a record of
    independent normal block rates with mean at the margin with probability ``1 - confidence``
    in all.

    Computed from :data:`_N_SIMULATED` simulated records (the looks' t statistics are pivotal:
    neither the rates' mean nor their spread enters): ``C`` is the ``confidence`` quantile of
    ``max_k z_k / w_k``, ``z_k`` the normal quantile of look ``k``'s two-sided t p-value,
    rounded up to :data:`_ROUND` (so the stated level is held, not exceeded, up to the
    simulation's error).  One look: ``Phi^-1((1 + confidence) / 2)`` exactly.
    """
    from scipy.special import ndtri, stdtr

    looks = np.arange(int(min_blocks), int(max_blocks) + 1)
    w = _weights(boundary, looks, int(max_blocks))
    if looks.size == 1:
        return float(ndtri(0.5 + confidence / 2.0) / w[0])
    rng = np.random.default_rng(_SEED)
    total = np.zeros(_N_SIMULATED)
    total_sq = np.zeros(_N_SIMULATED)
    u = np.full(_N_SIMULATED, -np.inf)
    for k in range(1, int(max_blocks) + 1):
        x = rng.standard_normal(_N_SIMULATED)
        total += x
        total_sq += x * x
        if k < min_blocks:
            continue
        mean = total / k
        sd = np.sqrt(np.maximum(total_sq - k * mean * mean, 0.0) / (k - 1))
        tail = stdtr(k - 1, -np.abs(mean) * math.sqrt(k) / sd)  # one-sided p-value of |t|
        np.maximum(u, -ndtri(tail) / w[k - min_blocks], out=u)
    c = float(np.quantile(u, confidence))
    return math.ceil(c / _ROUND) * _ROUND


def look_errors(boundary: str, min_blocks: int, max_blocks: int, confidence: float) -> np.ndarray:
    """Nominal two-sided error ``alpha_k`` of each look's interval, after ``min_blocks ..
    max_blocks`` blocks (module docstring): ``2 Phi(-C w_k)`` with :func:`boundary_constant`;
    ``boundary = "none"``: ``1 - confidence`` at every look.  Errors, not levels: the first
    looks of a wide O'Brien-Fleming boundary have ``alpha_k`` far below the spacing of doubles
    near 1."""
    looks = np.arange(int(min_blocks), int(max_blocks) + 1)
    if boundary == "none":
        return np.full(looks.size, 1.0 - float(confidence))
    from scipy.special import ndtr

    c = boundary_constant(boundary, int(min_blocks), int(max_blocks), float(confidence))
    return 2.0 * ndtr(-c * _weights(boundary, looks, int(max_blocks)))




def _whole_blocks(n_samples: int, burn_in: int, block: int) -> int:
    """Whole blocks of ``block`` periods in a record of ``n_samples`` period ends after the
    burn-in (a trailing partial block is left out)."""
    return (n_samples - 1 - burn_in) // block

@dataclass(frozen=True)
class BlockPlan:
    """How long a record is run: ``burn_in + min_blocks * block`` periods first, then one block
    at a time while the verdict is :data:`UNDETERMINED`, up to ``burn_in + max_blocks * block``.

    block, burn_in : periods per block, periods discarded at the start.
    min_blocks, max_blocks : blocks measured at least / at most (``2 <= min <= max``).
    confidence : two-sided level of the interval the record stops at (of the sequential test,
        through ``boundary``).
    margin : per forcing period (:func:`decide`).
    boundary : one of :data:`BOUNDARIES`: each look's interval is widened to this
        group-sequential boundary (module docstring), so that a record whose rate is the
        margin gets either verdict with probability ``(1 - confidence) / 2`` over all looks
        together; ``none``: every look at ``confidence`` (more looks, more errors:
        docs/lyapunov.md, section 10).
    """

    block: int = 25
    burn_in: int = 25
    min_blocks: int = 3
    max_blocks: int = 16
    confidence: float = 0.95
    margin: float = 0.05
    boundary: str = "obrien-fleming"

    def __post_init__(self):
        if not (self.block >= 1 and self.burn_in >= 0 and 2 <= self.min_blocks <= self.max_blocks):
            raise ValueError(f"BlockPlan needs block >= 1, burn_in >= 0, 2 <= min_blocks <= "
                             f"max_blocks; got {self}")
        if not 0.0 < self.confidence < 1.0:
            raise ValueError(f"BlockPlan.confidence must be in (0, 1), got {self.confidence!r}")
        if self.boundary not in BOUNDARIES:
            raise ValueError(f"BlockPlan.boundary must be one of {BOUNDARIES}, got {self.boundary!r}")

    @property
    def first_periods(self) -> int:
        """Periods of the first run."""
        return self.burn_in + self.min_blocks * self.block

    @property
    def max_periods(self) -> int:
        """Periods of the longest record."""
        return self.burn_in + self.max_blocks * self.block

    def look_error(self, n_blocks: int) -> float:
        """Nominal two-sided error of the interval after ``n_blocks`` blocks
        (:func:`look_errors`; a record shorter than ``min_blocks`` blocks is taken at the first
        look's, one longer than ``max_blocks`` at the last's)."""
        errors = look_errors(self.boundary, self.min_blocks, self.max_blocks, self.confidence)
        return float(errors[min(max(int(n_blocks), self.min_blocks), self.max_blocks) - self.min_blocks])

    def statistics(self, log_err: np.ndarray, period: float) -> LLEStatistics:
        """:func:`block_statistics` of ``log_err`` with this plan's settings, its interval at
        the error of its look (:meth:`look_error`)."""
        n_blocks = _whole_blocks(np.asarray(log_err).size, self.burn_in, self.block)
        return block_statistics(log_err, period, block=self.block, burn_in=self.burn_in,
                                confidence=self.confidence, margin=self.margin,
                                look_error=self.look_error(n_blocks))

    def continues(self, stats: LLEStatistics) -> bool:
        """Whether a record with these statistics is run one block further: its verdict is
        :data:`UNDETERMINED` and it is shorter than :attr:`max_periods`."""
        return stats.verdict == UNDETERMINED and stats.burn_in + stats.n_periods < self.max_periods

    def sequential(self, log_err: np.ndarray, period: float) -> LLEStatistics:
        """The statistics this plan stops at on a given record (at least :attr:`max_periods`
        long): those of the first :attr:`first_periods`, then one block more while
        :meth:`continues`, as the beam's records are run
        (:func:`analysis.lyapunov.beam.beam_lle`, whose first run is :attr:`first_periods` long
        where the Stefanski window is not longer).  The verdict is taken at every block from
        ``min_blocks`` on, so its error rates are those of a sequential test, held at
        ``(1 - confidence) / 2`` per side at the margin by :attr:`boundary` (docs/lyapunov.md,
        section 10)."""
        log_err = np.asarray(log_err, dtype=float)
        if log_err.size - 1 < self.max_periods:
            raise ValueError(f"the record holds {log_err.size - 1} periods, the plan needs "
                             f"{self.max_periods}")
        n = self.first_periods
        stats = self.statistics(log_err[:n + 1], period)
        while self.continues(stats):
            n += self.block
            if n > log_err.size - 1:  # only a stopping rule that ignores the cap gets here
                raise RuntimeError(f"BlockPlan.continues asked for {n} periods, past the cap "
                                   f"{self.max_periods}")
            stats = self.statistics(log_err[:n + 1], period)
        return stats


@dataclass(frozen=True)
class LLEStatistics:
    """Block statistics of ``lambda_1`` (rates per unit time; multiply by ``T`` for per period).

    mean, se : mean block rate and its standard error.
    lo, hi : the confidence interval ``mean -+ t se``, ``t`` at the two-sided error
        ``look_error``.
    blocks : the block rates, in time order.
    n_periods : periods measured (after the burn-in), ``len(blocks) * block``.
    block, burn_in : periods per block and periods discarded at the start.
    confidence : two-sided confidence level of ``[lo, hi]`` as the stopping interval of a
        :class:`BlockPlan`'s sequential test (of one fixed-length record without a plan).
    look_error : the nominal two-sided error its t quantile was taken at (``1 - confidence``
        without a plan or with ``boundary = "none"``; smaller on a group-sequential boundary).
    verdict : :data:`POSITIVE`, :data:`NON_POSITIVE`, :data:`UNDETERMINED` (interval
        straddles the margin) or :data:`DIVERGED` (the record is not finite).
    margin : the margin per forcing period the verdict was taken against.
    period : forcing period ``T``.
    """

    mean: float
    se: float
    lo: float
    hi: float
    blocks: np.ndarray
    n_periods: int
    block: int
    burn_in: int
    confidence: float
    verdict: str
    margin: float
    period: float
    look_error: float

    @property
    def per_period(self) -> tuple[float, float, float, float]:
        """``(mean, se, lo, hi)`` times the forcing period (growth per map iteration)."""
        T = self.period
        return self.mean * T, self.se * T, self.lo * T, self.hi * T

    def summary(self) -> str:
        """One line: ``lambda_1 T = mean +- se (95 % CI [lo, hi]) over N periods: verdict``
        (with the look's nominal level where it differs)."""
        m, s, lo, hi = self.per_period
        look = ("" if math.isclose(self.look_error, 1.0 - self.confidence, rel_tol=1e-9)
                else f", this look's two-sided error {self.look_error:.2g}")
        return (f"lambda_1 T = {m:.3g} +- {s:.2g} ({100 * self.confidence:.0f} % CI{look} "
                f"[{lo:.3g}, {hi:.3g}]) over {self.n_periods} periods in {len(self.blocks)} "
                f"blocks, margin {self.margin:g}: {self.verdict}")


def decide(lo_per_period: float, hi_per_period: float, margin: float) -> str:
    """The verdict of an interval ``[lo, hi]`` (per forcing period) against ``margin``."""
    if not (math.isfinite(lo_per_period) and math.isfinite(hi_per_period)):
        return DIVERGED
    if lo_per_period > margin:
        return POSITIVE
    if hi_per_period <= margin:
        return NON_POSITIVE
    return UNDETERMINED


def block_statistics(log_err: np.ndarray, period: float, *, block: int = 25, burn_in: int = 25,
                     confidence: float = 0.95, margin: float = 0.05,
                     look_error: float | None = None) -> LLEStatistics:
    """Block statistics of one renormalised record (module docstring).

    log_err : ``ln eps`` at the period ends ``0 .. K`` (``K >= burn_in + 2 block``), rescaling
        factors included (:func:`beamsim.coupled_copies.run_copies` with ``renorm_period``).
    period : forcing period ``T`` (time units of the rates).
    block, burn_in : periods per block, periods discarded at the start; a trailing partial
        block is left out.
    confidence : two-sided level of the interval, in (0, 1).
    margin : per forcing period (see :func:`decide`).
    look_error : the nominal two-sided error of the t quantile when it is not ``1 -
        confidence`` (a look of a sequential test: :meth:`BlockPlan.statistics`).
    """
    log_err = np.asarray(log_err, dtype=float)
    block, burn_in = int(block), int(burn_in)
    if block < 1 or burn_in < 0:
        raise ValueError(f"block must be >= 1 and burn_in >= 0, got {block}, {burn_in}")
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    look = 1.0 - confidence if look_error is None else float(look_error)
    if not 0.0 < look < 1.0:
        raise ValueError(f"look_error must be in (0, 1), got {look_error!r}")
    if not period > 0:
        raise ValueError(f"period must be > 0, got {period!r}")
    n_blocks = _whole_blocks(log_err.size, burn_in, block)
    if n_blocks < 2:
        raise ValueError(f"log_err holds {log_err.size - 1} periods: need burn_in + 2 blocks = "
                         f"{burn_in + 2 * block}")
    ends = log_err[burn_in:burn_in + n_blocks * block + 1:block]
    nan, ninf = float("nan"), float("-inf")
    if np.any(np.isnan(log_err) | (log_err == np.inf)):
        return LLEStatistics(nan, nan, nan, nan, np.full(n_blocks, nan), n_blocks * block, block,
                             burn_in, confidence, DIVERGED, margin, period, look)
    if np.any(np.isneginf(ends)):  # the copy coincided with the drive (round-off): contraction
        return LLEStatistics(ninf, 0.0, ninf, ninf, np.full(n_blocks, ninf), n_blocks * block,
                             block, burn_in, confidence, NON_POSITIVE, margin, period, look)
    blocks = np.diff(ends) / (block * period)
    mean = float(blocks.mean())
    se = float(blocks.std(ddof=1) / math.sqrt(n_blocks))
    from scipy.special import stdtrit  # Student's t quantile (what scipy.stats.t.ppf calls); not
    # scipy.stats, and not at the top: slow to import, and the Snakefile's plan imports this

    half = -float(stdtrit(n_blocks - 1, look / 2.0)) * se  # the upper quantile, from the tail
    lo, hi = mean - half, mean + half
    return LLEStatistics(mean, se, lo, hi, blocks, n_blocks * block, block, burn_in, confidence,
                         decide(lo * period, hi * period, margin), margin, period, look)

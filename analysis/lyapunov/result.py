"""The result type every Lyapunov estimator returns (generic, beam, nolds)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["LLEResult"]


@dataclass
class LLEResult:
    """Largest Lyapunov exponent and how it was obtained.

    Attributes
    ----------
    value
        lambda_1 estimate in 1 / (time unit of the rhs).  ``nan`` when no
        verdict could be reached (see ``verdict``).
    method
        ``"stefanski"``, ``"benettin"`` or ``"nolds-rosenstein"``.
    verdict
        How the value was reached, in words, e.g. ``"chaotic: d_s bracketed"``
        or ``"non-chaotic: synchronised at d = 0 ..."``.
    chaotic
        True when the estimator found lambda_1 > 0 (Stefanski: the pair does
        not synchronise at d = 0; Benettin/nolds: value > 0).
    bracket
        Stefanski only: ``(d_lo, d_hi)``, the largest coupling found *not* to
        synchronise and the smallest found to synchronise (1/time unit).
    sync_error
        Stefanski only: RMS scaled synchronisation error |x - y| (relative to
        the attractor size, see ``scale``) sampled at ``sync_time`` for each
        coupling in ``sync_d`` of the last batch (and the d = 0 run first).
    sync_time, sync_d
        Sample times (from the start of the test window) and couplings of the
        rows of ``sync_error``.
    rounds
        Stefanski only: one dict per batch with the candidate couplings, the
        measured windowed error-change rate ``rate`` (1/time unit, negative =
        synchronising) and the boolean ``synced``.
    scale
        Per-component attractor size (standard deviation over the drive
        transient) used to make errors dimensionless.
    runtime
        Wall time in seconds (including the numba compile on first use of an
        rhs).
    n_rhs_evals
        Number of right-hand side evaluations, a machine-independent cost.
    extras
        Method-specific diagnostics (Benettin: running estimate and standard
        error; nolds: the divergence curve and fit).
    """

    value: float
    method: str
    verdict: str
    chaotic: bool
    bracket: tuple[float, float] | None = None
    sync_error: np.ndarray | None = None
    sync_time: np.ndarray | None = None
    sync_d: np.ndarray | None = None
    rounds: list[dict[str, Any]] = field(default_factory=list)
    scale: np.ndarray | None = None
    runtime: float = 0.0
    n_rhs_evals: int = 0
    extras: dict[str, Any] = field(default_factory=dict)

    def __float__(self) -> float:  # convenience: float(result)
        return float(self.value)

r"""Rosenstein's time-series estimate of the largest Lyapunov exponent (``nolds.lyap_r``).

Reference
---------
.. [R1993] M. T. Rosenstein, J. J. Collins, C. J. De Luca, "A practical method
   for calculating largest Lyapunov exponents from small data sets", Physica D
   65 (1993) 117-134.
"""

from __future__ import annotations

import functools
import importlib.util
import os
import time
from typing import Any, Callable

import numpy as np

from analysis.lyapunov.coupled_rk4 import check_positive_finite
from analysis.lyapunov.result import LLEResult

__all__ = ["nolds_lle"]


@functools.cache
def _load_lyap_r() -> Callable:
    """Return ``nolds.lyap_r`` (loaded once per process).

    nolds 0.6.3 fails to import on our Python 3.11 (``TypeError: 'nolds.datasets'
    is not a package``, CSchoel/nolds issue #80: ``importlib.resources.files``
    is called on a module).  ``lyap_r`` itself lives in ``nolds/measures.py``,
    which only needs numpy, so in that case the module is loaded on its own
    without running the package ``__init__``.  Loaded once per process: the failed import,
    repeated at every call, reset Python's warning registries (its ``catch_warnings``), so
    nolds' notes on the ``lag`` / ``min_tsep`` it picks itself were printed at every call (most
    of a default run's job logs: docs/pipeline.md, "Results version 17") and its module was
    executed again each time.
    """
    try:
        import nolds
        return nolds.lyap_r
    except TypeError:
        spec = importlib.util.find_spec("nolds")
        if spec is None or not spec.submodule_search_locations:
            raise
        path = os.path.join(list(spec.submodule_search_locations)[0], "measures.py")
        mspec = importlib.util.spec_from_file_location("_nolds_measures", path)
        mod = importlib.util.module_from_spec(mspec)
        mspec.loader.exec_module(mod)  # type: ignore[union-attr]
        return mod.lyap_r


def nolds_lle(series: Any, *, sample_dt: float, emb_dim: int = 10, lag: int | None = None,
              min_tsep: int | None = None, trajectory_len: int = 20, fit_offset: int = 0,
              min_neighbors: int = 20) -> LLEResult:
    r"""Rosenstein estimate (``nolds.lyap_r``) on a sampled scalar series.

    ``nolds.lyap_r`` returns the slope of the mean log divergence per *sample*
    (we call it with ``tau=1``); the exponent per time unit is
    :math:`\lambda_1 = \text{slope} / \Delta t_s` with ``sample_dt`` =
    :math:`\Delta t_s` the sampling interval (for a stroboscopic series, the
    forcing period).  ``fit="poly"`` (least squares) is always used: nolds'
    default RANSAC fit needs scikit-learn, which this project does not install.

    Note: nolds' own test (``test_lyap_lorenz``) asserts ``lyap_r`` = 2.4 +- 0.5
    for the Lorenz system; 2.4 is not lambda_1 (0.906 for (10, 28, 8/3)) but a
    dimension-like value (the project brief identifies it as the Kaplan-Yorke
    dimension; from Sprott's spectrum 0.9056, 0, -14.5723 the Kaplan-Yorke
    dimension is 2 + 0.9056/14.5723 = 2.06).  Do not use it as a reference.  Rosenstein's
    method is sensitive to ``emb_dim``, ``lag``, ``min_tsep`` and ``trajectory_len`` (the fit
    must cover the linear part of the divergence curve only); treat it as an
    order-of-magnitude cross-check, not a reference.

    Parameters
    ----------
    series
        1-D finite series (e.g. one state component).
    sample_dt
        Time between samples, in the time unit of the model.
    emb_dim, lag, min_tsep, trajectory_len, fit_offset, min_neighbors
        Passed to ``nolds.lyap_r`` (``lag``/``min_tsep`` in samples).

    Returns
    -------
    LLEResult
        ``extras`` holds ``slope_per_sample``, the divergence curve ``ks``,
        ``div_traj`` and the fitted ``poly``.
    """
    t_start = time.perf_counter()
    sample_dt = check_positive_finite("sample_dt", sample_dt)
    data = np.asarray(series, dtype=np.float64)
    if data.ndim != 1 or data.size < 10:
        raise ValueError(f"series must be a 1-D array with >= 10 samples, got shape {data.shape}")
    if not np.all(np.isfinite(data)):
        raise ValueError("series must be finite (found nan or inf)")
    lyap_r = _load_lyap_r()
    slope, (ks, div_traj, poly) = lyap_r(
        data, emb_dim=emb_dim, lag=lag, min_tsep=min_tsep, tau=1,
        min_neighbors=min_neighbors, trajectory_len=trajectory_len, fit="poly",
        debug_data=True, fit_offset=fit_offset)
    value = float(slope) / sample_dt
    return LLEResult(
        value=value, method="nolds-rosenstein",
        verdict=f"Rosenstein slope {float(slope):.4g} per sample / sample_dt {sample_dt:.4g}",
        chaotic=bool(value > 0), runtime=time.perf_counter() - t_start,
        extras={"slope_per_sample": float(slope), "ks": np.asarray(ks),
                "div_traj": np.asarray(div_traj), "poly": np.asarray(poly)})

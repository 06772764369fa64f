"""Largest Lyapunov exponent: the Stefanski synchronisation method (valid for discontinuous
systems), Benettin's two-trajectory estimate and Rosenstein's time-series estimate (nolds).

Modules, one idea each:

* :mod:`~analysis.lyapunov.sync_rule` -- the synchronisation decision and its constants (RK4
  coupling limit, round-off floor, zero-exponent resolution), shared by every estimate;
* :mod:`~analysis.lyapunov.sync_search` -- the bracket search for the synchronising coupling;
* :mod:`~analysis.lyapunov.coupled_rk4` -- drive + coupled responses of a numba rhs (RK4);
* :mod:`~analysis.lyapunov.generic` -- :func:`stefanski_lle`, :func:`benettin_lle`,
  :func:`sample_trajectory` for any numba rhs;
* :mod:`~analysis.lyapunov.beam` -- both estimates on the beam's full state, batched;
* :mod:`~analysis.lyapunov.nolds_rosenstein` -- :func:`nolds_lle`;
* :mod:`~analysis.lyapunov.reference_systems` -- validation cases with published exponents;
* :mod:`~analysis.lyapunov.result` -- :class:`LLEResult`, what every estimator returns.
"""

from analysis.lyapunov.coupled_rk4 import attractor_scale
from analysis.lyapunov.generic import benettin_lle, sample_trajectory, stefanski_lle
from analysis.lyapunov.nolds_rosenstein import nolds_lle
from analysis.lyapunov.result import LLEResult
from analysis.lyapunov.sync_search import sync_search

__all__ = ["LLEResult", "attractor_scale", "benettin_lle", "nolds_lle", "sample_trajectory",
           "stefanski_lle", "sync_search"]

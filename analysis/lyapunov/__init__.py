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

import importlib

# numpy only; imported here because the function ``sync_search`` has its module's name (a lazy
# name would be shadowed by the submodule once something imports it)
from analysis.lyapunov.result import LLEResult
from analysis.lyapunov.sync_search import sync_search

#: the names whose modules need numba or nolds, and the submodule each comes from, imported on
#: first use (PEP 562): a module that needs only, say, the block statistics (the pipeline's
#: plan, which every ``snakemake`` call parses; a classify job) does not pay for them
_EXPORTS = {"attractor_scale": "coupled_rk4", "benettin_lle": "generic", "sample_trajectory": "generic",
            "stefanski_lle": "generic", "nolds_lle": "nolds_rosenstein"}

__all__ = ["LLEResult", "attractor_scale", "benettin_lle", "nolds_lle", "sample_trajectory",
           "stefanski_lle", "sync_search"]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"analysis.lyapunov.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))

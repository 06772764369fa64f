"""analysis: Lyapunov exponents, Poincare sections, regime classification, pipeline stages
and figures.

Importing :mod:`beamsim` first pins BLAS/LAPACK to one thread (see ``beamsim/__init__.py``)
before numpy is loaded by any analysis module.
"""

import beamsim as _beamsim  # noqa: F401

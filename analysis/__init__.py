"""analysis: Lyapunov exponents, Poincare sections, regime classification, pipeline stages
and figures.

Importing :mod:`beamsim` first applies its single-threaded-BLAS default (see
``beamsim/__init__.py``) before numpy is loaded by any analysis module.
"""

import beamsim as _beamsim  # noqa: F401

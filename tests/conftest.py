"""Import beamsim before any test module imports numpy, so the tests run with the same
single-threaded BLAS as the library and the workflow (see beamsim/__init__.py)."""

import beamsim  # noqa: F401

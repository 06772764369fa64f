"""Import beamsim before any test module imports numpy, so the tests run with the same
single-threaded-BLAS default as the library and the workflow (see beamsim/__init__.py).

Before the xdist workers start, the controller compiles the simulator's and the Lyapunov
stage's numba kernels once into numba's on-disk cache: on a fresh clone every worker and every
Snakemake job of the workflow tests would otherwise compile the same kernels again, side by
side (docs/architecture.md, "Tests")."""

import beamsim  # noqa: F401


def pytest_sessionstart(session):
    if hasattr(session.config, "workerinput"):  # an xdist worker: the controller did it
        return
    from analysis.pipeline.stages import compile_kernels

    compile_kernels("simulate", methods=("expo", "rk4", "newmark"))
    compile_kernels("lyapunov")

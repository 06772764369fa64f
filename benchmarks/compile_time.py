"""Benchmark: how long a fresh install compiles the pipeline's kernels (an empty numba cache).

Run:  .venv/bin/python benchmarks/compile_time.py [--alone]          (about 1-4 minutes)

The default run's first two jobs are ``compile_kernels`` for the simulate and the Lyapunov
stage (``analysis.pipeline.stages.compile_kernels``), side by side on the two cores, each one
thread; no chunk job starts before both are done.  This runs them the same way: two processes
into one empty ``NUMBA_CACHE_DIR``, with the default config's integrators (simulate: ``expo``
and the RK4 fallback; Lyapunov: the RK4 copies, then the ``expo`` copies), and prints each
process's wall time.  With ``--alone`` it also compiles each stage alone into an empty cache,
one after the other, which shows how much the two jobs share through the cache.

Each process also lists the compiled functions of the project that numba compiled for more
than one signature in it.  A second signature is compiled code, but it can be one no code
calls: a variable that starts as a constant (``slot = -1``) is a ``Literal`` type while numba's
type inference first resolves a call in a loop, and numba compiles a specialisation for it
besides the ``int64`` one that runs (docs/performance.md, "Compilation").
Results: docs/performance.md ("Compilation").
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

#: the default config's integrators per stage (``Plan.simulation_methods``,
#: ``Plan.lyapunov_methods``)
STAGES = {"simulate": ("expo", "rk4"), "lyapunov": ("expo",)}

_CHILD = """
import sys
from numba.core.registry import CPUDispatcher
from analysis.pipeline.stages import compile_kernels
stage, methods = sys.argv[1], tuple(sys.argv[2].split(","))
t = compile_kernels(stage, methods)
multi = []
for name in ("common", "expo", "expo_copies", "copies", "rk4", "bundles", "real_eig"):
    mod = __import__("beamsim.kernels." + name, fromlist=["x"])
    for fname, obj in vars(mod).items():
        if isinstance(obj, CPUDispatcher) and obj.__module__ == mod.__name__:
            if len(obj.signatures) > 1:
                multi.append(f"{name}.{fname}: {len(obj.signatures)}")
print(f"{t:.1f}")
print("; ".join(multi) or "none")
"""


def _start(stage: str, cache: str) -> subprocess.Popen:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    return subprocess.Popen([sys.executable, "-c", _CHILD, stage, ",".join(STAGES[stage])],
                            env=env, stdout=subprocess.PIPE, text=True)


def _finish(proc: subprocess.Popen) -> tuple[float, str]:
    out, _ = proc.communicate()
    if proc.returncode:
        raise RuntimeError(f"compile process failed ({proc.returncode})")
    t, multi = out.strip().splitlines()[-2:]
    return float(t), multi


def side_by_side() -> dict[str, tuple[float, str]]:
    """Both stages' compile jobs at once into one empty cache (as the pipeline runs them)."""
    with tempfile.TemporaryDirectory() as cache:
        procs = {stage: _start(stage, cache) for stage in STAGES}
        return {stage: _finish(p) for stage, p in procs.items()}


def alone() -> dict[str, tuple[float, str]]:
    """Each stage alone into an empty cache of its own, one after the other."""
    res = {}
    for stage in STAGES:
        with tempfile.TemporaryDirectory() as cache:
            res[stage] = _finish(_start(stage, cache))
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--alone", action="store_true", help="also each stage alone")
    args = ap.parse_args()
    t0 = time.perf_counter()
    runs = {"side by side": side_by_side()}
    if args.alone:
        runs["alone"] = alone()
    print(f"{'how':<14}{'stage':<10}{'compile [s]':>12}  functions compiled for >1 signature")
    for how, res in runs.items():
        for stage, (t, multi) in res.items():
            print(f"{how:<14}{stage:<10}{t:>12.1f}  {multi}")
    side = runs["side by side"]
    print(f"critical path (both jobs side by side): {max(t for t, _ in side.values()):.1f} s "
          f"(benchmark {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()

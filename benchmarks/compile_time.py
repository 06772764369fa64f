"""Benchmark: how long a fresh install compiles the pipeline's kernels (an empty numba cache).

Run:  .venv/bin/python benchmarks/compile_time.py [--alone] [--side-by-side]   (about 2-5 minutes)

The default run's first two jobs are ``compile_kernels`` for the simulate and then the Lyapunov
stage (``analysis.pipeline.stages.compile_kernels``), one thread each, the second after the
first (side by side, the Lyapunov kernels' last bits depended on which callees each job found
in the cache: docs/reliability.md, "Compiled kernels"); no chunk job starts before the first is
done, and the simulate chunks run on the other core while the second compiles.  This runs them
the same way: two processes into one empty ``NUMBA_CACHE_DIR``, with the default config's
integrators (simulate: ``expo`` and the RK4 fallback; Lyapunov: the RK4 copies, then the
``expo`` copies), and prints each process's wall time.  With ``--alone`` it
also compiles each stage alone into an empty cache, and with ``--side-by-side`` both at once
into one (the order of 245b8ef-ef47c56), for comparison.  (d1df88a-0d2eea5 ran the Lyapunov
stage's first: then both were on the critical path.)

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


def in_order() -> dict[str, tuple[float, str]]:
    """The simulate stage's compile job, then the Lyapunov stage's, into one empty cache (as the
    pipeline runs them)."""
    with tempfile.TemporaryDirectory() as cache:
        return {stage: _finish(_start(stage, cache)) for stage in ("simulate", "lyapunov")}


def side_by_side() -> dict[str, tuple[float, str]]:
    """Both stages' compile jobs at once into one empty cache (the order before d1df88a)."""
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
    ap.add_argument("--side-by-side", action="store_true", help="also both stages at once")
    args = ap.parse_args()
    t0 = time.perf_counter()
    runs = {"in order": in_order()}
    if args.alone:
        runs["alone"] = alone()
    if args.side_by_side:
        runs["side by side"] = side_by_side()
    print(f"{'how':<14}{'stage':<10}{'compile [s]':>12}  functions compiled for >1 signature")
    for how, res in runs.items():
        for stage, (t, multi) in res.items():
            print(f"{how:<14}{stage:<10}{t:>12.1f}  {multi}")
    order = runs["in order"]
    print(f"critical path: the simulate job, {order['simulate'][0]:.1f} s (the Lyapunov job's "
          f"{order['lyapunov'][0]:.1f} s after it, beside the simulate chunks)", end="")
    if args.side_by_side:
        print(f"; side by side: {max(t for t, _ in runs['side by side'].values()):.1f} s", end="")
    print(f" (benchmark {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()

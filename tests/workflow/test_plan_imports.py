"""What the Snakefile imports is paid by every `snakemake` call and, on a cluster, by every job
(each runs as `snakemake --target-jobs`; docs/architecture.md, "What the suite's time is made
of"): the modules it imports must not pull in the slow libraries that only the jobs' scripts
need.  A local job is a Python process running its script: the modules the compute scripts
import must not pull in the libraries only some of them use (scipy.stats, scipy.optimize:
"What a local job costs"), and a job that only reads tables must not load the kernels."""

from __future__ import annotations

import re
import subprocess
import sys

from workflow_run import ROOT, snakemake_env

#: imported by a job's script when it needs them, never while the Snakefile is parsed
SLOW = ("matplotlib", "scipy.stats", "scipy.signal")


def _snakefile_imports() -> list[str]:
    """The project modules the Snakefile and its rule files import."""
    mods = set()
    for path in [ROOT / "Snakefile", *sorted((ROOT / "workflow" / "rules").glob("*.smk"))]:
        for line in path.read_text().splitlines():
            m = re.match(r"\s*from\s+((?:analysis|beamsim)[\w.]*)\s+import", line)
            if m:
                mods.add(m.group(1))
    return sorted(mods)


def test_the_snakefile_imports_no_slow_library():
    mods = _snakefile_imports()
    assert "analysis.pipeline.plan" in mods and len(mods) >= 5, mods
    code = (f"import sys\nfor m in {mods!r}: __import__(m)\n"
            f"print(','.join(s for s in {SLOW!r} if s in sys.modules))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=snakemake_env(), cwd=ROOT)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "", f"imported while the Snakefile is parsed: {res.stdout.strip()}"


#: imported where they are used (fitting the arch modes, the figures), not by a compute job
NOT_IN_JOBS = ("matplotlib", "scipy.stats", "scipy.optimize")


def test_a_compute_job_imports_no_library_it_does_not_use():
    """The modules of the simulate, Lyapunov and classify scripts and of the modes' cache, and
    the two Student-t quantiles of the stages (the block statistics' interval, the drift
    test), import none of ``NOT_IN_JOBS``."""
    code = ("import sys\nimport numpy as np\n"
            "import analysis.pipeline.stages, analysis.pipeline.atomic, beamsim.mode_cache\n"
            "from analysis.lyapunov.block_statistics import block_statistics\n"
            "from analysis.transients import drifting_component\n"
            "s = block_statistics(np.cumsum(np.full(61, 0.01)), 1.0, block=5, burn_in=5)\n"
            "assert np.isfinite(s.hi), s\n"
            "x = np.random.default_rng(0).random((64, 3))\n"
            "drifting_component(x + np.linspace(0.0, 5.0, 64)[:, None], np.ones(3))\n"
            f"print(','.join(s for s in {NOT_IN_JOBS!r} if s in sys.modules))")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=snakemake_env(), cwd=ROOT)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "", f"imported by a compute job's modules: {res.stdout.strip()}"


#: the kernels' libraries: a job that only reads tables (classify, the map's table) needs none
KERNEL_LIBRARIES = ("numba", "beamsim.simulate", "beamsim.kernels", "nolds", "scipy.cluster",
                    "scipy.spatial")


def test_a_table_job_imports_no_kernel_library():
    """The classify and table jobs' modules (the stages, the plan, the classifier) load neither
    numba and the kernels nor the libraries only the classifier's clustering uses (their import
    time: docs/architecture.md); the clustering and the lazily loaded estimators still work."""
    code = ("import sys\nimport numpy as np\n"
            "import analysis.pipeline.stages, analysis.pipeline.atomic, analysis.pipeline.plan\n"
            "from analysis.pipeline.stages import classify_points, lle_resolution\n"
            "from analysis.lyapunov.block_statistics import block_statistics\n"
            f"print(','.join(s for s in {KERNEL_LIBRARIES!r} if s in sys.modules))\n"
            "from analysis.poincare import cluster_points\n"
            "x = np.r_[np.zeros((8, 2)), np.ones((8, 2))]\n"
            "assert cluster_points(x, tol=0.1).n_clusters == 2\n"
            "from analysis.lyapunov import LLEResult, stefanski_lle\n"
            "import analysis.lyapunov as L\n"
            "assert 'stefanski_lle' in dir(L) and callable(L.sync_search) and callable(L.stefanski_lle)\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                         env=snakemake_env(), cwd=ROOT)
    assert res.returncode == 0, res.stderr[-2000:]
    assert res.stdout.strip() == "", f"imported by a table job's modules: {res.stdout.strip()}"

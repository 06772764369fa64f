"""Every Snakemake job of a local run is a Snakemake process that parses the Snakefile before
its script starts, so what the Snakefile imports is paid once per job (docs/architecture.md,
"What the suite's time is made of"): the modules it imports must not pull in the slow
libraries that only the jobs' scripts need."""

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

"""Snakemake's local scheduler held to ``--cores`` (analysis.pipeline.local_cores).

Three jobs of two threads each, ready together after a job that ran alone, under ``-c2``: with
the patch no two of them run at the same time.  Without it they overlap exactly when
Snakemake's source has the lone-job shortcut (snakemake/snakemake#3913), so the detector that
decides whether to patch is checked against the behaviour it predicts."""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SNAKEFILE = textwrap.dedent("""
    import sys
    sys.path.insert(0, {root!r})
    if {patch}:
        from analysis.pipeline.local_cores import hold_local_cores
        assert hold_local_cores() == {expect_patch}

    rule final:
        input: expand("out{{n}}", n=range(3))

    rule prepare:
        output: "common"
        threads: 2
        shell: "touch {{output}}"

    rule work:
        input: "common"
        output: "out{{n}}"
        threads: 2
        shell:
            "python3 -c 'import time; print(\\"start\\", time.time())' >> trace_{{wildcards.n}}; "
            "sleep 1; "
            "python3 -c 'import time; print(\\"end\\", time.time())' >> trace_{{wildcards.n}}; "
            "touch {{output}}"
""")


def _intervals(folder: Path) -> list[tuple[float, float]]:
    out = []
    for f in sorted(folder.glob("trace_*")):
        t = dict(line.split() for line in f.read_text().splitlines())
        out.append((float(t["start"]), float(t["end"])))
    return sorted(out)


def _overlap(intervals) -> bool:
    return any(b[0] < a[1] for a, b in zip(intervals, intervals[1:]))


def _run(folder: Path, patch: bool, expect_patch: bool) -> list[tuple[float, float]]:
    folder.mkdir()
    text = SNAKEFILE.format(root=str(ROOT), patch=patch, expect_patch=expect_patch)
    (folder / "Snakefile").write_text(text)
    subprocess.run([sys.executable, "-m", "snakemake", "-c2", "-q"], cwd=folder, check=True,
                   capture_output=True, text=True)
    return _intervals(folder)


def test_two_thread_jobs_do_not_overlap_on_two_cores(tmp_path):
    from snakemake.scheduling.job_scheduler import JobScheduler

    from analysis.pipeline.local_cores import has_lone_job_shortcut

    faulty = has_lone_job_shortcut(JobScheduler)
    held = _run(tmp_path / "held", patch=True, expect_patch=faulty)
    assert len(held) == 3 and not _overlap(held), held
    bare = _run(tmp_path / "bare", patch=False, expect_patch=False)
    assert len(bare) == 3
    assert _overlap(bare) == faulty, (bare, faulty)

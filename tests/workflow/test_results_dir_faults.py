"""Environment faults: ``results/`` on a read-only mount or on a full disk (a real tmpfs or bind
mount, so these need root, as CI has; skipped otherwise).  The run stops in one line before any
job and nothing already in ``results/`` changes; a store write that hits a full disk leaves
neither a partial record nor a temporary file."""

from __future__ import annotations

import errno
import re
import subprocess
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
import yaml
from workflow_run import GRID, setup_workdir, snakemake, tree_digest

from analysis.pipeline.store import PointStore


def _mount(*args: str) -> None:
    subprocess.run(["mount", *args], check=True, capture_output=True)


@contextmanager
def mounted(*args: str, target: Path):
    try:
        _mount(*args, str(target))
    except (OSError, subprocess.CalledProcessError) as exc:
        pytest.skip(f"cannot mount here (needs root): {exc}")
    try:
        yield target
    finally:
        subprocess.run(["umount", "-l", str(target)], check=False)


def _one_line(res: subprocess.CompletedProcess, start: str) -> str:
    lines = [ln for ln in (res.stdout + res.stderr).splitlines() if ln.startswith(start)]
    assert res.returncode != 0 and len(lines) == 1, res.stdout[-2000:] + res.stderr[-2000:]
    return lines[0]


@pytest.mark.parametrize("populated, start, words", [
    # results/ empty: the preflight check (analysis.pipeline.preflight) refuses the run
    (False, "cannot run:", r"not writable \(Read-only file system\)"),
    # a table there to rewrite (a point added): Snakemake's own check of the outputs refuses first
    # (it names the first of the jobs to rerun it meets: a chunk job whose chunk gained the point,
    # the table, its convergence evidence -- the sample is drawn from the table -- or a figure)
    (True, "Write-protected output files",
     r"for rule (simulate_chunk|lyapunov_chunk|classify_chunk|regime_table|regime_figures|portraits"
     r"|convergence_runs|convergence_table|convergence_figure):"),
])
def test_read_only_results_stop_before_any_job_and_keep_what_is_there(tmp_path, populated, start, words):
    work = setup_workdir(tmp_path / "ro")
    results = work / "results"
    results.mkdir()
    if populated:  # the table's chain only: the figure and evidence rules add time, not cases
        assert snakemake(work, "results/regimes/tiny.parquet").returncode == 0
        grid = yaml.safe_load(yaml.safe_dump(GRID))
        grid["grids"]["tiny"]["axes"]["f0_rel"] = [0.5, 1.5, 3.0]
        (work / "grid.yaml").write_text(yaml.safe_dump(grid))
    before = tree_digest(results)
    with mounted("--bind", str(results), target=results):
        _mount("-o", "remount,bind,ro", str(results))
        res = snakemake(work, "regimes")
        assert re.search(words, _one_line(res, start))
        assert "Select jobs to execute" not in res.stdout + res.stderr  # no job was started
        assert tree_digest(results) == before


def test_a_full_disk_stops_the_run_in_one_line_before_any_job(tmp_path):
    work = setup_workdir(tmp_path / "full")
    (work / "results").mkdir()
    with mounted("-t", "tmpfs", "-o", "size=48k", "tmpfs", target=work / "results"):
        res = snakemake(work, "regimes")
        line = _one_line(res, "cannot run:")
        assert "free, the new results need about" in line
        assert tree_digest(work / "results") == {}


def test_a_store_write_that_fills_the_disk_leaves_no_partial_record(tmp_path):
    disk = tmp_path / "disk"
    disk.mkdir()
    with mounted("-t", "tmpfs", "-o", "size=256k", "tmpfs", target=disk):
        store = PointStore(disk, "simulate")
        store.save("aa01", {"x": np.arange(1000.0), "label": "kept"})
        before = tree_digest(disk)
        with pytest.raises(OSError) as err:
            store.save("aa02", {"x": np.random.default_rng(0).random(100_000)})  # 800 kB
        assert err.value.errno == errno.ENOSPC
        assert tree_digest(disk) == before  # no partial record, no temporary file
        assert store.find("aa02") is None and store.load("aa01")["label"] == "kept"

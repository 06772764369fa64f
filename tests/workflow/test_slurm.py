"""Scale-out on a real cluster engine: the workflow through `--executor slurm` on a local SLURM.

A single-node SLURM (Debian's slurm-wlm + munge, installed here if missing) is started on
127.0.0.1 by tests/support/slurm_cluster.py; the small target is run through the real
snakemake-executor-plugin-slurm with the repository's profiles/slurm/, and its outputs must equal
those of a plain local run (-c1) of the same Snakefile and config. Skips only where the cluster
cannot exist: not root, or no apt-get to install it. The daemons are stopped by pid in teardown.
See docs/slurm.md.
"""

from __future__ import annotations

import copy
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from slurm_cluster import LocalSlurm, can_run, install
from workflow_run import SHORT_LYAPUNOV

ROOT = Path(__file__).resolve().parents[2]
VENV_BIN = str(Path(sys.executable).parent)
#: the kernel jobs' outputs (rule compile_kernels)
KERNEL_STAMPS = ("results/kernels/simulate.done", "results/kernels/lyapunov.done")
RUN_TIMEOUT = 300  # seconds for one snakemake run (the SLURM one takes 75-100 s here)

# slow, and mostly waiting on status polls (run first: tests/conftest.py); one local cluster for
# the module (make test hands whole files to a worker: --dist loadfile)
pytestmark = [pytest.mark.slow, pytest.mark.waits]


@dataclass(frozen=True)
class Case:
    """Targets of the workflow, a small config for them, and the outputs to compare."""

    targets: tuple[str, ...]
    outputs: tuple[str, ...]  # glob patterns under the working directory; each must match
    overrides: dict = field(default_factory=dict)  # deep-merged into config/config.yaml
    ignore_metadata: tuple[bytes, ...] = ()  # Parquet metadata keys allowed to differ
    jobs: int | None = None  # SLURM submissions expected (None: at least one)

    def __str__(self) -> str:
        return "+".join(Path(t).stem for t in self.targets)


CASES = [
    # the arch modes with their figures, and the regime table (its chain: modes and compiled
    # kernels, one group job per chunk -- simulate, Lyapunov, classify: profiles/slurm/ --,
    # the table; each level costs a SLURM status-poll round of 15-35 s here)
    Case(("modes", "results/regimes/tiny.parquet"),
         ("results/modes/*/modes.parquet", "results/modes/*/characteristic_function.png",
          "results/modes/*/mode_shapes.png", "results/regimes/*.parquet"),
         jobs=8,  # 2 compute_modes, 2 compile_kernels, 2 chunk groups, plot_modes, regime_table
         overrides={"grid_file": str(ROOT / "tests" / "workflow" / "data" / "grid_tiny.yaml"),
                    "numerics": {"n_transient": 4, "n_record": 128, "n_transient_max": 4, "chunk_size": 1,
                                 "lyapunov": SHORT_LYAPUNOV}}),
]


def _merge(base: dict, over: dict) -> dict:
    out = copy.deepcopy(base)
    for k, v in over.items():
        out[k] = _merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
    return out


def _snakemake(workdir: Path, config: Path, targets: tuple[str, ...], *extra: str,
               env: dict) -> tuple[subprocess.CompletedProcess, float]:
    cmd = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(workdir),
           "--configfile", str(config), *extra, *targets]
    t0 = time.monotonic()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=workdir, timeout=RUN_TIMEOUT)
    return res, time.monotonic() - t0


@pytest.fixture(scope="module")
def slurm():
    ok, why = can_run()
    if not ok:
        pytest.skip(why)
    t0 = time.monotonic()
    installed = install()
    cluster = LocalSlurm()
    try:
        cluster.start()
        yield cluster
    finally:
        cluster.stop()
        assert cluster.running() == [], f"daemons still running: {cluster.running()}"
        print(f"\nlocal SLURM: install {installed:.1f} s, start {cluster.start_seconds:.1f} s, "
              f"fixture total {time.monotonic() - t0:.1f} s")


@pytest.mark.parametrize("case", CASES, ids=str)
def test_slurm_run_equals_local_run(slurm, case, tmp_path):
    config = _merge(yaml.safe_load((ROOT / "config" / "config.yaml").read_text()), case.overrides)
    local_dir, slurm_dir = tmp_path / "local", tmp_path / "slurm"
    for d in (local_dir, slurm_dir):  # the repo's config/ (other files it names resolve in -d)
        shutil.copytree(ROOT / "config", d / "config")
        (d / "config" / "config.yaml").write_text(yaml.safe_dump(config, sort_keys=False))

    env = slurm.env(extra_path=[VENV_BIN]) | {"PYTHONPATH": str(ROOT)}
    # The local reference run computes while the SLURM run mostly waits on its status polls, so
    # the two run side by side (separate working directories), after the local run's kernel
    # jobs: they fill numba's cache, which both runs read (on a fresh clone the two would
    # otherwise compile the same kernels at once, minutes of CPU each).
    kernels, _ = _snakemake(local_dir, local_dir / "config" / "config.yaml", KERNEL_STAMPS, "-c1", env=env)
    assert kernels.returncode == 0, kernels.stdout[-3000:] + kernels.stderr[-5000:]
    with ThreadPoolExecutor(max_workers=2) as pool:
        local_run = pool.submit(_snakemake, local_dir, local_dir / "config" / "config.yaml", case.targets,
                                "-c1", env=env)
        slurm_run = pool.submit(
            _snakemake, slurm_dir, slurm_dir / "config" / "config.yaml", case.targets,
            "--profile", str(ROOT / "profiles" / "slurm"),
            # the local cluster: no accounting (squeue, not sacct), partition `debug`, small
            # jobs, a short first status check; everything else comes from the profile. (A
            # command-line --default-resources replaces the profile's whole list, so all four
            # are given.)
            "--slurm-status-command", "squeue",
            "--slurm-init-seconds-before-status-checks", "2",
            "--default-resources", "slurm_partition=debug", "runtime=10", "mem_mb=1000",
            "cpus_per_task=threads",
            "--latency-wait", "10", "--retries", "0", "--slurm-keep-successful-logs",
            env=env,
        )
        (local, t_local), (remote, t_slurm) = local_run.result(), slurm_run.result()
    assert local.returncode == 0, local.stdout[-3000:] + local.stderr[-5000:]
    text = remote.stdout + remote.stderr
    assert remote.returncode == 0, text[-6000:] + "\n" + slurm.logs()
    print(f"\n{case}: local -c1 run {t_local:.1f} s, SLURM run {t_slurm:.1f} s")

    # the jobs really went through sbatch and ran as SLURM jobs on the node
    submitted = text.count("has been submitted with SLURM jobid")
    assert submitted >= 1 and case.jobs in (None, submitted), (submitted, text[-4000:])
    job_logs = sorted((slurm_dir / ".snakemake" / "slurm_logs").rglob("*.log"))
    assert len(job_logs) == submitted, job_logs
    for log in job_logs:  # SLURM's --output of each job: the job's own Snakemake ran and finished there
        assert "Finished jobid: 0 (Rule: " in log.read_text(errors="replace"), log

    for pattern in case.outputs:
        got = sorted(p.relative_to(slurm_dir) for p in slurm_dir.glob(pattern))
        want = sorted(p.relative_to(local_dir) for p in local_dir.glob(pattern))
        assert want, f"local run produced nothing matching {pattern}"
        assert got == want, pattern
        for rel in want:
            a, b = local_dir / rel, slurm_dir / rel
            assert b.stat().st_size > 0, rel
            if rel.suffix == ".parquet":
                pd.testing.assert_frame_equal(pd.read_parquet(b), pd.read_parquet(a), check_exact=True)
                meta_a = {k: v for k, v in (pq.read_schema(a).metadata or {}).items()
                          if k not in case.ignore_metadata}
                meta_b = {k: v for k, v in (pq.read_schema(b).metadata or {}).items()
                          if k not in case.ignore_metadata}
                assert meta_b == meta_a, rel  # geometry, versions, pandas schema


def test_profile_is_valid_yaml_with_the_fields_a_user_edits():
    prof = yaml.safe_load((ROOT / "profiles" / "slurm" / "config.yaml").read_text())
    assert prof["executor"] == "slurm"
    assert {"slurm_partition", "runtime", "mem_mb", "cpus_per_task"} <= set(prof["default-resources"])
    assert prof["jobs"] >= 1 and prof["latency-wait"] >= 0

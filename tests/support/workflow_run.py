"""Run the workflow on a throw-away working directory (a small config and grid), as a user would:
``snakemake -s <repo>/Snakefile -d <workdir> --configfile <workdir>/config.yaml``."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
#: two points, one below and one above the slip onset, one of them marked
GRID = {"grids": {"tiny": {"axes": {"f0_rel": [0.5, 3.0]}, "fixed": {"Omega": 2.5, "mu_s": 0.45, "mu_k": 0.3},
                           "mark": [{"f0_rel": 3.0}]}}}


#: block statistics of the Lyapunov stage within the shipped 25-period Stefanski window
SHORT_LYAPUNOV = {"block_periods": 5, "burn_in": 5, "min_blocks": 2, "max_blocks": 4}

#: the convergence step of the test workflows: one sampled point, one refinement
SHORT_CONVERGENCE = {"sample": 1, "seed": 0, "refinements": ["k_t"]}

#: the multistability step of the test workflows: off (tests/workflow/test_workflow_regimes.py
#: turns it on)
NO_MULTISTABILITY = {"sample": 0}

#: the lifetime step of the test workflows: every label, two short copies per cell
SHORT_LIFETIMES = {"labels": ["periodic", "quasi-periodic", "chaotic", "undetermined", "unsettled"],
                   "copies": 2, "periods": 20}


def snakemake_command(workdir: Path, *args: str, cores: int = 2) -> list[str]:
    return [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(workdir),
            f"-c{cores}", *args, "--configfile", str(workdir / "config.yaml")]


def snakemake_env() -> dict:
    return os.environ | {"PYTHONPATH": str(ROOT)}


def snakemake(workdir: Path, *args: str, cores: int = 2) -> subprocess.CompletedProcess:
    return subprocess.run(snakemake_command(workdir, *args, cores=cores), capture_output=True, text=True,
                          timeout=900, env=snakemake_env())


def setup_workdir(path: Path, grid: dict = GRID, convergence: dict = SHORT_CONVERGENCE,
                  multistability: dict = NO_MULTISTABILITY, lifetimes: dict = SHORT_LIFETIMES,
                  **numerics) -> Path:
    """``path`` with ``config.yaml`` (the shipped config, short runs -- a fixed transient, a
    long Benettin record no longer than the Stefanski window, no long run, ``convergence`` for the
    convergence step, ``multistability`` for the runs from other starts, ``lifetimes`` for the
    lifetime runs --, chunks of two
    points -- the tiny grid in one chunk: every chunk is three jobs, each a Python process
    that imports the package and loads the kernels; the tests of chunking pass
    ``chunk_size=1`` --, and ``numerics`` overrides) and ``grid.yaml``."""
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    cfg["numerics"]["lyapunov"].update(SHORT_LYAPUNOV)
    cfg["convergence"] = dict(convergence)
    cfg["multistability"] = dict(multistability)
    cfg["lifetimes"] = dict(lifetimes)
    cfg["numerics"].update({"n_transient": 4, "n_record": 128, "chunk_size": 2, "n_long_transient": 0}
                           | numerics)
    if "n_transient_max" not in numerics:
        cfg["numerics"]["n_transient_max"] = cfg["numerics"]["n_transient"]
    cfg["grid_file"] = str(path / "grid.yaml")
    path.mkdir(parents=True, exist_ok=True)
    (path / "config.yaml").write_text(yaml.safe_dump(cfg))
    (path / "grid.yaml").write_text(yaml.safe_dump(grid))
    return path


def tree_digest(root: Path) -> dict:
    """sha256 of every file under ``root`` by relative path: compare before and after to show
    that nothing was written, changed or removed."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}

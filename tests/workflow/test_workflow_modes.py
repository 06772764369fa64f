"""The Snakemake side of the mode cache: lint, dry-run, a tiny real run, caching, bad config."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from beamsim.mode_cache import cache_key, read_geometry, read_modes
from beamsim.modes import arch_modes

ROOT = Path(__file__).resolve().parents[2]


def snakemake(workdir: Path, *args: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "snakemake", "-s", str(ROOT / "Snakefile"), "-d", str(workdir), "-c1", *args]
    env = os.environ | {"PYTHONPATH": str(ROOT)}
    return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)


def write_config(path: Path, alpha=0.02, beta=0.5, n_modes=3, **model) -> Path:
    """The repository's config with the geometry replaced (equal layers of thickness alpha)."""
    cfg = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    cfg["model"].update(alpha1=alpha, alpha2=alpha, beta=beta, **model)
    cfg["modes"]["n_modes"] = n_modes
    cfg["grid_file"] = str(ROOT / "config" / "grid.yaml")
    path.write_text(yaml.safe_dump(cfg))
    return path


def test_lint_is_clean():
    res = subprocess.run([sys.executable, "-m", "snakemake", "--lint"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "Congratulations" in res.stdout + res.stderr


def test_default_config_dry_run():
    res = subprocess.run([sys.executable, "-m", "snakemake", "-n", "modes"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr


def test_modes_rule_writes_cache_and_reruns_only_on_geometry_change(tmp_path):
    cfg = write_config(tmp_path / "c.yaml")
    res = snakemake(tmp_path, "modes", "--configfile", str(cfg))
    assert res.returncode == 0, res.stderr
    key = cache_key(0.02, 0.5, "clamped-free", 3)
    out = tmp_path / "results" / "modes" / key
    for name in ("modes.parquet", "characteristic_function.png", "mode_shapes.png"):
        assert (out / name).stat().st_size > 0
    geom = read_geometry(out / "modes.parquet")
    assert ({k: geom[k] for k in ("alpha", "beta", "bc", "n_modes")}
            == {"alpha": 0.02, "beta": 0.5, "bc": "clamped-free", "n_modes": 3})
    cached = read_modes(out / "modes.parquet")
    fresh = arch_modes(0.02, 0.5, 3)
    np.testing.assert_allclose(cached.lam, fresh.lam, rtol=1e-12)
    th = np.linspace(0, 0.5, 9)
    np.testing.assert_allclose(cached.W(th, 2), fresh.W(th, 2), rtol=1e-9, atol=1e-9)

    # same geometry: nothing to do
    res = snakemake(tmp_path, "-n", "modes", "--configfile", str(cfg))
    assert "Nothing to be done" in res.stdout + res.stderr
    # new geometry: only the new key is built, the old cache stays
    mtime = (out / "modes.parquet").stat().st_mtime_ns
    cfg2 = write_config(tmp_path / "c2.yaml", beta=0.6)
    res = snakemake(tmp_path, "-n", "modes", "--configfile", str(cfg2))
    text = res.stdout + res.stderr
    assert "compute_modes" in text and cache_key(0.02, 0.6, "clamped-free", 3) in text
    assert (out / "modes.parquet").stat().st_mtime_ns == mtime


@pytest.fixture(scope="module")
def built_workdir(tmp_path_factory):
    workdir = tmp_path_factory.mktemp("built")
    good = write_config(workdir / "good.yaml")
    res = snakemake(workdir, "modes", "--configfile", str(good))
    assert res.returncode == 0, res.stderr
    return workdir


@pytest.mark.parametrize(
    "override,key,allowed",
    [
        ({"alpha": -0.02}, "model.alpha", "> 0"),
        ({"beta": 7.0}, "model.beta", "< 6.28"),
        ({"bc": "free-free"}, "model.bc", "clamped-free"),
        ({"n_modes": 0}, "modes.n_modes", ">= 1"),
        ({"mu_s": -0.1}, "model.mu_s", ">= 0"),
        ({"law": "viscous"}, "model.law", "stick-slip"),
        ({"mu_s": float("nan")}, "model.mu_s", "finite"),
        ({"mu_k": 0.9}, "model", "mu_s must be >= mu_k"),  # a cross rule of the model
    ],
)
def test_bad_config_fails_before_any_job_and_changes_nothing(built_workdir, override, key, allowed):
    tmp_path = built_workdir
    before = {p: p.stat().st_mtime_ns for p in (tmp_path / "results").rglob("*") if p.is_file()}
    kw = {"alpha": 0.02, "beta": 0.5, "n_modes": 3} | override
    bad = write_config(tmp_path / f"bad_{key}.yaml", **kw)
    res = snakemake(tmp_path, "modes", "--configfile", str(bad))
    assert res.returncode != 0
    lines = [ln for ln in (res.stdout + res.stderr).splitlines() if ln.startswith("invalid config:")]
    assert len(lines) == 1 and key in lines[0] and allowed in lines[0], res.stderr
    after = {p: p.stat().st_mtime_ns for p in (tmp_path / "results").rglob("*") if p.is_file()}
    assert after == before


def test_results_folder_is_not_committed():
    ignored = subprocess.run(["git", "check-ignore", "-q", "results/modes/x.parquet"], cwd=ROOT)
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    assert ignored.returncode == 0

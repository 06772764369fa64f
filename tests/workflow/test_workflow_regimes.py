"""The regime pipeline end to end on a tiny grid: outputs, metadata, incrementality,
reproducibility across core counts, and config errors that stop before any job."""

from __future__ import annotations

import json
import subprocess
import sys

import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from workflow_run import GRID, ROOT, setup_workdir, snakemake

from analysis.lyapunov.beam import RK4_SECOND_OPINION
from analysis.pipeline.chaos_lifetime import summary_line
from analysis.pipeline.grid import RESULTS_VERSION
from analysis.pipeline.stages import BY_SHAKEDOWN
from analysis.pipeline.table import read_regime_metadata
from analysis.regimes import CLASSIFIER_VERSION

# the tests share one built working directory (module fixture; make test hands whole files to a
# worker: --dist loadfile)

#: the convergence step with every refinement, on one sampled point
CONVERGENCE = {"sample": 1, "seed": 0, "refinements": ["step", "windows", "k_t", "modes"]}
#: every cell run again from its neighbour's end state and one seeded random state (a small
#: perturbation: at the shipped 0.3 the tiny grid's three-mode beam goes onto a large motion that
#: doubles the step's time; what these tests check is the bookkeeping, not the attractors)
MULTISTABILITY = {"sample": "all", "perturbations": 1, "amplitude": 0.05}
#: the tiny grid with a two-point continuation line (one mode: with the grid's three, the
#: Stefanski ladder at the line's unsettled points took 25 s of the module's two minutes)
GRID_L = yaml.safe_load(yaml.safe_dump(GRID))
GRID_L["grids"]["tiny"]["lines"] = {"sweep": {"axes": {"f0_rel": [2.0, 3.0]},
                                              "fixed": {"mu_s": 0.5, "n_modes": 1}}}


@pytest.fixture(scope="module")
def first_run(tmp_path_factory):
    work = setup_workdir(tmp_path_factory.mktemp("regimes"), grid=GRID_L, convergence=CONVERGENCE,
                         multistability=MULTISTABILITY, chunk_size=1)  # a chunk per point
    res = snakemake(work, "regimes")
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    return work


def test_dry_run_of_every_target():
    for target in ("regimes", "modes", "paper", "all"):
        res = subprocess.run([sys.executable, "-m", "snakemake", "-n", target], cwd=ROOT, capture_output=True,
                             text=True, timeout=300)
        assert res.returncode == 0, (target, res.stderr[-2000:])


def test_the_kernel_jobs_compile_one_after_the_other():
    """The Lyapunov stage's compile job waits for the simulate stage's: side by side, which of
    the shared callees each found in numba's cache depended on the timing, and with it the last
    bits of the Lyapunov kernels (three fresh-clone runs of one commit gave two different sets of
    lambda_1 columns, docs/reliability.md).  The compile jobs come before any chunk that is
    ready with them (priority), and every computing rule takes one thread, so the simulate
    chunks run on the other core while the Lyapunov kernels compile."""
    res = subprocess.run([sys.executable, "-m", "snakemake", "-n", "--forceall", "regimes"], cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    blocks = res.stdout.split("\n\n")
    jobs = [block for block in blocks if "rule compile_kernels:" in block]
    assert len(jobs) == 2
    simulate = next(b for b in jobs if "output: results/kernels/simulate.done" in b)
    lyapunov = next(b for b in jobs if "output: results/kernels/lyapunov.done" in b)
    assert "input: results/kernels/simulate.done" in lyapunov
    assert "input:" not in simulate
    assert all("priority: 10" in b for b in jobs)
    chunks = [b for b in blocks if "rule simulate_chunk:" in b]
    assert chunks and all("priority:" not in b and "threads:" not in b for b in chunks)  # 1 thread
    assert all("results/kernels/lyapunov.done" not in b for b in chunks)


@pytest.mark.parametrize("grid_file", sorted(p.name for p in (ROOT / "config").glob("grid*.yaml")))
def test_every_shipped_grid_file_validates_and_plans(grid_file):
    """The grid files the project ships (the default and the three-mode chaos grid) pass the
    schemas (structure and model values, marks on the grid) and plan."""
    res = subprocess.run([sys.executable, "-m", "snakemake", "-n", "regimes", "--config",
                          f"grid_file=config/{grid_file}"], cwd=ROOT, capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, (grid_file, res.stderr[-2000:])


def test_outputs_table_schema_and_metadata(first_run):
    out = first_run / "results" / "regimes"
    for name in ("tiny.parquet", "tiny/regimes.png", "tiny/lle.png", "tiny/portraits.png"):
        assert (out / name).stat().st_size > 0, name
    table = pd.read_parquet(out / "tiny.parquet")
    assert list(table["f0_rel"]) == [0.5, 3.0]  # grid order
    for col in ("point_id", "label", "period", "lle_stefanski", "lle_benettin", "lle_nolds",
                "lle_stefanski_verdict", "method", "lle_free_copy", "K",
                "slipped", "t_first_slip", "stick_fraction", "diss_per_cycle", "diverged", "settled",
                "params_json", "poincare_w_tip", "reason"):
        assert col in table.columns, col
    assert set(table["label"]) <= {"periodic", "quasi-periodic", "chaotic", "diverged", "unsettled"}
    # the tiny grid's mu_s > mu_k points: expo reference runs and expo free copies, no Zeno guard
    assert list(table["method"]) == ["expo", "expo"] and list(table["lle_free_copy"]) == ["expo", "expo"]
    # the expo pair's own statistics are the label's here, so no second-opinion columns
    assert table[["lle_expo_mean", "lle_expo_lo", "lle_expo_hi"]].isna().all().all()
    # expo's noise floor was measured at both (numerics.lyapunov.expo_floor), below its guard
    assert table["lle_expo_floor"].between(0.0, 0.1 * 1e-4).all(), list(table["lle_expo_floor"])
    assert table["point_id"].is_unique
    meta = read_regime_metadata(out / "tiny.parquet")
    assert len(meta["config_hash"]) == 16 and meta["grid_name"] == "tiny"
    assert meta["versions"]["numpy"] and meta["grid"]["fixed"]["Omega"] == 2.5
    assert meta["classifier_version"] == CLASSIFIER_VERSION and meta["results_version"] == RESULTS_VERSION


def test_convergence_step_ships_with_the_map(first_run):
    """The convergence runs of every refinement, their table (with the config hash of the map)
    and figure are part of `regimes`; the sampled point's row under each refinement refers to
    the map's point and to a refined point of its own."""
    out = first_run / "results" / "regimes"
    assert (out / "tiny" / "convergence.png").stat().st_size > 0
    runs = pd.read_parquet(out / "tiny" / "convergence.parquet")
    assert list(runs["refinement"]) == CONVERGENCE["refinements"]
    table = pd.read_parquet(out / "tiny.parquet")
    assert set(runs["point_id"]) <= set(table["point_id"]) and runs["point_id"].nunique() == 1
    assert not set(runs["refined_point_id"]) & set(table["point_id"])
    row = table.set_index("point_id").loc[runs["point_id"].iloc[0]]
    assert (runs["label"] == row["label"]).all() and (runs["f0_rel"] == row["f0_rel"]).all()
    assert (runs["holds"] == (runs["label"] == runs["refined_label"])).all()
    meta = pq.read_schema(out / "tiny" / "convergence.parquet").metadata[b"beamsim.convergence"]
    assert json.loads(meta)["config_hash"] == read_regime_metadata(out / "tiny.parquet")["config_hash"]
    # the refinements that ran on this grid (all of the list's: each is a knob of stick-slip)
    assert json.loads(meta)["settings"]["refinements"] == CONVERGENCE["refinements"]


def test_a_census_reruns_every_cell_of_its_labels(first_run):
    """``convergence.census`` (here with no sample): the convergence runs hold every cell of the
    census labels and no other, and a census of a label the map lacks gives an empty table of
    the usual columns, with the map's figures still made (their title says why nothing ran)."""
    cfg_path = first_run / "config.yaml"
    shipped = cfg_path.read_text()
    table = pd.read_parquet(first_run / "results" / "regimes" / "tiny.parquet")
    present = sorted(set(table["label"]))
    absent = next(lab for lab in ("chaotic", "unsettled", "undetermined", "quasi-periodic")
                  if lab not in present)
    targets = ("results/regimes/tiny/convergence.parquet", "results/regimes/tiny/regimes.png")
    try:
        for census, cells in ((present[:1], int((table["label"] == present[0]).sum())), ([absent], 0)):
            cfg = yaml.safe_load(shipped)
            cfg["convergence"] = {"sample": 0, "seed": 0, "census": census, "refinements": ["step"]}
            cfg_path.write_text(yaml.safe_dump(cfg))
            res = snakemake(first_run, *targets)
            assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
            runs = pd.read_parquet(first_run / targets[0])
            assert len(runs) == cells and set(runs["label"]) <= set(census)
            assert {"point_id", "refinement", "label", "refined_label", "holds"} <= set(runs.columns)
            assert set(runs["point_id"]) == set(table.loc[table["label"].isin(census), "point_id"])
    finally:
        cfg_path.write_text(shipped)  # restore for the other tests


def test_multistability_step_ships_with_the_map(first_run):
    """Every cell of the map run from the other starts: rows per cell (its attractors, then the
    starts that reached none), in the map's order; the row holding the start from rest has the
    map's label (an attractor, or the map's `unsettled` with the short test numerics), except
    where the map's label is periodic-1 by the shakedown limit: its record is still a
    transient, so its run reached no attractor and sits in the `unsettled` row; every start
    named once; the config hash of the map."""
    out = first_run / "results" / "regimes"
    att = pd.read_parquet(out / "tiny" / "attractors.parquet")
    table = pd.read_parquet(out / "tiny.parquet")
    assert list(att["point_id"].drop_duplicates()) == list(table["point_id"])
    for _, row in table.iterrows():
        cell = att[att["point_id"] == row["point_id"]]
        rest = cell[cell["starts"].map(lambda s: "rest" in list(s))]
        by_theorem = row["reason"].startswith(BY_SHAKEDOWN)
        if by_theorem:  # a record still a transient below the limit: not settled, ratio below 1
            assert not row["settled"] and row["shakedown_ratio"] < 1.0
        assert len(rest) == 1
        assert rest["label"].iloc[0] == ("unsettled" if by_theorem else row["label"])
        a = rest["attractor"].iloc[0]
        assert (pd.notna(a) and a == 0) == (row["label"] not in ("unsettled", "diverged") and not by_theorem)
        assert (cell["n_starts"] == 3).all()  # rest, the one neighbour, one perturbation
        assert (cell["n_attractors"] == cell["attractor"].notna().sum()).all()
    starts = [s for ss in att["starts"] for s in ss]
    assert sorted(starts) == sorted(["rest", "f0_rel+", "perturbed0", "rest", "f0_rel-", "perturbed0"])
    assert att["weight"].eq(1.0).all()
    meta = json.loads(pq.read_schema(out / "tiny" / "attractors.parquet").metadata[b"beamsim.attractors"])
    assert meta["config_hash"] == read_regime_metadata(out / "tiny.parquet")["config_hash"]
    assert meta["settings"]["perturbations"] == 1


def test_lifetime_step_ships_with_the_map(first_run):
    """The lifetime table holds exactly the map's cells with a label of the settings, below
    the lock-up limit, whose runs slip (none on the tiny grid: its slipping point lies above
    the limit), with the config hash of the map."""
    out = first_run / "results" / "regimes"
    life = pd.read_parquet(out / "tiny" / "lifetimes.parquet")
    table = pd.read_parquet(out / "tiny.parquet")
    expected = table[(table["lock_ratio"] < 1.0) & (table["stick_fraction"] < 1.0) & ~table["diverged"]]
    assert list(life["point_id"]) == list(expected["point_id"])
    for col in ("n_escaped", "n_unproven", "n_failed", "decorrelation", "n_counted", "exposure", "lifetime",
                "lifetime_lo", "lifetime_hi", "escape_periods", "censor_periods", "lock_ratio", "f0_rel"):
        assert col in life.columns, col
    meta = json.loads(pq.read_schema(out / "tiny" / "lifetimes.parquet").metadata[b"beamsim.lifetimes"])
    assert meta["config_hash"] == read_regime_metadata(out / "tiny.parquet")["config_hash"]
    assert meta["settings"]["copies"] == 2
    assert summary_line(life) in (first_run / "logs" / "regimes" / "tiny" / "chaos_lifetime.log").read_text()


def test_continuation_line_ships_with_the_map(first_run):
    """A grid's line is swept up and down (each point from its neighbour's end state), with the
    line's own fixed values on top of the grid's, and drawn."""
    out = first_run / "results" / "regimes" / "tiny" / "lines"
    assert (out / "sweep.png").stat().st_size > 0
    t = pd.read_parquet(out / "sweep.parquet")
    assert list(t["branch"]) == ["up", "up", "down", "down"] and list(t["f0_rel"]) == [2.0, 3.0] * 2
    assert list(t["start"]) == ["rest", "continued", "continued", "rest"]
    assert t["label"].notna().all() and t["lle_verdict"].notna().all()
    # expo throughout, no Zeno fallback; a short record on this tiny line may take the RK4
    # pair's second opinion (numerics.lyapunov.confirm, docs/lyapunov.md section 15)
    assert list(t["method"]) == ["expo"] * 4
    assert set(t["lle_free_copy"]) <= {"expo", RK4_SECOND_OPINION}, list(t["lle_free_copy"])
    meta = read_regime_metadata(out / "sweep.parquet")
    assert meta["grid"]["fixed"] == {"mu_s": 0.5, "n_modes": 1} and len(meta["config_hash"]) == 16
    # the line's own inputs: the grid's fixed values under the line's, the map's numerics
    assert [pt["mu_s"] for pt in meta["config"]["points"]] == [0.5, 0.5]
    assert [pt["n_modes"] for pt in meta["config"]["points"]] == [1, 1]
    assert [pt["Omega"] for pt in meta["config"]["points"]] == [2.5, 2.5]
    map_meta = read_regime_metadata(first_run / "results/regimes/tiny.parquet")
    assert meta["config"]["version"] == RESULTS_VERSION
    for key in ("n_transient", "n_record", "n_transient_max"):
        assert meta["config"]["numerics"][key] == map_meta["config"]["numerics"][key], key


def test_report_holds_the_maps_with_captions(first_run):
    """The HTML report of `regimes` (before the tests below edit the grid) holds the maps with
    their captions (the paper's items: tests/workflow/test_workflow_paper.py)."""
    res = snakemake(first_run, "regimes", "--report", str(first_run / "report.html"))
    assert res.returncode == 0, res.stderr[-3000:]
    html = (first_run / "report.html").read_text(errors="replace")
    for caption in ("Regime map of grid", "Largest Lyapunov exponent per forcing period"):
        assert caption in html, caption


def test_adding_a_point_computes_only_the_new_one(first_run, tmp_path):
    """A point added to the grid: the map's table and the grid's continuation line brought up
    to date compute the new point only (the line, whose inputs did not change, not at all).
    The evidence and figure rules downstream of the table rerun as well under `regimes`; they
    are left out here to keep the suite short."""
    grid = yaml.safe_load(yaml.safe_dump(GRID_L))
    grid["grids"]["tiny"]["axes"]["f0_rel"] = [0.5, 1.5, 3.0]
    log_dir = first_run / "logs" / "regimes" / "tiny"
    for old in log_dir.glob("simulate_*.log"):  # count only what this run computes
        old.unlink()
    (first_run / "grid.yaml").write_text(yaml.safe_dump(grid))
    try:
        res = snakemake(first_run, "results/regimes/tiny.parquet", "results/regimes/tiny/lines/sweep.parquet")
        assert res.returncode == 0, res.stderr[-3000:]
        logs = "".join(p.read_text() for p in log_dir.glob("simulate_*.log"))
        computed = sum(int(line.split(" cached, ")[1].split()[0]) for line in logs.splitlines()
                       if " cached, " in line)
        assert computed == 1, logs
        assert "continuation_line" not in res.stdout + res.stderr  # a line reruns only for its inputs
        table = pd.read_parquet(first_run / "results" / "regimes" / "tiny.parquet")
        assert list(table["f0_rel"]) == [0.5, 1.5, 3.0]
    finally:
        (first_run / "grid.yaml").write_text(yaml.safe_dump(GRID_L))  # restore for the other tests


def test_same_config_same_table_whatever_the_core_count(first_run, tmp_path):
    """The map, its runs from other starts and its four-mode convergence runs at -c1 equal
    those at -c2 bit for bit.  The four-mode refinement is the one that found threaded LAPACK
    rounding expo's decompositions by the job's thread count (docs/pipeline.md); the step,
    windows and k_t refinements are left out (the same stages with other numerics; with all
    four the test took 89 s in the suite, without any 54 s)."""
    other = setup_workdir(tmp_path / "again", grid=GRID_L, convergence=CONVERGENCE,
                          multistability=MULTISTABILITY, chunk_size=1)
    targets = ("results/regimes/tiny.parquet", "results/regimes/tiny/attractors.parquet",
               "results/regimes/tiny/convergence/modes.parquet", "results/regimes/tiny/lifetimes.parquet")
    res = snakemake(other, *targets, cores=1)
    assert res.returncode == 0, res.stderr[-3000:]
    res = snakemake(first_run, *targets)  # first_run's grid restored above
    assert res.returncode == 0, res.stderr[-3000:]
    for name in targets:
        a = pd.read_parquet(first_run / name)
        b = pd.read_parquet(other / name)
        pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert read_regime_metadata(other / "results/regimes/tiny.parquet")["config_hash"] == \
        read_regime_metadata(first_run / "results/regimes/tiny.parquet")["config_hash"]


def test_same_table_whatever_the_chunk_size(first_run, tmp_path):
    """Chunking is bookkeeping: one chunk of two points (here) or two chunks of one (first_run)
    give the same table, row for row and bit for bit (the config hash differs: chunk_size is
    part of the config)."""
    other = setup_workdir(tmp_path / "chunks", chunk_size=2)
    res = snakemake(other, "results/regimes/tiny.parquet", cores=1)
    assert res.returncode == 0, res.stderr[-3000:]
    a = pd.read_parquet(first_run / "results" / "regimes" / "tiny.parquet")
    b = pd.read_parquet(other / "results" / "regimes" / "tiny.parquet")
    assert len(list((other / "results" / "regimes" / "tiny" / "chunks").glob("*.simulate.parquet"))) == 1
    pd.testing.assert_frame_equal(a, b, check_exact=True)


@pytest.mark.parametrize(
    "grid,expected",
    [
        ({"grids": {"g": {"axes": {"Omega": [1.0, -2.0]}}}}, "grids.g.axes.Omega = -2.0"),
        ({"grids": {"g": {"axes": {"Omgea": [1.0]}}}}, "unknown model parameter 'Omgea'"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "fixed": {"mu_s": -1}}}}, "grids.g.fixed.mu_s = -1"),
        ({"grids": {"g": {"axes": {"Omega": {"range": [1, 2]}}}}}, "grids.g.axes.Omega"),
        # non-finite values, cross-field rules of the model, contradictory grids
        ({"grids": {"g": {"axes": {"Omega": [1.0, float("nan")]}}}}, "grids.g.axes.Omega.1 = nan"),
        ({"grids": {"g": {"axes": {"Omega": {"range": [1.25, float("inf")], "num": 3}}}}},
         "grids.g.axes.Omega.range.1 = inf"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "fixed": {"mu_s": 0.45, "mu_k": 0.9}}}},
         "mu_s must be >= mu_k"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "fixed": {"f0": 1e-5}}}}, "only one of f0 and f0_rel"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "fixed": {"interface_damping": 0.5,
                                                             "interface_viscosity": 0.1}}}},
         "give only one of interface_damping (> 0) and interface_viscosity"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "fixed": {"Omega": 2.0}}}}, "both as axis and as fixed"),
        # continuation lines: one axis, a state that can be carried along it, valid values
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "fixed": {"law": "rigid-stick"},
                          "lines": {"l": {"axes": {"n_modes": [1, 2]}, "fixed": {"Omega": 1.0}}}}}},
         "grids.g.lines.l: a continuation line along n_modes or n_quad needs law stick-slip"),
        # a line off its grid's other axis would run at the model's value there, off the map
        ({"grids": {"g": {"axes": {"Omega": [1.0], "f0_rel": [1.0]},
                          "lines": {"l": {"axes": {"k_t": [10.0, 30.0]}, "fixed": {"Omega": 1.0}}}}}},
         "grids.g.lines.l: the grid's axis f0_rel is neither the line's axis nor in its fixed"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]},
                          "lines": {"l": {"axes": {"Omega": [1.0], "f0_rel": [1.0]}}}}}},
         "grids.g.lines.l.axes"),
        ({"grids": {"g": {"axes": {"Omega": [1.0]}, "lines": {"l": {"axes": {"Omega": [1.0, -1.0]}}}}}},
         "grids.g.lines.l.axes.Omega = -1.0"),
    ],
)
def test_bad_grid_is_one_line_before_any_job(tmp_path, grid, expected):
    work = setup_workdir(tmp_path / "bad", grid=grid)
    res = snakemake(work, "regimes")
    assert res.returncode != 0
    lines = [ln for ln in (res.stdout + res.stderr).splitlines() if ln.startswith("invalid config:")]
    assert len(lines) == 1 and expected in lines[0], res.stderr[-2000:]
    assert not (work / "results").exists()

"""Property: any edit of the shipped config files is refused cleanly or accepted and planned.

Hypothesis mutates ``config/config.yaml`` and ``config/grid.yaml`` as a user editing them by
hand might (a value's type, sign, NaN/inf, a key deleted, renamed, added or given twice, a file
cut short) and runs the workflow's own parse-time pass on the result, in-process: the Snakefile's
:func:`check_config_files` and common.smk's :func:`build_plan`, exactly what
``snakemake`` runs before any job.  Either it raises ``WorkflowError`` with one line starting
``invalid config:``, or it returns a plan with points and chunks for every grid.  Any other
exception is a traceback a user would see.  No file may be touched.  A few mutations also go
through a real ``snakemake -n`` (the wiring of those two calls).
"""

from __future__ import annotations

import copy
import subprocess
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from snakemake.exceptions import WorkflowError
from workflow_run import snakemake_command, snakemake_env, tree_digest

from analysis.pipeline.plan import build_plan, check_config_files

ROOT = Path(__file__).resolve().parents[2]
SCHEMAS = ROOT / "workflow" / "schemas"
CONFIG = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
GRID = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())


def _paths(obj, prefix=()):
    """Every node's path (dict keys and list indices) in a nested structure."""
    out = []
    items = obj.items() if isinstance(obj, dict) else enumerate(obj) if isinstance(obj, list) else ()
    for k, v in items:
        out.append(prefix + (k,))
        out += _paths(v, prefix + (k,))
    return out


def _parent(doc, path):
    node = doc
    for k in path[:-1]:
        node = node[k]
    return node


ODD_VALUES = st.one_of(
    st.none(), st.booleans(), st.integers(-10**9, 10**9), st.text(max_size=6),
    st.floats(allow_nan=True, allow_infinity=True), st.just([]), st.just({}),
    st.lists(st.floats(allow_nan=True, allow_infinity=True), max_size=3),
)


@st.composite
def mutation(draw, doc):
    """One edit of ``doc`` (in place); returns a short description."""
    paths = _paths(doc)
    path = draw(st.sampled_from(paths))
    parent, key = _parent(doc, path), path[-1]
    kind = draw(st.sampled_from(["value", "negate", "delete", "rename", "add"]))
    if kind == "value":
        parent[key] = draw(ODD_VALUES)
    elif kind == "negate" and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
        parent[key] = -parent[key]
    elif kind == "delete":
        del parent[key]
    elif kind == "rename" and isinstance(parent, dict):
        new = draw(st.one_of(st.just(str(key)[:-1] or "x"), st.just(str(key) + "s"),
                             st.text(min_size=1, max_size=6)))
        parent[new] = parent.pop(key)
    elif kind == "add" and isinstance(parent, dict):
        parent[draw(st.text(min_size=1, max_size=8))] = draw(ODD_VALUES)
    return f"{kind} {'.'.join(map(str, path))}"


@st.composite
def edited_text(draw, base: dict):
    """YAML text of ``base`` after 0-3 edits, and maybe a line given twice or the file cut short."""
    doc = copy.deepcopy(base)
    what = [draw(mutation(doc)) for _ in range(draw(st.integers(1, 3))) if _paths(doc)]
    text = yaml.safe_dump(doc, sort_keys=False)
    lines = text.splitlines(keepends=True)
    tail = draw(st.sampled_from(["none"] * 6 + ["duplicate line", "cut"]))
    if tail == "duplicate line" and lines:
        i = draw(st.integers(0, len(lines) - 1))
        lines.insert(i, lines[i])
    elif tail == "cut" and text:
        lines = [text[:draw(st.integers(0, len(text) - 1))]]
    return "".join(lines), what + [tail]


def parse_like_snakemake(config_text: str, grid_text: str, folder: Path):
    """The workflow's parse-time pass on these two files: the plan, or the refusal."""
    (folder / "config.yaml").write_text(config_text)
    (folder / "grid.yaml").write_text(grid_text)
    before = tree_digest(folder)
    try:
        check_config_files([folder / "config.yaml"])
        config = yaml.safe_load(config_text)  # Snakemake's loader, once the file passed the check
        config["grid_file"] = str(folder / "grid.yaml")
        return build_plan(config, SCHEMAS), None
    except WorkflowError as exc:
        return None, str(exc)
    finally:
        assert tree_digest(folder) == before  # nothing written, nothing removed


@st.composite
def edited_files(draw):
    """(config text, grid text, edits): one of the two shipped files edited, the other as shipped."""
    if draw(st.booleans()):
        text, edits = draw(edited_text(CONFIG))
        return text, yaml.safe_dump(GRID), ["config"] + edits
    text, edits = draw(edited_text(GRID))
    return yaml.safe_dump(CONFIG), text, ["grid"] + edits


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(files=edited_files())
def test_an_edited_config_is_refused_in_one_line_or_planned(tmp_path, files):
    config_text, grid_text, edits = files
    plan, refusal = parse_like_snakemake(config_text, grid_text, tmp_path)
    if refusal is not None:
        assert refusal.startswith("invalid config:") and "\n" not in refusal, (edits, refusal)
    else:
        assert plan.points and set(plan.points) == set(plan.grids["grids"])
        for name, pts in plan.points.items():
            assert pts and sum(len(c) for c in plan.chunks[name]) == len(pts)
    assert not (tmp_path / "results").exists()


def test_unedited_config_plans_the_default_grid(tmp_path):
    plan, refusal = parse_like_snakemake(yaml.safe_dump(CONFIG), yaml.safe_dump(GRID), tmp_path)
    assert refusal is None and len(plan.points["default"]) == 400


@pytest.mark.parametrize("edit, words", [
    (lambda t: t + "model:\n  beta: 0.3\n", "key 'model' given twice"),
    (lambda t: t.replace("  beta: 0.4", "  beta: 0.4\n  beta: 0.5"), "key 'beta' given twice"),
    (lambda t: t.replace("numerics:", "numerics: [", 1), "is not valid YAML (line"),
    (lambda t: "", "is empty"),
])
def test_a_broken_config_file_stops_snakemake_in_one_line(tmp_path, edit, words):
    """Through a real ``snakemake -n`` on the config file the workflow reads by default
    (``config/config.yaml`` of the working directory): Snakemake's own loader would keep the last
    of two keys silently, and report a YAML error without the file or the line.  (A file given
    with ``--configfile`` is read by Snakemake's command line before the workflow: a YAML error
    there gets Snakemake's message.)"""
    text = (ROOT / "config" / "config.yaml").read_text()
    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "config.yaml").write_text(edit(text))
    (tmp_path / "config" / "grid.yaml").write_text((ROOT / "config" / "grid.yaml").read_text())
    before = tree_digest(tmp_path / "config")
    cmd = [a for a in snakemake_command(tmp_path, "-n", "regimes") if a != "--configfile"][:-1]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=snakemake_env())
    assert res.returncode != 0
    lines = [ln for ln in (res.stdout + res.stderr).splitlines() if ln.startswith("invalid config:")]
    assert len(lines) == 1 and words in lines[0], res.stderr[-2000:]
    assert "config/config.yaml" in lines[0]
    assert not (tmp_path / "results").exists()
    assert tree_digest(tmp_path / "config") == before


def test_each_grid_runs_the_refinements_of_its_law_in_the_dag(tmp_path):
    """The wiring of ``Plan.grid_refinements`` (a real ``snakemake -n``): from one refinement
    list a stick-slip grid's convergence runs are ``k_t``'s and a Stribeck grid's ``band``'s,
    and neither gets the other's; a grid with no refinement of its law gets no convergence
    table or figure."""
    from workflow_run import setup_workdir

    grid = {"grids": {
        "dry": {"axes": {"f0_rel": [0.5, 3.0]}, "fixed": {"Omega": 2.5}},
        "wet": {"axes": {"f0_rel": [0.5, 3.0]}, "fixed": {"Omega": 2.5, "law": "stribeck", "v_s": 4e-4}},
        "rigid": {"axes": {"f0_rel": [0.5, 3.0]}, "fixed": {"Omega": 2.5, "law": "rigid-stick",
                                                              "mu_s": 0.3, "mu_k": 0.3}}}}
    work = setup_workdir(tmp_path / "w", grid=grid,
                         convergence={"sample": 1, "seed": 0, "refinements": ["k_t", "band"]})
    res = subprocess.run(snakemake_command(work, "-n", "regimes"), capture_output=True, text=True,
                         timeout=300, env=snakemake_env())
    assert res.returncode == 0, res.stderr[-3000:]
    out = res.stdout + res.stderr
    assert "results/regimes/dry/convergence/k_t.parquet" in out
    assert "results/regimes/wet/convergence/band.parquet" in out
    for absent in ("dry/convergence/band", "wet/convergence/k_t", "rigid/convergence"):
        assert absent not in out, absent
    assert not (work / "results").exists()

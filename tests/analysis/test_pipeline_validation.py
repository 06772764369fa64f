"""Config and grid checks (analysis.pipeline.validation): one line naming the key, before any
work; the model's own parameter rules (beamsim.point.check_point) applied to every grid point."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from snakemake.exceptions import WorkflowError

from analysis.pipeline.convergence import ConvergenceSettings
from analysis.pipeline.grid import expand_grid
from analysis.pipeline.validation import (
    load_yaml_mapping,
    validate_config,
    validate_grid_points,
    validate_model,
)
from beamsim.point import check_point, prepare_point

ROOT = Path(__file__).resolve().parents[2]
SCHEMA = ROOT / "workflow" / "schemas" / "config.schema.yaml"


def _config():
    return yaml.safe_load((ROOT / "config" / "config.yaml").read_text())


def test_shipped_config_passes():
    validate_config(_config(), SCHEMA, "config")


@pytest.mark.parametrize("key, value", [("mu_s", math.nan), ("p", math.inf), ("k_t", -math.inf)])
def test_non_finite_model_value_is_named(key, value):
    cfg = _config()
    cfg["model"][key] = value
    with pytest.raises(WorkflowError, match=rf"invalid config: model\.{key} = {value!r}: must be a finite"):
        validate_config(cfg, SCHEMA, "config")


def _points(fixed):
    grids = {"g": {"axes": {"Omega": [1.0, 2.0]}, "fixed": fixed}}
    cfg = _config()
    return {"g": expand_grid("g", grids["g"], cfg["model"], cfg["numerics"])}, grids


def test_grid_points_pass_the_model_rules():
    validate_grid_points(*_points({"mu_s": 0.45, "mu_k": 0.3}), "grid.yaml")


@pytest.mark.parametrize("fixed, rule", [
    ({"mu_s": 0.45, "mu_k": 0.9}, "mu_s must be >= mu_k"),
    ({"f0": 1e-5}, "only one of f0 and f0_rel"),
    ({"law": "stribeck", "F_c": 2e-5, "F_s": 1e-5}, "F_s must be >= F_c"),
])
def test_grid_point_breaking_a_model_rule_is_one_line(fixed, rule):
    with pytest.raises(WorkflowError, match=r"grids\.g \(point Omega=1\.0\): .*" + rule):
        validate_grid_points(*_points(fixed), "grid.yaml")


def test_check_point_is_the_rule_the_python_api_applies():
    """One source: every point check_point refuses, prepare_point refuses with the same words."""
    bad = dict(n_modes=1, mu_s=0.45, mu_k=0.9)
    with pytest.raises(ValueError, match="mu_s must be >= mu_k") as a:
        check_point(bad)
    with pytest.raises(ValueError) as b:
        prepare_point(**bad)
    assert str(a.value) == str(b.value)


def test_model_defaults_are_a_point_too():
    validate_model(_config()["model"], "config")
    with pytest.raises(WorkflowError, match=r"invalid config: model: mu_s must be >= mu_k"):
        validate_model(dict(_config()["model"], mu_k=0.9), "config")


@pytest.mark.parametrize("text, words", [
    (None, "not found"),
    ("grids: {g: {axes: {Omega: [1.0, 2.0]}}", "is not valid YAML (line"),
    ("", "is empty"),
    ("- 1\n- 2\n", "a list, not a mapping"),
    ("grids:\n  g:\n    axes: {Omega: [1.0]}\n  g:\n    axes: {Omega: [2.0]}\n", "key 'g' given twice"),
])
def test_unreadable_grid_file_is_one_line(tmp_path, text, words):
    path = tmp_path / "grid.yaml"
    if text is not None:
        path.write_text(text)
    with pytest.raises(WorkflowError) as err:
        load_yaml_mapping(str(path), "grid_file", "a 'grids:' mapping")
    msg = str(err.value)
    assert msg.startswith("invalid config:") and words in msg and "\n" not in msg, msg


def test_a_key_with_a_folded_description_is_still_one_line():
    """A schema description written as a folded YAML text (``lines`` of a grid) spans several
    lines; the refusal quoting it must not (found by tests/workflow/test_config_mutations.py:
    ``lines:`` left empty)."""
    grid = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())
    grid["grids"]["default"]["lines"] = None
    with pytest.raises(WorkflowError) as err:
        validate_config(grid, ROOT / "workflow" / "schemas" / "grid.schema.yaml", "grid.yaml")
    assert str(err.value).startswith("invalid config: grids.default.lines = None (1-D lines")
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("value", [-1, "some", 1.5, True])
def test_a_key_with_alternatives_names_all_of_them(value):
    """``multistability.sample`` is an integer or ``all``: a bad value gets the key, the
    description and both alternatives in one line."""
    cfg = _config()
    cfg["multistability"]["sample"] = value
    with pytest.raises(WorkflowError) as err:
        validate_config(cfg, SCHEMA, "config")
    msg = str(err.value)
    assert msg.startswith(f"invalid config: multistability.sample = {value!r} (cells of each grid")
    assert msg.endswith("allowed: integer and >= 0 and <= 100000 or one of all [config]") and "\n" not in msg


def test_unknown_key_gets_a_did_you_mean():
    cfg = _config()
    cfg["numerics"]["n_trasient"] = 10
    with pytest.raises(WorkflowError, match=r"did you mean 'n_transient'\?"):
        validate_config(cfg, SCHEMA, "config")


def test_contradicting_numerics_are_one_line_before_any_point(tmp_path):
    """A cap of the adaptive transient below the transient itself: ``invalid config:`` naming
    both keys, from the plan (before any job)."""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    cfg["numerics"]["n_transient_max"] = 100
    cfg["grid_file"] = str(ROOT / "config" / "grid.yaml")
    with pytest.raises(WorkflowError) as err:
        build_plan(cfg, SCHEMA.parent)
    msg = str(err.value)
    assert msg.startswith("invalid config:") and "n_transient_max = 100" in msg and "\n" not in msg, msg


@pytest.mark.parametrize("edit, words", [
    (dict(method="expo"), ("numerics.method = 'expo'", "law='rigid-stick'")),
    (dict(method="newmark"), ("numerics.method = 'newmark'", "law='rigid-stick'")),
    (dict(method="auto", lyapunov="expo"), ("numerics.lyapunov.method = 'expo'", "law='rigid-stick'")),
])
def test_rigid_stick_with_an_integrator_it_lacks_is_one_line(tmp_path, edit, words):
    """The rigid stick has no ``expo``/``newmark`` integrator: refused at planning, in one line
    naming the key.  (Its missing stick stiffness is not an error: its grids do not run ``k_t``,
    ``test_each_grid_plans_the_refinements_of_its_law``.)"""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    cfg["model"]["law"] = "rigid-stick"
    cfg["model"]["mu_s"] = cfg["model"]["mu_k"] = 0.3
    cfg["grid_file"] = str(_equal_coefficients_grid(tmp_path))
    cfg["numerics"]["method"] = edit["method"]
    if "lyapunov" in edit:
        cfg["numerics"]["lyapunov"]["method"] = edit["lyapunov"]
    cfg["convergence"] = {"sample": 4, "refinements": edit.get("refinements", ["step"])}
    with pytest.raises(WorkflowError) as err:
        build_plan(cfg, SCHEMA.parent)
    msg = str(err.value)
    assert msg.startswith("invalid config:") and "\n" not in msg, msg
    for w in words:
        assert w in msg, msg


@pytest.mark.parametrize("law, knob", [("stick-slip", "k_t"), ("stribeck", "band"),
                                       ("full-slip", "band"), ("rigid-stick", None)])
def test_each_grid_plans_the_refinements_of_its_law(tmp_path, law, knob):
    """``k_t`` is the stick-slip law's interface knob, ``band`` (the velocity band) the
    regularised laws', the rigid stick has neither: from the shipped list each grid gets its
    law's (the workflow's use of them: tests/workflow/test_config_mutations.py)."""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    cfg["model"]["law"] = law
    if law == "rigid-stick":
        cfg["model"]["mu_s"] = cfg["model"]["mu_k"] = 0.3
    cfg["grid_file"] = str(_equal_coefficients_grid(tmp_path) if law == "rigid-stick"
                           else ROOT / "config" / "grid.yaml")
    plan = build_plan(cfg, SCHEMA.parent)
    shipped = ConvergenceSettings().refinements
    assert plan.convergence.refinements == shipped
    want = tuple(r for r in shipped if r not in ("k_t", "band") or r == knob)
    assert plan.grid_refinements == {g: want for g in plan.points}
    cfg["convergence"] = {"sample": 0}
    assert build_plan(cfg, SCHEMA.parent).grid_refinements == {g: () for g in plan.points}
    cfg["convergence"] = {"sample": 0, "census": ["chaotic"]}  # a census alone runs them too
    assert build_plan(cfg, SCHEMA.parent).grid_refinements == {g: want for g in plan.points}


def test_a_census_label_is_checked_and_its_absence_keeps_the_hash():
    """``convergence.census`` names map labels: another word is refused in one line naming the
    key; the key has no schema default, so a config without it hashes as before it existed."""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    before = build_plan(cfg, SCHEMA.parent).config_hash
    assert "census" not in cfg["convergence"]
    cfg["convergence"]["census"] = ["chaos"]
    with pytest.raises(WorkflowError) as err:
        build_plan(cfg, SCHEMA.parent)
    msg = str(err.value)
    assert msg.startswith("invalid config: convergence.census.0 = 'chaos' (a label of the map)"), msg
    assert "\n" not in msg
    assert "chaotic" in msg
    cfg["convergence"]["census"] = ["chaotic"]
    assert build_plan(cfg, SCHEMA.parent).config_hash != before


def test_a_grid_mixing_laws_of_different_knobs_is_one_line(tmp_path):
    """A grid whose axis is the law: ``k_t`` would refine some of its points and not others,
    so its row would mix knobs; refused at planning, in one line naming the key and the law."""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    grids = {"grids": {"laws": {"axes": {"law": {"values": ["stick-slip", "stribeck"]}},
                                "fixed": {"Omega": 1.5, "f0_rel": 2.0}}}}
    path = tmp_path / "grid.yaml"
    path.write_text(yaml.safe_dump(grids))
    cfg["grid_file"] = str(path)
    with pytest.raises(WorkflowError) as err:
        build_plan(cfg, SCHEMA.parent)
    msg = str(err.value)
    assert msg.startswith("invalid config:") and "\n" not in msg, msg
    for w in ("convergence.refinements", "'k_t'", "grid laws", "law stribeck"):
        assert w in msg, msg
    cfg["convergence"] = {"refinements": ["step", "modes"]}
    assert build_plan(cfg, SCHEMA.parent).grid_refinements == {"laws": ("step", "modes")}


def _equal_coefficients_grid(tmp_path):
    """The shipped grid file with ``mu_s = mu_k`` on every grid (the rigid stick's exponent
    exists only then)."""
    grids = yaml.safe_load((ROOT / "config" / "grid.yaml").read_text())
    for g in grids["grids"].values():
        g.setdefault("fixed", {}).update(mu_s=0.3, mu_k=0.3)
    path = tmp_path / "grid.yaml"
    path.write_text(yaml.safe_dump(grids))
    return path


def test_rigid_stick_plans_with_rk4(tmp_path):
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    cfg["model"]["law"] = "rigid-stick"
    cfg["grid_file"] = str(_equal_coefficients_grid(tmp_path))
    cfg["convergence"] = {"sample": 4, "refinements": ["step", "windows", "modes"]}
    plan = build_plan(cfg, SCHEMA.parent)
    assert plan.simulation_methods == ["rk4"] and plan.lyapunov_methods == ["rk4"]
    # compile_kernels builds the rigid stick's own kernels, so no chunk job compiles them
    assert plan.rigid_stick
    cfg = _config()
    cfg["grid_file"] = str(ROOT / "config" / "grid.yaml")
    plan = build_plan(cfg, SCHEMA.parent)
    assert not plan.rigid_stick
    # the shipped (stick-slip) config: expo reference runs (RK4 compiled too, for a run that
    # meets expo's Zeno guard) and expo free copies (the RK4 pair with them: the fallback and
    # the second opinion); rk4: RK4 pairs
    assert plan.simulation_methods == ["expo", "rk4"] and plan.lyapunov_methods == ["expo", "rk4"]
    cfg["numerics"]["lyapunov"]["method"] = "rk4"
    assert build_plan(cfg, SCHEMA.parent).lyapunov_methods == ["rk4"]


def test_a_grid_with_rk4_free_copies_keeps_the_kernel_stamps_params():
    """The kernel stamps' params (what ``compile_kernels`` builds) are the same for the shipped
    grid file and for config/grid_chaos.yaml, whose ``mu_s = mu_k`` row runs RK4 free copies:
    changed params rebuild a stamp, and Snakemake 9.15 then drops every job that reads it
    through ``ancient()`` (found running the chaos grid after the default one: the run ended
    after recompiling, asking to be run again).  The RK4 pair is compiled first in any case."""
    from analysis.pipeline.plan import build_plan
    from analysis.pipeline.stages import free_copy_integrator

    plans = []
    for grid_file in ("grid.yaml", "grid_chaos.yaml"):
        cfg = _config()
        cfg["grid_file"] = str(ROOT / "config" / grid_file)
        plans.append(build_plan(cfg, SCHEMA.parent))
    chaos = plans[1]
    frees = {free_copy for pts in chaos.points.values() for free_copy in
             (free_copy_integrator(chaos.numerics.lyapunov.method, p.params) for p in pts)}
    assert frees == {"expo", "rk4"}  # the chaos grid does need both
    for plan in plans:
        assert plan.simulation_methods == ["expo", "rk4"] and plan.lyapunov_methods == ["expo", "rk4"]
        assert not plan.rigid_stick


def test_equal_coefficients_keep_the_rk4_free_copy(tmp_path):
    """``mu_s = mu_k`` (the paper's law): ``auto`` gives the stick-slip map expo reference runs
    but RK4 free copies (an element sticks at its slip limit; the expo copy can chatter there,
    docs/lyapunov.md section 12), and ``lyapunov.method: expo`` is refused in one line naming
    the key and both coefficients."""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    cfg["grid_file"] = str(_equal_coefficients_grid(tmp_path))
    plan = build_plan(cfg, SCHEMA.parent)
    assert plan.simulation_methods == ["expo", "rk4"] and plan.lyapunov_methods == ["rk4"]
    cfg["numerics"]["lyapunov"]["method"] = "expo"
    with pytest.raises(WorkflowError) as err:
        build_plan(cfg, SCHEMA.parent)
    msg = str(err.value)
    assert msg.startswith("invalid config: numerics.lyapunov.method = 'expo'") and "\n" not in msg
    assert "needs mu_s > mu_k" in msg and "mu_s = 0.3, mu_k = 0.3" in msg, msg


def test_a_rigid_stick_map_with_a_breakaway_drop_is_refused():
    """``mu_s > mu_k`` with the rigid stick: no Lyapunov exponent to map (one line, naming
    both coefficients and the alternative)."""
    from analysis.pipeline.plan import build_plan

    cfg = _config()
    cfg["model"]["law"] = "rigid-stick"
    cfg["grid_file"] = str(ROOT / "config" / "grid.yaml")  # mu_s 0.45, mu_k 0.3
    with pytest.raises(WorkflowError) as err:
        build_plan(cfg, SCHEMA.parent)
    msg = str(err.value)
    assert msg.startswith("invalid config:") and "\n" not in msg, msg
    assert "mu_s = 0.45 > mu_k = 0.3" in msg and "stick-slip" in msg, msg


@pytest.mark.parametrize("key", ["\n\n", " Omega", ""])
def test_a_grid_key_that_does_not_print_as_itself_is_named_in_one_line(key):
    """A fixed override whose key holds a newline, blanks around it, or nothing (an edit the
    config-mutation test found, 2026-11-27) is named by its ``repr``: the refusal stays one
    line."""
    from analysis.pipeline.validation import validate_grid_values

    model_schema = yaml.safe_load(SCHEMA.read_text())["$defs"]["model"]
    grids = {"g": {"axes": {"Omega": [1.0]}, "fixed": {key: 1.85}}}
    with pytest.raises(WorkflowError) as err:
        validate_grid_values(grids, model_schema, "grid.yaml")
    msg = str(err.value)
    assert msg.startswith(f"invalid config: grids.g.fixed.{key!r}: unknown model parameter"), msg
    assert "\n" not in msg

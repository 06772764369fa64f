"""Convergence evidence of a map (analysis.pipeline.convergence): what each refinement changes,
the stratified seeded sample, the summary, and a linear limit whose label must hold under every
refinement."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.figures.convergence import row_labels
from analysis.pipeline.config import Numerics
from analysis.pipeline.convergence import (
    CENSUS_LABELS,
    LONG_RUN_PERIODS,
    MAX_MODES,
    NUDGE,
    REFINEMENTS,
    REGULARISED_LAWS,
    ConvergenceSettings,
    census_line,
    convergence_runs,
    convergence_summary,
    grid_refinements,
    held_interval,
    refine,
    reuses_reference_runs,
    same_label,
    sample_points,
    summary_line,
    title_line,
    unchecked_reason,
)
from analysis.pipeline.grid import canonical_json, point_id
from analysis.pipeline.stages import expo_copy_steps
from beamsim.coupled_copies import EXPO_COPY_STEPS_PER_PERIOD
from beamsim.friction import Friction
from beamsim.point import DEFAULT_STEPS_PER_PERIOD

ROOT = Path(__file__).resolve().parents[2]
POINT = {"n_modes": 2, "k_t": 10.0, "mu_s": 0.45, "mu_k": 0.3, "Omega": 2.5, "f0_rel": 0.3}


def test_each_refinement_changes_its_knob_only():
    nm = Numerics()
    p, r = refine("step", POINT, nm)  # stick-slip: expo reference, its switch checks twice as dense
    assert p == POINT
    # (and the RK4 step of its Zeno fallback halved: expo itself does not use step_factor)
    assert r.steps_per_period == 2 * DEFAULT_STEPS_PER_PERIOD["expo"] and r.step_factor == nm.step_factor / 2
    assert r.lyapunov.step_factor == nm.lyapunov.step_factor / 2
    # the Lyapunov stage's expo copies: their own grid, doubled with the reference's
    assert expo_copy_steps(nm.steps_per_period) is None
    assert expo_copy_steps(r.steps_per_period) == 2 * EXPO_COPY_STEPS_PER_PERIOD
    p, r = refine("step", POINT | {"law": "stribeck"}, nm)  # RK4 reference: its step halved
    assert r.steps_per_period is None and r.step_factor == nm.step_factor / 2
    _, r = refine("step", POINT, Numerics(method="rk4", steps_per_period=300))
    assert r.steps_per_period == 600
    p, r = refine("windows", POINT, nm)
    assert p == POINT and r.n_long_transient == nm.n_long_transient  # long_run refines that
    assert (r.n_transient, r.n_transient_max, r.n_record) == (2 * nm.n_transient, 2 * nm.n_transient_max,
                                                              2 * nm.n_record)
    ly, ly0 = r.lyapunov, nm.lyapunov
    assert (ly.n_periods, ly.burn_in, ly.block_periods) == (2 * ly0.n_periods, 2 * ly0.burn_in,
                                                            2 * ly0.block_periods)
    assert (ly.min_blocks, ly.max_blocks, ly.step_factor) == (ly0.min_blocks, ly0.max_blocks, ly0.step_factor)
    p, r = refine("separation", POINT, nm)  # both pairs' separations a tenth, nothing else
    assert p == POINT
    assert r == replace(nm, lyapunov=replace(nm.lyapunov, expo_e0=nm.lyapunov.expo_e0 / 10,
                                             rk4_e0=nm.lyapunov.rk4_e0 / 10))
    assert (r.lyapunov.expo_e0, r.lyapunov.rk4_e0) == (pytest.approx(1e-5), pytest.approx(1e-7))
    p, r = refine("k_t", POINT, nm)
    assert p == POINT | {"k_t": 30.0} and r == nm
    p, r = refine("modes", POINT, nm)
    assert p == POINT | {"n_modes": 3} and r == nm
    stribeck = POINT | {"law": "stribeck"}  # the regularised laws' band: eps_rel, or eps_v if given
    p, r = refine("band", stribeck, nm)
    assert p == stribeck | {"eps_rel": Friction.eps_rel / 2} and r == nm
    p, r = refine("band", stribeck | {"eps_rel": 0.02}, nm)
    assert p == stribeck | {"eps_rel": 0.01}
    absolute = POINT | {"law": "full-slip", "eps_v": 3e-5}
    assert refine("band", absolute, nm)[0] == absolute | {"eps_v": 1.5e-5}
    with pytest.raises(ValueError, match="'band'.*law stick-slip"):
        refine("band", POINT, nm)
    with pytest.raises(ValueError, match="'band'.*law rigid-stick"):
        refine("band", POINT | {"law": "rigid-stick"}, nm)
    for law in (*REGULARISED_LAWS, "rigid-stick"):  # k_t is no knob of theirs
        with pytest.raises(ValueError, match=f"'k_t'.*law {law}"):
            refine("k_t", POINT | {"law": law}, nm)
    # the transient, and no long run of its own (it is one); the start is the map's end state
    p, r = refine("long_run", POINT, nm)
    assert p == POINT and r == replace(nm, n_transient=LONG_RUN_PERIODS, n_long_transient=0,
                                       n_transient_max=max(nm.n_transient_max, LONG_RUN_PERIODS))
    assert nm.n_long_transient > 0 and r.n_long_transient == 0
    p, r = refine("load_up", POINT, nm)  # the controls: the load, not the numerics
    assert p == POINT | {"f0_rel": pytest.approx(0.3 * 1.02)} and r == nm
    p, r = refine("load_down", POINT, nm)
    assert p == POINT | {"f0_rel": pytest.approx(0.3 / 1.02)} and r == nm
    absolute = {k: v for k, v in POINT.items() if k != "f0_rel"} | {"f0": 4e-7, "f0_rel": None}
    assert refine("load_up", absolute, nm)[0] == absolute | {"f0": pytest.approx(4e-7 * 1.02)}
    unloaded = {k: v for k, v in POINT.items() if k != "f0_rel"}  # prepare_point's default 2
    assert refine("load_down", unloaded, nm)[0] == unloaded | {"f0_rel": pytest.approx(2 / 1.02)}
    p, r = refine("nudge", POINT, nm)  # the load's ninth digit
    assert p == POINT | {"f0_rel": 0.3 * (1 + NUDGE)} and p["f0_rel"] != POINT["f0_rel"] and r == nm
    assert refine("nudge", absolute, nm)[0] == absolute | {"f0": 4e-7 * (1 + NUDGE)}
    assert POINT["n_modes"] == 2 and POINT["k_t"] == 10.0  # the input is not modified
    with pytest.raises(ValueError, match="n_modes"):
        refine("modes", POINT | {"n_modes": 12}, nm)
    with pytest.raises(ValueError, match="unknown refinement"):
        refine("dt", POINT, nm)


def test_refined_points_have_their_own_ids():
    """The per-point store is keyed by id: a refined run must never be mistaken for the map's."""
    for point, knob in ((POINT, "k_t"), (POINT | {"law": "stribeck"}, "band")):
        refs = [r for r in REFINEMENTS if r not in ("k_t", "band")] + [knob]
        ids = {point_id(point, Numerics())}
        for ref in refs:
            ids.add(point_id(*refine(ref, point, Numerics())))
        assert len(ids) == 1 + len(refs)
    # an RK4-pair grid (mu_s = mu_k: expo_e0 is not in its ids): the separation is rk4_e0's
    rk4 = Numerics.from_dict({"lyapunov": {"method": "rk4"}})
    assert point_id(*refine("separation", POINT, rk4)) != point_id(POINT, rk4)


def test_only_the_separation_reuses_the_maps_reference_runs():
    """The refinements that change the reference runs' parameters or numerics run them again;
    ``separation`` changes the Lyapunov stage's numerics alone."""
    nm = Numerics()
    for point in (POINT, POINT | {"law": "stribeck"}):
        for ref in grid_refinements(REFINEMENTS, [point], "g"):
            p, r = refine(ref, point, nm)
            assert reuses_reference_runs(point, nm, p, r) == (ref == "separation"), ref


def test_each_grid_runs_the_knobs_of_its_law():
    """One ``convergence.refinements`` serves grids of different laws: each runs the
    refinements that are knobs of its law; a grid that mixes laws with different knobs is an
    error naming the refinement and the law."""
    refs = ("step", "k_t", "band", "modes")
    assert grid_refinements(refs, [POINT, POINT], "g") == ("step", "k_t", "modes")
    assert grid_refinements(refs, [POINT | {"law": "stribeck"}], "g") == ("step", "band", "modes")
    assert grid_refinements(refs, [POINT | {"law": "full-slip"}], "g") == ("step", "band", "modes")
    assert grid_refinements(refs, [POINT | {"law": "rigid-stick"}], "g") == ("step", "modes")
    assert grid_refinements(("k_t",), [POINT | {"law": "stribeck"}], "g") == ()
    with pytest.raises(ValueError, match="'k_t'.*grid g.*law stribeck"):
        grid_refinements(refs, [POINT, POINT | {"law": "stribeck"}], "g")
    # step, windows, modes and the controls are knobs of every law
    mixed = [POINT, POINT | {"law": "stribeck"}]
    assert grid_refinements(refs[:1] + refs[3:], mixed, "g") == ("step", "modes")


def test_a_map_without_runs_says_why():
    """The map's title says why its labels were not checked: no sample, or no refinement of the
    list is a knob of the grid's law (a grid of law stribeck given only ``k_t``)."""
    assert summary_line(None) == "labels not checked under refinement (convergence.sample = 0)"
    assert unchecked_reason((), [POINT]) == "convergence.sample = 0"
    why = unchecked_reason(("k_t",), [POINT | {"law": "stribeck"}])
    assert why == "none of convergence.refinements (k_t) is a knob of law stribeck"
    assert summary_line(None, why) == f"labels not checked under refinement ({why})"


@pytest.mark.parametrize("band", [{}, {"eps_rel": 0.02}, {"eps_v": 3e-5}])
def test_the_band_refinement_halves_the_kernels_band(band):
    """What the kernels integrate: the prepared point's velocity band is half the map's, and
    nothing else of the point moves (load, frequency, slip-onset load, pressure)."""
    from beamsim.point import prepare_point

    point = {"n_modes": 1, "law": "stribeck", "mu_s": 0.45, "mu_k": 0.3, "v_s": 4e-4,
             "Omega": 1.5, "f0_rel": 2.0} | band
    a = prepare_point(**point)
    b = prepare_point(**refine("band", point, Numerics())[0])
    assert b.eps_v == pytest.approx(a.eps_v / 2, rel=1e-12)
    assert (b.f0, b.omega, b.f_cr) == (a.f0, a.omega, a.f_cr)
    # its stiffness: the band's slope F_s / eps_v sets the RK4 step (omega_max about doubles)
    assert 1.8 < b.omega_max / a.omega_max <= 2.0


def _table(counts: dict) -> pd.DataFrame:
    labels = [lab for lab, c in counts.items() for _ in range(c)]
    return pd.DataFrame({"point_id": [f"{i:04d}" for i in range(len(labels))], "label": labels})


def test_sample_is_stratified_seeded_and_weighted():
    t = _table({"periodic": 165, "quasi-periodic": 169, "chaotic": 21, "undetermined": 38, "unsettled": 7})
    s = sample_points(t, 20, seed=0)
    assert len(s) == 20 and s["point_id"].is_unique
    got = s["label"].value_counts()
    assert set(got.index) == set(t["label"])  # every label present, rare ones at least twice
    assert got.min() >= 2
    assert got["quasi-periodic"] >= got["chaotic"] and got["periodic"] >= got["unsettled"]
    # the stratum weights make the sample stand for the whole map
    assert s["weight"].sum() == pytest.approx(len(t))
    for lab, g in s.groupby("label"):
        assert g["weight"].iloc[0] == pytest.approx((t["label"] == lab).sum() / len(g))
    assert list(s.index) == sorted(s.index)  # the table's order
    again = sample_points(t.sample(frac=1.0, random_state=3), 20, seed=0)  # row order is irrelevant
    assert set(again["point_id"]) == set(s["point_id"])
    assert set(sample_points(t, 20, seed=1)["point_id"]) != set(s["point_id"])
    small = sample_points(_table({"periodic": 3, "chaotic": 1}), 10)
    assert len(small) == 4 and (small["weight"] == 1.0).all()
    tight = sample_points(_table({"a": 50, "b": 5, "c": 1}), 2)  # fewer slots than labels x 2
    assert len(tight) == 2 and set(tight["label"]) == {"b", "c"}


def test_a_census_takes_every_cell_of_its_labels_and_keeps_the_other_draws():
    """``census``: every cell of the named labels, weight 1 (each stands for itself); the
    other labels' cells are the sample's without the census, to the point, so that the census
    only adds cells; the estimate of the map's fraction still sums to the map's cells."""
    t = _table({"periodic": 165, "quasi-periodic": 169, "chaotic": 21, "undetermined": 38, "unsettled": 7})
    for seed in (0, 1, 7):
        plain = sample_points(t, 20, seed=seed)
        s = sample_points(t, 20, seed=seed, census=["chaotic", "undetermined"])
        whole = s["label"].isin(["chaotic", "undetermined"])
        assert set(s.loc[whole, "point_id"]) == set(t.loc[t["label"].isin(["chaotic", "undetermined"]),
                                                          "point_id"])
        assert (s.loc[whole, "weight"] == 1.0).all()
        rest = plain[~plain["label"].isin(["chaotic", "undetermined"])]
        assert list(s.loc[~whole, "point_id"]) == list(rest["point_id"])
        assert list(s.loc[~whole, "weight"]) == list(rest["weight"])
        assert s["weight"].sum() == pytest.approx(len(t))
        assert list(s.index) == sorted(s.index)
    # a census of a label the map does not have adds nothing; with no sample, the census alone
    assert sample_points(t, 20, census=["diverged"]).equals(sample_points(t, 20))
    only = sample_points(t, 0, census=["unsettled"])
    assert list(only["label"]) == ["unsettled"] * 7


def test_held_interval_is_the_exact_binomial_one():
    """Clopper-Pearson closed forms: all ``n`` held gives ``[(a/2)^(1/n), 1]``, none held
    ``[0, 1 - (a/2)^(1/n)]`` (``a = 0.05``); one of two: ``1 - (1 - p)^2 = a/2`` at the lower
    end, so ``[1 - sqrt(1 - a/2), sqrt(1 - a/2)]``; the interval holds its fraction and narrows
    as the sample grows."""
    for n in (3, 20, 100):
        assert held_interval(n, n) == pytest.approx((0.025 ** (1 / n), 1.0))
        assert held_interval(0, n) == pytest.approx((0.0, 1 - 0.025 ** (1 / n)))
    assert held_interval(1, 2) == pytest.approx((1 - 0.975 ** 0.5, 0.975 ** 0.5))
    lo, hi = held_interval(19, 20)
    assert lo < 0.95 < hi and lo == pytest.approx(0.7513, abs=1e-4)
    assert np.diff(held_interval(95, 100)) < np.diff(held_interval(19, 20))
    assert all(np.isnan(held_interval(0, 0)))


def test_the_sample_follows_grid_positions_not_ids():
    """With index columns the draw follows the points' grid positions: new ids (a new results
    version) give the same points wherever the labels are the same."""
    t = _table({"periodic": 60, "quasi-periodic": 30, "chaotic": 6})
    t["index_0"] = np.arange(len(t)) % 12
    t["index_1"] = np.arange(len(t)) // 12
    s = sample_points(t, 10, seed=0)
    renamed = t.assign(point_id=[f"v13-{i:04d}"[::-1] for i in range(len(t))])  # other ids, other order
    again = sample_points(renamed, 10, seed=0)
    assert list(again.index) == list(s.index)


def test_summary_counts_fractions_and_flips():
    runs = pd.DataFrame({
        "point_id": ["a", "b", "c", "a", "b", "c"],
        "refinement": ["step"] * 3 + ["k_t"] * 3,
        "weight": [1.0, 3.0, 6.0] * 2,
        "label": ["chaotic", "periodic", "periodic"] * 2,
        "refined_label": ["chaotic", "periodic", "periodic", "quasi-periodic", "periodic", "chaotic"],
        "period": [None, 1, 2] * 2, "refined_period": [None, 1, 2, None, 1, None],
    })
    runs["holds"] = [same_label(*r) for r in runs[["label", "period", "refined_label", "refined_period"]]
                     .itertuples(index=False)]
    s = convergence_summary(runs)
    assert list(s["refinement"]) == ["step", "k_t"]
    assert list(s["held"]) == [3, 1] and list(s["n"]) == [3, 3]
    assert s["fraction"].tolist() == pytest.approx([1.0, 1 / 3])
    assert s["map_fraction"].tolist() == pytest.approx([1.0, 0.3])
    assert list(s["contradicted"]) == [0, 2]
    assert s["flips"].iloc[1] == "chaotic -> quasi-periodic: 1; periodic-2 -> chaotic: 1"
    assert summary_line(s) == ("labels hold (sampled points; 95 % interval): step / 2 3/3 [0.29-1.00], "
                               "k_t x 3 1/3 [0.01-0.91]; moved without a flag (no verdict, no "
                               "neighbour shares it, moves under a control): step / 2 0, k_t x 3 2")
    runs.loc[3, "refined_label"] = "undetermined"  # no verdict: a change, not a contradiction
    runs.loc[3, "holds"] = False
    runs.loc[4, "refined_period"] = 3  # period 1 -> 3: the label does not hold
    runs.loc[4, "holds"] = same_label("periodic", 1, "periodic", 3)
    s = convergence_summary(runs)
    assert list(s["held"]) == [3, 0] and list(s["contradicted"]) == [0, 2]
    assert "periodic-1 -> periodic-3: 1" in s["flips"].iloc[1]
    assert same_label("periodic", 2, "periodic", 2) and not same_label("periodic", 2, "periodic", 1)
    assert same_label("chaotic", None, "chaotic", pd.NA)
    assert not same_label("chaotic", None, "undetermined", None)
    assert "not checked" in summary_line(None)


def test_summary_counts_the_labels_that_hold_among_the_robust_points():
    """Five points: a and b keep their labels under every control (robust), c moves under one
    load control, d under the other and e under the nudge.  k_t moves a, c, d and e: of the 2
    robust points 1 holds; the controls' own rows and a summary without controls have no
    robust counts."""
    refs = ["k_t", "load_up", "load_down", "nudge"]
    moved = {"k_t": "acde", "load_up": "c", "load_down": "d", "nudge": "e"}
    runs = pd.DataFrame([{"point_id": p, "refinement": ref, "weight": 1.0, "label": "periodic",
                          "period": 1, "refined_label": "chaotic" if p in moved[ref] else "periodic",
                          "refined_period": None if p in moved[ref] else 1, "holds": p not in moved[ref]}
                         for ref in refs for p in "abcde"])
    s = convergence_summary(runs)
    assert list(s["held"]) == [1, 4, 4, 4]
    assert s["n_robust"].tolist() == [2] + [pd.NA] * 3 and s["held_robust"].tolist() == [1] + [pd.NA] * 3
    assert "; of the 2/5 whose label holds under the controls: k_t x 3 1/2;" in summary_line(s)
    # c, d and e move under a control (flagged); a moved without a flag
    assert s["unflagged"].tolist() == [1] + [pd.NA] * 3
    assert summary_line(s).endswith("moves under a control): k_t x 3 1")
    alone = convergence_summary(runs[runs["refinement"] == "k_t"])
    assert alone["n_robust"].isna().all() and "holds under the controls" not in summary_line(alone)
    # the map's title: the same counts, short (an entry's words joined by no-break spaces)
    assert "k_t\u00a0x\u00a03\u00a01/5" in title_line(s)
    short = title_line(s).replace("\u00a0", " ")
    assert short == ("labels held (convergence.png): k_t x 3 1/5; controls: load x 1.02 4/5, "
                     "load / 1.02 4/5, load x (1 + 1e-9) 4/5; of the 2 robust: k_t x 3 1; "
                     "moved without a flag: k_t x 3 1")
    # without the controls nothing flags c, d and e: four moves without a flag
    assert title_line(alone).replace("\u00a0", " ") == ("labels held (convergence.png): k_t x 3 1/5; "
                                                       "moved without a flag: k_t x 3 4")
    assert title_line(None, "why") == summary_line(None, "why")


def test_the_census_line_counts_each_census_label_apart():
    """The title's census clause: per census label, its own cells' labels held per refinement
    and control and among its robust cells; the sample's other labels do not enter it; a label
    with no robust cell says so; no census, or a label the map lacks, adds nothing."""
    refs = ["k_t", "modes", "load_up", "load_down", "nudge"]
    moved = {"k_t": "cdx", "modes": "d", "load_up": "c", "load_down": "e", "nudge": ""}
    runs = pd.DataFrame([{"point_id": p, "refinement": ref, "weight": 1.0,
                          "label": "chaotic" if p in "abcde" else "quasi-periodic", "period": None,
                          "refined_label": "periodic" if p in moved[ref] else "chaotic",
                          "refined_period": 1 if p in moved[ref] else None, "holds": p not in moved[ref]}
                         for ref in refs for p in "abcdexy"])
    line = census_line(runs, ["chaotic"]).replace("\u00a0", " ")
    # robust: a, b, d (c and e move under a load control); k_t keeps a, b of them, modes a, b
    assert line == ("every chaotic cell (5): k_t x 3 3, modes + 1 4; controls: load x 1.02 4, "
                    "load / 1.02 4, load x (1 + 1e-9) 5; of its 3 robust: k_t x 3 2, modes + 1 2")
    tori = runs[runs["label"] == "quasi-periodic"].assign(
        holds=lambda d: d["refinement"].isin(["k_t", "modes", "nudge"]))
    assert census_line(tori, ["quasi-periodic"]).replace("\u00a0", " ").endswith("; none robust")
    assert census_line(runs, []) == "" and census_line(runs, ["unsettled"]) == ""


def test_a_census_without_cells_gives_empty_tables_of_the_same_columns(tmp_path):
    """No sample and a census of a label the map lacks: no cell to re-run, and an empty runs
    table and summary of the usual columns (not a crash), which the title reads as unchecked."""
    table = pd.DataFrame([{"point_id": "p", "label": "periodic", "params_json": json.dumps(POINT),
                           "Omega": 2.5, "f0_rel": 0.3}])
    runs = convergence_runs(table, "k_t", Numerics(), ConvergenceSettings(sample=0, census=("chaotic",)),
                            str(tmp_path), axes=["Omega", "f0_rel"])
    assert runs.empty and {"point_id", "Omega", "label", "refined_label", "holds"} <= set(runs.columns)
    summary = convergence_summary(runs)
    assert summary.empty and {"held", "n_robust", "unflagged"} <= set(summary.columns)
    assert title_line(summary, "why") == "labels not checked under refinement (why)"


def test_settings_defaults_are_the_shipped_config_and_bad_values_are_refused():
    shipped = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["convergence"]
    assert ConvergenceSettings.from_dict(shipped) == ConvergenceSettings()
    schema = yaml.safe_load((ROOT / "workflow" / "schemas" / "config.schema.yaml").read_text())
    props = schema["properties"]["convergence"]["properties"]
    assert {k: v["default"] for k, v in props.items() if "default" in v} == {
        "sample": 20, "seed": 0, "refinements": list(REFINEMENTS)}
    # every refinement the config can name is one of the module's (and only those); so are the
    # census labels, which have no default (a config without them keeps its hash)
    assert props["refinements"]["items"]["enum"] == list(REFINEMENTS)
    assert props["census"]["items"]["enum"] == list(CENSUS_LABELS) and "default" not in props["census"]
    assert ConvergenceSettings.from_dict({}) == ConvergenceSettings()
    assert schema["$defs"]["model"]["properties"]["n_modes"]["maximum"] == MAX_MODES
    assert ConvergenceSettings.from_dict({"sample": 0}).active == ()
    for bad, match in (({"sample": -1}, "sample"), ({"refinements": ["dt"]}, "refinements"),
                       ({"refinements": ["k_t", "k_t"]}, "twice"), ({"size": 3}, "unknown"),
                       ({"census": ["chaos"]}, "convergence.census"),
                       ({"census": ["chaotic", "chaotic"]}, "distinct")):
        with pytest.raises(ValueError, match=match):
            ConvergenceSettings.from_dict(bad)
    # a census runs the refinements even without a sample; the jobs' settings name it only
    # where it is given (the shipped config's jobs keep their parameters)
    census = ConvergenceSettings.from_dict({"sample": 0, "census": ["chaotic"]})
    assert census.active == tuple(REFINEMENTS) and census.census == ("chaotic",)
    assert census.as_dict() == {"sample": 0, "seed": 0, "census": ["chaotic"]}
    assert ConvergenceSettings().as_dict() == {"sample": 20, "seed": 0}


def _one_point_map(point: dict, nm: Numerics, store) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The regime table of a one-point map through the pipeline's stages (store ``store``),
    with its simulate and Lyapunov records."""
    from analysis.pipeline.stages import classify_points, lle_resolution, lyapunov_points, simulate_points
    from analysis.pipeline.table import assemble_regime_table

    pts = [{"point_id": point_id(point, nm), "params": point, "index": [0]}]
    sim = simulate_points(pts, nm, str(store), threads=2)
    lyap = lyapunov_points(pts, sim, nm, str(store), threads=2)
    return assemble_regime_table(pts, sim, lyap, classify_points(sim, lyap, lle_resolution(nm))), sim, lyap


def test_a_linear_point_keeps_its_label_under_every_refinement(tmp_path):
    """A limit with a known answer: below the slip onset (f0_rel 0.3: the peak tip load 0.6 of
    the static slip load) every Jenkins element stays stuck and, with 10 % modal damping, the
    beam is a linear damped structure under a harmonic load: after the transient its response
    is the unique periodic orbit of the forcing period, whatever the step, the windows, k_t or
    the mode count.  The label must be periodic-1 under every refinement and the refined run
    must still never slip.  (A refinement that broke a run -- divergence, a spurious slip, a
    transient cut short -- fails this.)  Without the damping the stuck beam's free vibration
    never decays and the same point is a torus (quasi-periodic), which is not a test of the
    refinements but of the start."""
    nm = Numerics(n_transient=80, n_record=128, n_transient_max=80)  # 40: the decay still shows
    point = POINT | {"damping": 0.1}
    table, sim, lyap = _one_point_map(point, nm, tmp_path)
    assert table["label"].iloc[0] == "periodic" and not table["slipped"].iloc[0]
    settings = ConvergenceSettings(sample=1)
    for ref in grid_refinements(REFINEMENTS, [point], "g"):  # every knob of the stick-slip law
        runs = convergence_runs(table, ref, nm, settings, str(tmp_path), axes=["f0_rel"], threads=2)
        assert len(runs) == 1
        r = runs.iloc[0]
        assert r["refinement"] == ref and r["f0_rel"] == point["f0_rel"]
        assert r["refined_label"] == "periodic" and r["refined_period"] == 1, (ref, r["refined_reason"])
        assert bool(r["holds"])
        assert r["refined_point_id"] != r["point_id"]
        assert json.loads(table["params_json"].iloc[0]) == point  # the map's point is untouched
    assert canonical_json(point) == table["params_json"].iloc[0]


def test_a_moved_model_label_is_followed_from_the_maps_attractor(tmp_path):
    """A model refinement's moved label is followed from the map run's stored end state into
    the refined model (``k_t`` in three geometric steps, ``modes`` in one) and classified there:
    on the linear damped structure (one attractor, whatever ``k_t`` or the mode count) the
    continued label is the refined one, periodic-1.  The map's label is set to chaotic by hand
    so that it "moves"; a label that holds is not followed (NA)."""
    from analysis.pipeline.convergence import K_T_STEPS, continuation_path

    nm = Numerics(n_transient=80, n_record=128, n_transient_max=80)
    point = POINT | {"damping": 0.1}
    table, sim, lyap = _one_point_map(point, nm, tmp_path)
    settings = ConvergenceSettings(sample=1)
    path = continuation_path("k_t", point, refine("k_t", point, nm)[0])
    assert len(path) == K_T_STEPS and path[-1]["k_t"] == 3 * point["k_t"]
    assert point["k_t"] < path[0]["k_t"] < path[1]["k_t"] < path[2]["k_t"]
    assert path[1]["k_t"] / path[0]["k_t"] == pytest.approx(path[0]["k_t"] / point["k_t"])
    held = convergence_runs(table, "k_t", nm, settings, str(tmp_path), axes=["f0_rel"], threads=2)
    assert bool(held["holds"].iloc[0]) and pd.isna(held["continued_label"].iloc[0])
    moved = table.assign(label="chaotic", period=pd.array([None], dtype="Int64"))
    runs = [convergence_runs(moved, ref, nm, settings, str(tmp_path), axes=["f0_rel"], threads=2)
            for ref in ("k_t", "modes", "step")]
    for r in runs[:2]:
        assert not bool(r["holds"].iloc[0])
        assert (r["continued_label"].iloc[0], r["continued_period"].iloc[0]) == ("periodic", 1)
    assert pd.isna(runs[2]["continued_label"].iloc[0])  # not a model refinement
    # the summary: one moved label followed per model refinement, none ending on the map's label
    summary = convergence_summary(pd.concat(runs, ignore_index=True)).set_index("refinement")
    assert list(summary.loc[["k_t", "modes"], "followed"]) == [1, 1]
    assert list(summary.loc[["k_t", "modes"], "persisted"]) == [0, 0]
    assert pd.isna(summary.loc["step", "followed"])
    assert (f"ending on the map's label: {REFINEMENTS['k_t']} 0/1, {REFINEMENTS['modes']} 0/1"
            in summary_line(summary.reset_index()))
    names = row_labels(summary.reset_index())  # the convergence figure's rows
    assert names[0].endswith("the map's label 0/1") and names[2] == REFINEMENTS["step"]


def test_the_long_run_continues_the_maps_own_run(tmp_path):
    """``long_run`` starts each sampled point from the end state the map's run stored and runs
    LONG_RUN_PERIODS periods before its record: its record is, to the bit, that of the simulate
    stage run by hand from that state with the long transient (not from rest), and its id
    contains the state.  On the lightly damped stuck structure (0.2 % modal damping, below the
    shakedown limit: one attractor, periodic-1) the long run's label is periodic-1: it holds
    where the map says so, and moves where the map's label is set by hand to quasi-periodic (as
    a record read during a slow creep is)."""
    from analysis.continuation import state_params
    from analysis.pipeline.stages import simulate_runs
    from analysis.pipeline.store import PointStore
    from beamsim.simulate import prepare_point

    nm = Numerics(n_transient=80, n_record=128, n_transient_max=80)
    point = POINT | {"damping": 0.002}
    table, sim, lyap = _one_point_map(point, nm, tmp_path)
    settings = ConvergenceSettings(sample=1)
    held = convergence_runs(table, "long_run", nm, settings, str(tmp_path), axes=["f0_rel"], threads=2)
    moved = convergence_runs(table.assign(label="quasi-periodic", period=pd.array([None], dtype="Int64")),
                             "long_run", nm, settings, str(tmp_path), axes=["f0_rel"], threads=2)
    for runs, holds in ((held, True), (moved, False)):
        r = runs.iloc[0]
        assert (r["refined_label"], r["refined_period"]) == ("periodic", 1), r["refined_reason"]
        assert bool(r["holds"]) == holds
    end = sim["final_state"].iloc[0]
    model = prepare_point(**point).model
    start = {k: np.asarray(v).tolist() for k, v in state_params(end, model.n, model.n_quad).items()}
    params, long_nm = refine("long_run", point, nm)
    rid = held["refined_point_id"].iloc[0]
    assert rid == moved["refined_point_id"].iloc[0] == point_id(params | start, long_nm)
    stored = PointStore(str(tmp_path), "simulate").load(rid)
    assert stored["n_transient_used"] >= LONG_RUN_PERIODS
    from_end, from_rest = (simulate_runs([{"point_id": "x", "params": p}], long_nm, 1)[0]["poincare_state"]
                           for p in (point | start, point))
    np.testing.assert_array_equal(stored["poincare_state"], from_end)
    assert np.any(stored["poincare_state"] != from_rest)


def test_neighbour_support_counts_axis_neighbours_with_the_same_label():
    """A 3 x 3 grid, computed by hand: the centre is chaotic in a periodic-1 map but for its
    right neighbour, which is chaotic too; the corner (2, 2) is periodic-2, which no neighbour
    shares (its neighbours are periodic-1); a missing cell has no neighbour row."""
    from analysis.pipeline.neighbours import neighbour_support, supported

    label = {(1, 1): ("chaotic", None), (1, 2): ("chaotic", None), (2, 2): ("periodic", 2)}
    rows = [{"index_0": i, "index_1": j, "point_id": f"{i}{j}",
             "label": label.get((i, j), ("periodic", 1))[0], "period": label.get((i, j), ("periodic", 1))[1]}
            for i in range(3) for j in range(3) if (i, j) != (0, 0)]
    t = pd.DataFrame(rows)
    t["period"] = t["period"].astype("Int64")
    s = t.join(neighbour_support(t)).set_index("point_id")
    assert s.loc["11", ["n_neighbours", "neighbours_same"]].tolist() == [4, 1]
    assert s.loc["12", ["n_neighbours", "neighbours_same"]].tolist() == [3, 1]
    assert s.loc["22", ["n_neighbours", "neighbours_same"]].tolist() == [2, 0]   # period 2 among period 1
    assert s.loc["01", ["n_neighbours", "neighbours_same"]].tolist() == [2, 1]   # (0, 0) is missing
    assert s.loc["21", ["n_neighbours", "neighbours_same"]].tolist() == [3, 1]  # only (2, 0) agrees
    sup = supported(s)
    assert not sup["22"] and sup["11"] and sup.sum() == 7
    one = t.iloc[:1].drop(columns=["index_0", "index_1"])
    assert neighbour_support(one).iloc[0].tolist() == [0, 0] and supported(one).isna().all()


def test_summary_counts_the_labels_that_hold_among_the_supported_points():
    """Three points, a and b with a grid neighbour sharing the label, c without: k_t moves b and
    c, so 1 of the 2 supported labels holds; the title line says so; without the column there
    are no counts."""
    runs = pd.DataFrame([{"point_id": p, "refinement": "k_t", "weight": 1.0, "label": "periodic",
                          "period": 1, "supported": p != "c",
                          "refined_label": "periodic" if p == "a" else "chaotic",
                          "refined_period": 1 if p == "a" else None, "holds": p == "a"} for p in "abc"])
    runs["supported"] = runs["supported"].astype("boolean")
    s = convergence_summary(runs)
    assert s["n_supported"].tolist() == [2] and s["held_supported"].tolist() == [1]
    assert "; of the 2/3 whose label a grid neighbour shares: k_t x 3 1/2;" in summary_line(s)
    assert s["unflagged"].tolist() == [1]  # b; c moved too, but no neighbour shares its label
    bare = convergence_summary(runs.drop(columns="supported"))
    assert bare["n_supported"].isna().all()
    assert "whose label a grid neighbour shares" not in summary_line(bare)


def test_a_label_without_a_verdict_is_flagged_and_a_moved_verdict_is_not():
    """``flagged``: the map's undetermined / unsettled labels are flagged (the map said it could
    not tell), a verdict is flagged only by its neighbours or the controls."""
    from analysis.pipeline.convergence import flagged

    runs = pd.DataFrame({"point_id": list("abcd"),
                         "label": ["undetermined", "unsettled", "chaotic", "periodic"],
                         "supported": pd.array([True, True, True, pd.NA], dtype="boolean")})
    assert flagged(runs, None).tolist() == [True, True, False, False]
    robust = pd.Series({"a": True, "b": True, "c": False, "d": True})
    assert flagged(runs, robust).tolist() == [True, True, True, False]
    assert flagged(runs.assign(supported=False), None).tolist() == [True] * 4


def test_a_move_that_ends_locked_below_the_lock_up_limit_is_counted_apart_from_unflagged_moves():
    """Four chaotic cells under the doubled windows: a and b end periodic-1 with every element
    stuck, but only a's map point is below its lock-up limit (``lock_ratio`` below 1); c is too
    but ends on a slipping period-1 orbit; d keeps its label.  Only a's move ends locked below
    the limit; b's and c's are unmarked.  (A rule that read any periodic-1 end, or any cell
    below the limit, as marked fails this.)  Under a refinement that changes the model (k_t)
    the map's limit is another model's, and the same move counts as unmarked."""
    from analysis.pipeline.convergence import onto_locked

    rows = [("a", True, 1.0), ("b", False, 1.0), ("c", True, 0.9), ("d", True, 0.8)]
    runs = pd.DataFrame([{"point_id": p, "refinement": "windows", "weight": 1.0, "label": "chaotic",
                          "period": None, "refined_label": "chaotic" if p == "d" else "periodic",
                          "refined_period": None if p == "d" else 1, "refined_stick_fraction": sf,
                          "locked": locked, "holds": p == "d"} for p, locked, sf in rows])
    runs["locked"] = runs["locked"].astype("boolean")
    for c in ("period", "refined_period"):
        runs[c] = runs[c].astype("Int64")
    assert onto_locked(runs).tolist() == [True, False, False, False]
    s = convergence_summary(runs)
    assert s["locked_moves"].tolist() == [1] and s["unflagged"].tolist() == [2]
    assert summary_line(s).endswith("windows x 2 2; ended locked below the lock-up limit (the map's label "
                                    "there may be a transient): windows x 2 1")
    model_row = convergence_summary(runs.assign(refinement="k_t"))
    assert model_row["locked_moves"].tolist() == [0] and model_row["unflagged"].tolist() == [3]
    # a periodic-1 map label that ends locked has not moved: nothing to explain
    same = runs.assign(label="periodic", period=pd.array([1] * 4, dtype="Int64"))
    assert not onto_locked(same).any()
    # without the columns (an older table) nothing counts as explained
    assert not onto_locked(runs.drop(columns="locked")).any()
    assert "lock-up limit" not in summary_line(convergence_summary(runs.drop(columns="locked")))


@pytest.mark.parametrize("mu_s, free", [(0.31, "expo"), (0.3, "rk4")])
def test_the_separation_row_reads_the_maps_reference_runs_and_moves_only_the_copies(tmp_path, mu_s, free):
    """``separation`` re-runs the Lyapunov stage alone: the refined point's reference run is
    the map's record, read from the store under the map's id (no simulate record is stored
    under the refined id), while the Lyapunov copies run again a tenth as far apart -- the
    ``expo`` pair's ``expo_e0`` at ``mu_s > mu_k``, the RK4 pair's ``rk4_e0`` at ``mu_s =
    mu_k`` (a separation that did not reach the kernels would give the map's window value to
    the bit).  At a slipping point on a stable orbit the exponent must not depend on the
    separation (a dynamical exponent is its limit of vanishing separation): the label,
    periodic-1 with about half the record's samples slipping, holds, and the two window values
    agree within the Lyapunov margin."""
    from analysis.pipeline.store import PointStore

    nm = Numerics(n_transient=60, n_record=128, n_transient_max=60)
    point = {"n_modes": 1, "k_t": 10.0, "mu_s": mu_s, "mu_k": 0.3, "Omega": 2.5, "f0_rel": 4.0,
             "damping": 0.05}
    table, sim, lyap = _one_point_map(point, nm, tmp_path)
    assert table["label"].iloc[0] == "periodic" and table["period"].iloc[0] == 1
    assert 0.3 < sim["stick_fraction"].iloc[0] < 0.7 and lyap["lle_free_copy"].iloc[0] == free
    runs = convergence_runs(table, "separation", nm, ConvergenceSettings(sample=1), str(tmp_path),
                            threads=2)
    rid = runs["refined_point_id"].iloc[0]
    assert rid != table["point_id"].iloc[0]
    assert not PointStore(str(tmp_path), "simulate").has(rid)
    refined = PointStore(str(tmp_path), "lyapunov").load(rid)
    assert refined["lle_free_copy"] == free
    t = 2 * np.pi / float(sim["omega"].iloc[0])
    base_T, refined_T = lyap["lle_benettin"].iloc[0] * t, refined["lle_benettin"] * t
    assert base_T != refined_T
    assert abs(base_T - refined_T) < nm.lyapunov.margin, (base_T, refined_T)
    assert bool(runs["holds"].iloc[0]), (table["label"].iloc[0], runs["refined_reason"].iloc[0])


def test_the_nudge_moves_a_chaotic_run_and_not_a_periodic_one():
    """The control ``nudge`` changes the load in its ninth digit: physically nothing.  Its
    premise, checked on two points with known answers: at a slipping period-1 orbit (one mode,
    tests/analysis/test_lyapunov_beam.py's ``SLIPPING``) the nudged run's Poincare samples stay
    within 1e-7 of the attractor's size of the map's (the linear response to the nudge is about
    1e-9 of it), while at a chaotic point (``CHAOTIC``: lambda_1 T = 1.67, docs/lyapunov.md
    section 7) the 1e-9 grows by e^1.67 a period and the two runs are apart by over 1 % of
    the attractor within 40 periods (the largest of the last 10 samples): the nudge reaches
    the trajectory, and only the dynamics amplify it."""
    from test_lyapunov_beam import CHAOTIC, SLIPPING

    from beamsim.simulate import simulate_batch

    nm = Numerics()
    for point, chaotic in ((SLIPPING, False), (CHAOTIC, True)):
        nudged = refine("nudge", point, nm)[0]
        a, b = simulate_batch([point, nudged], n_transient=10, n_record=30, method="expo", n_threads=2)
        size = np.abs(a.poincare_state).max()
        apart = np.abs(a.poincare_state - b.poincare_state).max(axis=1) / size
        assert apart[0] > 0  # the nudge is not lost in the parameters
        if chaotic:
            assert apart[-10:].max() > 1e-2, apart  # measured: 0.39 at the last sample
        else:
            assert apart.max() < 1e-7, apart  # measured: 1.2e-9 to 1.8e-9

"""Multistability of a map (analysis.pipeline.cell_attractors): the settings, the starts of a
cell (neighbours' end states in a fixed order, seeded perturbations independent of the table's
order), a linear limit with one attractor per cell, and a planted second attractor that must be
found, labelled by its own runs and counted."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from analysis.pipeline.cell_attractors import (
    REST,
    MultistabilitySettings,
    cell_attractors,
    cell_starts,
    cell_summary,
    summary_line,
)
from analysis.pipeline.config import Numerics
from analysis.pipeline.grid import canonical_json, point_id

ROOT = Path(__file__).resolve().parents[2]
#: below the slip onset, 10 % modal damping: a linear damped structure (one periodic orbit)
LINEAR = {"n_modes": 2, "k_t": 10.0, "mu_s": 0.45, "mu_k": 0.3, "Omega": 2.5, "damping": 0.1}
NM = Numerics(n_transient=80, n_record=128, n_transient_max=80)


def test_settings_defaults_are_the_shipped_config_and_bad_values_are_refused():
    shipped = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["multistability"]
    assert MultistabilitySettings.from_dict(shipped) == MultistabilitySettings()
    schema = yaml.safe_load((ROOT / "workflow" / "schemas" / "config.schema.yaml").read_text())
    props = schema["properties"]["multistability"]["properties"]
    assert {k: v["default"] for k, v in props.items()} == MultistabilitySettings().as_dict()
    off = MultistabilitySettings.from_dict({"sample": 0})
    assert not off.active and off.n_cells(400) == 0
    assert not MultistabilitySettings(neighbours=False, perturbations=0, locked=False).active
    assert MultistabilitySettings(neighbours=False, perturbations=0).active  # the locked start
    assert MultistabilitySettings(sample="all").n_cells(400) == 400
    assert MultistabilitySettings(sample=40).n_cells(9) == 9
    assert MultistabilitySettings(perturbations=2).starts_per_cell(2) == 7
    assert MultistabilitySettings(perturbations=2, locked=False).starts_per_cell(2) == 6
    for bad, match in (({"sample": -1}, "sample"), ({"sample": "some"}, "sample"),
                       ({"perturbations": 17}, "perturbations"), ({"amplitude": 0.0}, "amplitude"),
                       ({"neighbours": "yes"}, "neighbours"), ({"seed": -2}, "seed"),
                       ({"locked": 1}, "locked"),
                       ({"starts": 3}, "unknown")):
        with pytest.raises(ValueError, match=match):
            MultistabilitySettings.from_dict(bad)


def _grid_table(params: dict, f0s: list[float], omegas: list[float]) -> pd.DataFrame:
    """A regime table's bookkeeping columns for a 2-D grid (Omega x f0_rel)."""
    rows = []
    for i, om in enumerate(omegas):
        for j, f0 in enumerate(f0s):
            p = params | {"Omega": om, "f0_rel": f0}
            rows.append({"point_id": point_id(p, NM), "params_json": canonical_json(p), "index_0": i,
                         "index_1": j, "Omega": om, "f0_rel": f0, "label": "periodic"})
    return pd.DataFrame(rows)


def test_starts_are_the_neighbours_end_states_in_order_and_seeded_perturbations():
    from beamsim.simulate import prepare_point

    table = _grid_table(LINEAR, [0.2, 0.3, 0.4], [2.0, 2.5])
    model = prepare_point(**json.loads(table["params_json"].iloc[0])).model
    size = 2 * model.n + 2 * model.n_quad
    finals = {pid: np.full(size, float(k)) for k, pid in enumerate(table["point_id"])}
    finals[table["point_id"].iloc[5]] = np.full(size + 2, 5.0)  # another state size: left out
    settings = MultistabilitySettings(perturbations=2, seed=3)
    starts = cell_starts(table, finals, settings, ["Omega", "f0_rel"])
    # the cell (Omega 2.0, f0_rel 0.3): index (0, 1); neighbours (1, 1) = row 4, (0, 0) = 0, (0, 2) = 2
    names = [n for n, _ in starts[table["point_id"].iloc[1]]]
    assert names == ["Omega+", "f0_rel-", "f0_rel+", "perturbed0", "perturbed1"]
    by_name = dict(starts[table["point_id"].iloc[1]])
    assert np.all(by_name["Omega+"]["q0"] == 4.0) and np.all(by_name["f0_rel-"]["z0"] == 0.0)
    assert np.all(by_name["f0_rel+"]["v0"] == 2.0) and by_name["f0_rel+"]["mode0"].size == model.n_quad
    # the cell (Omega 2.5, f0_rel 0.4) = row 5 has another state size: no neighbour start at all;
    # its neighbours do not start from it
    assert [n for n, _ in starts[table["point_id"].iloc[5]]] == ["perturbed0", "perturbed1"]
    assert "f0_rel+" not in dict(starts[table["point_id"].iloc[4]])
    # perturbations: seeded by the config seed and the cell's grid index, not the row order
    again = cell_starts(table.iloc[::-1].reset_index(drop=True), finals, settings, ["Omega", "f0_rel"])
    for pid, st in starts.items():
        mine, theirs = dict(st), dict(again[pid])
        assert np.array_equal(mine["perturbed1"]["q0"], theirs["perturbed1"]["q0"])
    axes = ["Omega", "f0_rel"]
    other_seed = cell_starts(table, finals, MultistabilitySettings(perturbations=2, seed=4), axes)
    pid = table["point_id"].iloc[1]
    assert not np.array_equal(dict(other_seed[pid])["perturbed0"]["q0"], by_name["perturbed0"]["q0"])
    assert not np.array_equal(by_name["perturbed0"]["q0"], by_name["perturbed1"]["q0"])
    none = cell_starts(table, finals, MultistabilitySettings(neighbours=False, perturbations=0), axes)
    assert all(v == [] for v in none.values())


def _load_by(axis: str, values: list, seed: int):
    """Cells ``f0_rel`` 0.2, 0.3 by ``axis`` ``values`` with random end states (every element
    stuck at a random traction) and their neighbour starts: ``(pid, finals, models, starts)``,
    ``pid`` and ``models`` keyed by ``(f0_rel, value)`` and ``value``."""
    from beamsim.simulate import prepare_point

    rows, finals, models = [], {}, {}
    rng = np.random.default_rng(seed)
    for i, f0 in enumerate([0.2, 0.3]):
        for j, value in enumerate(values):
            p = LINEAR | {"f0_rel": f0, axis: value}
            pid = point_id(p, NM)
            rows.append({"point_id": pid, "params_json": canonical_json(p), "index_0": i, "index_1": j,
                         "f0_rel": f0, axis: value, "label": "periodic"})
            m = models[value] = prepare_point(**p).model
            q, v = 1e-2 * rng.standard_normal(m.n), 1e-3 * rng.standard_normal(m.n)
            tau = 1e-3 * rng.standard_normal(m.n_quad)  # the elements' tractions
            finals[pid] = np.concatenate([q, v, m.S @ q - tau / m.geom.k_t, np.zeros(m.n_quad)])
    starts = cell_starts(pd.DataFrame(rows), finals, MultistabilitySettings(perturbations=0, locked=False),
                         ["f0_rel", axis])
    return {(r["f0_rel"], r[axis]): r["point_id"] for r in rows}, finals, models, starts


def test_a_neighbour_with_another_mode_count_starts_the_cell_from_its_carried_state():
    """Along an ``n_modes`` axis a neighbour's end state is carried into the cell's basis
    (beamsim.state_transfer): from two modes to three its displacement fields exactly (each
    model evaluates its own), from three to two a state of the two-mode layout; along the load
    the numbers pass as they are."""
    pid, finals, models, starts = _load_by("n_modes", [2, 3], seed=0)
    three = dict(starts[pid[(0.2, 3)]])
    assert list(three) == ["f0_rel+", "n_modes-"]
    up = three["n_modes-"]
    m2, m3 = models[2], models[3]
    assert up["q0"].size == m3.n and up["z0"].size == m3.n_quad and up["mode0"].size == m3.n_quad
    src = finals[pid[(0.2, 2)]]
    theta = np.linspace(0.0, 0.4, 41)
    for ours, theirs in ((up["q0"], src[:m2.n]), (up["v0"], src[m2.n:2 * m2.n])):
        f2, f3 = m2.displacements(theirs, theta), m3.displacements(ours, theta)
        assert np.abs(f3 - f2).max() <= 1e-9 * np.abs(f2).max()
    down = dict(starts[pid[(0.3, 2)]])["n_modes+"]
    assert down["q0"].size == m2.n and down["z0"].size == m2.n_quad
    same = dict(starts[pid[(0.3, 3)]])["f0_rel-"]  # the same model: the numbers as they are
    assert np.array_equal(same["q0"], finals[pid[(0.2, 3)]][:m3.n])


def test_a_neighbour_with_another_stick_stiffness_starts_the_cell_with_its_tractions():
    """Along a ``k_t`` axis (elastic stick) a neighbour's end state is carried with every
    element's traction ``k_t (s_j - z_j)`` kept and its displacements as they were (the same
    basis); the numbers as they are would triple the tractions from ``k_t`` 10 to 30 and start
    stuck elements beyond their limit.  Along the load the numbers pass as they are."""
    pid, finals, models, starts = _load_by("k_t", [10.0, 30.0], seed=1)
    for cell, name, nb in (((0.2, 30.0), "k_t-", (0.2, 10.0)), ((0.3, 10.0), "k_t+", (0.3, 30.0))):
        got = dict(starts[pid[cell]])[name]
        src, m_src, m_dst = finals[pid[nb]], models[nb[1]], models[cell[1]]
        n = m_src.n
        for ours, theirs in ((got["q0"], src[:n]), (got["v0"], src[n:2 * n])):
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12 * np.abs(theirs).max())
        tau_src = nb[1] * (m_src.S @ src[:n] - src[2 * n:2 * n + m_src.n_quad])
        tau_dst = cell[1] * (m_dst.S @ got["q0"] - got["z0"])
        np.testing.assert_allclose(tau_dst, tau_src, rtol=0, atol=1e-9 * np.abs(tau_src).max())
    same = dict(starts[pid[(0.3, 30.0)]])["f0_rel-"]  # the same model: the numbers as they are
    m30 = models[30.0]
    assert np.array_equal(same["z0"], finals[pid[(0.2, 30.0)]][2 * m30.n:2 * m30.n + m30.n_quad])


def test_a_cell_below_its_lock_up_limit_whose_run_slips_also_starts_from_its_locked_orbit():
    """The locked start: last, the locked orbit's state (every element stuck, the slips of
    :func:`beamsim.shakedown.locked_orbit`), only where the map's run slips (``stick_fraction``
    below 1; unknown counts as not), the load is below the lock-up limit and ``locked`` is on."""
    from beamsim.shakedown import lock_ratio, locked_orbit
    from beamsim.simulate import prepare_point

    table = _grid_table(LINEAR, [0.2, 5.0], [2.0])
    pp = [prepare_point(**json.loads(p)) for p in table["params_json"]]
    assert lock_ratio(pp[0]) < 1.0 < lock_ratio(pp[1])
    finals = {}
    settings = MultistabilitySettings(neighbours=False, perturbations=0)
    axes = ["Omega", "f0_rel"]
    slipping = table.assign(stick_fraction=[0.9, 0.9])
    starts = cell_starts(slipping, finals, settings, axes)
    low, high = (starts[pid] for pid in table["point_id"])
    assert [n for n, _ in low] == ["locked"] and high == []  # above the limit: no locked orbit
    x = locked_orbit(pp[0]).state
    n, nq = pp[0].model.n, pp[0].model.n_quad
    got = low[0][1]
    assert np.array_equal(np.concatenate([got["q0"], got["v0"], got["z0"], got["mode0"]]), x)
    assert np.all(got["mode0"] == 0.0) and got["z0"].size == nq and got["q0"].size == n
    locked_map = table.assign(stick_fraction=[1.0, 0.9])  # the map's run is locked itself
    assert all(v == [] for v in cell_starts(locked_map, finals, settings, axes).values())
    assert all(v == [] for v in cell_starts(table, finals, settings, axes).values())  # unknown
    off = MultistabilitySettings(neighbours=False, perturbations=0, locked=False)
    assert all(v == [] for v in cell_starts(slipping, finals, off, axes).values())
    two_random = MultistabilitySettings(neighbours=False, perturbations=2)
    with_random = cell_starts(slipping, finals, two_random, axes)
    assert [n for n, _ in with_random[table["point_id"].iloc[0]]] == ["perturbed0", "perturbed1", "locked"]


@pytest.fixture(scope="module")
def linear_map(tmp_path_factory):
    """A 1 x 3 map of the linear damped structure through the pipeline's stages."""
    from analysis.pipeline.stages import classify_points, lle_resolution, lyapunov_points, simulate_points
    from analysis.pipeline.table import assemble_regime_table

    store = str(tmp_path_factory.mktemp("store"))
    pts = []
    for j, f0 in enumerate((0.2, 0.3, 0.4)):
        p = LINEAR | {"f0_rel": f0}
        pts.append({"point_id": point_id(p, NM), "params": p, "index": [j]})
    sim = simulate_points(pts, NM, store, threads=2)
    lyap = lyapunov_points(pts, sim, NM, store, threads=2)
    table = assemble_regime_table(pts, sim, lyap, classify_points(sim, lyap, lle_resolution(NM)))
    return table, sim, store


#: random starts small enough not to slip: a random state loads the stuck interface springs
#: with shear unlike any the load makes (measured at f0_rel 0.3: amplitude 1e-3 of the response
#: scale slips at t = 0 and locks a slip that moves the orbit's mean by 9 %; 1e-4 does not slip)
SMALL = 1e-4


def test_a_linear_structure_has_one_attractor_per_cell(linear_map):
    """Every start of a linear damped structure (the neighbours' end states, a small random state
    that does not slip) ends on the one periodic orbit of the forcing: one attractor per cell,
    the map's label."""
    table, sim, store = linear_map
    assert (table["label"] == "periodic").all() and not table["slipped"].any()
    settings = MultistabilitySettings(sample="all", perturbations=1, amplitude=SMALL)
    att = cell_attractors(table, sim, NM, settings, store, axes=["f0_rel"], threads=2)
    assert list(att["point_id"]) == list(table["point_id"])  # one row per cell, table order
    assert (att["attractor"] == 0).all() and (att["n_attractors"] == 1).all() and not att["multistable"].any()
    assert list(att["n_starts"]) == [3, 4, 3]  # rest + neighbours (1 at an edge, 2 inside) + 1
    assert [s[0] for s in att["starts"]] == [REST] * 3 and list(att["starts"].iloc[1]) == \
        [REST, "f0_rel-", "f0_rel+", "perturbed0"]
    assert (att["label_text"] == "periodic-1").all() and (att["run_id"] == table["point_id"]).all()
    summary = cell_summary(att)
    assert summary_line(summary).startswith("other starts: 0/3 cells multistable")
    assert summary_line(None).startswith("cells not run")
    # deterministic: the same call gives the same table
    pd.testing.assert_frame_equal(att, cell_attractors(table, sim, NM, settings, store, axes=["f0_rel"],
                                                       threads=1), check_exact=True)
    # a sample of one cell: that cell only, with its stratum's weight
    one = cell_attractors(table, sim, NM, MultistabilitySettings(sample=1, amplitude=SMALL), store,
                          axes=["f0_rel"], threads=2)
    assert one["point_id"].nunique() == 1 and float(one["weight"].iloc[0]) == 3.0


def test_a_planted_second_attractor_is_found_counted_and_labelled_by_its_own_runs(linear_map):
    """The middle cell's own record is replaced by a shifted copy (as if the start from rest had
    ended elsewhere): its other starts, which all end on the true orbit, now form a second
    attractor, labelled by its own Lyapunov and classifier runs (periodic-1), while the first
    keeps the map's label.  (A grouping that merged the two, or that took the map's label for
    both, fails this.)"""
    table, sim, store = linear_map
    planted = sim.copy()
    mid = table["point_id"].iloc[1]
    k = planted.index[planted["point_id"] == mid][0]
    x = np.asarray([np.asarray(r, dtype=float) for r in planted.at[k, "poincare_state"]])
    planted.at[k, "poincare_state"] = list(x + 0.5 * np.ptp(x, axis=0).max() + 1e-3)
    table2 = table.copy()
    table2.loc[table2["point_id"] == mid, "label"] = "quasi-periodic"  # the map's label of its run
    att = cell_attractors(table2, planted, NM, MultistabilitySettings(sample="all", perturbations=1,
                                                                      amplitude=SMALL),
                          store, axes=["f0_rel"], threads=2)
    cell = att[att["point_id"] == mid]
    assert list(cell["attractor"]) == [0, 1]
    assert (cell["n_attractors"] == 2).all() and cell["multistable"].all()
    assert list(cell["starts"].iloc[0]) == [REST]
    assert list(cell["starts"].iloc[1]) == ["f0_rel-", "f0_rel+", "perturbed0"]
    assert list(cell["label_text"]) == ["quasi-periodic", "periodic-1"]
    assert (cell["n_regimes"] == 2).all() and cell["run_id"].iloc[1] != mid
    assert cell["lle_T"].iloc[1] < 0  # its own Lyapunov run: a damped linear orbit contracts
    others = att[att["point_id"] != mid]
    assert (others["n_attractors"] == 1).all()
    summary = cell_summary(att)
    assert summary_line(summary).startswith("other starts: 1/3 cells multistable")

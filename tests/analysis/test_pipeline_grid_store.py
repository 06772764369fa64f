"""Grid expansion, point identity and the per-point store of the regime pipeline."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.pipeline.grid import axis_values, chunk_points, expand_grid, point_id
from analysis.pipeline.store import PointStore

DEFAULTS = {"alpha1": 0.005, "alpha2": 0.005, "beta": 0.4, "mu_s": 0.3, "mu_k": 0.3, "p": 1e-4,
            "f0_rel": 2.0, "Omega": 1.0, "law": "stick-slip"}
NUMERICS = {"method": "newmark", "n_transient": 10, "n_record": 20}


def test_axis_values_forms():
    assert axis_values("a", [1, 2, 3]) == [1, 2, 3]
    assert axis_values("a", {"values": [0.5]}) == [0.5]
    lin = axis_values("a", {"range": [0.1, 0.3], "num": 3})
    assert lin == [0.1, 0.2, 0.3]  # stable decimals, no 0.30000000000000004
    log = axis_values("a", {"range": [1, 100], "num": 3, "scale": "log"})
    np.testing.assert_allclose(log, [1, 10, 100])
    with pytest.raises(ValueError, match="log range"):
        axis_values("a", {"range": [0, 1], "num": 3, "scale": "log"})


def test_point_identity_is_its_parameters_not_its_position():
    g1 = {"axes": {"Omega": [1.0, 2.0]}, "fixed": {"mu_s": 0.45}}
    g2 = {"axes": {"Omega": [0.5, 2.0, 1.0]}, "fixed": {"mu_s": 0.45}}
    ids1 = {p.params["Omega"]: p.point_id for p in expand_grid("a", g1, DEFAULTS, NUMERICS)}
    ids2 = {p.params["Omega"]: p.point_id for p in expand_grid("b", g2, DEFAULTS, NUMERICS)}
    assert ids1[1.0] == ids2[1.0] and ids1[2.0] == ids2[2.0]  # other grid name, other order
    assert len(set(ids2.values())) == 3


def test_changing_a_default_or_a_result_numeric_changes_the_id():
    pid = point_id(DEFAULTS, NUMERICS)
    assert point_id(DEFAULTS | {"p": 2e-4}, NUMERICS) != pid
    assert point_id(DEFAULTS, NUMERICS | {"n_record": 21}) != pid
    # integer-valued floats and ints are the same parameter value; key order does not matter
    assert point_id(dict(reversed(list(DEFAULTS.items()))), NUMERICS) == pid
    assert point_id(DEFAULTS | {"Omega": 1}, NUMERICS) == pid


def test_expand_grid_order_and_errors():
    g = {"axes": {"Omega": [1.0, 2.0], "f0_rel": [0.5, 1.0, 2.0]}}
    pts = expand_grid("g", g, DEFAULTS, NUMERICS)
    assert [p.index for p in pts][:4] == [(0, 0), (0, 1), (0, 2), (1, 0)]
    assert pts[4].params["Omega"] == 2.0 and pts[4].params["f0_rel"] == 1.0
    with pytest.raises(ValueError, match="unknown parameter"):
        expand_grid("g", {"axes": {"Omgea": [1.0]}}, DEFAULTS, NUMERICS)
    with pytest.raises(ValueError, match="both as axis and as fixed"):
        expand_grid("g", {"axes": {"Omega": [1.0]}, "fixed": {"Omega": 2.0}}, DEFAULTS, NUMERICS)
    with pytest.raises(ValueError, match="repeated"):
        expand_grid("g", {"axes": {"Omega": [1.0, 1.0]}}, DEFAULTS, NUMERICS)


def test_chunks_cover_every_point_once():
    pts = expand_grid("g", {"axes": {"Omega": {"range": [0.5, 3], "num": 23}}}, DEFAULTS, NUMERICS)
    chunks = chunk_points(pts, 5)
    assert len(chunks) == 5
    ids = [p.point_id for c in chunks for p in c]
    assert sorted(ids) == sorted(p.point_id for p in pts)
    assert max(map(len, chunks)) - min(map(len, chunks)) <= 1


def test_point_store_round_trip_and_atomicity(tmp_path):
    store = PointStore(tmp_path, "stage")
    pid = "0123456789abcdef"
    assert not store.has(pid)
    store.save(pid, {"x": np.arange(6.0).reshape(2, 3), "flag": True, "value": np.float64(1.5)})
    rec = store.load(pid)
    np.testing.assert_array_equal(rec["x"], np.arange(6.0).reshape(2, 3))
    assert rec["flag"] is True and rec["value"] == 1.5
    assert not list(store.path(pid).parent.glob(".*tmp*"))  # no temporary file left behind

"""The pipeline's numerics: one typed bundle whose defaults are the shipped config's, and point
ids that do not depend on whether a setting is written out or left to its default."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from analysis.pipeline.config import LyapunovNumerics, Numerics
from analysis.pipeline.grid import point_id

ROOT = Path(__file__).resolve().parents[2]


def test_defaults_are_the_shipped_config():
    shipped = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())["numerics"]
    assert Numerics.from_dict(shipped) == Numerics()
    # every default is written out in the config (a reader sees the values that run)
    assert set(shipped) | {"steps_per_period"} == set(Numerics.__dataclass_fields__)
    assert set(shipped["lyapunov"]) == set(LyapunovNumerics.__dataclass_fields__)


def test_point_id_is_the_same_for_a_default_left_out_or_written_out():
    params = {"n_modes": 1, "Omega": 2.0}
    full = Numerics().result_dict()
    partial = {"method": "auto", "n_transient": 200, "n_record": 256}
    assert point_id(params, partial) == point_id(params, full) == point_id(params, Numerics())
    assert point_id(params, dict(partial, step_factor=0.5)) != point_id(params, full)
    assert point_id(params, dict(partial, lyapunov={"n_periods": 50})) != point_id(params, full)


def test_the_ladder_enters_the_id_only_when_not_the_default_expo_one():
    params = {"n_modes": 1, "Omega": 2.0}
    assert Numerics().lyapunov.ladder == "expo"
    assert "ladder" not in Numerics().result_dict()["lyapunov"]
    rk4 = Numerics.from_dict({"lyapunov": {"ladder": "rk4"}})
    assert rk4.result_dict()["lyapunov"]["ladder"] == "rk4"
    assert point_id(params, rk4) != point_id(params, Numerics())
    expo = Numerics.from_dict({"lyapunov": {"ladder": "expo"}})
    assert point_id(params, expo) == point_id(params, Numerics())


def test_a_grid_point_has_the_id_of_its_definition():
    """expand_grid hashes a grid with the numerics resolved once: each point's id is still the
    definition's, sha256 of the canonical JSON of parameters, numerics and results version (a
    stored result found under its id is the same point; numpy and Python values alike)."""
    import hashlib

    import numpy as np

    from analysis.pipeline.grid import RESULTS_VERSION, canonical_json, expand_grid

    nm = Numerics.from_dict({"n_transient": 300, "lyapunov": {"n_periods": 40}})
    grid = {"axes": {"Omega": {"range": [1.25, 8.0], "num": 3, "scale": "log"}, "f0_rel": [0.8, 2]},
            "fixed": {"mu_s": np.float64(0.45), "n_modes": np.int64(2)}}
    points = expand_grid("g", grid, {"mu_k": 0.3, "k_t": 10.0, "law": "stick-slip"}, nm)
    assert len(points) == 6
    for p in points:
        payload = canonical_json({"params": p.params, "numerics": nm.result_dict(),
                                  "version": RESULTS_VERSION})
        expected = hashlib.sha256(payload.encode()).hexdigest()[:16]
        assert p.point_id == expected == point_id(p.params, nm)
    assert len({p.point_id for p in points}) == 6


def test_result_dict_leaves_out_chunk_size_and_an_unset_step_count():
    d = Numerics(chunk_size=7).result_dict()
    assert "chunk_size" not in d and "steps_per_period" not in d
    assert Numerics(steps_per_period=64).result_dict()["steps_per_period"] == 64


def test_the_free_copys_integrator_and_separation_enter_the_id():
    """The free copy's integrator is part of a point's id, and the separation of an ``expo``
    copy too -- but not for an RK4 pair, whose results it does not change."""
    params = {"n_modes": 1, "Omega": 2.0}
    assert Numerics().result_dict()["lyapunov"]["expo_e0"] == 1e-4
    rk4 = Numerics.from_dict({"lyapunov": {"method": "rk4"}})
    assert "expo_e0" not in rk4.result_dict()["lyapunov"]
    assert point_id(params, rk4) != point_id(params, Numerics())
    assert point_id(params, Numerics.from_dict({"lyapunov": {"expo_e0": 1e-5}})) \
        != point_id(params, Numerics())
    assert point_id(params, Numerics.from_dict({"lyapunov": {"method": "rk4", "expo_e0": 1e-5}})) \
        == point_id(params, rk4)
    # the RK4 pair's separation: in the id only away from 1e-6, the value of every version
    # before it was a setting (so the shipped maps keep their ids), and for either free copy
    assert "rk4_e0" not in Numerics().result_dict()["lyapunov"]
    written_out = Numerics.from_dict({"lyapunov": {"rk4_e0": 1e-6}})
    assert point_id(params, written_out) == point_id(params, Numerics())
    for base in ({}, {"method": "rk4"}):
        other = Numerics.from_dict({"lyapunov": base | {"rk4_e0": 1e-7}})
        assert other.result_dict()["lyapunov"]["rk4_e0"] == 1e-7
        assert point_id(params, other) != point_id(params, Numerics.from_dict({"lyapunov": base}))


def test_the_second_opinion_enters_the_id_where_the_free_copy_can_be_expos():
    """``lyapunov.confirm`` changes the label's exponent of ``expo`` pairs only, so it is part of
    a point's id except for the RK4 pair; a value outside its choices is refused by name."""
    params = {"n_modes": 1, "Omega": 2.0}
    assert Numerics().lyapunov.confirm == "contradicted"
    for other in ("all", "none"):
        assert point_id(params, Numerics.from_dict({"lyapunov": {"confirm": other}})) \
            != point_id(params, Numerics())
    rk4 = Numerics.from_dict({"lyapunov": {"method": "rk4"}})
    assert point_id(params, Numerics.from_dict({"lyapunov": {"method": "rk4", "confirm": "all"}})) \
        == point_id(params, rk4)
    msg = r"numerics\.lyapunov\.confirm = 'rk4'; allowed: contradicted, all, none"
    with pytest.raises(ValueError, match=msg):
        Numerics.from_dict({"lyapunov": {"confirm": "rk4"}})


def test_the_noise_floor_guard_enters_the_id_where_the_free_copy_can_be_expos():
    """``lyapunov.expo_floor`` decides which points run on the RK4 pair, so it is part of a
    point's id except for the RK4 pair; ``null`` switches it off; a value outside ``(0, 1]`` is
    refused by name with the allowed range, before anything runs."""
    params = {"n_modes": 1, "Omega": 2.0}
    assert Numerics().lyapunov.expo_floor == 0.1
    for other in (0.3, None):
        assert point_id(params, Numerics.from_dict({"lyapunov": {"expo_floor": other}})) \
            != point_id(params, Numerics())
    rk4 = Numerics.from_dict({"lyapunov": {"method": "rk4"}})
    assert point_id(params, Numerics.from_dict({"lyapunov": {"method": "rk4", "expo_floor": 0.5}})) \
        == point_id(params, rk4)
    msg = r"numerics\.lyapunov\.expo_floor = .*allowed: a number in \(0, 1\]"
    for bad in (0, -0.1, 1.5, "high", True):
        with pytest.raises(ValueError, match=msg):
            Numerics.from_dict({"lyapunov": {"expo_floor": bad}})


def test_the_sequential_boundary_enters_the_id_and_is_checked_by_name():
    """``lyapunov.boundary`` widens the long record's intervals, so it is part of every point's
    id; a value outside its choices is refused by name with the choices."""
    params = {"n_modes": 1, "Omega": 2.0}
    assert Numerics().lyapunov.boundary == "obrien-fleming"
    assert Numerics().lyapunov.block_plan().boundary == "obrien-fleming"
    for other in ("pocock", "none"):
        num = Numerics.from_dict({"lyapunov": {"boundary": other}})
        assert num.lyapunov.block_plan().boundary == other
        assert point_id(params, num) != point_id(params, Numerics())
    msg = r"numerics\.lyapunov\.boundary = 'bonferroni'; allowed: obrien-fleming, pocock, none"
    with pytest.raises(ValueError, match=msg):
        Numerics.from_dict({"lyapunov": {"boundary": "bonferroni"}})


@pytest.mark.parametrize("bad, key", [({"step_size": 1.0}, "step_size"),
                                      ({"lyapunov": {"periods": 3}}, "periods"),
                                      ({"method": "euler"}, "euler")])
def test_unknown_settings_are_named(bad, key):
    with pytest.raises(ValueError, match=key):
        Numerics.from_dict(bad)


@pytest.mark.parametrize("bad, message", [
    ({"n_transient": 300, "n_transient_max": 200},
     "n_transient_max = 200 must be >= numerics.n_transient = 300"),
    ({"lyapunov": {"min_blocks": 5, "max_blocks": 4}}, "min_blocks = 5, max_blocks = 4"),
])
def test_settings_that_contradict_each_other_are_named(bad, message):
    with pytest.raises(ValueError, match=message):
        Numerics.from_dict(bad)


def test_block_plan_follows_the_settings():
    plan = Numerics.from_dict({"lyapunov": {"block_periods": 10, "burn_in": 5, "min_blocks": 2,
                                            "max_blocks": 6, "margin": 0.1}}).lyapunov.block_plan()
    got = (plan.block, plan.burn_in, plan.first_periods, plan.max_periods, plan.margin)
    assert got == (10, 5, 25, 65, 0.1)

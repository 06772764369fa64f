"""Continuation sweeps along a line (analysis.continuation): where each branch starts, that a
continued point really starts from its neighbour's end state, and a limit with a known answer --
a linear damped line has one attractor per point, so the up- and down-sweep must agree."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.continuation import continuation_sweeps, continue_from, hysteresis, state_params
from analysis.pipeline.config import Numerics
from analysis.pipeline.stages import simulate_runs

#: stuck (f0_rel well below the slip onset) and damped: a linear structure under a harmonic load
LINEAR = {"n_modes": 2, "mu_s": 0.45, "mu_k": 0.3, "interface_damping": 0.5, "damping": 0.1, "Omega": 2.5}
# short transients and no long run: the continuation's bookkeeping, not the points' attractors
NUMERICS = Numerics(n_transient=80, n_record=128, n_transient_max=80, n_long_transient=0)


@pytest.fixture(scope="module")
def linear_line():
    pts = [LINEAR | {"f0_rel": f} for f in (0.2, 0.25, 0.3)]
    return pts, continuation_sweeps(pts, NUMERICS, axis="f0_rel", threads=2)


def test_each_branch_starts_from_rest_and_continues(linear_line):
    pts, t = linear_line
    assert list(t["branch"]) == ["up"] * 3 + ["down"] * 3
    assert list(t["k"]) == [0, 1, 2] * 2 and list(t["f0_rel"]) == [0.2, 0.25, 0.3] * 2
    starts = dict(zip(zip(t["branch"], t["k"]), t["start"]))
    assert starts[("up", 0)] == "rest" and starts[("down", 2)] == "rest"
    assert {starts[k] for k in [("up", 1), ("up", 2), ("down", 0), ("down", 1)]} == {"continued"}
    # the first point of a branch is the map's start from rest, sample for sample
    for b, k in (("up", 0), ("down", 2)):
        ref = simulate_runs([{"point_id": "r", "params": pts[k]}], NUMERICS, 1)[0]
        got = t[(t["branch"] == b) & (t["k"] == k)].iloc[0]["poincare_w_tip"]
        np.testing.assert_array_equal(np.asarray(got), ref["poincare_tip"][:, 0])


def test_a_continued_point_starts_from_its_neighbours_end_state():
    """The up-sweep's second point equals a run of that point started, by hand, from the first
    point's final state (coordinates, velocities, slips and stick flags), and differs from
    its start from rest (the beam is undamped here: the start is remembered)."""
    pts = [LINEAR | {"damping": 0.0, "f0_rel": f} for f in (0.5, 0.6)]
    nm = Numerics(n_transient=10, n_record=128, n_transient_max=10, n_long_transient=0)
    t = continuation_sweeps(pts, nm, axis="f0_rel", threads=2)
    first = simulate_runs([{"point_id": "a", "params": pts[0]}], nm, 1)[0]
    from beamsim.simulate import prepare_point

    md = prepare_point(**pts[0]).model
    init = state_params(first["final_state"], md.n, md.n_quad)
    assert set(init) == {"q0", "v0", "z0", "mode0"}
    by_hand = simulate_runs([{"point_id": "b", "params": pts[1] | init}], nm, 1)[0]
    rest = simulate_runs([{"point_id": "c", "params": pts[1]}], nm, 1)[0]
    got = np.asarray(t[(t["branch"] == "up") & (t["k"] == 1)].iloc[0]["poincare_w_tip"])
    np.testing.assert_array_equal(got, by_hand["poincare_tip"][:, 0])
    assert np.max(np.abs(got - rest["poincare_tip"][:, 0])) > 1e-3 * np.max(np.abs(got))
    assert state_params(np.full(first["final_state"].size, np.nan), md.n, md.n_quad) == {}


def test_a_linear_damped_line_has_no_hysteresis(linear_line):
    """One attractor per point (the forced periodic orbit of a linear damped structure): both
    sweeps converge to it, label periodic-1, the last quarter of their stroboscopic samples the
    same to 1e-8 of the amplitude (the start's remnant decays like exp(-zeta omega_1 t): 4e-5
    of the amplitude at the record's start, 1e-12 at its end), and ``hysteresis`` finds no
    point where the branches differ."""
    _, t = linear_line
    assert (t["label"] == "periodic").all() and (t["period"] == 1).all() and not t["slipped"].any()
    up, down = t[t["branch"] == "up"], t[t["branch"] == "down"]
    for (_, a), (_, b) in zip(up.iterrows(), down.iterrows()):
        wa, wb = np.asarray(a["poincare_w_tip"]), np.asarray(b["poincare_w_tip"])
        tail = slice(3 * wa.size // 4, None)
        assert np.max(np.abs(wa[tail] - wb[tail])) < 1e-8 * np.max(np.abs(wa))
    hy = hysteresis(t, "f0_rel")
    assert not hy["differs"].any() and list(hy["label_up"]) == ["periodic-1"] * 3
    assert list(hy["same_attractor"]) == [True] * 3
    # and hysteresis does see a difference when there is one
    t2 = t.copy()
    t2.loc[(t2["branch"] == "down") & (t2["k"] == 1), "label"] = "chaotic"
    assert list(hysteresis(t2, "f0_rel")["differs"]) == [False, True, False]
    # and two sets of the same label apart from each other are two attractors
    moved = t2[(t2["branch"] == "down") & (t2["k"] == 2)].index[0]
    t2.at[moved, "poincare_state"] = [[v + 1.0 for v in row] for row in t2.at[moved, "poincare_state"]]
    assert list(hysteresis(t2, "f0_rel")["same_attractor"]) == [True, True, False]


def test_a_line_along_the_mode_count_carries_each_end_state_into_the_next_basis():
    """Along ``n_modes`` a continued point starts from its predecessor's end state carried into
    its own basis (beamsim.state_transfer): the up-sweep's second point equals a run started by
    hand from the carried state, and differs from its start from rest (undamped, a short
    transient: the start is remembered); the down-sweep carries three modes into two."""
    from beamsim.simulate import prepare_point
    from beamsim.state_transfer import transfer_state

    pts = [LINEAR | {"damping": 0.0, "f0_rel": 0.5, "n_modes": n} for n in (2, 3)]
    nm = Numerics(n_transient=10, n_record=128, n_transient_max=10, n_long_transient=0)
    t = continuation_sweeps(pts, nm, axis="n_modes", threads=2)
    starts = dict(zip(zip(t["branch"], t["k"]), t["start"]))
    assert starts == {("up", 0): "rest", ("up", 1): "continued",
                      ("down", 1): "rest", ("down", 0): "continued"}
    m2, m3 = (prepare_point(**p).model for p in pts)
    width = {(b, k): len(s[0]) for b, k, s in zip(t["branch"], t["k"], t["poincare_state"])}
    assert width[("up", 0)] == width[("down", 0)] == 2 * m2.n  # Poincare samples of q and v
    assert width[("up", 1)] == width[("down", 1)] == 2 * m3.n
    first = simulate_runs([{"point_id": "a", "params": pts[0]}], nm, 1)[0]
    carried = transfer_state(first["final_state"], m2, m3)
    by_hand = simulate_runs([{"point_id": "b", "params": pts[1] | state_params(carried, m3.n, m3.n_quad)}],
                            nm, 1)[0]
    rest = simulate_runs([{"point_id": "c", "params": pts[1]}], nm, 1)[0]
    got = np.asarray(t[(t["branch"] == "up") & (t["k"] == 1)].iloc[0]["poincare_w_tip"])
    np.testing.assert_array_equal(got, by_hand["poincare_tip"][:, 0])
    assert np.max(np.abs(got - rest["poincare_tip"][:, 0])) > 1e-3 * np.max(np.abs(got))


def test_a_line_along_the_stick_stiffness_keeps_each_end_states_tractions():
    """Along ``k_t`` (elastic stick, the same basis) a continued point starts from its
    predecessor's end state with the tractions kept (beamsim.state_transfer), not its numbers:
    the up-sweep's second point equals a run by hand from the carried state, and a run from the
    numbers as they are is another trajectory (its stuck elements start at three times their
    tractions)."""
    from beamsim.simulate import prepare_point
    from beamsim.state_transfer import transfer_state

    # slipping (above the onset), undamped: the start is remembered over a short transient
    pts = [{"n_modes": 2, "mu_s": 0.45, "mu_k": 0.3, "damping": 0.0, "Omega": 2.5, "f0_rel": 2.0,
            "k_t": kt} for kt in (10.0, 30.0)]
    nm = Numerics(n_transient=10, n_record=128, n_transient_max=10, n_long_transient=0)
    t = continuation_sweeps(pts, nm, axis="k_t", threads=2)
    m10, m30 = (prepare_point(**p).model for p in pts)
    first = simulate_runs([{"point_id": "a", "params": pts[0]}], nm, 1)[0]
    carried = transfer_state(first["final_state"], m10, m30)
    runs = simulate_runs([{"point_id": "b", "params": pts[1] | state_params(carried, m30.n, m30.n_quad)},
                          {"point_id": "c", "params": pts[1] | state_params(first["final_state"], m30.n,
                                                                             m30.n_quad)}], nm, 1)
    got = np.asarray(t[(t["branch"] == "up") & (t["k"] == 1)].iloc[0]["poincare_w_tip"])
    np.testing.assert_array_equal(got, runs[0]["poincare_tip"][:, 0])
    assert np.max(np.abs(got - runs[1]["poincare_tip"][:, 0])) > 1e-3 * np.max(np.abs(got))


def test_continue_from_follows_a_state_along_a_path_as_a_line_does():
    """``continue_from`` (the convergence evidence's path from a map's attractor into the refined
    model) is a line's up-branch without its first point: from the first point's end state,
    carried along ``k_t``, the last point gets the same label and exponent as the sweep's; a
    state that is not finite is refused (it would be a start from rest, not a continuation)."""
    from analysis.pipeline.stages import lle_resolution
    from beamsim.simulate import prepare_point

    pts = [{"n_modes": 1, "mu_s": 0.45, "mu_k": 0.3, "damping": 0.0, "Omega": 2.5, "f0_rel": 2.0,
            "k_t": kt} for kt in (10.0, 17.0, 30.0)]
    nm = Numerics(n_transient=10, n_record=128, n_transient_max=10, n_long_transient=0)
    t = continuation_sweeps(pts, nm, axis="k_t", threads=2)
    up = t[t["branch"] == "up"].sort_values("k")
    first = simulate_runs([{"point_id": "a", "params": pts[0]}], nm, 1)[0]
    m10 = prepare_point(**pts[0]).model
    got = continue_from(first["final_state"], m10, pts[1:], nm, lle_threshold=lle_resolution(nm))
    want = up.iloc[-1]
    assert (got["label"], got["period"]) == (want["label"], want["period"]), got["reason"]
    period_t = 2 * np.pi / got["omega"]
    assert got["lle_mean"] * period_t == pytest.approx(want["lle_T"], rel=1e-12, abs=1e-15)
    with pytest.raises(ValueError, match="not finite"):
        continue_from(np.full_like(first["final_state"], np.nan), m10, pts[1:], nm, lle_threshold=0.05)

"""A beam point with two attractors (analysis.multistability.point_attractors): runs from rest
and from a neighbouring point's end state, grouped by attractor, each group classified by the
pipeline's own stages; and the seeded perturbed starts."""

from __future__ import annotations

import numpy as np

from analysis.continuation import state_params
from analysis.lyapunov.beam import slow_modes
from analysis.multistability import perturbed_starts, point_attractors
from analysis.pipeline.config import Numerics
from analysis.pipeline.stages import simulate_runs
from beamsim.point import prepare_point

#: a cell of the two-mode default grid (Omega 2.48, f0_rel 2.61; the multistability job of
#: results version 13).  In version 13 it had a chaotic attractor (lambda_1 T 0.23-0.29) and a
#: regular one (-0.012), reached from rest and from its upper load neighbour's end state, which
#: start reaching which depending on the CPU's last bits (the basins are intertwined).  Since
#: version 14 (expo's checks placed by decaying bounds, a coarser output grid: the trajectories
#: moved in the last bits) neither start reaches the chaotic set: from rest, the four grid
#: neighbours' end states and two seeded perturbations, three attractors, an undetermined one
#: (lambda_1 T 0.010, [-0.024, 0.043], broadband: a CONFLICT) and two tori (-0.027 and -0.015,
#: intervals at or below the margin), 2026-11-27 on an AVX-512 host.  In version 15 (Newton
#: refinement of the switches) three attractors again, all undetermined: rest, two neighbours
#: and one perturbation on a set whose interval straddles the margin (0.22, [0.010, 0.42],
#: broadband, K = 1.00), two neighbours on a torus-like set ([-0.043, 0.079]) and one
#: perturbation on a CONFLICT set whose interval lies below the margin ([-0.024, -0.005]).
#: In version 26 (no explicit M^-1 in the first-order matrices) two: rest, the four neighbours
#: and one perturbation on an undetermined set (0.032, [-0.057, 0.121]), the other perturbation
#: on a chaotic one (0.21, [0.050, 0.37]).
CELL = dict(n_modes=2, mu_s=0.45, mu_k=0.3, p=1e-4, k_t=10.0, damping=0.0, interface_viscosity=0.0939,
            law="stick-slip", alpha1=0.005, alpha2=0.005, beta=0.4, bc="clamped-free",
            Omega=2.47698677388, f0_rel=2.61033899224)
#: its four neighbours on the default grid (one step along each axis, both directions)
NEIGHBOURS = [CELL | {"f0_rel": 2.79839542894}, CELL | {"f0_rel": 2.43492023463},
              CELL | {"Omega": 2.73120445758}, CELL | {"Omega": 2.24643140903}]


def test_beam_cell_with_several_attractors():
    """The pipeline's starts of a cell (rest, the neighbours' end states, seeded perturbations)
    reach more than one attractor there; each start is grouped once, each attractor gets its
    own lambda_1 interval and label, and at least two are different sets, not two samplings of
    one (centres apart).  The starts, not a chosen pair: which start reaches which basin, and
    which regimes the attractors have, depend on the last bits (the history above; a regular
    attractor among them, asserted in versions 16-25, is not there in version 26)."""
    nm = Numerics()
    ends = simulate_runs([{"point_id": str(i), "params": p} for i, p in enumerate(NEIGHBOURS)], nm, 2)
    model = prepare_point(**CELL).model
    starts = ([{}] + [state_params(e["final_state"], model.n, model.n_quad) for e in ends]
              + perturbed_starts(CELL, 2, seed=[0, 1], amplitude=0.3))
    table = point_attractors(CELL, starts, nm, threads=2)
    shown = table[["starts", "label", "lle_T", "lle_lo_T", "lle_hi_T"]]
    assert len(table) >= 2, shown
    assert sorted(s for group in table["starts"] for s in group) == list(range(len(starts)))
    assert table["label"].notna().all() and np.isfinite(table["lle_T"]).all(), shown
    sets = [np.asarray(x) for x in table["poincare_state"]]
    span = np.ptp(np.vstack(sets), axis=0).max()
    apart = [np.abs(a.mean(axis=0) - b.mean(axis=0)).max() > 0.05 * span
             for i, a in enumerate(sets) for b in sets[i + 1:]]
    assert any(apart), shown


def test_perturbed_starts_are_seeded_and_stay_in_the_slow_modes():
    """The perturbed starts lie in the span of the stuck structure's slowest modes (no energy
    in the fast interface-penalty and membrane modes, which the undamped structure would keep:
    docs/pipeline.md, "Multistability of a map") and are the same for the same seed."""
    starts = perturbed_starts(CELL, 3, seed=[0, 4, 7], amplitude=0.3)
    again = perturbed_starts(CELL, 3, seed=[0, 4, 7], amplitude=0.3)
    assert all(np.array_equal(x["q0"], y["q0"]) and np.array_equal(x["v0"], y["v0"])
               for x, y in zip(starts, again))
    model = prepare_point(**CELL).model
    _, phi = model.eig_stuck
    slow = slow_modes(model)
    k = slow.shape[1]
    for s in starts:
        for x in (s["q0"], s["v0"]):
            modal = phi.T @ model.M @ x  # M-orthonormal modes: the modal coordinates
            assert np.abs(modal[k:]).max() < 1e-9 * np.abs(modal[:k]).max()
            assert np.linalg.norm(x) > 0


#: a chaotic cell of the two-mode default grid (results version 23: lambda_1 T 0.11, interval
#: above the margin, stick fraction 0.93) whose load is below its lock-up limit (lock_ratio
#: 0.88, beamsim.shakedown)
BELOW_LOCK_UP = CELL | {"Omega": 1.84770349, "f0_rel": 1.49623441}


def test_beam_cell_below_its_lock_up_limit_holds_the_locked_attractor_beside_the_one_from_rest():
    """The start from rest and the locked start (:func:`analysis.pipeline.cell_attractors.
    locked_start`) through the pipeline's stages: the locked start stays on the locked orbit,
    periodic-1 with a contracting exponent and every element stuck, while the start from rest
    reaches a slipping attractor elsewhere: two attractors, as the linear analysis says (a
    locked state proven to exist does not make the map's run end there)."""
    from analysis.pipeline.cell_attractors import locked_start
    from beamsim.shakedown import lock_ratio

    assert lock_ratio(prepare_point(**BELOW_LOCK_UP)) < 1.0
    locked = locked_start(BELOW_LOCK_UP)
    assert locked
    nm = Numerics()
    table = point_attractors(BELOW_LOCK_UP, [{}, locked], nm, threads=2)
    shown = table[["starts", "label", "period", "lle_T", "lle_lo_T", "lle_hi_T"]]
    assert len(table) == 2 and [list(s) for s in table["starts"]] == [[0], [1]], shown
    lock_row = table.iloc[1]
    assert lock_row["label"] == "periodic" and lock_row["period"] == 1 and lock_row["lle_T"] < 0, shown
    rest = np.asarray(table["poincare_state"].iloc[0])
    assert np.ptp(rest, axis=0).max() > 1e3 * np.ptp(np.asarray(lock_row["poincare_state"]), axis=0).max()
    rest_run, locked_run = simulate_runs([{"point_id": "rest", "params": BELOW_LOCK_UP},
                                          {"point_id": "locked", "params": BELOW_LOCK_UP | locked}], nm, 2)
    assert rest_run["stick_fraction"] < 1.0  # the start from rest slips over its record
    assert locked_run["stick_fraction"] == 1.0 and not locked_run["slipped"]

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
from analysis.regimes import CHAOTIC, QUASI_PERIODIC, UNDETERMINED
from beamsim.point import prepare_point

#: a cell of the two-mode default grid (Omega 2.48, f0_rel 2.61; the multistability job of
#: results version 13) with a chaotic attractor (lambda_1 T 0.23-0.29, interval above 0.09) and
#: a regular one (-0.012, interval below 0.015), reached from rest and from the end state of its
#: upper neighbour in the load (f0_rel 2.80, itself periodic).  Which start reaches which
#: depends on the CPU's last bits: on a host without AVX-512 the rest start the regular one
#: (a torus) and the neighbour's state the chaotic one, on an AVX-512 host the other way round
#: (2026-11-26; the regular one then undetermined: its record broadband, a CONFLICT): the two
#: basins are intertwined near these starts.
CELL = dict(n_modes=2, mu_s=0.45, mu_k=0.3, p=1e-4, k_t=10.0, damping=0.0, interface_viscosity=0.0939,
            law="stick-slip", alpha1=0.005, alpha2=0.005, beta=0.4, bc="clamped-free",
            Omega=2.47698677388, f0_rel=2.61033899224)
NEIGHBOUR = CELL | {"f0_rel": 2.79839542894}


def test_beam_cell_with_two_attractors():
    nm = Numerics()
    end = simulate_runs([{"point_id": "neighbour", "params": NEIGHBOUR}], nm, 1)[0]["final_state"]
    model = prepare_point(**CELL).model
    table = point_attractors(CELL, [{}, state_params(end, model.n, model.n_quad)], nm, threads=2)
    assert len(table) == 2, table[["starts", "label", "lle_T"]]
    assert sorted(s for starts in table["starts"] for s in starts) == [0, 1]  # one start each
    chaotic, regular = table[table["lle_lo_T"] > 0.05], table[table["lle_hi_T"] <= 0.05]
    assert len(chaotic) == 1 and len(regular) == 1, table[["starts", "label", "lle_lo_T", "lle_hi_T"]]
    chaotic, regular = chaotic.iloc[0], regular.iloc[0]
    assert chaotic["label"] == CHAOTIC
    # regular by its exponent; a torus, or undetermined where its record looks broadband
    assert regular["label"] == QUASI_PERIODIC or (regular["label"] == UNDETERMINED
                                                  and "CONFLICT" in regular["reason"]), regular["reason"]
    # two different sets, not two samplings of one: their centres are apart
    a, b = (np.asarray(r["poincare_state"]) for r in (chaotic, regular))
    assert np.abs(a.mean(axis=0) - b.mean(axis=0)).max() > 0.05 * np.ptp(np.vstack([a, b]), axis=0).max()


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

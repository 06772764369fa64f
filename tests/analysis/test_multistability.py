"""A beam point with two attractors (analysis.multistability.point_attractors): runs from rest
and from seeded perturbed starts, grouped by attractor, each group classified by the pipeline's
own stages."""

from __future__ import annotations

import numpy as np

from analysis.multistability import perturbed_starts, point_attractors
from analysis.pipeline.config import Numerics
from analysis.regimes import CHAOTIC

#: a cell of the default grid (first column, second row): the start from rest and one
#: perturbed start reach a chaotic attractor, two others a set with a discrete spectrum
#: (measured: lambda_1 T 0.24 with interval [0.06, 0.42] against 0.02 [-0.03, 0.07])
POINT = dict(n_modes=2, mu_s=0.45, mu_k=0.3, p=1e-4, k_t=10.0, damping=0.0, interface_damping=0.5,
             law="stick-slip", alpha1=0.005, alpha2=0.005, beta=0.4, bc="clamped-free",
             Omega=1.37828978659, f0_rel=0.857634334011)


def test_beam_point_with_two_attractors():
    starts = [{}] + perturbed_starts(POINT, 3, seed=0, amplitude=0.3)
    table = point_attractors(POINT, starts, Numerics(), threads=2)
    assert len(table) == 2, table[["starts", "label", "lle_T"]]
    rest = table[table["starts"].map(lambda s: 0 in s)].iloc[0]
    other = table[table["starts"].map(lambda s: 0 not in s)].iloc[0]
    assert rest["label"] == CHAOTIC and rest["lle_lo_T"] > 0.05
    assert other["label"] != CHAOTIC and other["lle_lo_T"] < 0.05
    # two different sets, not two samplings of one: their centres are apart
    a, b = (np.asarray(r["poincare_state"]) for r in (rest, other))
    assert np.abs(a.mean(axis=0) - b.mean(axis=0)).max() > 0.05 * np.ptp(np.vstack([a, b]), axis=0).max()
    # deterministic: the starts are seeded
    again = perturbed_starts(POINT, 3, seed=0, amplitude=0.3)
    assert all(np.array_equal(x["q0"], y["q0"]) for x, y in zip(starts[1:], again))

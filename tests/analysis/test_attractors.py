"""Grouping runs from several initial states by attractor (analysis.attractors) on systems
whose attractors are known."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_regimes import henon, torus2

from analysis.attractors import group_records
from analysis.regimes import CHAOTIC, PERIODIC, classify

#: hardening Duffing x'' + 0.1 x' + x + 0.2 x^3 = 0.6 cos(1.4 t), inside its hysteresis range:
#: a small period-1 orbit (reached from rest) and a large one (from far starts)
DUFFING = (0.1, 1.0, 0.2, 0.6, 1.4)
STARTS = [(0.0, 0.0), (3.0, 0.0), (0.5, 0.0), (-3.0, 0.0), (2.0, 2.0), (0.0, -0.5)]


@cache
def duffing_record(x0: float, v0: float, n_transient: int = 250, n_record: int = 128) -> np.ndarray:
    d, a, b, g, w = DUFFING
    T = 2 * np.pi / w
    sol = solve_ivp(lambda t, u: [u[1], -d * u[1] - a * u[0] - b * u[0] ** 3 + g * np.cos(w * t)],
                    (0.0, (n_transient + n_record) * T), [x0, v0],
                    t_eval=T * np.arange(n_transient, n_transient + n_record + 1), method="DOP853",
                    rtol=1e-10, atol=1e-10)
    return sol.y.T.copy()


def test_duffing_hysteresis_two_attractors() -> None:
    records = [duffing_record(*s) for s in STARTS]
    groups = group_records(records)
    assert len(groups) == 2, groups
    assert groups[0][0] == 0  # rest reaches the first attractor
    amplitude = []
    for g in groups:
        res = classify(records[g[0]])
        assert res.label == PERIODIC and res.period == 1
        amplitude.append(np.abs(records[g[0]][-1]).max())
    # the two orbits: the small one from rest and the large resonant one
    assert max(amplitude) > 2.5 * min(amplitude)
    # the grouping does not depend on which start comes first (same partition)
    back = group_records(records[::-1])
    as_sets = {frozenset(len(records) - 1 - i for i in g) for g in back}
    assert as_sets == {frozenset(g) for g in groups}


def test_one_attractor_sampled_twice_is_one_group() -> None:
    h = henon(1200)
    assert group_records([h[:300], h[600:900]]) == [[0, 1]]
    t = torus2(600)
    assert group_records([t[:256], t[300:556]]) == [[0, 1]]


def test_distinct_attractors_are_separated() -> None:
    h = henon(300)
    fixed = np.tile(h.mean(axis=0), (300, 1))  # a fixed point inside the chaotic set's hull
    shifted = h + np.ptp(h, axis=0) * 0.5
    assert group_records([h, fixed]) == [[0], [1]]
    assert group_records([h, shifted]) == [[0], [1]]
    assert classify(h).label == CHAOTIC and classify(fixed).label == PERIODIC


def test_rejects_bad_records() -> None:
    with pytest.raises(ValueError, match="records"):
        group_records([np.zeros((10, 2)), np.zeros((10, 3))])
    assert group_records([]) == []


def test_record_distance_is_the_brute_force_one() -> None:
    """The nearest-neighbour distances (``cdist``) are those of the definition, computed on the
    whole ``(n, n, d)`` array of differences, to the bit."""
    from analysis.attractors import _nearest

    rng = np.random.default_rng(3)
    a, b = rng.standard_normal((70, 6)), rng.standard_normal((50, 6)) * 2.0
    brute = np.max(np.abs(a[:, None, :] - b[None, :, :]), axis=2)
    assert _nearest(a, b).tobytes() == brute.min(axis=1).tobytes()
    own = np.max(np.abs(a[:, None, :] - a[None, :, :]), axis=2)
    np.fill_diagonal(own, np.inf)
    assert _nearest(a, a, same=True).tobytes() == own.min(axis=1).tobytes()
    twice = np.vstack([a[:5], a[:5]])  # repeated samples: the nearest other one is at distance 0
    assert not _nearest(twice, twice, same=True).any()

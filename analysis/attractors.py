r"""Which attractors do runs from several initial states reach?  Grouping Poincare records.

A forced nonlinear system can hold several attractors at one parameter point (the forced
Duffing oscillator in its hysteresis range: a small and a large period-1 orbit; the beam with
friction: a start from rest and a start from a neighbouring point's state can end on a
periodic orbit and on a chaotic attractor).  A regime map that runs every point from rest shows
one of them.  :func:`group_records` takes the post-transient Poincare records of runs from
several starts and groups them by the attractor they sample; each group is then classified on
its own (:func:`analysis.regimes.classify`).

Distance between two records ``A`` and ``B`` (rows = samples), in units of the per-component
scale ``S_j`` of all records together (:func:`analysis.poincare.component_scales`) and the
Chebyshev norm: the mean over ``a in A`` of the distance to the nearest ``b in B``, and the
same from ``B`` to ``A``; the larger of the two (a symmetric, outlier-tolerant Hausdorff
distance).  Two records sample the same attractor when that distance is at most
``tol + spread_factor * max(s_A, s_B)``, with ``s_A`` the mean nearest-neighbour spacing of
``A``'s own samples: zero on a periodic orbit (its samples repeat), the sampling density of a
torus or chaotic attractor.  So two samplings of one chaotic set match, while a periodic orbit
inside a chaotic attractor's region does not (its points are near the chaotic set, but most
chaotic points are far from its few points).

Groups are formed greedily in the order of the records (a record joins the first group whose
first record matches it), so the result is deterministic for a given list of starts.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.spatial.distance import cdist

from analysis.poincare import component_scales

__all__ = ["group_records", "record_distance"]


def _nearest(a: np.ndarray, b: np.ndarray, same: bool = False) -> np.ndarray:
    """For every row of ``a`` the Chebyshev distance to the nearest row of ``b`` (excluding the
    row itself when ``same``)."""
    d = cdist(a, b, "chebyshev")
    if same:
        np.fill_diagonal(d, np.inf)
    return d.min(axis=1)


def record_distance(a: np.ndarray, b: np.ndarray, scales: np.ndarray) -> tuple[float, float, float]:
    """``(distance, spacing_a, spacing_b)`` of two records in units of ``scales`` (module
    docstring)."""
    a = np.asarray(a, dtype=float) / scales
    b = np.asarray(b, dtype=float) / scales
    dist = max(float(_nearest(a, b).mean()), float(_nearest(b, a).mean()))
    sa = float(_nearest(a, a, True).mean()) if len(a) > 1 else 0.0
    sb = float(_nearest(b, b, True).mean()) if len(b) > 1 else 0.0
    return dist, sa, sb


def group_records(records: Sequence[np.ndarray], *, tol: float = 0.02, spread_factor: float = 3.0,
                  scale_floor_rtol: float = 0.1, max_points: int = 512) -> list[list[int]]:
    """Group Poincare records (one per initial state, same components) by attractor.

    records : ``(n_i, d)`` arrays of post-transient stroboscopic samples.
    tol : distance (scaled) below which two records always match (periodic orbits).
    spread_factor : multiple of the records' own sample spacing also allowed.
    max_points : the last ``max_points`` samples of each record are compared (memory
        ``O(max_points^2)``).
    Returns the groups as lists of record indices, in order of first appearance.
    """
    recs = [np.asarray(r, dtype=float)[-max_points:] for r in records]
    if not recs:
        return []
    if any(r.ndim != 2 or r.shape[1] != recs[0].shape[1] or not np.all(np.isfinite(r)) for r in recs):
        raise ValueError("records must be finite 2-D arrays with the same number of columns")
    scales = component_scales(np.concatenate(recs), floor_rtol=scale_floor_rtol)
    groups: list[list[int]] = []
    for i, r in enumerate(recs):
        for g in groups:
            dist, sa, sb = record_distance(recs[g[0]], r, scales)
            if dist <= tol + spread_factor * max(sa, sb):
                g.append(i)
                break
        else:
            groups.append([i])
    return groups

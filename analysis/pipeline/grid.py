"""Parameter grids of the regime pipeline: expansion into points, point identity, chunks.

A grid (``config/grid.yaml``) has ``axes`` -- any model parameter, given as a list
(``values: [...]``) or a range with a count (``range: [lo, hi], num: n``, optionally
``scale: log``) -- and ``fixed`` overrides of the model defaults (``config/config.yaml``,
section ``model``).  A 1-D grid yields a bifurcation diagram, a 2-D grid a regime map.

A point's identity is its parameters, not its position in a list:
``point_id = sha256(canonical JSON of the resolved parameters and the resolved numerics that
change results, :meth:`analysis.pipeline.config.Numerics.result_dict`)[:16]``.  Adding points
or reordering a grid therefore recomputes only new points; changing a default changes the id of
every point that uses it.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from dataclasses import dataclass

import numpy as np

from analysis.pipeline.config import Numerics, as_numerics

#: bump when a code change alters results for unchanged parameters (invalidates all ids)
RESULTS_VERSION = "30"  # 6: adaptive transients, block statistics of lambda_1; 7: expo's
#                        conjugate pairs with damping, kernels with reassociated sums; 8: the
#                        continuation check (the record kept is the continued one); 9: the
#                        Lyapunov stage's free copy on expo (numerics.lyapunov.method: auto);
#                        10: auto keeps the RK4 free copy where mu_s = mu_k; 11: a point whose
#                        expo run or expo pair meets expo's Zeno guard is run on RK4
#                        (simulate record's method, lle_free_copy); 12: expo's real
#                        eigen-decomposition, check ladder and closed form in the interval's
#                        coefficients (switch times move in the last bits); 13: the Stefanski
#                        ladder on expo where the free copy is (numerics.lyapunov.ladder: expo);
#                        14: expo's check bounds follow the free modes' decay, its reference
#                        runs' output grid 16 steps per period (64 before); 15: expo's
#                        switches refined by Newton steps, magnitudes without hypot (switch
#                        times move in the last bits); 16: the expo copies' output grid 16
#                        steps per period (64 before), their Zeno guard counted per T / 64;
#                        17: the expo drive's Zeno guard counted per T / 64 too (per output
#                        step before: where a step had more than 10 nq + 10 switches but no
#                        window did, the point fell back to the RK4 pair); 18: expo's
#                        reference runs' output grid 4 steps per period (16 before), its
#                        stick fractions time averages per interval (sampled at step ends
#                        before); 19: a record with every element stuck gets the exact
#                        lambda_1 of the stuck beam and, when that is negative, the label
#                        periodic-1 (quasi-periodic or a long period before); 20: that
#                        label only where no element can slip again (the stuck record's
#                        stuck_bound below 1: beamsim.shakedown), undetermined otherwise;
#                        21: the continuation check also tests two aperiodic records joined
#                        (transient_reason at twice the baseline, not for stuck records), a
#                        record that only the cluster route calls periodic gets its long
#                        Benettin record (undetermined where the interval is above the
#                        margin), aperiodic samples with an interval below minus the margin
#                        are undetermined; 22: expo's modal load of the interface tractions
#                        from per-pattern unit loads (V^-1 M^-1 of the load vector before:
#                        rounding in the slow modes, docs/lyapunov.md section 17); 23: the
#                        long record's looks on an O'Brien-Fleming boundary
#                        (numerics.lyapunov.boundary; each look at 95 % before); 24: a record
#                        that slips below the point's shakedown limit is a transient
#                        (beamsim.shakedown; the simulate record's shakedown_ratio); 25:
#                        that rule checked by its energy (stages.ShakedownWatch): a record
#                        whose W grows there is unsettled, not periodic-1 by the theorem
#                        (the simulate record's shakedown_trouble; the shipped maps' labels
#                        are version 24's); 26: no explicit M^-1 in the first-order
#                        matrices: RK4's by Cholesky solves, expo's damped decompositions in
#                        mass-normalised coordinates (its rounding, eps cond(M), was a floor of
#                        ~3e-7 (RK4) and ~1e-6 (expo) of the state per period; the rigid
#                        stick keeps it); 27: a multistability neighbour or continuation
#                        predecessor with another k_t (elastic stick) starts a point with
#                        its tractions kept (analysis.continuation.carries; its numbers before,
#                        which scaled the tractions by the ratio of the stiffnesses): only
#                        grids with k_t as an axis or line change; 28: the long run
#                        (numerics.n_long_transient) of aperiodic and unsettled records
#                        (simulate record's long_run); 29: taken by a reverted commit
#                        (7b120db); 30: the long run also after a period-m record (m > 1)
#                        near a shorter period (analysis.transients.near_shorter_period)


def _canonical(value):
    """JSON-stable form: floats via repr (exact), numpy scalars to Python, dict keys sorted."""
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in sorted(value.items())}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_canonical(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        v = float(value)
        if v.is_integer() and abs(v) < 2**53:
            return int(v)  # 1 and 1.0 are the same parameter value
        return v
    return value


def canonical_json(obj) -> str:
    return json.dumps(_canonical(obj), sort_keys=True, separators=(",", ":"))


def point_id(params: dict, numerics: Numerics | dict) -> str:
    """16-hex-digit identity of a point from its resolved parameters and the numerics (resolved:
    a setting left to its default gives the same id as the default written out)."""
    return _hashed_id(params, canonical_numerics(numerics))


def canonical_numerics(numerics: Numerics | dict) -> dict:
    """The numerics' part of a point id (:func:`point_id`), to hash many points with one
    resolution (:func:`expand_grid`)."""
    return _canonical(as_numerics(numerics).result_dict())


def _hashed_id(params: dict, numerics_canonical: dict) -> str:
    # the same string as canonical_json({"params": .., "numerics": .., "version": ..}): the
    # numerics are canonical already, and json.dumps sorts the keys
    payload = json.dumps({"params": _canonical(params), "numerics": numerics_canonical,
                          "version": RESULTS_VERSION}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(payload.encode()).hexdigest()[:16]


def axis_values(name: str, spec) -> list:
    """Values of one axis: a list, or ``{"values": [...]}``, or ``{"range": [lo, hi], "num": n,
    "scale": "linear" | "log"}`` (endpoints included)."""
    if isinstance(spec, list):
        values = spec
    elif "values" in spec:
        values = spec["values"]
    else:
        lo, hi = spec["range"]
        num = int(spec["num"])
        if spec.get("scale", "linear") == "log":
            if lo <= 0 or hi <= 0:
                raise ValueError(f"axis {name}: a log range needs positive ends, got {spec['range']}")
            values = np.geomspace(lo, hi, num)
        else:
            values = np.linspace(lo, hi, num)
        values = [float(f"{v:.12g}") for v in values]  # stable decimal values, no 0.30000000000000004
    if len(values) == 0:
        raise ValueError(f"axis {name}: no values")
    return list(values)


@dataclass(frozen=True)
class GridPoint:
    grid: str
    index: tuple  # position along each axis
    params: dict  # fully resolved model parameters
    point_id: str


def expand_grid(name: str, grid: dict, model_defaults: dict, numerics: Numerics | dict) -> list[GridPoint]:
    """All points of a grid, in axis order (first axis slowest)."""
    from beamsim.point import POINT_KEYS

    axes = grid.get("axes", {})
    known = set(model_defaults) | set(POINT_KEYS)
    unknown = (set(axes) | set(grid.get("fixed", {}))) - known
    if unknown:
        raise ValueError(f"grid {name}: unknown parameter(s) {sorted(unknown)}; allowed: {sorted(known)}")
    both = set(axes) & set(grid.get("fixed", {}))
    if both:
        raise ValueError(f"grid {name}: {sorted(both)} given both as axis and as fixed")
    base = dict(model_defaults) | dict(grid.get("fixed", {}))
    names = list(axes)
    values = [axis_values(a, axes[a]) for a in names]
    resolved = canonical_numerics(numerics)
    points = []
    for idx in itertools.product(*(range(len(v)) for v in values)):
        params = dict(base)
        for a, i, v in zip(names, idx, values):
            params[a] = v[i]
        params = {k: v for k, v in params.items() if v is not None}
        points.append(GridPoint(grid=name, index=idx, params=params, point_id=_hashed_id(params, resolved)))
    ids = [p.point_id for p in points]
    if len(set(ids)) != len(ids):
        raise ValueError(f"grid {name}: repeated points (an axis lists a value twice)")
    return points


def chunk_points(points: list[GridPoint], chunk_size: int) -> list[list[GridPoint]]:
    """Split into ``ceil(n / chunk_size)`` chunks; the assignment depends only on the ids."""
    n_chunks = max(1, math.ceil(len(points) / chunk_size))
    ordered = sorted(points, key=lambda p: p.point_id)
    return [ordered[k::n_chunks] for k in range(n_chunks)]

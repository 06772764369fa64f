r"""Every attractor a beam point reaches from several initial states, each with its label.

:func:`point_attractors` runs one parameter point from a list of initial states (rest, seeded
perturbations from :func:`perturbed_starts`, or the end states of neighbouring points: a
continuation), with the pipeline's numerics and stages (adaptive transient, long Benettin
record, classifier), groups the post-transient Poincare records by attractor
(:func:`analysis.attractors.group_records`) and classifies one representative per group.  The
result is one row per attractor: which starts reached it, its label, period, ``lambda_1 T``
with its confidence interval, and the classifier's reason.  Deterministic: the starts are
seeded and the grouping follows their order.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from analysis.attractors import group_records
from analysis.lyapunov.beam import SLOW_MODES
from analysis.pipeline.config import Numerics, as_numerics

__all__ = ["perturbed_starts", "point_attractors"]


def perturbed_starts(params: dict, n: int, *, seed: int | Sequence[int] = 0,
                     amplitude: float = 1.0, n_slow: int = SLOW_MODES) -> list[dict]:
    """``n`` seeded initial states of a point, in the ``n_slow`` slowest modes of the stuck
    structure (:attr:`beamsim.two_layer.TwoLayerModel.eig_stuck`, eigenvector signs fixed):
    modal displacements and velocities drawn from a standard normal distribution, the
    displacement scaled to ``amplitude`` times the size of the forced-response scale
    (:func:`analysis.lyapunov.beam.response_scale`, Euclidean norm over the coordinates) times
    ``|a| / sqrt(k)`` (``a`` the ``k = min(n_slow, n)`` drawn amplitudes: the size is random as
    well), the velocity likewise with ``omega`` times that scale; Jenkins slips zero, every
    element stuck.  The fast interface-penalty and membrane modes are not excited: a
    perturbation drawn in every coordinate puts energy into them, which the undamped structure
    keeps, and ``expo`` then pays for their oscillation at every event check (measured in
    docs/pipeline.md, "Multistability of a map").  ``seed``: an integer or a sequence of integers (numpy's
    ``default_rng``; e.g. a config seed and a grid index).  Returns dicts of ``q0``, ``v0`` to
    merge into the parameters."""
    from analysis.lyapunov.beam import response_scale, slow_modes
    from beamsim.simulate import prepare_point

    pp = prepare_point(**params)
    size = float(np.linalg.norm(response_scale(pp)))
    phi = slow_modes(pp.model, n_slow)
    k = phi.shape[1]
    scale = amplitude * size / np.sqrt(k)
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(int(n)):
        a, b = rng.standard_normal(k), rng.standard_normal(k)
        q, v = phi @ a, phi @ b
        out.append({"q0": scale * np.linalg.norm(a) * q / np.linalg.norm(q),
                    "v0": scale * pp.omega * np.linalg.norm(b) * v / np.linalg.norm(v)})
    return out


def point_attractors(params: dict, starts: Sequence[dict], numerics: Numerics | dict, *,
                     threads: int = 1) -> pd.DataFrame:
    """One row per attractor reached from ``starts`` (dicts of initial-state parameters,
    ``{}`` for rest), in order of first appearance.

    Columns: ``attractor`` (0, 1, ...), ``starts`` (indices of the starts that reached it),
    ``label``, ``period``, ``lle_T``, ``lle_lo_T``, ``lle_hi_T`` (per forcing period),
    ``reason``, ``poincare_state`` (the representative's record).  Starts that diverged form one
    row labelled ``diverged``.
    """
    from analysis.pipeline.stages import classify_points, lyapunov_records, records_table, simulate_runs
    from analysis.regimes import DIVERGED

    nm = as_numerics(numerics)
    pts = [{"point_id": f"start{k}", "params": dict(params) | dict(s)} for k, s in enumerate(starts)]
    sims = simulate_runs(pts, nm, threads)
    ok = [k for k, r in enumerate(sims) if not r["diverged"] and np.all(np.isfinite(r["poincare_state"]))]
    groups = [[ok[i] for i in g] for g in group_records([sims[k]["poincare_state"] for k in ok])]
    reps = [pts[g[0]] for g in groups]
    rows = []
    if reps:
        sim_df = records_table(reps, [sims[g[0]] for g in groups])
        lyap = lyapunov_records(reps, sim_df.set_index("point_id"), nm, threads)
        lab = classify_points(sim_df, records_table(reps, lyap), lle_threshold=nm.lyapunov.margin)
        for a, (g, (_, s), (_, c), ly) in enumerate(zip(groups, sim_df.iterrows(), lab.iterrows(), lyap)):
            T = 2.0 * np.pi / float(s["omega"])
            rows.append({"attractor": a, "starts": list(g), "label": c["label"],
                         "period": c["period"], "lle_T": ly["lle_mean"] * T,
                         "lle_lo_T": ly["lle_lo"] * T, "lle_hi_T": ly["lle_hi"] * T,
                         "reason": c["reason"], "poincare_state": sims[g[0]]["poincare_state"]})
    bad = [k for k in range(len(pts)) if k not in ok]
    if bad:
        rows.append({"attractor": len(rows), "starts": bad, "label": DIVERGED, "period": None,
                     "lle_T": np.nan, "lle_lo_T": np.nan, "lle_hi_T": np.nan,
                     "reason": "integration diverged", "poincare_state": None})
    return pd.DataFrame(rows)

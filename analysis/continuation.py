r"""Continuation sweeps along a 1-D line of parameter points, up and down.

A regime map starts every point from rest; a beam with dry friction is hysteretic and
multistable (slip locked into stuck elements, coexisting attractors), so which attractor a
point shows can depend on where it came from.  :func:`continuation_sweeps` runs a line of
points twice, in both directions: the up-sweep starts its first point from rest and every next
point from the previous point's end state (coordinates, velocities, Jenkins slips and stick
flags: the full state, so the restart is exact), the down-sweep the same from the last point
backwards.  Both chains advance together, one point each per step (a batch of two: two
threads), each point with the pipeline's own numerics and stages (adaptive transient, long
Benettin record with its block statistics, classifier).  A chain whose run diverged restarts
its next point from rest (``start`` says so).

Where the two branches disagree the line is hysteretic; a bifurcation diagram with both
branches and their ``lambda_1`` curves (:func:`analysis.figures.continuation.plot_continuation`)
shows where.  Deterministic: the same line and numerics give the same table.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from analysis.pipeline.config import Numerics, as_numerics

__all__ = ["BRANCHES", "carried_state", "carries", "continuation_sweeps", "continue_from", "hysteresis",
           "state_params"]

#: the two sweep directions, in table order
BRANCHES = ("up", "down")


def state_params(final_state: np.ndarray, n: int, nq: int) -> dict:
    """Initial-state parameters (``q0``, ``v0``, ``z0``, ``mode0``) of a final state, or ``{}``
    (rest) when it is not finite."""
    x = np.asarray(final_state, dtype=float)
    if x.size != 2 * n + 2 * nq or not np.all(np.isfinite(x)):
        return {}
    return {"q0": x[:n].copy(), "v0": x[n:2 * n].copy(), "z0": x[2 * n:2 * n + nq].copy(),
            "mode0": x[2 * n + nq:].copy()}


def carries(src, dst, law: str) -> bool:
    """Whether an end state of model ``src`` must be carried into model ``dst``
    (:func:`carried_state`) rather than passed on as its numbers: the state's layout differs
    (``n_modes``, ``n_quad``), or, for the elastic stick (``law`` ``stick-slip``), the stick
    stiffness ``k_t`` does -- the same numbers would scale every element's traction
    ``k_t (s_j - z_j)`` by the ratio of the stiffnesses and start stuck elements beyond their
    friction limit, where the carried state keeps the tractions the interface held."""
    return ((src.n, src.n_quad) != (dst.n, dst.n_quad)
            or (law == "stick-slip" and src.geom.k_t != dst.geom.k_t))


def carried_state(state: np.ndarray, src, dst, law: str) -> np.ndarray:
    """An end state of model ``src`` as a start of model ``dst`` of another layout or stick
    stiffness (:func:`carries`; :func:`beamsim.state_transfer.transfer_state`); a state that is
    not finite stays so (the next point then starts from rest, as after a diverged one)."""
    from beamsim.state_transfer import transfer_state

    x = np.asarray(state, dtype=float)
    if not np.all(np.isfinite(x)):
        return np.full(2 * dst.n + 2 * dst.n_quad, np.nan)
    return transfer_state(x, src, dst, law=law)


def _carried_start(prev: np.ndarray, src, dst, law: str) -> dict:
    """The initial-state parameters of a point of model ``dst`` started from ``prev``, an end
    state of model ``src``: carried where :func:`carries` says so, ``{}`` (rest) where it is
    not finite."""
    if carries(src, dst, law):
        prev = carried_state(prev, src, dst, law)
    return state_params(prev, dst.n, dst.n_quad)


def continuation_sweeps(points: Sequence[dict], numerics: Numerics | dict, *, axis: str,
                        threads: int = 2) -> pd.DataFrame:
    """Up- and down-sweep of ``points`` (parameter dicts in axis order).  Each point starts
    from its predecessor's end state; where the axis changes the state's layout (``n_modes``,
    ``n_quad``) or the elastic stick's ``k_t`` (:func:`carries`) the end state is carried into
    the point's model by :func:`beamsim.state_transfer.transfer_state` (fields projected onto
    the other basis, tractions kept; law ``stick-slip``).

    Returns one row per branch and point (``up`` rows in axis order, then ``down`` rows in axis
    order): ``branch``, ``k`` (position on the line), ``axis`` value, ``start`` (``rest`` or
    ``continued``), ``label``, ``period``, ``lle_T``, ``lle_lo_T``, ``lle_hi_T`` (per forcing
    period), ``lle_verdict``, ``reason``, ``n_transient_used``, ``slipped``, ``poincare_w_tip``
    (the tip's stroboscopic samples), ``poincare_state`` (the full state's), ``diverged``, and
    the integrators as in the regime table: ``method`` (of the reference run) and
    ``lle_free_copy`` (of the Lyapunov stage's free copy; both name a Zeno fallback), and the
    point's ``lock_ratio`` and ``shakedown_ratio`` (:func:`analysis.pipeline.table.lock_ratios`).
    """
    from analysis.pipeline.stages import (
        classify_points,
        each_on_threads,
        lyapunov_records,
        records_table,
        simulate_runs,
    )
    from analysis.pipeline.table import lock_ratios
    from beamsim.pattern_store import PatternStore
    from beamsim.simulate import prepare_point

    nm = as_numerics(numerics)
    n_pts = len(points)
    if n_pts == 0:
        raise ValueError("continuation_sweeps: no points")
    models = [prepare_point(**p).model for p in points]
    order = {"up": list(range(n_pts)), "down": list(range(n_pts - 1, -1, -1))}
    patterns = PatternStore()  # expo's decompositions, shared by both chains (a cost)

    def chain(b: str) -> dict:
        """Branch ``b``'s points in its order, each started from the previous one's end state:
        ``k -> (start, point, record)``."""
        prev, prev_k, out = None, None, {}
        for k in order[b]:
            init = ({} if prev is None else
                    _carried_start(prev, models[prev_k], models[k], points[k].get("law", "stick-slip")))
            p = {"point_id": f"{b}{k:05d}", "params": dict(points[k]) | init}
            rec = simulate_runs([p], nm, 1, patterns)[0]
            out[k] = ("continued" if init else "rest", p, rec)
            prev, prev_k = rec["final_state"], k
        return out

    # the two chains side by side, each on a thread of its own (a point's records depend on its
    # own runs only, so this is what one batch of two per step gave, without its barrier)
    sims = {(b, k): v for b, runs in each_on_threads(chain, BRANCHES, min(threads, 2))
            for k, v in runs.items()}
    keys = [(b, k) for b in BRANCHES for k in range(n_pts)]
    starts = {key: sims[key][0] for key in keys}
    pts = [sims[key][1] for key in keys]
    recs = [sims[key][2] for key in keys]
    sim_df = records_table(pts, recs)
    lyap = lyapunov_records(pts, sim_df.set_index("point_id"), nm, threads)
    lab = classify_points(sim_df, records_table(pts, lyap), lle_threshold=nm.lyapunov.margin)
    rows = []
    for (b, k), rec, ly, (_, c) in zip(keys, recs, lyap, lab.iterrows()):
        period_t = 2.0 * np.pi / float(rec["omega"])
        tip = np.asarray(rec["poincare_tip"], dtype=float)
        rows.append({"branch": b, "k": k, axis: points[k][axis], "start": starts[(b, k)],
                     "label": c["label"], "period": c["period"],
                     "lle_T": float(ly["lle_mean"]) * period_t, "lle_lo_T": float(ly["lle_lo"]) * period_t,
                     "lle_hi_T": float(ly["lle_hi"]) * period_t, "lle_verdict": ly["lle_verdict"],
                     "reason": c["reason"], "n_transient_used": int(rec["n_transient_used"]),
                     "slipped": bool(rec["slipped"]), "diverged": bool(rec["diverged"]),
                     "method": rec["method"], "lle_free_copy": ly["lle_free_copy"],
                     "poincare_w_tip": tip[:, 0].tolist() if tip.ndim == 2 and tip.size else [],
                     "poincare_state": np.asarray(rec["poincare_state"], dtype=float).tolist()})
    out = pd.DataFrame(rows)
    out["period"] = out["period"].astype("Int64")
    out[["lock_ratio", "shakedown_ratio"]] = lock_ratios(points)[out["k"].to_numpy()]
    return out


def continue_from(state: np.ndarray, src, points: Sequence[dict], numerics: Numerics | dict, *,
                  lle_threshold: float, threads: int = 1) -> pd.Series:
    """Where an attractor goes along a path of parameter points: ``state`` (an end state of
    model ``src``, e.g. a map point's) starts ``points[0]``, each next point starts from its
    predecessor's end state (carried into its model where :func:`carries` says so), every
    point through the pipeline's simulate stage (adaptive transient, continuation check); the
    last point's record then through the Lyapunov and classify stages (``lle_threshold``: the
    classifier's margin).  Returns the last point's classification row (``label``, ``period``,
    ``reason``, ...) with its ``lle_mean``, ``lle_lo``, ``lle_hi`` and ``omega``.  Raises
    ``ValueError`` where a state cannot be carried (another beam, a law without stick
    elongations) or ``state`` is not finite (a start from rest would not continue anything)."""
    from analysis.pipeline.stages import classify_points, lyapunov_records, records_table, simulate_runs
    from beamsim.simulate import prepare_point

    nm = as_numerics(numerics)
    prev, prev_model = np.asarray(state, dtype=float), src
    if not points or not np.all(np.isfinite(prev)):
        raise ValueError("continue_from: no points, or a start state that is not finite")
    for k, params in enumerate(points):
        model = prepare_point(**params).model
        start = _carried_start(prev, prev_model, model, params.get("law", "stick-slip"))
        if not start:
            raise ValueError(f"continue_from: point {k} has no finite start state")
        p = {"point_id": f"continued{k:05d}", "params": dict(params) | start}
        rec = simulate_runs([p], nm, threads)[0]
        prev, prev_model = rec["final_state"], model
    sim = records_table([p], [rec])
    lyap = records_table([p], lyapunov_records([p], sim.set_index("point_id"), nm, threads))
    out = classify_points(sim, lyap, lle_threshold=lle_threshold).iloc[0].copy()
    for c in ("lle_mean", "lle_lo", "lle_hi"):
        out[c] = lyap[c].iloc[0]
    out["omega"] = rec["omega"]
    return out


def hysteresis(table: pd.DataFrame, axis: str) -> pd.DataFrame:
    """Per point of a line, the up and down labels side by side: ``label_up``, ``label_down``,
    ``differs`` (another regime, or another period) and ``same_attractor`` (the two branches'
    Poincare records are one set, :func:`analysis.attractors.group_records`: two attractors of
    the same label -- e.g. chaotic sets shifted by slip locked into stuck elements -- count
    as different; ``None`` where a record is missing or not finite)."""
    from analysis.attractors import group_records
    from analysis.pipeline.convergence import label_text

    t = table.assign(text=[label_text(lab, per) for lab, per in zip(table["label"], table["period"])])
    up = t[t["branch"] == "up"].set_index("k")
    down = t[t["branch"] == "down"].set_index("k")
    out = pd.DataFrame({axis: up[axis], "label_up": up["text"], "label_down": down["text"]})
    out["differs"] = out["label_up"] != out["label_down"]
    same = []
    for k in out.index:
        recs = [np.asarray([np.asarray(r, dtype=float) for r in b.loc[k, "poincare_state"]])
                if "poincare_state" in b.columns else np.zeros((0, 0)) for b in (up, down)]
        ok = all(r.ndim == 2 and r.size and np.all(np.isfinite(r)) for r in recs)
        same.append(len(group_records(recs)) == 1 if ok else None)
    out["same_attractor"] = same
    return out.reset_index()

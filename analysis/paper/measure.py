"""Run a paper item's simulations (:mod:`analysis.paper.runs`) and collect one table row per run.

Classified runs go through the regime pipeline's own stages and store
(:mod:`analysis.pipeline.stages`): the same reference run, Lyapunov estimates and classifier as
a regime map, so a paper verdict and a map cell at the same parameters agree by construction.
"""

from __future__ import annotations

import logging
from dataclasses import asdict

import numpy as np
import pandas as pd

from analysis.paper.runs import PaperRun
from analysis.pipeline.config import Numerics, as_numerics
from analysis.pipeline.grid import point_id
from analysis.pipeline.stages import (
    classify_points,
    lle_resolution,
    lyapunov_points,
    reference_run,
    simulate_points,
)

__all__ = ["measure_runs", "dense_history", "drawn"]

log = logging.getLogger("paper")

#: columns copied from the stages' tables to a classified run's row
_STAGE_COLUMNS = ("label", "period", "reason", "lle_mean", "lle_stefanski", "lle_benettin", "omega", "Omega",
                  "f0",
                  "f_cr", "diverged", "slipped", "t_first_slip", "stick_fraction", "poincare_tip")


def dense_history(params: dict, numerics: Numerics, n_transient: int, n_record: int,
                  samples_per_period: int, n_show: int | None = None, start=None) -> dict:
    """Dense tip history of one point: ``t``, ``w``, ``u1``, ``u2`` (tip radial and
    circumferential displacements of both layers, units R) and their velocities (central
    differences of the dense samples), over the last ``n_show`` periods (all when None).  Same
    integrator as the point's reference run (a fixed step count is rounded up to a multiple of
    ``samples_per_period``).  ``start``: a state to start from (a reference run's
    ``final_state``: the forcing is periodic and runs end on period boundaries, so the history
    continues that run, up to the integrator's switch-location tolerance)."""
    if start is not None:
        from beamsim.point import prepare_point
        from beamsim.simulate import state_params

        params = state_params(params, start, prepare_point(**params).model.n)

    spp = numerics.steps_per_period
    if spp is not None:
        spp = max(samples_per_period, int(np.ceil(spp / samples_per_period) * samples_per_period))
    r = reference_run(params, numerics, n_transient=n_transient, n_record=n_record, steps_per_period=spp,
                      dense_per_period=samples_per_period)
    t = r.dense_t
    first = 0 if n_show is None else max(0, len(t) - n_show * samples_per_period - 1)
    keep = slice(first, len(t))
    out = {"t": t[keep].tolist(), "period_T": 2.0 * np.pi / r.omega}
    for j, name in enumerate(("w", "u1", "u2")):
        x = r.dense[:, j]
        out[name] = x[keep].tolist()
        out[name + "_dot"] = np.gradient(x, t)[keep].tolist()
    return out


def _classified(runs: list[PaperRun], nm: Numerics, store_root: str, threads: int) -> list[dict]:
    points, seen = [], set()
    ids = [point_id(r.params, nm) for r in runs]
    for pid, r in zip(ids, runs):
        if pid not in seen:
            seen.add(pid)
            points.append({"point_id": pid, "params": r.params})
    # one batch per integrator and state size, as the regime chunks do
    sim = simulate_points(points, nm, store_root, threads=threads)
    lyap = lyapunov_points(points, sim, nm, store_root, threads=threads)
    lab = classify_points(sim, lyap, lle_threshold=lle_resolution(nm))
    table = sim.merge(lyap, on="point_id").merge(lab, on="point_id").set_index("point_id")
    rows = []
    for pid in ids:
        t = table.loc[pid]
        row = {"point_id": pid} | {c: t[c] for c in _STAGE_COLUMNS}
        T = 2.0 * np.pi / float(t["omega"])
        row["lle_T"] = float(t["lle_mean"]) * T
        row["lle_lo_T"] = float(t["lle_lo"]) * T
        row["lle_hi_T"] = float(t["lle_hi"]) * T
        row["lle_stefanski_T"] = float(t["lle_stefanski"]) * T
        row["period"] = None if pd.isna(t["period"]) else int(t["period"])
        row["final_state"] = t["final_state"]
        rows.append(row)
    return rows


def measure_runs(runs: list[PaperRun], numerics: Numerics | dict, store_root: str, *, threads: int = 1,
                 samples_per_period: int = 64, n_show: int = 30) -> pd.DataFrame:
    """One row per run, in the runs' order: the run's description (item, case, law, kind,
    f0_paper, anchor, ratio, its load ``f0_rel``, all its parameters as JSON) and what it
    measured.

    classified : label, period, reason, ``lle_T`` (``lambda_1`` per forcing period, the block
        mean of the long Benettin record: the classifier's input) with its confidence interval
        ``lle_lo_T``, ``lle_hi_T``, the Stefanski cross-check ``lle_stefanski_T``, slip indicators,
        Poincare tip samples; with
        ``draw``, the dense history of ``n_show`` periods continuing the reference run.
    history : the dense history from rest over ``extra['n_periods']`` periods.
    transient : Poincare tip samples from rest over ``extra['n_periods']`` periods.
    """
    from analysis.pipeline.grid import canonical_json

    nm = as_numerics(numerics)
    rows = []
    for r in runs:
        d = asdict(r)
        params = d.pop("params")
        extra = d.pop("extra")
        rows.append(d | {"params_json": canonical_json(params), "f0_rel": params.get("f0_rel", np.nan)}
                    | extra)
    cls = [i for i, r in enumerate(runs) if r.kind == "classified"]
    if cls:
        for i, rec in zip(cls, _classified([runs[i] for i in cls], nm, store_root, threads)):
            rows[i].update(rec)
    for i, r in enumerate(runs):
        if r.kind == "classified" and r.draw:
            if not rows[i]["diverged"]:
                rows[i].update(dense_history(r.params, nm, 0, n_show, samples_per_period,
                                             start=rows[i]["final_state"]))
        elif r.kind == "history":
            rows[i].update(dense_history(r.params, nm, 0, r.extra["n_periods"], samples_per_period))
        elif r.kind == "transient":
            res = reference_run(r.params, nm, n_transient=0, n_record=r.extra["n_periods"],
                                steps_per_period=nm.steps_per_period)
            rows[i].update(poincare_tip=res.poincare_tip.tolist(), omega=res.omega, f0=res.f0, f_cr=res.f_cr,
                           slipped=res.slipped)
        log.info("paper %s: run %d / %d done (%s, %s, %s)", r.item, i + 1, len(runs), r.kind, r.case, r.law)
    for row in rows:
        row.pop("final_state", None)
    table = pd.DataFrame(rows)
    if "period" in table:
        table["period"] = table["period"].astype("Int64")
    return table


def drawn(table: pd.DataFrame) -> pd.DataFrame:
    """The rows that hold a dense history (drawn runs that did not diverge)."""
    if "t" not in table:
        return table.iloc[:0]
    return table[table["draw"].astype(bool) & table["t"].notna()]



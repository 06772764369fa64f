r"""Multistability of a regime map: every cell run from several initial states, its attractors
counted and labelled.

A map runs each point from rest; the beam with dry friction is hysteretic and multistable, so a
cell may hold other attractors than the one the start from rest finds.  :func:`cell_attractors`
re-runs cells of a finished map (a seeded sample stratified by label, or every cell) from

* the end states of its neighbours on the grid, along each axis and in both directions (the
  neighbour's full state from its own start from rest: coordinates, velocities, Jenkins slips
  and stick flags, so the restart is exact: one step of a continuation up and down each axis);
* ``perturbations`` seeded random states (:func:`analysis.multistability.perturbed_starts`,
  seeded by the config's seed and the cell's grid index, so independent of the table's order
  and of the number of cores),
* with ``locked``, the locked orbit (:func:`beamsim.shakedown.locked_orbit`: every element
  stuck, the slips where the mean tractions vanish) where the cell's load is below its lock-up
  limit (``lock_ratio`` below 1) and the map's own run slips (``stick_fraction`` below 1), so
  that the locked attractor the linear analysis proves is found, grouped and labelled by the
  same runs as any other.  (Locked orbits form a family, one per set of locked slips; where
  the map's run is itself locked, another member of the family would count as a second
  attractor that differs only in the slips locked in, so none is started there.)

with the map's own numerics and stages (adaptive transient, classifier; the per-point store
caches every run under an id that contains its initial state).  A run that diverged, or whose
record is still a transient at the adaptive transient's cap, reaches no attractor that could be
named, and is reported as such.  The settled records of a cell, the map's own first, are grouped
by attractor (:func:`analysis.attractors.group_records`); the group holding the start from rest
keeps the map's label, every other group gets its own Lyapunov run and label through the same
stages (:func:`analysis.pipeline.stages.lyapunov_points`, :func:`~analysis.pipeline.stages.classify_points`).

The result (:func:`cell_attractors`) is one row per cell and attractor; a cell is
``multistable`` when it has two or more attractors, and its ``n_regimes`` says whether they differ
in regime (e.g. a periodic orbit beside a chaotic attractor) or only as orbits (two period-1
orbits with different slip locked into stuck elements).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from analysis.pipeline.config import Numerics, as_numerics, check_keys
from analysis.regimes import CHAOTIC, PERIODIC, QUASI_PERIODIC

__all__ = ["MultistabilitySettings", "cell_attractors", "cell_starts", "cell_summary", "locked_start",
           "summary_line", "write_attractor_table"]

#: name of the map's own start
REST = "rest"

#: name of the start on the locked orbit (:func:`locked_start`)
LOCKED = "locked"

#: labels that are verdicts on a regime (an ``undetermined`` attractor differs from none)
VERDICTS = (PERIODIC, QUASI_PERIODIC, CHAOTIC)


@dataclass(frozen=True)
class MultistabilitySettings:
    """The ``multistability`` section of the config.

    sample : cells of each grid run from the other starts: an integer (a seeded sample,
        stratified by label like the convergence sample,
        :func:`analysis.pipeline.convergence.sample_points`; 0: none) or ``"all"``.
    neighbours : start a cell from the end states of its grid neighbours (both directions
        along each axis).
    perturbations : seeded random starts per cell (0: none).
    amplitude : their size in units of the point's forced-response scale.
    locked : start a cell below its lock-up limit from its locked orbit
        (:func:`beamsim.shakedown.locked_orbit`; elastic stick only).
    seed : seed of the sample and of the random starts (combined with the cell's grid index).
    """

    sample: int | str = 40
    neighbours: bool = True
    perturbations: int = 1
    amplitude: float = 0.3
    locked: bool = True
    seed: int = 0

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> MultistabilitySettings:
        d = dict(d or {})
        check_keys("multistability", d, [f.name for f in fields(cls)])
        out = cls(**d)
        if not (out.sample == "all" or (isinstance(out.sample, int) and not isinstance(out.sample, bool)
                                        and out.sample >= 0)):
            raise ValueError(f"multistability.sample = {out.sample!r}; allowed: an integer >= 0 or 'all'")
        for key in ("neighbours", "locked"):
            if not isinstance(getattr(out, key), bool):
                raise ValueError(f"multistability.{key} = {getattr(out, key)!r}; allowed: true or false")
        if not (isinstance(out.perturbations, int) and not isinstance(out.perturbations, bool)
                and 0 <= out.perturbations <= 16):
            raise ValueError(f"multistability.perturbations = {out.perturbations!r}; "
                             "allowed: an integer 0..16")
        if not (isinstance(out.amplitude, (int, float)) and 0.0 < out.amplitude <= 10.0):
            raise ValueError(f"multistability.amplitude = {out.amplitude!r}; allowed: 0 < amplitude <= 10")
        if not (isinstance(out.seed, int) and not isinstance(out.seed, bool) and out.seed >= 0):
            raise ValueError(f"multistability.seed = {out.seed!r}; allowed: an integer >= 0")
        return out

    @property
    def active(self) -> bool:
        """Whether any cell is run from any start besides rest."""
        return self.sample != 0 and (self.neighbours or self.perturbations > 0 or self.locked)

    def n_cells(self, n_points: int) -> int:
        """Cells run from the other starts in a grid of ``n_points`` (0 when not active)."""
        if not self.active:
            return 0
        return n_points if self.sample == "all" else min(int(self.sample), n_points)

    def as_dict(self) -> dict:
        return {"sample": self.sample, "neighbours": self.neighbours, "perturbations": self.perturbations,
                "amplitude": self.amplitude, "locked": self.locked, "seed": self.seed}

    def starts_per_cell(self, n_axes: int) -> int:
        """The most extra starts of one cell (an edge cell has fewer neighbours; a cell above
        its lock-up limit has no locked start)."""
        return (2 * n_axes if self.neighbours else 0) + self.perturbations + int(self.locked)


def cell_starts(table: pd.DataFrame, final_states: Mapping[str, Sequence[float]],
                settings: MultistabilitySettings, axes: Sequence[str],
                cells: pd.DataFrame | None = None) -> dict[str, list[tuple[str, dict]]]:
    """The extra starts of the ``cells`` (rows of ``table``; default: all) of a regime table
    (``point_id``, ``params_json``, ``index_0``, ... columns), in a fixed order: the neighbours'
    end states (``final_states``: point id -> the full end state of its start from rest),
    ``<axis>-`` from the lower and ``<axis>+`` from the higher neighbour along each axis in axis
    order, then ``perturbed<k>``, then ``locked`` (with ``settings.locked``, where the map's
    row says that its run slips, ``stick_fraction`` below 1, the law is the elastic stick and
    the load is below the lock-up limit: :func:`locked_start`).
    A neighbour of another state layout (``n_modes`` or ``n_quad`` as an axis) or, with the
    elastic stick, of another ``k_t`` starts the cell from its end state carried into the
    cell's model (:func:`beamsim.state_transfer.transfer_state`: the displacement fields
    projected onto the cell's basis, every element's traction kept; law ``stick-slip``); one
    whose end state is not finite, does not fit its own model, is of another beam (``beta`` or
    a thickness as an axis with another layout) or of another law is left out, as is every
    neighbour of a cell whose own end state does not fit its model.
    Returns point id -> ``[(name, initial-state parameters), ...]``."""
    import json

    from analysis.continuation import state_params
    from analysis.multistability import perturbed_starts
    from analysis.pipeline.table import index_columns
    from beamsim.simulate import prepare_point

    idx_cols = index_columns(table)
    if len(idx_cols) != len(axes):
        raise ValueError(f"cell_starts: {len(axes)} axes but index columns {idx_cols}")
    by_index = {tuple(int(v) for v in row[idx_cols]): row["point_id"] for _, row in table.iterrows()}
    params_of = dict(zip(table["point_id"], table["params_json"]))
    out: dict[str, list[tuple[str, dict]]] = {}
    for _, row in (table if cells is None else cells).iterrows():
        pid = row["point_id"]
        params = json.loads(row["params_json"])
        index = tuple(int(v) for v in row[idx_cols])
        own = np.asarray(final_states.get(pid, ()), dtype=float)
        starts: list[tuple[str, dict]] = []
        if settings.neighbours:
            model = prepare_point(**params).model
            for k, axis in enumerate(axes):
                for step, sign in ((-1, "-"), (1, "+")):
                    nb = index[:k] + (index[k] + step,) + index[k + 1:]
                    if nb not in by_index:
                        continue
                    fs = np.asarray(final_states.get(by_index[nb], ()), dtype=float)
                    nb_params = json.loads(params_of[by_index[nb]])
                    if fs.size != own.size or nb_params.get("k_t") != params.get("k_t"):
                        fs = _carried(fs, nb_params, model)
                        if fs is None or fs.size != own.size:
                            continue
                    state = state_params(fs, model.n, model.n_quad)
                    if state:
                        starts.append((f"{axis}{sign}", state))
        for k, s in enumerate(perturbed_starts(params, settings.perturbations, seed=[settings.seed, *index],
                                               amplitude=settings.amplitude)):
            starts.append((f"perturbed{k}", s))
        slips = float(row.get("stick_fraction", np.nan)) < 1.0  # NaN (unknown): no
        if settings.locked and slips and (locked := locked_start(params)):
            starts.append((LOCKED, locked))
        out[pid] = starts
    return out


def _carried(state: np.ndarray, params: dict, model) -> np.ndarray | None:
    """A neighbour's end ``state`` (of the point ``params``) carried into ``model`` where it
    must be (:func:`analysis.continuation.carries`: another layout, or the elastic stick's
    other ``k_t``), the state itself where it need not, or ``None`` where it cannot be: not of
    its own model's size, of another beam, or of a law other than the elastic stick
    (:func:`~beamsim.state_transfer.transfer_state`); a state that is not finite comes back so
    (``state_params`` then gives no start)."""
    from analysis.continuation import carried_state, carries
    from beamsim.simulate import prepare_point

    src = prepare_point(**params).model
    law = params.get("law", "stick-slip")
    if state.size != 2 * src.n + 2 * src.n_quad:
        return None
    if not carries(src, model, law):
        return state
    try:
        return carried_state(state, src, model, law)
    except ValueError:  # another beam or law
        return None


def locked_start(params: dict) -> dict:
    """The initial-state parameters of a point's locked orbit
    (:func:`beamsim.shakedown.locked_orbit`) where its law is the elastic stick and the orbit
    never slips (``lock_ratio`` below 1); ``{}`` otherwise."""
    from analysis.continuation import state_params
    from analysis.pipeline.stages import point_locked_orbit

    found = point_locked_orbit(params)
    if found is None or not np.max(found[1].ratio) < 1.0:
        return {}
    pp, orbit = found
    return state_params(orbit.state, pp.model.n, pp.model.n_quad)


def _num(value) -> float:
    return np.nan if value is None or pd.isna(value) else float(value)


def cell_attractors(table: pd.DataFrame, simulated: pd.DataFrame, numerics: Numerics | dict,
                    settings: MultistabilitySettings, store_root: str, axes: Sequence[str] = (),
                    threads: int = 1) -> pd.DataFrame:
    """The attractors of the map's cells (all, or the sample of ``settings.sample``; module
    docstring).

    table : the map's regime table; simulated : its simulate-stage records (``point_id``,
        ``poincare_state``, ``final_state``, ``diverged``).
    Returns one row per cell and attractor, cells in the table's order, attractors in order of
    first appearance (attractor 0 is the map's own unless the map's run is ``diverged`` or
    ``unsettled``), then a row per verdict for the starts that reached no attractor; with
    ``weight`` (the cell's stratum weight in the sample, 1 with ``sample: all``), ``point_id``,
    the ``axes`` values, ``attractor``
    (0, 1, ...; missing for the row collecting starts that ``diverged`` or stayed ``unsettled``),
    ``starts`` (names, :func:`cell_starts`), ``label``, ``period``, ``label_text``, ``lle_T``,
    ``lle_lo_T``, ``lle_hi_T`` (per forcing period), ``reason``, ``run_id`` (the representative
    run's id in the store), ``poincare_w_tip`` (its tip's radial displacement at ``t = kT``),
    ``n_starts``, ``n_attractors``, ``n_regimes`` (distinct verdicts among the attractors:
    periodic-m, quasi-periodic, chaotic; ``undetermined`` is no verdict) and ``multistable``."""
    from analysis.pipeline.convergence import sample_points

    nm = as_numerics(numerics)
    if not settings.active:
        return pd.DataFrame()
    if settings.sample == "all":
        cells = table.assign(weight=1.0)
    else:
        cells = sample_points(table, int(settings.sample), settings.seed)
    sim_rest = simulated.set_index("point_id")
    finals = {pid: sim_rest.loc[pid, "final_state"] for pid in table["point_id"] if pid in sim_rest.index}
    runs, sim = _run_starts(cells, cell_starts(table, finals, settings, axes, cells), nm, store_root, threads)
    grouped = [_group_cell(row, runs[row["point_id"]], sim_rest, sim) for _, row in cells.iterrows()]
    labels = _label_new_attractors(grouped, sim, nm, store_root, threads)
    res = pd.DataFrame([r for cell in grouped for r in _cell_rows(cell, labels, axes)])
    res["attractor"] = res["attractor"].astype("Int64")
    res["period"] = res["period"].astype("Int64")
    return res


class _Cell(NamedTuple):
    """One cell's runs: the map's row, start names, run ids, parameters and simulate records
    (the start from rest first), each run's status (``None``: on an attractor, else
    ``diverged`` / ``unsettled``) and the groups of settled runs (indices into the lists)."""

    row: pd.Series
    names: list[str]
    ids: list[str]
    params: list[dict]
    recs: list[pd.Series]
    status: list[str | None]
    groups: list[list[int]]


def _run_starts(cells: pd.DataFrame, starts: Mapping[str, list[tuple[str, dict]]], nm: Numerics,
                store_root: str, threads: int) -> tuple[dict, pd.DataFrame | None]:
    """Every start of every cell through the simulate stage in one pass (the store caches each
    run under an id that contains its initial state).  Returns point id -> ``[(name, run id,
    parameters), ...]`` and the simulate records indexed by run id."""
    import json

    from analysis.pipeline.grid import point_id
    from analysis.pipeline.stages import simulate_points

    runs: dict[str, list[tuple[str, str, dict]]] = {}
    pts = []
    for _, row in cells.iterrows():
        params = json.loads(row["params_json"])
        runs[row["point_id"]] = []
        for name, state in starts[row["point_id"]]:
            p = params | {k: np.asarray(v, dtype=float).tolist() for k, v in state.items()}
            rid = point_id(p, nm)
            runs[row["point_id"]].append((name, rid, p))
            pts.append({"point_id": rid, "params": p})
    sim = simulate_points(pts, nm, store_root, threads).set_index("point_id") if pts else None
    return runs, sim


def _status(rec: pd.Series) -> str | None:
    """``None`` for a record on an attractor, else the label saying why not."""
    from analysis.pipeline.stages import poincare_array, unsettled_reason
    from analysis.regimes import DIVERGED, UNSETTLED

    x = poincare_array(rec["poincare_state"])
    if rec["diverged"] or not np.all(np.isfinite(x)):
        return DIVERGED
    return UNSETTLED if unsettled_reason(rec) is not None else None


def _group_cell(row: pd.Series, runs: list[tuple[str, str, dict]], sim_rest: pd.DataFrame,
                sim: pd.DataFrame | None) -> _Cell:
    """Group a cell's settled records by attractor, the map's own run first (its verdict
    ``diverged`` / ``unsettled`` stands)."""
    import json

    from analysis.attractors import group_records
    from analysis.pipeline.stages import poincare_array
    from analysis.regimes import DIVERGED, UNSETTLED

    pid = row["point_id"]
    recs = [sim_rest.loc[pid]] + [sim.loc[rid] for _, rid, _ in runs]
    status = [_status(r) for r in recs]
    if row["label"] in (DIVERGED, UNSETTLED):
        status[0] = row["label"]
    ok = [k for k, s in enumerate(status) if s is None]
    settled = [poincare_array(recs[k]["poincare_state"]) for k in ok]
    groups = [[ok[i] for i in g] for g in group_records(settled)] if ok else []
    return _Cell(row, [REST] + [name for name, _, _ in runs], [pid] + [rid for _, rid, _ in runs],
                 [json.loads(row["params_json"])] + [p for _, _, p in runs], recs, status, groups)


def _label_new_attractors(cells: Sequence[_Cell], sim: pd.DataFrame | None, nm: Numerics, store_root: str,
                          threads: int) -> dict:
    """Lyapunov and classifier stages for one representative (the first run) of every group
    without the map's own run.  Returns run id -> its classified row with ``lle_*``."""
    from analysis.pipeline.stages import classify_points, lle_resolution, lyapunov_points

    reps: dict[str, dict] = {}
    for c in cells:
        for g in c.groups:
            if 0 not in g:
                reps.setdefault(c.ids[g[0]], {"point_id": c.ids[g[0]], "params": c.params[g[0]]})
    if not reps:
        return {}
    rep_pts = list(reps.values())
    rep_sim = sim.loc[[p["point_id"] for p in rep_pts]].reset_index()
    lyap = lyapunov_points(rep_pts, rep_sim, nm, store_root, threads)
    cls = classify_points(rep_sim, lyap, lle_threshold=lle_resolution(nm))
    merged = cls.merge(lyap[["point_id", "lle_mean", "lle_lo", "lle_hi"]], on="point_id")
    return {m["point_id"]: m for _, m in merged.iterrows()}


def _cell_rows(cell: _Cell, labels: Mapping[str, pd.Series], axes: Sequence[str]) -> list[dict]:
    """The table rows of one cell (:func:`cell_attractors`)."""
    from analysis.pipeline.convergence import label_text
    from analysis.pipeline.stages import poincare_array
    from analysis.regimes import DIVERGED, UNSETTLED

    row, names, ids = cell.row, cell.names, cell.ids
    period_t = 2.0 * np.pi / float(row["omega"])
    base = {"point_id": row["point_id"]} | {a: row[a] for a in axes} | {"weight": float(row["weight"])}
    rows = []
    for a, g in enumerate(cell.groups):
        lab = row if 0 in g else labels[ids[g[0]]]  # the map's own attractor keeps its label
        rows.append(base | {
            "attractor": a, "starts": [names[k] for k in g], "label": lab["label"],
            "period": lab["period"], "label_text": label_text(lab["label"], lab["period"]),
            "lle_T": _num(lab["lle_mean"]) * period_t, "lle_lo_T": _num(lab["lle_lo"]) * period_t,
            "lle_hi_T": _num(lab["lle_hi"]) * period_t, "reason": lab["reason"], "run_id": ids[g[0]],
            "poincare_w_tip": poincare_array(cell.recs[g[0]]["poincare_tip"])[:, 0].tolist()})
    for verdict in (UNSETTLED, DIVERGED):
        left = [k for k, s in enumerate(cell.status) if s == verdict]
        if left:
            rows.append(base | {
                "attractor": None, "starts": [names[k] for k in left], "label": verdict, "period": None,
                "label_text": verdict, "lle_T": np.nan, "lle_lo_T": np.nan, "lle_hi_T": np.nan,
                "reason": ("integration diverged" if verdict == DIVERGED
                           else "record still a transient at the adaptive transient's cap (its own tests "
                                 "or the continuation check)"),
                "run_id": ids[left[0]], "poincare_w_tip": None})
    regimes = {r["label_text"] for r in rows if r["attractor"] is not None and r["label"] in VERDICTS}
    for r in rows:
        r.update(n_starts=len(names), n_attractors=len(cell.groups), n_regimes=len(regimes),
                 multistable=len(cell.groups) > 1)
    return rows


def cell_summary(attractors: pd.DataFrame) -> pd.DataFrame:
    """One row per cell run from other starts (table order): ``point_id``, ``weight``,
    ``n_starts``, ``n_attractors``, ``n_regimes``, ``multistable`` and ``labels`` (the
    attractors' label texts, the map's first)."""
    rows = []
    if attractors is None or attractors.empty:
        return pd.DataFrame(rows)
    for pid, g in attractors.groupby("point_id", sort=False):
        att = g[g["attractor"].notna()]
        first = g.iloc[0]
        rows.append({"point_id": pid, "weight": float(first["weight"]), "n_starts": int(first["n_starts"]),
                     "n_attractors": int(first["n_attractors"]), "n_regimes": int(first["n_regimes"]),
                     "multistable": bool(first["multistable"]), "labels": list(att["label_text"])})
    return pd.DataFrame(rows)


def summary_line(summary: pd.DataFrame | None) -> str:
    """One line for a map's title: the cells run from other starts that hold more than one
    attractor, and the map-weighted estimate of that fraction when the cells are a sample."""
    if summary is None or summary.empty:
        return "cells not run from other initial states (multistability off)"
    n = len(summary)
    multi = int(summary["multistable"].sum())
    regimes = int((summary["n_regimes"] > 1).sum())
    w = summary["weight"].to_numpy(dtype=float)
    share = float(np.sum(w * summary["multistable"].to_numpy(dtype=float)) / np.sum(w))
    return (f"other starts: {multi}/{n} cells multistable (hatched; map estimate {100 * share:.0f} %), "
            f"{regimes} with two regimes (cross-hatched)")


def write_attractor_table(attractors: pd.DataFrame, path: str, *, grid_name: str, settings: dict,
                          config_hash: str) -> None:
    """Write the attractor table to Parquet (atomically) with ``beamsim.attractors`` metadata
    (:func:`analysis.pipeline.convergence.run_metadata`)."""
    from analysis.pipeline.atomic import write_parquet
    from analysis.pipeline.convergence import run_metadata

    meta = run_metadata(grid_name, settings, config_hash)
    write_parquet(attractors, path, metadata={"beamsim.attractors": meta})

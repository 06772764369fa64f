r"""Lifetimes of a map's chaos (and tori) below the lock-up limit: attractor or long transient?

Below a cell's lock-up limit (``lock_ratio`` < 1) a locked period-1 orbit exists beside
whatever the start from rest reached (:func:`beamsim.shakedown.locked_orbit`, docs/model.md
section 7); above the shakedown limit a motion may still slip for ever.  So a chaotic record
there may be a chaotic attractor or a chaotic saddle that the beam leaves, after a random
time, for a locked orbit.  One run cannot tell the two apart; many can.
:func:`chaos_lifetimes` runs ``copies`` copies of every such cell (by default its chaotic,
undetermined and quasi-periodic ones: an undetermined record is broadband or has an exponent
interval across the margin, and can be a transient as well; a torus there can be a slow
approach to the locked orbit) from the map's end state, each perturbed by a
seeded random ``perturbation`` (relative to the largest coordinate and velocity), for
``periods`` forcing periods with the map's integrator and step, and records per copy

* the period after which it never slipped again (no friction dissipation in any later
  period), and whether the stuck state at the end is **proven** to last (the bound of
  :func:`analysis.pipeline.stages.stuck_bound` below 1): then the copy **escaped** to a locked
  orbit at that time;
* otherwise its censoring time: the run's end if it still slips there, the start of its
  final stuck stretch if that stretch is not proven to last (``n_unproven``).

Copies that diverged or met ``expo``'s Zeno guard are left out and counted (``n_failed``).
The mean lifetime follows from the escape and censoring times
(:func:`analysis.lifetimes.exponential_lifetime`: escape rate, mean lifetime and its 95 %
interval in forcing periods; with no escape, a lower bound).  Copies are independent only once
their perturbations have grown to the attractor's size, after :func:`decorrelation_periods`
(from the lower end of the map's exponent interval); until then they are one trajectory.  So
the first copy counts from the start and every other one only after that time (left
truncation; none of them where that end is not above zero, as at a torus, whose copies never
decorrelate, or at an undetermined record).  The table's
``decorrelation`` and ``n_counted`` say which.

What it does not measure: escapes to another slipping attractor (a copy that leaves the
chaotic set for a slipping periodic orbit is counted as surviving), and lifetimes of chaos
above the lock-up limit, where no locked orbit exists.  Deterministic: the perturbations are
seeded by the settings' seed and the cell's grid index, and each copy's run depends on its own
start only (not on the number of threads).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from analysis.lifetimes import exponential_lifetime
from analysis.pipeline.config import Numerics, as_numerics, check_keys
from analysis.regimes import CHAOTIC, QUASI_PERIODIC, UNDETERMINED, UNSETTLED
from analysis.regimes import LABELS as REGIME_LABELS

__all__ = ["LifetimeGroups", "LifetimeSettings", "chaos_lifetimes", "copy_starts", "copy_outcome",
           "decorrelation_periods", "group_text", "lifetime_cells", "lifetime_groups", "lifetime_range",
           "summary_line", "write_lifetime_table"]

#: labels a setting may name (the classifier's, and a record still transient at the cap)
LABELS = (*REGIME_LABELS, UNSETTLED)


@dataclass(frozen=True)
class LifetimeSettings:
    """The ``lifetimes`` section of the config.

    labels : the map labels whose cells below the lock-up limit are run (default: chaotic,
        undetermined and quasi-periodic: the motions that look chaotic, and the tori, which
        can be slow approaches to a locked orbit; chaotic alone until 2026-11-29).
    copies : perturbed copies per cell (0: the step is off).
    periods : forcing periods each copy runs.
    perturbation : size of the perturbation, relative to the largest coordinate and the
        largest velocity of the map's end state.
    max_cells : at most this many cells per grid (the first in grid order).
    seed : seed of the perturbations (combined with the cell's grid index).
    """

    labels: tuple[str, ...] = (CHAOTIC, UNDETERMINED, QUASI_PERIODIC)
    copies: int = 8
    periods: int = 2000
    perturbation: float = 1e-6
    max_cells: int = 40
    seed: int = 0

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> LifetimeSettings:
        d = dict(d or {})
        check_keys("lifetimes", d, [f.name for f in fields(cls)])
        labels = d.pop("labels", list(cls.labels))
        if (not isinstance(labels, (list, tuple)) or not labels
                or any(lab not in LABELS for lab in labels)):
            raise ValueError(f"lifetimes.labels = {labels!r}; allowed: a non-empty list of {list(LABELS)}")
        out = cls(labels=tuple(labels), **d)
        for key, lo, hi in (("copies", 0, 256), ("periods", 1, 10**6), ("max_cells", 1, 10**5),
                            ("seed", 0, 2**32 - 1)):
            v = getattr(out, key)
            if not (isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi):
                raise ValueError(f"lifetimes.{key} = {v!r}; allowed: an integer {lo}..{hi}")
        p = out.perturbation
        if not (isinstance(p, (int, float)) and not isinstance(p, bool) and 0.0 < p <= 0.1):
            raise ValueError(f"lifetimes.perturbation = {p!r}; allowed: 0 < perturbation <= 0.1")
        return out

    @property
    def active(self) -> bool:
        """Whether any copy runs."""
        return self.copies > 0

    def as_dict(self) -> dict:
        return {"labels": list(self.labels), "copies": self.copies, "periods": self.periods,
                "perturbation": self.perturbation, "max_cells": self.max_cells, "seed": self.seed}


def lifetime_cells(table: pd.DataFrame, settings: LifetimeSettings) -> pd.DataFrame:
    """The rows of a regime table whose cells are run: a label of ``settings.labels``, below the
    lock-up limit (``lock_ratio`` < 1), a run that slips (``stick_fraction`` < 1) and did not
    diverge; the first ``settings.max_cells`` in grid order."""
    lock = pd.to_numeric(table["lock_ratio"], errors="coerce")
    slips = pd.to_numeric(table["stick_fraction"], errors="coerce") < 1.0
    keep = table["label"].isin(settings.labels) & (lock < 1.0) & slips & ~table["diverged"].astype(bool)
    return table[keep].head(settings.max_cells)


def copy_starts(params: dict, final_state: Sequence[float], index: Sequence[int],
                settings: LifetimeSettings) -> list[dict]:
    """``settings.copies`` point parameter dicts started from ``final_state`` (the map's end
    state, kernels' layout ``(q, v, z, mode)``), coordinates and velocities perturbed by
    ``perturbation`` times their largest magnitude times a standard normal draw (seeded by
    ``settings.seed`` and the grid ``index``); slips and stick flags unchanged."""
    from beamsim.simulate import prepare_point, state_params

    x0 = np.asarray(final_state, dtype=float)
    n = prepare_point(**params).model.n
    rng = np.random.default_rng([settings.seed, *(int(i) for i in index)])
    sq, sv = float(np.abs(x0[:n]).max()), float(np.abs(x0[n:2 * n]).max())
    out = []
    for _ in range(settings.copies):
        x = x0.copy()
        x[:n] += settings.perturbation * sq * rng.standard_normal(n)
        x[n:2 * n] += settings.perturbation * sv * rng.standard_normal(n)
        out.append(state_params(params, x, n))
    return out


def copy_outcome(result, pp) -> tuple[str, float]:
    """One copy's run (a :class:`beamsim.results.SimResult` started at ``t = 0``; ``pp`` its
    cell's :class:`beamsim.point.PreparedPoint`): ``("escaped", t)`` if it does no friction work
    in any period after the first ``t`` (``t`` = 0: none at all) and its end state, every element
    stuck, is proven to stay stuck (:func:`analysis.pipeline.stages.stuck_bound` below 1);
    ``("unproven", t)`` if it does no friction work after ``t`` but the proof fails;
    ``("slipping", N)`` if it does in its last period (``N`` its periods); ``("failed", nan)``
    if it diverged or met ``expo``'s Zeno guard.  The friction work per period is the difference
    of the run's cumulative friction dissipation, so a slip whose work is below that sum's
    rounding is not seen; the end state's flags and its bound are what prove the lock."""
    from analysis.pipeline.stages import stuck_bound

    if result.diverged or result.n_zeno > 0 or not np.all(np.isfinite(result.energy[:, 1])):
        return "failed", np.nan
    diss = result.diss_per_cycle
    slipping = np.flatnonzero(diss != 0.0)
    quiet = int(slipping[-1]) + 1 if slipping.size else 0
    if quiet >= diss.size:
        return "slipping", float(diss.size)
    x = np.asarray(result.final_state, dtype=float)
    stuck = not np.any(x[2 * pp.model.n + pp.model.n_quad:])  # every element's flag 0 (stuck)
    return ("escaped" if stuck and stuck_bound(pp, x) < 1.0 else "unproven"), float(quiet)


def decorrelation_periods(lle_lo_T: float, perturbation: float) -> float:
    """Forcing periods after which copies perturbed by ``perturbation`` (relative to the
    largest coordinate and velocity, about the attractor's size) have decorrelated:
    ``ceil(ln(1 / perturbation) / lle_lo_T)``, with ``lle_lo_T`` the lower end of the map's
    95 % interval of ``lambda_1 T`` (per forcing period; the slowest growth the record allows);
    ``inf`` where it is not positive or not known (a regular or neutral motion, a torus, an
    undetermined record: its copies need not part at an exponential rate, and count as one
    trajectory)."""
    if not (np.isfinite(lle_lo_T) and lle_lo_T > 0.0):
        return np.inf
    return float(np.ceil(np.log(1.0 / perturbation) / lle_lo_T))


def _cell_row(row: pd.Series, outcomes: list[tuple[str, float]], axes: Sequence[str],
              settings: LifetimeSettings, method: str) -> dict:
    kinds = [k for k, _ in outcomes]
    used = [(k, t) for k, t in outcomes if k != "failed"]
    T = 2.0 * np.pi / float(row["omega"])
    lle_T = float(row["lle_mean"]) * T
    t_dec = decorrelation_periods(float(row.get("lle_lo", np.nan)) * T, settings.perturbation)
    # the first copy that ran counts from the start, the others once they have decorrelated
    est = exponential_lifetime([t for _, t in used], [k == "escaped" for k, _ in used],
                               entries=[0.0] + [t_dec] * (len(used) - 1) if used else [])
    return {"point_id": row["point_id"], **{a: row[a] for a in axes},
            **{c: int(row[c]) for c in row.index if c.startswith("index_")},
            "label": row["label"], "lle_T": lle_T,
            "lock_ratio": float(row["lock_ratio"]), "shakedown_ratio": float(row["shakedown_ratio"]),
            "copies": settings.copies, "periods": settings.periods, "method": method,
            "n_escaped": kinds.count("escaped"), "n_unproven": kinds.count("unproven"),
            "n_failed": kinds.count("failed"), "decorrelation": t_dec, "n_counted": est.n,
            "exposure": est.exposure, "escape_rate": est.rate,
            "lifetime": est.lifetime, "lifetime_lo": est.lifetime_lo, "lifetime_hi": est.lifetime_hi,
            "escape_periods": sorted(int(t) for k, t in used if k == "escaped"),
            "censor_periods": sorted(int(t) for k, t in used if k != "escaped")}


def chaos_lifetimes(table: pd.DataFrame, simulated: pd.DataFrame, numerics: Numerics | dict,
                    settings: LifetimeSettings, axes: Sequence[str], threads: int = 1) -> pd.DataFrame:
    """One row per cell of :func:`lifetime_cells` (grid order): the map's label, ``lle_T``,
    ``lock_ratio``, ``shakedown_ratio``, the copies' outcomes (``n_escaped``, ``n_unproven``,
    ``n_failed``, ``escape_periods``, ``censor_periods``), ``decorrelation`` (periods,
    :func:`decorrelation_periods`), ``n_counted`` (the copies that count: the first, and the
    others that outlast the decorrelation) and the exponential estimate (``exposure``,
    ``escape_rate`` per period, ``lifetime``, ``lifetime_lo``, ``lifetime_hi`` in forcing
    periods; :func:`analysis.lifetimes.exponential_lifetime` with the others left-truncated at
    the decorrelation).

    ``simulated``: the map's simulate records (``point_id``, ``final_state``)."""
    from beamsim.pattern_store import PatternStore
    from beamsim.simulate import prepare_point, simulate_batch

    nm = as_numerics(numerics)
    cells = lifetime_cells(table, settings)
    finals = simulated.set_index("point_id")["final_state"]
    store = PatternStore()
    rows = []
    for _, row in cells.iterrows():
        params = json.loads(row["params_json"])
        index = [row[c] for c in row.index if c.startswith("index_")]
        starts = copy_starts(params, finals.loc[row["point_id"]], index, settings)
        method = _map_integrator(row, nm, params)
        batch = simulate_batch(starts, n_transient=0, n_record=settings.periods, method=method,
                               steps_per_period=nm.steps_per_period, step_factor=nm.step_factor,
                               n_threads=threads, pattern_store=store)
        pp = prepare_point(**params)
        rows.append(_cell_row(row, [copy_outcome(r, pp) for r in batch.results], axes, settings, method))
    columns = ["point_id", *axes, *(c for c in table.columns if c.startswith("index_")), "label", "lle_T",
               "lock_ratio", "shakedown_ratio", "copies", "periods", "method", "n_escaped", "n_unproven",
               "n_failed", "decorrelation", "n_counted", "exposure", "escape_rate", "lifetime", "lifetime_lo",
               "lifetime_hi", "escape_periods", "censor_periods"]
    return pd.DataFrame(rows, columns=columns)


def _map_integrator(row: pd.Series, nm: Numerics, params: dict) -> str:
    """The integrator the map's run of a cell used: RK4 where ``expo`` met its Zeno guard there
    (the table's ``method`` says so), else the configured one."""
    from analysis.pipeline.stages import integrator

    return "rk4" if str(row.get("method", "")).startswith("rk4") else integrator(nm.method, params)


def lifetime_range(lifetimes: pd.Series) -> str:
    """``"lo-hi"`` of finite mean lifetimes rounded to periods, or one number when they round alike."""
    lo, hi = f"{lifetimes.min():.0f}", f"{lifetimes.max():.0f}"
    return lo if lo == hi else f"{lo}-{hi}"


class LifetimeGroups(NamedTuple):
    """The rows of a lifetime table by outcome (:func:`lifetime_groups`)."""

    escaped: pd.DataFrame      #: some copy escaped to a proven locked orbit: a transient
    none: pd.DataFrame         #: no copy proven to escape, some time observed: a lower bound
    unmeasured: pd.DataFrame   #: no time observed (every copy failed, or all escaped at once)


def lifetime_groups(lifetimes: pd.DataFrame) -> LifetimeGroups:
    """Split a lifetime table (:func:`chaos_lifetimes`) by outcome; a cell without a finite
    estimate (``exposure`` 0) is unmeasured whatever its copies did."""
    measured = lifetimes["exposure"].astype(float) > 0
    esc = lifetimes["n_escaped"] > 0
    return LifetimeGroups(lifetimes[measured & esc], lifetimes[measured & ~esc], lifetimes[~measured])


def group_text(groups: LifetimeGroups) -> dict[str, str]:
    """Per non-empty group of :func:`lifetime_groups`, one clause with its count and lifetimes
    (``escaped``: the range of the finite mean lifetimes, and how many have none because no
    copy that counts escaped, :func:`chaos_lifetimes`; ``none``: the least lower bound, how
    many of those cells had copies stuck at the end but not proven to stay so, and the cells
    whose copies do not decorrelate within the run (one trajectory each; their count and least
    bound given apart where there are others)."""
    out = {}
    if len(groups.escaped):
        life = groups.escaped["lifetime"].astype(float)
        finite = life[np.isfinite(life)]
        span = f", mean lifetimes {lifetime_range(finite)} periods" if len(finite) else ""
        n_early = len(life) - len(finite)  # escapes only of copies that had not decorrelated
        early = f"; {n_early} with no escape among the copies counted" if n_early else ""
        out["escaped"] = f"{len(groups.escaped)} with copies proven to end locked (a transient{span}{early})"
    if len(groups.none):
        none = groups.none
        unproven = int((none["n_unproven"] > 0).sum())
        stuck = f"; {unproven} with copies stuck at the end, not proven" if unproven else ""
        # cells whose copies do not decorrelate within the run count one trajectory: their
        # (lower) bounds are given apart, where there are others
        one = (none["decorrelation"] >= none["periods"] if "decorrelation" in none
               else pd.Series(False, index=none.index))
        bound, apart = none, ""
        if one.any() and not one.all():
            bound = none[~one]
            apart = (f"; {int(one.sum())} whose copies do not decorrelate within the run: > "
                     f"{none.loc[one, 'lifetime_lo'].min():.0f}")
        elif one.any():
            apart = "; copies that do not decorrelate within the run"
        out["none"] = (f"{len(none)} without (mean lifetime > {bound['lifetime_lo'].min():.0f} periods"
                       f"{stuck}{apart})")
    if len(groups.unmeasured):
        out["unmeasured"] = f"{len(groups.unmeasured)} not measured (no time observed)"
    return out


def summary_line(lifetimes: pd.DataFrame | None) -> str:
    """One clause for a map's legend or title: the cells run, those whose copies escaped to a
    proven locked orbit (a transient) with their mean lifetimes, the least lower bound on the
    others' (:func:`group_text`)."""
    if lifetimes is None:
        return "lifetimes not measured"
    if lifetimes.empty:
        return "no cell run for its lifetime (none below the lock-up limit with the labels set)"
    parts = group_text(lifetime_groups(lifetimes))
    return f"lifetimes of {len(lifetimes)} cells below the lock-up limit: " + ", ".join(parts.values())


def write_lifetime_table(lifetimes: pd.DataFrame, path: str, *, grid_name: str, settings: dict,
                         config_hash: str) -> None:
    """Write the lifetime table to Parquet (atomically) with ``beamsim.lifetimes`` metadata
    (:func:`analysis.pipeline.convergence.run_metadata`)."""
    from analysis.pipeline.atomic import write_parquet
    from analysis.pipeline.convergence import run_metadata

    meta = run_metadata(grid_name, settings, config_hash)
    write_parquet(lifetimes, path, metadata={"beamsim.lifetimes": meta})

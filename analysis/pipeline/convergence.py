"""Convergence evidence of a regime map: a seeded sample of its points re-run with refined
numerics and model discretisation, and the fraction of points whose label holds.

A label is a result only if it does not move with a numerical knob.  Each refinement of
:data:`REFINEMENTS` changes one knob of every sampled point (the reference and the refined
run share everything else; a grid runs the refinements that are knobs of its friction law,
:func:`grid_refinements`) and sends the refined points through the pipeline's own stages
(:func:`analysis.pipeline.stages.simulate_points`, :func:`~analysis.pipeline.stages.lyapunov_points`,
:func:`~analysis.pipeline.stages.classify_points`), with the refined settings in their point ids
(so the per-point store caches them like any other point):

* ``step``: integration steps halved: the reference run's step (RK4: ``step_factor / 2``;
  ``expo`` and ``newmark``: twice the steps per period, i.e. half the spacing of ``expo``'s
  switch checks) and the Lyapunov runs' RK4 step;
* ``windows``: transient (and its cap), record, Stefanski window, Lyapunov burn-in and blocks
  all twice as long (the same number of blocks, each twice as long);
* ``separation``: the Lyapunov copies' separation a tenth (``expo_e0`` and ``rk4_e0``): a
  Benettin exponent is the limit of vanishing separation, so a label that moves with it was
  read from a finite-size effect or from the integrator's noise (docs/lyapunov.md, sections
  16-17); the reference runs are the map's (:func:`reuses_reference_runs`), so only the
  Lyapunov stage runs again;
* ``k_t``: the Jenkins (stick) stiffness of the interface three times larger (law
  ``stick-slip`` only: the rigid stick has none, and the regularised laws have no stick);
* ``band``: the velocity band ``eps_v`` of the regularised laws (``full-slip``, ``stribeck``:
  :data:`REGULARISED_LAWS`) halved (``eps_v`` where a point gives it, else ``eps_rel``), their
  interface's regularisation as ``k_t`` is the stick-slip law's;
* ``modes``: one more arch mode in the Galerkin basis;
* ``long_run``: the map's own run, longer: each sampled point starts from the end state the
  map's run stored and runs :data:`LONG_RUN_PERIODS` forcing periods before its record (the
  transient's length, a knob that ``windows`` doubles only from rest, where the adaptive
  transient stops at the first record that passes the transient tests); a label that moves
  was read from a transient slower than those tests see (a creep of the slip locked into the
  stuck elements, lasting thousands of periods: docs/pipeline.md, "Long runs from the map's
  end states").  Where the map's record came after its own long run
  (``numerics.n_long_transient``) this row runs on by as much again; it has no long run of its
  own.

A label that moves under a model refinement (``k_t``, ``modes``: :data:`CONTINUED`) is also
followed from the map's attractor (:func:`continuation_path`): the map run's end state is
stiffened in :data:`K_T_STEPS` geometric steps of ``k_t`` (each start carried with its
tractions kept), or carried into the basis with one more mode, and the refined model's
attractor reached that way is classified (``continued_label``).  A label other than the map's
says that the map's attractor does not persist in the refined model (the move is the model's);
the map's label says that an attractor of that label does (the map's, or one like it: a label
is not an attractor's identity), in another basin than the refined start from rest's (the move
is the refined model's multistability).

Three **controls** change the load instead of the numerics (:data:`CONTROLS`): ``load_up``
and ``load_down`` multiply the load amplitude by ``1 + LOAD_SHIFT`` and divide it by it
(``f0_rel``, or ``f0`` where a point gives that).  A label that moves under a 2 % change of the
load is finer than that in the parameter plane (a narrow window, a locking tongue, the edge of
a basin): a refinement that perturbs the model as much cannot be expected to keep it.
``nudge`` multiplies the load by ``1 + NUDGE`` (``1 + 1e-9``): no physical change, only a
trajectory that leaves the map's at the level of the integrator's own error (``expo``'s is
1.7e-10 to 3.0e-9 of the state in a period, docs/performance.md) and moves away where the
dynamics amplify that.  A label that moves under it is decided by the run's last digits, as
another compiler, BLAS or CPU could decide it (a periodic attractor absorbs the nudge; a
chaotic transient, a fractal basin edge or a Lyapunov record at its margin does not), so the
fraction of labels that hold under ``nudge`` is about the most a refinement can be expected to
show.  With controls in the runs, :func:`convergence_summary` also counts each refinement's
labels that hold among the **robust** points (those whose label holds under every control),
which separates a refinement that moves robust labels (the numerics or the model are not
converged) from one that moves only labels that a small change of the load, or none, moves
too.

The sample (:func:`sample_points`) is stratified by the map's labels: every label present is
represented (rare ones, such as ``chaotic``, by at least :data:`MIN_PER_LABEL` points when the
map has them), the rest of the sample is shared in proportion to the labels' counts, and the
points of a label are drawn with a seeded generator.  Each sampled point carries the weight of
its stratum (points of the label in the map / sampled points of the label), so
:func:`convergence_summary` gives both the fraction of sampled points whose label holds and the
map-weighted estimate of the fraction of the map's points.  A census (``convergence.census``)
takes every cell of the labels it names instead of their strata's draws (weight 1 each), so
that a label's cells are checked one by one, not estimated from two or three of them.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from analysis.pipeline.config import Numerics, as_numerics, check_keys
from analysis.pipeline.grid import canonical_json, point_id

__all__ = ["CENSUS_LABELS", "CONTINUED", "CONTROLS", "ConvergenceSettings", "K_T_STEPS", "LOAD_SHIFT",
           "LONG_RUN_PERIODS", "NUDGE", "REFINEMENTS", "REGULARISED_LAWS", "SEPARATION_FACTOR", "applies",
           "census_line",
           "continuation_path", "convergence_runs",
           "convergence_summary", "flagged", "grid_refinements", "held_interval", "label_text",
           "onto_locked", "refine",
           "reuses_reference_runs", "run_metadata", "same_label", "sample_points", "summary_line",
           "title_line", "write_convergence_table"]

#: the relative change of the load amplitude of the controls ``load_up`` / ``load_down``
#: (the size of the change of ``f_cr``, and so of the load at a given ``f0_rel``, that one more
#: mode makes on the default beam: 2.1 %, docs/pipeline.md)
LOAD_SHIFT = 0.02

#: the relative change of the load amplitude of the control ``nudge``: far below any physical
#: tolerance, about the state error of the reference integrator in one period
NUDGE = 1e-9

#: forcing periods the refinement ``long_run`` runs from the map run's end state before its record
LONG_RUN_PERIODS = 4000

#: refinement name -> what it changes (the figure's and the docs' wording)
REFINEMENTS = {
    "step": "step / 2",
    "windows": "windows x 2",
    "separation": "e0 / 10",
    "k_t": "k_t x 3",
    "band": "eps_v / 2",
    "modes": "modes + 1",
    "long_run": f"end state + {LONG_RUN_PERIODS} T",
    "load_up": f"load x {1 + LOAD_SHIFT:g}",
    "load_down": f"load / {1 + LOAD_SHIFT:g}",
    "nudge": f"load x (1 + {NUDGE:g})".replace("e-0", "e-"),  # 1e-9, not 1e-09
}

#: the friction laws with a velocity band (``tau ~ tanh(v / eps_v)``, docs/model.md section 6): their
#: interface knob is the band (refinement ``band``), not ``k_t``, which there only sets the
#: penalty-bonded beam that ``Omega`` and ``f0_rel`` are relative to (and, under the dashpot
#: rule ``interface_damping``, the dashpot coefficient)
REGULARISED_LAWS = ("full-slip", "stribeck")

#: the entries of :data:`REFINEMENTS` that change the load (by 2 %, or by 1e-9: physically nothing),
#: not the numerics
CONTROLS = ("load_up", "load_down", "nudge")

#: the least number of sampled points of every label the map has (when it has that many)
MIN_PER_LABEL = 2
#: the map labels a census (``convergence.census``) can name: a label's every cell re-run
CENSUS_LABELS = ("periodic", "quasi-periodic", "chaotic", "undetermined", "unsettled")

#: confidence level of the interval of the fraction of labels that hold (:func:`held_interval`)
HELD_CONFIDENCE = 0.95

#: the factor by which the refinement ``separation`` divides the Lyapunov copies' separations
SEPARATION_FACTOR = 10.0

#: the model's largest Galerkin basis (workflow/schemas/config.schema.yaml, model.n_modes)
MAX_MODES = 12

#: the model refinements whose moved labels are followed from the map's attractor
#: (:func:`continuation_path`)
CONTINUED = ("k_t", "modes")

#: geometric steps of the stick stiffness from the map's ``k_t`` to the refined one
K_T_STEPS = 3


@dataclass(frozen=True)
class ConvergenceSettings:
    """The ``convergence`` section of the config.

    sample : points of each grid re-run per refinement (0: no convergence runs; the map then
        says that its labels were not checked).
    seed : seed of the sample's draw.
    refinements : names from :data:`REFINEMENTS`, in the order of the table and figure; each
        grid runs those that are knobs of its law (:func:`grid_refinements`).
    census : map labels (:data:`CENSUS_LABELS`) whose every cell is re-run, in addition to the
        sample's other strata (:func:`sample_points`), e.g. ``["chaotic"]``: whether each of
        the map's chaotic cells keeps its label, not a sample of them.
    """

    sample: int = 20
    seed: int = 0
    refinements: tuple[str, ...] = tuple(REFINEMENTS)
    census: tuple[str, ...] = ()

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> ConvergenceSettings:
        d = dict(d or {})
        check_keys("convergence", d, ["census", "refinements", "sample", "seed"])
        refs = tuple(d.pop("refinements", cls.refinements))
        bad = [r for r in refs if r not in REFINEMENTS]
        if bad:
            raise ValueError(f"convergence.refinements = {bad}; allowed: {', '.join(REFINEMENTS)}")
        if len(set(refs)) != len(refs):
            raise ValueError(f"convergence.refinements = {list(refs)} names a refinement twice")
        census = tuple(d.pop("census", cls.census))
        bad = [c for c in census if c not in CENSUS_LABELS]
        if bad or len(set(census)) != len(census):
            raise ValueError(f"convergence.census = {list(census)}; allowed: distinct labels of "
                             f"{', '.join(CENSUS_LABELS)}")
        out = cls(refinements=refs, census=census, **d)
        if out.sample < 0:
            raise ValueError(f"convergence.sample = {out.sample}; allowed: an integer >= 0")
        return out

    @property
    def active(self) -> tuple[str, ...]:
        """The refinements that run (none when ``sample`` is 0 and there is no census)."""
        return self.refinements if self.sample > 0 or self.census else ()

    def as_dict(self) -> dict:
        """The settings that choose a grid's runs (the refinement is each job's own, so a
        change of the list does not rerun the refinements that stay), ``census`` only where it
        names a label: the jobs of a config without one keep their parameters (no rerun)."""
        census = {"census": list(self.census)} if self.census else {}
        return {"sample": self.sample, "seed": self.seed} | census


# ----------------------------------------------------------------------------- refinements
def _law(params: Mapping) -> str:
    """A point's friction law (the default when its parameters leave it out)."""
    from beamsim.friction import Friction

    return str(params.get("law", Friction.law))


def applies(refinement: str, params: Mapping) -> bool:
    """Whether ``refinement`` is a knob of the point ``params``: ``k_t`` of the stick-slip law
    (the rigid stick and the regularised laws have no stick stiffness), ``band`` of the
    regularised laws (:data:`REGULARISED_LAWS`), every other refinement of every law.
    :func:`refine` refuses a point it does not apply to."""
    law = _law(params)
    if refinement == "k_t":
        return law == "stick-slip"
    if refinement == "band":
        return law in REGULARISED_LAWS
    return True


def grid_refinements(refinements: Sequence[str], points: Sequence[Mapping], grid: str) -> tuple[str, ...]:
    """The refinements of ``refinements`` that run on one grid (``points``: its points'
    parameters): those that apply to its points' law (:func:`applies`), so that one
    ``convergence.refinements`` serves grids of different laws (the shipped list has ``k_t``
    and ``band``; a stick-slip grid runs the first, a Stribeck grid the second).  A refinement
    that applies to some of the grid's points and not to others (a grid whose axis is the law)
    is an error: its row would mix knobs."""
    keep = []
    for ref in refinements:
        ok = [applies(ref, p) for p in points]
        if all(ok):
            keep.append(ref)
        elif any(ok):
            laws = sorted({_law(p) for p, a in zip(points, ok) if not a})
            raise ValueError(f"convergence.refinements: {ref!r} is a knob of some points of grid "
                             f"{grid} but not of those of law {', '.join(laws)}: give the laws "
                             f"grids of their own")
    return tuple(keep)


def refine(refinement: str, params: dict, numerics: Numerics | dict) -> tuple[dict, Numerics]:
    """The parameters and numerics of ``refinement`` (a key of :data:`REFINEMENTS`, a control
    among them) applied to one point; everything else unchanged.  A point without load
    (``f0`` or ``f0_rel`` 0) is its own control: the refined point is the map's (same id)."""
    from analysis.pipeline.stages import integrator
    from beamsim.friction import Friction
    from beamsim.point import DEFAULT_F0_REL, DEFAULT_STEPS_PER_PERIOD
    from beamsim.two_layer import Geometry

    nm = as_numerics(numerics)
    p = dict(params)
    ly = nm.lyapunov
    if refinement == "step":
        method = integrator(nm.method, p)
        spp = nm.steps_per_period or DEFAULT_STEPS_PER_PERIOD.get(method)
        if spp is not None:
            nm = replace(nm, steps_per_period=2 * spp)
        if spp is None or method == "expo":
            # RK4's step; for expo too: a point whose expo run meets the Zeno guard is run on
            # RK4 at step_factor (analysis.pipeline.stages.simulate_runs)
            nm = replace(nm, step_factor=nm.step_factor / 2)
        nm = replace(nm, lyapunov=replace(ly, step_factor=ly.step_factor / 2))
    elif refinement == "windows":
        nm = replace(nm, n_transient=2 * nm.n_transient, n_transient_max=2 * nm.n_transient_max,
                     n_record=2 * nm.n_record,
                     lyapunov=replace(ly, n_periods=2 * ly.n_periods, burn_in=2 * ly.burn_in,
                                      block_periods=2 * ly.block_periods))
    elif refinement == "long_run":  # the start: the map's end state (convergence_runs)
        # the row is itself the long run: no second one (numerics.n_long_transient) after it
        nm = replace(nm, n_transient=LONG_RUN_PERIODS, n_long_transient=0,
                     n_transient_max=max(nm.n_transient_max, LONG_RUN_PERIODS))
    elif refinement == "separation":
        nm = replace(nm, lyapunov=replace(ly, expo_e0=ly.expo_e0 / SEPARATION_FACTOR,
                                          rk4_e0=ly.rk4_e0 / SEPARATION_FACTOR))
    elif refinement in ("k_t", "band") and not applies(refinement, p):
        knob = ("the stick stiffness of law stick-slip" if refinement == "k_t" else
                f"the velocity band of the regularised laws ({', '.join(REGULARISED_LAWS)})")
        raise ValueError(f"refinement {refinement!r} refines {knob}; the point has law {_law(p)}")
    elif refinement == "k_t":
        p["k_t"] = 3.0 * float(p.get("k_t", Geometry.k_t))
    elif refinement == "band" and p.get("eps_v") is not None:
        p["eps_v"] = 0.5 * float(p["eps_v"])
    elif refinement == "band":
        p["eps_rel"] = 0.5 * float(p.get("eps_rel", Friction.eps_rel))
    elif refinement == "modes":
        n = int(p.get("n_modes", Geometry.n_modes))
        if n + 1 > MAX_MODES:
            raise ValueError(f"convergence.refinements: 'modes' needs n_modes + 1 <= {MAX_MODES}, "
                             f"a point has n_modes = {n}")
        p["n_modes"] = n + 1
    elif refinement in CONTROLS:
        factor = {"load_up": 1.0 + LOAD_SHIFT, "load_down": 1.0 / (1.0 + LOAD_SHIFT),
                  "nudge": 1.0 + NUDGE}[refinement]
        if p.get("f0") is not None:
            p["f0"] = factor * float(p["f0"])
        else:
            p["f0_rel"] = factor * float(p.get("f0_rel", DEFAULT_F0_REL))
    else:
        raise ValueError(f"unknown refinement {refinement!r}; allowed: {', '.join(REFINEMENTS)}")
    return p, nm


def continuation_path(refinement: str, params: Mapping, refined_params: Mapping) -> list[dict]:
    """The points along which a moved label's map attractor is followed into the refined model
    (:data:`CONTINUED`): ``k_t`` in :data:`K_T_STEPS` geometric steps from the map's stiffness
    to the refined one (the last point the refined point itself), one more mode in one step."""
    if refinement not in CONTINUED:
        raise ValueError(f"continuation_path: refinement {refinement!r} is not one of {CONTINUED}")
    if refinement == "k_t":
        k0, k1 = float(params["k_t"]), float(refined_params["k_t"])
        return [dict(params) | {"k_t": k0 * (k1 / k0) ** (i / K_T_STEPS)} for i in range(1, K_T_STEPS)] + [
            dict(refined_params)]
    return [dict(refined_params)]


def reuses_reference_runs(params: Mapping, numerics: Numerics, refined_params: Mapping,
                          refined_numerics: Numerics) -> bool:
    """Whether a refined point's reference runs (the simulate stage) are the map's point's:
    the same parameters and the same numerics but for the Lyapunov stage's (``separation``).
    Its record is then the map's, to the bit (a point's record depends on its own runs and
    numerics only), so :func:`convergence_runs` reads it from the store under the map's id
    instead of running it again, and the run estimate counts the Lyapunov stage alone."""
    return (dict(refined_params) == dict(params)
            and replace(refined_numerics, lyapunov=numerics.lyapunov) == numerics)


# ----------------------------------------------------------------------------- sample
def _quotas(counts: pd.Series, n: int) -> dict:
    """Sampled points per label: at least ``min(count, MIN_PER_LABEL)`` each, the rest in
    proportion to the counts (largest remainder, ties by label name), never above a count."""
    counts = counts.sort_index()
    if n >= counts.sum():
        return counts.to_dict()
    q = {lab: min(int(c), MIN_PER_LABEL) for lab, c in counts.items()}
    while sum(q.values()) > n:  # more labels than room: the most common label gives way first
        lab = max((lab for lab in q if q[lab] > 0), key=lambda lab: (q[lab], counts[lab], lab))
        q[lab] -= 1
    left = n - sum(q.values())
    while left > 0:
        room = {lab: counts[lab] - q[lab] for lab in q if counts[lab] > q[lab]}
        total = sum(counts[lab] for lab in room)
        share = {lab: left * counts[lab] / total for lab in room}
        add = {lab: min(int(np.floor(s)), room[lab]) for lab, s in share.items()}
        if sum(add.values()) == 0:  # hand out one by largest remainder
            lab = sorted(room, key=lambda lab: (-(share[lab] - np.floor(share[lab])), lab))[0]
            add = {lab: 1}
        for lab, k in add.items():
            q[lab] += k
        left = n - sum(q.values())
    return q


def sample_points(table: pd.DataFrame, n: int, seed: int = 0, census: Sequence[str] = ()) -> pd.DataFrame:
    """A seeded sample of ``n`` rows of a regime table, stratified by ``label``
    (module docstring), with a ``weight`` column (the stratum's map count over its sample
    count), in the table's order.  Deterministic: depends on the table's ``label`` column, the
    points' grid positions (``index_0``, ``index_1``, ... where the table has them, else
    ``point_id``), ``n``, ``seed`` and ``census`` only.  The grid positions do not change with
    the results version (the ids do), so a new version re-runs the same points wherever its
    labels are the old ones: its evidence is paired with the old, not a fresh draw.  The labels in ``census``
    are taken whole (every cell, weight 1) instead of their stratum's draw; the draws of the
    other labels stay those without the census (the census labels' draws are made and set
    aside), so a census adds cells to the sample and removes none."""
    from analysis.pipeline.table import index_columns

    counts = table["label"].value_counts()
    quotas = _quotas(counts, int(n))
    rng = np.random.default_rng(seed)
    order = table.sort_values(index_columns(table) or ["point_id"], kind="stable")
    chosen = []
    for lab in sorted(quotas):  # every label of the map (a quota of 0 draws nothing)
        ids = order.loc[order["label"] == lab, "point_id"].to_numpy()
        k = quotas[lab]
        drawn = rng.choice(ids, size=k, replace=False) if k else ids[:0]
        if lab in census:
            chosen += [(pid, 1.0) for pid in ids]
        else:
            chosen += [(pid, counts[lab] / k) for pid in drawn]
    weight = dict(chosen)
    out = table[table["point_id"].isin(weight)].copy()
    out["weight"] = out["point_id"].map(weight).astype(float)
    return out


# ----------------------------------------------------------------------------- runs
def label_text(label: str, period) -> str:
    """A label with its period where it has one: ``periodic-2``, ``chaotic``."""
    if label == "periodic" and period is not None and not pd.isna(period):
        return f"periodic-{int(period)}"
    return str(label)


def same_label(label: str, period, other: str, other_period) -> bool:
    """Whether a label holds: the same regime and, for a periodic orbit, the same period (a
    period-2 orbit that becomes period 1 under a refinement is a different result)."""
    return label_text(label, period) == label_text(other, other_period)


def _num(value) -> float:
    """A table value as a float, NaN for a missing one (diverged points carry ``None``)."""
    return np.nan if value is None or pd.isna(value) else float(value)


def convergence_runs(table: pd.DataFrame, refinement: str, numerics: Numerics | dict,
                     settings: ConvergenceSettings, store_root: str, axes: Sequence[str] = (),
                     threads: int = 1) -> pd.DataFrame:
    """Re-run the sample of a regime table under one refinement.

    Returns one row per sampled point (the table's order): ``point_id`` (the map's),
    ``refinement``, the ``axes`` values, ``weight``, ``supported`` (a grid neighbour shares
    the map's label: :func:`analysis.pipeline.neighbours.supported`; NA for a table without the
    neighbour columns), ``label``/``period``/``lle_T``/``lle_lo_T``/
    ``lle_hi_T`` of the map and ``refined_*`` of the refined run (``lambda_1 T`` per forcing
    period; NaN where not measured), ``refined_reason``, ``refined_point_id``,
    ``refined_stick_fraction``, ``locked`` (the map's ``lock_ratio`` below 1: a locked period-1
    motion exists beside the map's; NA where the table has no ratio), ``holds``
    (:func:`same_label`: the same regime and, for a periodic orbit, the same period) and
    ``continued_label`` / ``continued_period``: for a label that moved under a model refinement
    (:data:`CONTINUED`), the refined model's label reached from the map run's stored end state
    along :func:`continuation_path` (:func:`analysis.continuation.continue_from`; NA for other
    rows, or where the end state is not in the store, not finite, or cannot be carried).
    Under ``long_run`` each refined point starts from the map run's end state
    (:func:`_map_end_states`), which its id then contains.
    """
    from analysis.pipeline.neighbours import supported
    from analysis.pipeline.stages import classify_points, lle_resolution, lyapunov_points, simulate_points

    base_nm = as_numerics(numerics)
    sample = sample_points(table, settings.sample, settings.seed, settings.census)
    base_support = supported(sample)
    starts = _map_end_states(sample, base_nm, store_root, threads) if refinement == "long_run" else {}
    refined = []
    for _, row in sample.iterrows():
        base_params = json.loads(row["params_json"])
        map_id = point_id(base_params, base_nm)
        params, nm = refine(refinement, base_params, base_nm)
        params |= starts.get(map_id, {})
        refined.append({"point_id": point_id(params, nm), "params": params, "numerics": nm,
                        "map_id": map_id, "reuse": reuses_reference_runs(base_params, base_nm, params, nm)})
    # one pass of the stages per distinct numerics (a refined step can differ by law)
    labels: dict = {}
    groups: dict = {}
    for r in refined:
        groups.setdefault((canonical_json(r["numerics"].result_dict()), r["reuse"]), []).append(r)
    for (_, reuse), members in groups.items():
        nm = members[0]["numerics"]
        pts = [{"point_id": r["point_id"], "params": r["params"]} for r in members]
        if reuse:  # the map's reference runs (from the store, or run again under the map's ids)
            sim = simulate_points([{"point_id": r["map_id"], "params": r["params"]} for r in members],
                                  base_nm, store_root, threads)
            sim["point_id"] = sim["point_id"].map({r["map_id"]: r["point_id"] for r in members})
        else:
            sim = simulate_points(pts, nm, store_root, threads)
        lyap = lyapunov_points(pts, sim, nm, store_root, threads)
        cls = classify_points(sim, lyap, lle_threshold=lle_resolution(nm))
        merged = cls.merge(lyap[["point_id", "lle_mean", "lle_lo", "lle_hi"]], on="point_id").merge(
            sim[["point_id", "omega", "stick_fraction"]], on="point_id")
        for _, m in merged.iterrows():
            labels[m["point_id"]] = m
    rows = []
    for (_, base), r in zip(sample.iterrows(), refined):
        m = labels[r["point_id"]]
        t_base, t_ref = 2.0 * np.pi / float(base["omega"]), 2.0 * np.pi / float(m["omega"])
        row = {"point_id": base["point_id"], "refinement": refinement}
        row |= {a: base[a] for a in axes}
        row |= {"weight": float(base["weight"]), "supported": base_support[base.name],
                "label": base["label"], "period": base["period"],
                "lle_T": _num(base["lle_mean"]) * t_base, "lle_lo_T": _num(base["lle_lo"]) * t_base,
                "lle_hi_T": _num(base["lle_hi"]) * t_base,
                "refined_label": m["label"], "refined_period": m["period"],
                "refined_lle_T": _num(m["lle_mean"]) * t_ref,
                "refined_lle_lo_T": _num(m["lle_lo"]) * t_ref,
                "refined_lle_hi_T": _num(m["lle_hi"]) * t_ref,
                "refined_reason": m["reason"], "refined_point_id": r["point_id"],
                "refined_stick_fraction": _num(m["stick_fraction"]),
                "locked": (pd.NA if pd.isna(base.get("lock_ratio", np.nan))
                           else bool(base["lock_ratio"] < 1.0)),
                "holds": same_label(base["label"], base["period"], m["label"], m["period"])}
        rows.append(row)
    if refinement in CONTINUED:
        _follow_moves(rows, sample, refined, store_root, threads)
    # the columns named, so that a sample without cells (a census of a label the map lacks,
    # with no sample) gives an empty table of the same columns
    columns = ["point_id", "refinement", *axes, "weight", "supported", "label", "period", "lle_T",
               "lle_lo_T", "lle_hi_T", "refined_label", "refined_period", "refined_lle_T",
               "refined_lle_lo_T", "refined_lle_hi_T", "refined_reason", "refined_point_id",
               "refined_stick_fraction", "locked", "holds", "continued_label", "continued_period"]
    out = pd.DataFrame(rows, columns=columns)
    for c in ("period", "refined_period", "continued_period"):
        out[c] = out[c].astype("Int64")
    out["supported"] = out["supported"].astype("boolean")
    out["locked"] = out["locked"].astype("boolean")
    return out


def _map_end_states(sample: pd.DataFrame, nm: Numerics, store_root: str, threads: int) -> dict:
    """Map point id -> the initial-state parameters (``q0``, ``v0``, ``z0``, ``mode0``, lists)
    of a start from the end state of the map's run (its simulate record: from the store, or run
    again, to the bit the same); none (rest) where that state is not finite (a diverged run)."""
    from analysis.continuation import state_params
    from analysis.pipeline.stages import simulate_points
    from beamsim.simulate import prepare_point

    pts = [{"point_id": point_id(p, nm), "params": p}
           for p in (json.loads(js) for js in sample["params_json"])]
    if not pts:
        return {}
    sim = simulate_points(pts, nm, store_root, threads).set_index("point_id")
    out = {}
    for p in pts:
        model = prepare_point(**p["params"]).model
        start = state_params(sim.loc[p["point_id"], "final_state"], model.n, model.n_quad)  # {}: rest
        out[p["point_id"]] = {k: v.tolist() for k, v in start.items()}
    return out


def _follow_moves(rows: list[dict], sample: pd.DataFrame, refined: list[dict], store_root: str,
                  threads: int) -> None:
    """``continued_label`` / ``continued_period`` of every row whose label moved (in place;
    :func:`convergence_runs`)."""
    from analysis.continuation import continue_from
    from analysis.pipeline.stages import lle_resolution
    from analysis.pipeline.store import PointStore
    from beamsim.simulate import prepare_point

    store = PointStore(store_root, "simulate")
    for row, (_, base), r in zip(rows, sample.iterrows(), refined):
        row["continued_label"], row["continued_period"] = None, None
        rec = None if row["holds"] else store.find(r["map_id"])
        if rec is None:
            continue
        base_params = json.loads(base["params_json"])
        path = continuation_path(row["refinement"], base_params, r["params"])
        try:
            c = continue_from(rec["final_state"], prepare_point(**base_params).model, path, r["numerics"],
                              lle_threshold=lle_resolution(r["numerics"]), threads=threads)
        except ValueError:  # not finite, or a law whose state cannot be carried
            continue
        row["continued_label"], row["continued_period"] = c["label"], c["period"]


#: labels that are a verdict on the dynamics (the others say that there is none yet)
DECIDED = ("periodic", "quasi-periodic", "chaotic")


def held_interval(held: int, n: int, level: float = HELD_CONFIDENCE) -> tuple[float, float]:
    """Exact (Clopper-Pearson) two-sided ``level`` interval of the fraction of points whose
    label holds, from ``held`` of ``n`` sampled points (``scipy.stats.binomtest``); ``(nan,
    nan)`` for ``n = 0``.  With 20 points, 19 held give [0.75, 1.00]: a sample this size cannot
    show a fraction of 95 %, only rule out one far below."""
    from scipy.stats import binomtest

    if n <= 0:
        return np.nan, np.nan
    ci = binomtest(int(held), int(n)).proportion_ci(confidence_level=level, method="exact")
    return float(ci.low), float(ci.high)


def flagged(runs: pd.DataFrame, robust: pd.Series | None) -> np.ndarray:
    """Per run row: whether the map flags its label as one a refinement need not keep: no
    verdict in the map (``undetermined``, ``unsettled``, ``diverged``), no grid neighbour
    sharing it (column ``supported`` False), or, with ``robust`` (per point: the label holds
    under every control), moving under a control: a 2 % change of the load, or its nudge by
    ``NUDGE``."""
    out = ~runs["label"].isin(DECIDED).to_numpy(bool)
    if "supported" in runs:
        out |= runs["supported"].eq(False).fillna(False).to_numpy(bool)
    if robust is not None:
        out |= ~runs["point_id"].map(robust).fillna(True).to_numpy(bool)
    return out


#: the refinements that keep the model (numerics only): the map's lock-up limit is theirs too
SAME_MODEL = ("step", "windows", "separation", "long_run")


def onto_locked(runs: pd.DataFrame) -> np.ndarray:
    """Per run row of a refinement that keeps the model (:data:`SAME_MODEL`): the refined run
    ended locked below the map's lock-up limit: the map's point has a locked period-1 motion
    (column ``locked``: its ``lock_ratio`` below 1, :func:`beamsim.shakedown.lock_ratio`; the
    map marks the cell by the dashed limit), its own label is not periodic-1, and the refined
    run ended periodic-1 with every element stuck (``refined_stick_fraction`` 1).  The map
    says why such a move can happen, but not that it will: where the refined run is the map's
    run continued for longer (the doubled windows), the map's label there may be a transient
    that ends locked.  False where the columns are missing."""
    if "locked" not in runs or "refined_stick_fraction" not in runs:
        return np.zeros(len(runs), bool)
    map_p1 = [label_text(a, p) == "periodic-1" for a, p in zip(runs["label"], runs["period"])]
    ref_p1 = [label_text(a, p) == "periodic-1" for a, p in zip(runs["refined_label"], runs["refined_period"])]
    stuck = runs["refined_stick_fraction"].astype(float).fillna(0.0).to_numpy() >= 1.0
    same_model = runs["refinement"].isin(SAME_MODEL).to_numpy(bool)
    return (same_model & runs["locked"].astype("boolean").fillna(False).to_numpy(bool)
            & ~np.asarray(map_p1, bool) & np.asarray(ref_p1, bool) & stuck)


def convergence_summary(runs: pd.DataFrame) -> pd.DataFrame:
    """Per refinement (first-appearance order): ``n`` sampled points, ``held`` (labels equal),
    ``fraction`` (held / n) with its exact 95 % interval ``fraction_lo``, ``fraction_hi``
    (:func:`held_interval`), ``map_fraction`` (the stratum-weighted estimate for the whole map),
    ``contradicted`` (both labels a verdict, :data:`DECIDED`, and different: e.g. chaotic ->
    periodic, unlike chaotic -> undetermined), ``flips`` (``"from -> to: count"``, most
    frequent first) and, when ``runs`` has :data:`CONTROLS`, for every refinement that is not
    one: ``n_robust`` (sampled points whose label holds under every control: robust) and
    ``held_robust`` (of those, the labels that hold under this refinement); NA otherwise; and
    for every refinement, when ``runs`` has the column ``supported``, ``n_supported`` (sampled
    points whose label a grid neighbour shares) and ``held_supported`` (of those, the labels
    that hold); NA otherwise; ``locked_moves`` (refinements only, NA for a control): the labels
    whose refined run ended locked below the map's lock-up limit (:func:`onto_locked`); and
    ``unflagged`` (refinements only, NA for a control): the labels that moved although the map
    flags nothing about them (:func:`flagged`) and that did not end locked below the limit,
    the count a referee re-running those cells would find no mark for; ``followed`` and
    ``persisted`` (model refinements, :data:`CONTINUED`, NA otherwise or without the column
    ``continued_label``): the moved labels followed from the map's attractor into the refined
    model, and of those the ones that ended on the map's label there (an attractor of the map's
    label persists; the move is the refined model's multistability, not a change of the model)."""
    controls = runs[runs["refinement"].isin(CONTROLS)]
    robust = controls.groupby("point_id")["holds"].all() if len(controls) else None
    rows = []
    for ref, g in runs.groupby("refinement", sort=False):
        w = g["weight"].to_numpy(float)
        holds = g["holds"].to_numpy(bool)
        decided = g["label"].isin(DECIDED) & g["refined_label"].isin(DECIDED)
        moved = g[~holds]
        flips = pd.Series([f"{label_text(a, p)} -> {label_text(b, q)}" for a, p, b, q in
                           zip(moved["label"], moved["period"], moved["refined_label"],
                               moved["refined_period"])], dtype=object).value_counts()
        flips = flips.sort_index().sort_values(ascending=False, kind="stable")
        lo, hi = held_interval(int(holds.sum()), len(g))
        n_robust = held_robust = pd.NA
        if robust is not None and ref not in CONTROLS:
            is_robust = g["point_id"].map(robust).fillna(False).to_numpy(bool)
            n_robust, held_robust = int(is_robust.sum()), int((holds & is_robust).sum())
        locked = ~holds & onto_locked(g)
        locked_moves = pd.NA if ref in CONTROLS else int(locked.sum())
        unflagged = pd.NA if ref in CONTROLS else int((~holds & ~locked & ~flagged(g, robust)).sum())
        followed = persisted = pd.NA
        if ref in CONTINUED and "continued_label" in g:
            cont = g[~holds & g["continued_label"].notna()]
            followed = len(cont)
            persisted = int(sum(same_label(a, p, b, q) for a, p, b, q in zip(
                cont["label"], cont["period"], cont["continued_label"], cont["continued_period"])))
        n_sup = held_sup = pd.NA
        if "supported" in g and g["supported"].notna().any():
            sup = g["supported"].fillna(False).to_numpy(bool)
            n_sup, held_sup = int(sup.sum()), int((holds & sup).sum())
        rows.append({"refinement": ref, "what": REFINEMENTS.get(ref, ref), "n": len(g),
                     "held": int(holds.sum()), "fraction": float(holds.mean()) if len(g) else np.nan,
                     "fraction_lo": lo, "fraction_hi": hi,
                     "map_fraction": float((w * holds).sum() / w.sum()) if w.sum() > 0 else np.nan,
                     "contradicted": int((decided & ~holds).sum()),
                     "flips": "; ".join(f"{k}: {v}" for k, v in flips.items()),
                     "n_robust": n_robust, "held_robust": held_robust,
                     "n_supported": n_sup, "held_supported": held_sup, "locked_moves": locked_moves,
                     "unflagged": unflagged, "followed": followed, "persisted": persisted})
    out = pd.DataFrame(rows, columns=["refinement", "what", "n", "held", "fraction", "fraction_lo",
                                      "fraction_hi", "map_fraction", "contradicted", "flips",
                                      "n_robust", "held_robust", "n_supported", "held_supported",
                                      "locked_moves", "unflagged", "followed", "persisted"])
    for c in ("n_robust", "held_robust", "n_supported", "held_supported", "locked_moves", "unflagged",
              "followed", "persisted"):
        out[c] = out[c].astype("Int64")
    return out


def unchecked_reason(refinements: Sequence[str], points: Sequence[Mapping]) -> str:
    """Why a grid has no convergence runs (its map's title says it): ``refinements`` are the
    config's active ones (none when ``convergence.sample`` is 0), ``points`` the grid's points'
    parameters, none of whose law has a knob among them (:func:`grid_refinements`)."""
    if not refinements:
        return "convergence.sample = 0"
    laws = sorted({_law(p) for p in points})
    return (f"none of convergence.refinements ({', '.join(refinements)}) is a knob of law "
            f"{', '.join(laws)}")


def _rows_with(summary: pd.DataFrame, column: str, positive: bool = False) -> pd.DataFrame:
    """The summary's rows where ``column`` is given (``positive``: above 0); none where the
    summary has no such column."""
    if column not in summary:
        return summary.iloc[:0]
    return summary[summary[column].fillna(0) > 0] if positive else summary[summary[column].notna()]


def summary_line(summary: pd.DataFrame, unchecked: str = "convergence.sample = 0") -> str:
    """The whole evidence in one sentence (the convergence table's log; the maps' titles carry
    its short form, :func:`title_line`; in the titles until 2026-11-29): ``labels hold (sampled
    points; 95 % interval): step / 2 19/20 [0.75-1.00], ...`` (no space inside an interval),
    followed, when the summary has controls, by ``; of the 9/20 whose label holds under the
    controls: step / 2 9/9, ...``, when it has the neighbour support, by ``; of the
    12/20 whose label a grid neighbour shares: step / 2 12/12, ...``, and by the refinements'
    ``unflagged`` counts: ``; moved without a flag (...): step / 2 0, ...``, and, where a
    refinement's runs ended locked below the map's lock-up limit (``locked_moves``), by
    ``; ended locked below the lock-up limit (...): windows x 2 3``, and, where moved labels
    were followed from the map's attractor (``followed``), by ``; moved labels followed from
    the map's attractor, ending on the map's label: k_t x 3 0/8, ...``.  Without runs:
    ``labels not checked under refinement (<unchecked>)``, the reason (:func:`unchecked_reason`)."""
    if summary is None or summary.empty:
        return f"labels not checked under refinement ({unchecked})"
    parts = [f"{r['what']} {r['held']}/{r['n']} [{r['fraction_lo']:.2f}-{r['fraction_hi']:.2f}]"
             for _, r in summary.iterrows()]
    line = "labels hold (sampled points; 95 % interval): " + ", ".join(parts)
    rob = _rows_with(summary, "n_robust")
    if len(rob):
        n_rob = int(rob["n_robust"].iloc[0])
        line += (f"; of the {n_rob}/{int(rob['n'].iloc[0])} whose label holds under the "
                 "controls: " + ", ".join(f"{r['what']} {int(r['held_robust'])}/{n_rob}"
                                          for _, r in rob.iterrows()))
    sup = _rows_with(summary, "n_supported")
    if len(sup):
        n_sup = int(sup["n_supported"].iloc[0])
        line += (f"; of the {n_sup}/{int(sup['n'].iloc[0])} whose label a grid neighbour shares: "
                 + ", ".join(f"{r['what']} {int(r['held_supported'])}/{n_sup}"
                             for _, r in sup.iterrows()))
    unf = _rows_with(summary, "unflagged")
    if len(unf):
        line += ("; moved without a flag (no verdict, no neighbour shares it, moves under a "
                 "control): "
                 + ", ".join(f"{r['what']} {int(r['unflagged'])}" for _, r in unf.iterrows()))
    onto = _rows_with(summary, "locked_moves", positive=True)
    if len(onto):
        line += ("; ended locked below the lock-up limit (the map's label there may be a transient): "
                 + ", ".join(f"{r['what']} {int(r['locked_moves'])}" for _, r in onto.iterrows()))
    fol = _rows_with(summary, "followed", positive=True)
    if len(fol):
        line += ("; moved labels followed from the map's attractor, ending on the map's label: "
                 + ", ".join(f"{r['what']} {int(r['persisted'])}/{int(r['followed'])}"
                             for _, r in fol.iterrows()))
    return line


def title_line(summary: pd.DataFrame | None, unchecked: str = "convergence.sample = 0") -> str:
    """The short form of :func:`summary_line` for a map's title: the labels held per refinement
    and control, among the robust points, and the moves without a flag where there are any,
    without the intervals and the neighbour counts, which the convergence figure and
    :func:`summary_line` (the convergence table's log) give: ``labels held (convergence.png):
    step / 2 20/20, ...; controls: load x 1.02 10/20, ...; of the 9 robust: step / 2 9, ...;
    moved without a flag: k_t x 3 1``, each entry's words joined by no-break spaces
    (U+00A0), so that a wrapped title keeps an entry whole.  Without runs:
    :func:`summary_line`'s sentence."""
    if summary is None or summary.empty:
        return summary_line(summary, unchecked)
    control = summary["refinement"].isin(CONTROLS)
    refs, ctls = summary[~control], summary[control]

    def held(rows: pd.DataFrame) -> str:
        return ", ".join(f"{r['what']} {r['held']}/{r['n']}".replace(" ", "\u00a0")
                         for _, r in rows.iterrows())

    parts = [held(refs)] if len(refs) else []
    if len(ctls):
        parts.append("controls: " + held(ctls))
    if len(rob := _rows_with(refs, "n_robust")):
        parts.append(f"of the {int(rob['n_robust'].iloc[0])} robust: " + _counts(rob, "held_robust"))
    if len(unf := _rows_with(refs, "unflagged", positive=True)):
        parts.append("moved without a flag: " + _counts(unf, "unflagged"))
    return "labels held (convergence.png): " + "; ".join(parts)


def _counts(rows: pd.DataFrame, column: str) -> str:
    """``what count, ...`` of a summary's ``rows`` (``column``: the count), each entry's words
    joined by no-break spaces (U+00A0), so that a wrapped title keeps an entry whole."""
    return ", ".join(f"{r['what']} {int(r[column])}".replace(" ", "\u00a0") for _, r in rows.iterrows())


def census_line(runs: pd.DataFrame, census: Sequence[str]) -> str:
    """The census of a map's convergence runs (``convergence.census``: every cell of those
    labels is in ``runs``) in one clause per label, for the map's title and the convergence
    table's log: ``every chaotic cell (26): k_t x 3 18, modes + 1 20; controls: load x 1.02
    19, ...; of its 12 robust: k_t x 3 10, modes + 1 11`` (the labels held per refinement and
    control, among that label's cells only); empty without a census or where the map has no
    cell of the label."""
    clauses = []
    for lab in census:
        cells = runs[runs["label"] == lab]
        if cells.empty:
            continue
        summary = convergence_summary(cells)
        control = summary["refinement"].isin(CONTROLS)
        parts = [f"every {lab} cell ({cells['point_id'].nunique()}): " + _counts(summary[~control], "held")]
        if control.any():
            parts.append("controls: " + _counts(summary[control], "held"))
        if len(rob := _rows_with(summary[~control], "n_robust")):
            n_rob = int(rob["n_robust"].iloc[0])
            parts.append(f"of its {n_rob} robust: " + _counts(rob, "held_robust") if n_rob else "none robust")
        clauses.append("; ".join(parts))
    return "; ".join(clauses)


def run_metadata(grid_name: str, settings: dict, config_hash: str) -> dict:
    """The metadata of a table derived from a map (convergence, multistability): grid name,
    settings, the map's config hash, results and classifier versions."""
    from analysis.pipeline.grid import RESULTS_VERSION
    from analysis.regimes import CLASSIFIER_VERSION

    return {"grid_name": grid_name, "settings": settings, "config_hash": config_hash,
            "results_version": RESULTS_VERSION, "classifier_version": CLASSIFIER_VERSION}


def write_convergence_table(runs: pd.DataFrame, path: str, *, grid_name: str, settings: dict,
                            config_hash: str) -> None:
    """Write the runs of every refinement to Parquet (atomically) with ``beamsim.convergence``
    metadata (:func:`run_metadata`)."""
    from analysis.pipeline.atomic import write_parquet

    meta = run_metadata(grid_name, settings, config_hash)
    write_parquet(runs, path, metadata={"beamsim.convergence": meta})

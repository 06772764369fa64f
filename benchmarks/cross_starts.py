"""Where a refined model moves a label: another attractor of the same cell, or another model?

The convergence evidence's ``k_t x 3`` and ``modes + 1`` rows re-run a sample of a map's cells
from rest with the stick three times stiffer or one more mode and compare labels
(docs/pipeline.md).  A label that moves there has two readings: the cell is multistable and the
refined run, started from rest like the map's, fell into the basin of another attractor that
the map's model has too; or the refined model's attractor near the cell is not the map model's
(the model changed, not the basin).  This tells them apart for every row of the convergence
table whose label moved, by two cross starts, each run through the pipeline's own stages
(:func:`analysis.multistability.point_attractors`: the adaptive transient, the Lyapunov record
and the classifier, with the run's numerics):

* the **map's model from the refined run's end state**: the refined label again means the map's
  model has that attractor too (a basin effect, which the map's multistability runs look for);
  the map's label again means its model returns to its own attractor from there;
* the **refined model from the map run's end state**: the map's label again means the refined
  model has the map's attractor too.

Both end states are the ones the map and the convergence runs stored (``results/store``), each
at a whole number of forcing periods, so a start from them keeps the forcing's phase.
``--mapping`` says how a state crosses: ``transfer`` (:func:`beamsim.state_transfer.transfer_state`:
the displacement fields projected onto the other basis, exact from three modes to four, and
every element's traction kept) or, where the layouts are the same (``k_t``), ``same`` (the
numbers as they are: each element's stick elongation ``s_j - z_j`` kept, so its traction
tripled or cut to a third).

    .venv/bin/python benchmarks/cross_starts.py --run <a finished run's working directory>
    .venv/bin/python benchmarks/cross_starts.py --run ... --refinement modes
    .venv/bin/python benchmarks/cross_starts.py --run ... --mapping same
    .venv/bin/python benchmarks/cross_starts.py --run ... --ladder 1.378 1.133 --k-t 10 20 30 --starts 3

``--ladder OMEGA F0_REL`` instead runs the map's cell nearest to those axis values at every
``--k-t`` from rest and ``--starts`` seeded perturbations
(:func:`analysis.multistability.perturbed_starts`, seed 0) and prints each attractor's label
with the starts that reached it: whether a moved label is one of several attractors of the
refined model or the only one, and how it depends on the stiffness.

``--continuation K_T ...`` instead follows every moved ``k_t`` row's cell along those
stiffnesses by continuation (:func:`analysis.continuation.continuation_sweeps`, as a line of the
workflow runs it: each point from its neighbour's end state, tractions kept): does the map's
attractor, stiffened step by step, keep the map's label up to the refined stiffness, or end
where the refined run from rest does?  And the refined attractor, softened step by step: does
it reach the map's stiffness with its own label (the map's model has such an attractor too) or
the map's?  (The first ``K_T`` should be the map's, the last the refined row's.)

    .venv/bin/python benchmarks/cross_starts.py --run ... --continuation 10 14 20 30

Results: docs/pipeline.md, "The refined models' moves: another attractor, or another model?".
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from analysis.continuation import state_params
from analysis.multistability import perturbed_starts, point_attractors
from analysis.pipeline.config import as_numerics
from analysis.pipeline.convergence import label_text, refine
from analysis.pipeline.store import PointStore
from beamsim.simulate import prepare_point
from beamsim.state_transfer import transfer_state

#: the refinements of the model (a cross start needs the other model's state)
MODEL_REFINEMENTS = ("k_t", "modes")


def crossed(state: np.ndarray, src, dst, mapping: str, law: str) -> np.ndarray:
    """An end state of model ``src`` as a start of model ``dst`` (friction law ``law``):
    ``transfer`` (:func:`~beamsim.state_transfer.transfer_state`) or ``same`` (the numbers as
    they are; the layouts must agree)."""
    if mapping == "transfer":
        return transfer_state(state, src, dst, law=law)
    if (src.n, src.n_quad) != (dst.n, dst.n_quad):
        raise SystemExit("--mapping same needs models of one state layout (refinement k_t)")
    return np.asarray(state, dtype=float).copy()


def ladder(table: pd.DataFrame, nm, omega_rel: float, f0_rel: float, k_ts: list[float], starts: int,
           threads: int) -> None:
    """The attractors of the cell nearest to (``omega_rel``, ``f0_rel``) at each stick stiffness,
    at the cell's relative load and frequency (as the refinement ``k_t x 3`` runs it)."""
    dist = np.hypot(np.log(table["Omega"] / omega_rel), np.log(table["f0_rel"] / f0_rel))
    row = table.loc[dist.idxmin()]
    params = json.loads(row["params_json"])
    own = label_text(row["label"], row["period"])
    print(f"cell Omega {row['Omega']:.4f} f0_rel {row['f0_rel']:.4f} (map: {own}), from rest (start 0) "
          f"and {starts} perturbed starts")
    for k_t in k_ts:
        p = params | {"k_t": k_t}
        t0 = time.perf_counter()
        found = point_attractors(p, [{}, *perturbed_starts(p, starts, seed=0)], nm, threads=threads)
        print(f"k_t {k_t:g}: " + "; ".join(
            f"{label_text(a.label, a.period)} (starts {list(a.starts)}, lambda_1 T {a.lle_T:+.3f})"
            for a in found.itertuples()) + f"  ({time.perf_counter() - t0:.0f} s)", flush=True)


def continued(table: pd.DataFrame, moved: pd.DataFrame, nm, k_ts: list[float], threads: int) -> None:
    """Every moved ``k_t`` row's cell swept up and down ``k_ts`` by continuation; prints each
    branch's labels and how the up-branch's last label and the down-branch's first compare with
    the refined row's and the map's."""
    from analysis.continuation import continuation_sweeps, hysteresis

    def text(r) -> str:
        return label_text(r.label, r.period)

    counts = {"up-branch label at the last k_t is the refined row's": 0, "... is the map's": 0,
              "down-branch label at the first k_t is the map's": 0, "... is the refined row's": 0}
    t_all = time.perf_counter()
    for _, r in moved.iterrows():
        params = json.loads(table.loc[r["point_id"], "params_json"])
        t0 = time.perf_counter()
        t = continuation_sweeps([params | {"k_t": k} for k in k_ts], nm, axis="k_t", threads=threads)
        up, down = (t[t["branch"] == b].sort_values("k") for b in ("up", "down"))
        last = text(up.iloc[-1])
        want_map = label_text(r["label"], r["period"])
        want_ref = label_text(r["refined_label"], r["refined_period"])
        first = text(down.iloc[0])
        counts["up-branch label at the last k_t is the refined row's"] += last == want_ref
        counts["... is the map's"] += last == want_map
        counts["down-branch label at the first k_t is the map's"] += first == want_map
        counts["... is the refined row's"] += first == want_ref
        same = "".join("Y" if x else "n" for x in hysteresis(t, "k_t")["same_attractor"])
        print(f"Omega {r['Omega']:.3f} f0_rel {r['f0_rel']:.3f}: {want_map} -> {want_ref}; up "
              + ", ".join(f"{k:g} {text(u)} ({u.lle_T:+.3f})" for k, u in zip(k_ts, up.itertuples()))
              + "; down " + ", ".join(f"{k:g} {text(d)}" for k, d in zip(k_ts, down.itertuples()))
              + f"; one attractor per k_t: {same}  ({time.perf_counter() - t0:.0f} s)", flush=True)
    n = len(moved)
    print(f"summary over {n} moved labels ({time.perf_counter() - t_all:.0f} s): "
          + ", ".join(f"{k} {v}/{n}" for k, v in counts.items()))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run", required=True, help="working directory of a finished run")
    ap.add_argument("--grid", default="default")
    ap.add_argument("--refinement", default="k_t", choices=MODEL_REFINEMENTS)
    ap.add_argument("--mapping", default="transfer", choices=("transfer", "same"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--ladder", type=float, nargs=2, metavar=("OMEGA", "F0_REL"),
                    help="instead: the attractors of this cell along --k-t")
    ap.add_argument("--k-t", type=float, nargs="+", default=[10.0, 20.0, 30.0])
    ap.add_argument("--starts", type=int, default=3, help="perturbed starts besides rest (--ladder)")
    ap.add_argument("--continuation", type=float, nargs="+", metavar="K_T",
                    help="instead: every moved k_t row's cell continued along these stiffnesses")
    args = ap.parse_args()

    run = Path(args.run)
    nm = as_numerics(yaml.safe_load((run / "config" / "config.yaml").read_text())["numerics"])
    table = pd.read_parquet(run / "results" / "regimes" / f"{args.grid}.parquet").set_index("point_id")
    if args.ladder:
        ladder(table, nm, *args.ladder, args.k_t, args.starts, args.threads)
        return
    conv = pd.read_parquet(run / "results" / "regimes" / args.grid / "convergence.parquet")
    store = PointStore(run / "results" / "store", "simulate")
    moved = conv[(conv["refinement"] == args.refinement) & ~conv["holds"].astype(bool)]
    if args.continuation:
        if args.refinement != "k_t":
            raise SystemExit("--continuation follows the k_t row's cells (--refinement k_t)")
        print(f"{len(moved)} of {int((conv['refinement'] == 'k_t').sum())} sampled labels move under k_t; "
              f"each cell continued along k_t {args.continuation}")
        continued(table, moved, nm, args.continuation, args.threads)
        return
    print(f"{len(moved)} of {int((conv['refinement'] == args.refinement).sum())} sampled labels move "
          f"under {args.refinement}; cross starts with mapping {args.mapping!r}")
    counts = dict.fromkeys(("map model keeps its label", "map model reaches the refined label",
                            "refined model keeps its label", "refined model reaches the map's label"), 0)
    t_all = time.perf_counter()
    for _, r in moved.iterrows():
        params = json.loads(table.loc[r["point_id"], "params_json"])
        refined, _ = refine(args.refinement, params, nm)
        m_map, m_ref = prepare_point(**params).model, prepare_point(**refined).model
        law = params.get("law", "stick-slip")
        rec_map, rec_ref = store.find(r["point_id"]), store.find(r["refined_point_id"])
        if rec_map is None or rec_ref is None:
            print(f"Omega {r['Omega']:.3f} f0_rel {r['f0_rel']:.3f}: a run is not in the store; left out")
            continue
        end_map, end_ref = rec_map["final_state"], rec_ref["final_state"]
        want_map = label_text(r["label"], r["period"])
        want_ref = label_text(r["refined_label"], r["refined_period"])
        t0 = time.perf_counter()
        cells = []
        to_map = crossed(end_ref, m_ref, m_map, args.mapping, law)
        to_ref = crossed(end_map, m_map, m_ref, args.mapping, law)
        for who, p, start, model, own, other, keep, reach in (
                ("map model from the refined end", params, to_map, m_map, want_map, want_ref,
                 "map model keeps its label", "map model reaches the refined label"),
                ("refined model from the map's end", refined, to_ref, m_ref, want_ref, want_map,
                 "refined model keeps its label", "refined model reaches the map's label")):
            a = point_attractors(p, [state_params(start, model.n, model.n_quad)], nm,
                                 threads=args.threads).iloc[0]
            got = label_text(a["label"], a["period"])
            if got == own:
                counts[keep] += 1
            elif got == other:
                counts[reach] += 1
            cells.append(f"{who}: {got} (lambda_1 T {a['lle_T']:+.3f} [{a['lle_lo_T']:+.3f}, "
                         f"{a['lle_hi_T']:+.3f}])")
        print(f"Omega {r['Omega']:.3f} f0_rel {r['f0_rel']:.3f}: {want_map} -> {want_ref}; "
              + "; ".join(cells) + f"  ({time.perf_counter() - t0:.0f} s)", flush=True)
    n = len(moved)
    print(f"summary over {n} moved labels ({time.perf_counter() - t_all:.0f} s): "
          + ", ".join(f"{k} {v}/{n}" for k, v in counts.items()))


if __name__ == "__main__":
    main()

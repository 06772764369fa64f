"""Do the labels of a model variant converge in the interface stiffness and the mode count?

Takes the convergence sample of a finished map (``analysis.pipeline.convergence.sample_points``
on ``results/regimes/<grid>.parquet``: the same points the map's convergence step re-ran),
changes the model of every sampled point by a variant (e.g. ``--set damping=0.01`` for 1 %
modal damping of the structure), runs the variant's own map labels through the pipeline's
stages, then its refinements (default ``k_t`` and ``modes``), and prints how many labels hold
-- the evidence for choosing a model default (docs/pipeline.md, "Convergence evidence").

    .venv/bin/python benchmarks/interface_convergence.py --set damping=0.01
    .venv/bin/python benchmarks/interface_convergence.py --set damping=0.0 --refinements k_t

Without a finished map, ``--cells N`` draws N points of the grid (``--grid``) uniformly with the
convergence seed instead, and the variant's own map is the reference of its refinements (the
k_t study of docs/pipeline.md):

    .venv/bin/python benchmarks/interface_convergence.py --cells 20 --set k_t=30 --refinements k_t
    .venv/bin/python benchmarks/interface_convergence.py --cells 20 --set k_t=30 \
        --set interface_damping=0 --set interface_viscosity=0.0939 --refinements k_t

For a full-slip or Stribeck variant the interface knob is the velocity band, not ``k_t``
(``--refinements band``; docs/pipeline.md, "The velocity band of the regularised laws").

``--labels chaotic`` takes every chaotic cell of the map instead of its sample (whether the
map's chaos survives a stiffer stick and one more mode, docs/pipeline.md, "The map's chaos
and tori under the model refinements"):

    .venv/bin/python benchmarks/interface_convergence.py --labels chaotic \
        --refinements k_t modes load_up load_down nudge

``--refinements`` with no name prints the variant's labels only; ``--config`` with a
``grid_file`` of its own runs the cells of another grid (e.g. a 1-D line through a band);
``--save PREFIX`` keeps the variant's table and the refinement runs as Parquet files (e.g. to
join them with a finished map's neighbour support: docs/pipeline.md, "Results version 19").

A few minutes per refinement on 2 cores (20 points); the runs go to a throw-away store.
"""

from __future__ import annotations

import argparse
import glob
import json
import tempfile
import time

import numpy as np
import pandas as pd
import yaml

from analysis.continuation import state_params
from analysis.pipeline.config import Numerics
from analysis.pipeline.convergence import (
    ConvergenceSettings,
    convergence_runs,
    convergence_summary,
    label_text,
    refine,
    same_label,
    sample_points,
)
from analysis.pipeline.grid import expand_grid, point_id
from analysis.pipeline.stages import (
    classify_points,
    lle_resolution,
    lyapunov_points,
    register_cached_modes,
    simulate_points,
)
from analysis.pipeline.table import assemble_regime_table
from beamsim.point import prepare_point


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", default="results/regimes/default.parquet")
    ap.add_argument("--cells", type=int, default=0,
                    help="sample this many grid points without a map (0: the map's convergence sample)")
    ap.add_argument("--grid", default="default", help="grid of config/grid.yaml for --cells")
    ap.add_argument("--labels", nargs="+", metavar="LABEL",
                    help="every cell of the map (--table) with one of these labels, e.g. chaotic, "
                         "instead of the map's convergence sample")
    ap.add_argument("--config", default="config/config.yaml")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="model override of the variant (repeatable), e.g. damping=0.01")
    ap.add_argument("--refinements", nargs="*", default=["k_t", "modes"],
                    help="refinements of convergence_runs (none: the variant's map only)")
    ap.add_argument("--continued", action="store_true",
                    help="also run each refinement (not modes) from the variant's end state")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--save", metavar="PREFIX",
                    help="write the variant's table and the refinement runs to PREFIX.map.parquet "
                         "and PREFIX.runs.parquet (for analysis beyond the printed summary)")
    args = ap.parse_args()

    cfg = yaml.safe_load(open(args.config))
    nm = Numerics.from_dict(cfg["numerics"])
    conv = ConvergenceSettings.from_dict(cfg.get("convergence"))
    register_cached_modes(sorted(glob.glob("results/modes/*/modes.parquet")))
    overrides = {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in args.set)}
    if args.cells:
        sample = grid_cells(cfg, args.grid, args.cells, conv.seed, nm)
        source = f"grid {args.grid} (no map)"
    elif args.labels:
        # the pipeline's census selection (convergence.census) without the sample's draws
        sample = sample_points(pd.read_parquet(args.table), 0, conv.seed, census=args.labels)
        source = f"{args.table}, every {' / '.join(args.labels)} cell"
    else:
        sample = sample_points(pd.read_parquet(args.table), conv.sample, conv.seed)
        source = args.table
    axes = [a for a in ("Omega", "f0_rel") if a in sample.columns]
    print(f"variant {overrides or 'shipped model'}; {len(sample)} sampled points of {source}")

    with tempfile.TemporaryDirectory() as store:
        t0 = time.perf_counter()
        pts = []
        for k, (_, row) in enumerate(sample.iterrows()):
            params = json.loads(row["params_json"]) | overrides
            pts.append({"point_id": point_id(params, nm), "params": params, "index": [k]})
        sim = simulate_points(pts, nm, store, args.threads)
        lyap = lyapunov_points(pts, sim, nm, store, args.threads)
        table = assemble_regime_table(pts, sim, lyap, classify_points(sim, lyap, lle_resolution(nm)))
        changed = ("" if args.cells else "; changed against the shipped map: "
                   f"{int((table['label'].to_numpy() != sample['label'].to_numpy()).sum())}/{len(table)}")
        print(f"variant map: {time.perf_counter() - t0:.0f} s; labels "
              f"{table['label'].value_counts().to_dict()}{changed}")
        for _, row in table.iterrows():
            lab = label_text(row["label"], row["period"])
            print(f"  {where(row, axes)}: {lab} "
                  f"(lambda_1 T {row['lle_mean'] * 2 * np.pi / row['omega']:.3f})")
        runs = []
        every = ConvergenceSettings(sample=len(table), seed=conv.seed)
        for ref in args.refinements:
            t0 = time.perf_counter()
            runs.append(convergence_runs(table, ref, nm, every, store, axes=axes, threads=args.threads))
            print(f"{ref}: {time.perf_counter() - t0:.0f} s")
        if not runs:
            return
        runs = pd.concat(runs, ignore_index=True)
        if args.save:
            table.to_parquet(f"{args.save}.map.parquet")
            runs.to_parquet(f"{args.save}.runs.parquet")
        for _, r in runs[~runs["holds"]].iterrows():
            was = label_text(r["label"], r["period"])
            now = label_text(r["refined_label"], r["refined_period"])
            print(f"  {r['refinement']}: {where(r, axes)}: {was} -> {now} "
                  f"(lambda_1 T {r['lle_T']:.3f} -> {r['refined_lle_T']:.3f})")
        summary = convergence_summary(runs)
        print(summary[["what", "n", "held", "contradicted", "flips"]].to_string(index=False))
        if args.continued:
            for ref in args.refinements:
                if ref != "modes":
                    continued_run(table, sim, ref, nm, store, args.threads, axes)


def continued_run(table: pd.DataFrame, sim: pd.DataFrame, refinement: str, nm: Numerics,
                  store: str, threads: int, axes: list[str]) -> None:
    """Run ``refinement`` of every point of ``table`` from the point's own end state (its
    variant's run) instead of from rest, and print how many labels hold: whether the attractor
    the variant reached persists under the refinement, apart from which attractor a start from
    rest picks in a multistable cell."""
    final = sim.set_index("point_id")["final_state"]
    pts = []
    for _, row in table.iterrows():
        params, nm_r = refine(refinement, json.loads(row["params_json"]), nm)
        model = prepare_point(**params).model
        state = state_params(np.asarray(final[row["point_id"]], dtype=float), model.n, model.n_quad)
        params |= {k: np.asarray(v, dtype=float).tolist() for k, v in state.items()}
        pts.append({"point_id": point_id(params, nm_r), "params": params})
    t0 = time.perf_counter()
    sim_r = simulate_points(pts, nm_r, store, threads)
    lyap_r = lyapunov_points(pts, sim_r, nm_r, store, threads)
    cls = classify_points(sim_r, lyap_r, lle_resolution(nm_r)).set_index("point_id")
    held = 0
    for (_, row), pt in zip(table.iterrows(), pts):
        r = cls.loc[pt["point_id"]]
        if same_label(row["label"], row["period"], r["label"], r["period"]):
            held += 1
        else:
            print(f"  {refinement} from the end state: {where(row, axes)}: "
                  f"{label_text(row['label'], row['period'])} -> {label_text(r['label'], r['period'])}")
    print(f"{refinement} from the end state: {held}/{len(table)} hold ({time.perf_counter() - t0:.0f} s)")


def where(row: pd.Series, axes: list[str]) -> str:
    """The axis values of a row, e.g. ``Omega 1.850 f0_rel 1.700``."""
    return " ".join(f"{a} {row[a]:.3f}" for a in axes)


def grid_cells(cfg: dict, grid: str, n: int, seed: int, nm: Numerics) -> pd.DataFrame:
    """``n`` points of ``grid`` (config/grid.yaml), drawn uniformly with ``seed``, in grid
    order, as rows with ``params_json`` and the axis values (the shape of a map's sample)."""
    grids = yaml.safe_load(open(cfg.get("grid_file", "config/grid.yaml")))["grids"]
    points = expand_grid(grid, grids[grid], cfg["model"], nm)
    pick = np.sort(np.random.default_rng(seed).choice(len(points), size=min(n, len(points)), replace=False))
    rows = [{"params_json": json.dumps(points[k].params)}
            | {a: points[k].params[a] for a in grids[grid]["axes"]} for k in pick]
    return pd.DataFrame(rows)


if __name__ == "__main__":
    main()

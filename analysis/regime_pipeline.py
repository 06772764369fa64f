"""The stages of the regime pipeline, one function per Snakemake rule (rules stay thin).

Every stage takes a chunk of grid points (``[{"point_id": ..., "params": {...}}, ...]``),
looks each point up in the content-addressed :class:`analysis.point_store.PointStore`,
computes only the missing ones (batched, threads inside), and returns one table row per
point in the chunk's order.  Progress (points done / total) goes to the ``logging`` log.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd

from analysis.grid import canonical_json
from analysis.point_store import PointStore

log = logging.getLogger("regimes")


def _cached_stage(points: Sequence[dict], store: PointStore, compute: Callable[[list[dict]], list[dict]],
                  batch_size: int, stage: str) -> list[dict]:
    """Records for ``points``: from the store where present, else ``compute``d in batches."""
    todo = [p for p in points if not store.has(p["point_id"])]
    n, done = len(points), len(points) - len(todo)
    log.info("%s: %d points, %d cached, %d to compute", stage, n, done, len(todo))
    t0 = time.perf_counter()
    for start in range(0, len(todo), batch_size):
        batch = todo[start:start + batch_size]
        for p, rec in zip(batch, compute(batch)):
            store.save(p["point_id"], rec)
        done += len(batch)
        log.info("%s: %d / %d points done (%.1f s)", stage, done, n, time.perf_counter() - t0)
    return [store.load(p["point_id"]) for p in points]


# ----------------------------------------------------------------------------- simulate
def integrator(method: str, params: dict) -> str:
    """``auto``: the exact piecewise-linear ``expo`` integrator where it applies (stick-slip),
    the RK4 reference otherwise."""
    if method != "auto":
        return method
    return "expo" if params.get("law", "stick-slip") == "stick-slip" else "rk4"


def _simulate_group(points: list[dict], numerics: dict, threads: int) -> list[dict]:
    """Reference and twin trajectories of each point in one batch, recorded from t = 0."""
    from analysis.beam_lyapunov import twin_perturbation
    from beamsim.simulate import prepare_point, simulate_batch

    n_trans, n_rec = numerics["n_transient"], numerics["n_record"]
    twins = [p["params"] | {"q0": twin_perturbation(prepare_point(**p["params"]))} for p in points]
    res = simulate_batch([p["params"] for p in points] + twins, n_transient=0, n_record=n_trans + n_rec,
                         method=integrator(numerics["method"], points[0]["params"]),
                         steps_per_period=numerics.get("steps_per_period"), n_threads=threads)
    out = []
    for r, tw in zip(res.results[: len(points)], res.results[len(points):]):
        energy = r.energy[n_trans:]
        w_in = float(energy[-1, 0] - energy[0, 0])
        residual = r.energy_residual[-1] - r.energy_residual[n_trans]
        diss = np.diff(energy[:, 1])
        out.append({
            "poincare_state": r.poincare_state[n_trans:], "poincare_tip": r.poincare_tip[n_trans:],
            "poincare_state_all": r.poincare_state, "twin_state_all": tw.poincare_state,
            "f0": r.f0, "f_cr": r.f_cr, "omega": r.omega, "Omega": r.Omega, "lam_f": r.lam_f,
            "steps_per_period": r.steps_per_period, "method": r.method,
            "diverged": bool(r.diverged or tw.diverged), "t_diverged": r.t_diverged,
            "slipped": r.slipped, "t_first_slip": r.t_first_slip,
            "stick_fraction": r.stick_fraction,
            "diss_per_cycle": float(np.mean(diss)) if np.isfinite(diss).all() else np.nan,
            "energy_residual_rel": float(abs(residual) / abs(w_in)) if w_in != 0 else np.nan,
        })
    return out


def simulate_points(points: Sequence[dict], numerics: dict, store_root: str, threads: int = 1) -> pd.DataFrame:
    """Stage 1: time integration; one row per point with its Poincare samples."""
    store = PointStore(store_root, "simulate")

    def compute(batch: list[dict]) -> list[dict]:
        # a batch must share the state size and the integrator
        groups: dict = {}
        for i, p in enumerate(batch):
            key = (p["params"].get("n_modes"), p["params"].get("n_quad"), integrator(numerics["method"], p["params"]))
            groups.setdefault(key, []).append(i)
        recs: list = [None] * len(batch)
        for idx in groups.values():
            for i, rec in zip(idx, _simulate_group([batch[i] for i in idx], numerics, threads)):
                recs[i] = rec
        return recs

    recs = _cached_stage(points, store, compute, batch_size=max(2 * threads, 16), stage="simulate")
    return _table(points, recs)


def _table(points: Sequence[dict], recs: Sequence[dict]) -> pd.DataFrame:
    rows = []
    for p, rec in zip(points, recs):
        row = {"point_id": p["point_id"]}
        for k, v in rec.items():
            row[k] = v.tolist() if isinstance(v, np.ndarray) else v
        rows.append(row)
    return pd.DataFrame(rows)


def poincare_array(value) -> np.ndarray:
    """A stored Poincare column (list of lists) back to a 2-D float array."""
    return np.array([np.asarray(r, dtype=float) for r in value], dtype=float)


# ----------------------------------------------------------------------------- lyapunov
def lyapunov_points(points: Sequence[dict], simulated: pd.DataFrame, numerics: dict) -> pd.DataFrame:
    """Stage 2: ``lambda_1`` (per unit time) of every point.

    * ``lle_two_trajectory``: separation of the twin trajectories integrated by stage 1
      (:func:`analysis.beam_lyapunov.twin_lle`);
    * ``lle_nolds``: Rosenstein's estimate (``nolds.lyap_r``) on the stroboscopic series of the
      tip radial displacement (NaN when the record is too short for the embedding);
    * ``lle_stefanski``: not computed for the beam yet (NaN; see docs/pipeline.md).
    """
    from analysis.beam_lyapunov import twin_lle
    from analysis.lyapunov import nolds_lle

    sim = simulated.set_index("point_id")
    emb_dim = int(numerics.get("lyapunov", {}).get("nolds_emb_dim", 6))
    rows = []
    for i, p in enumerate(points):
        r = sim.loc[p["point_id"]]
        period = 2.0 * np.pi / r["omega"]
        est = twin_lle(poincare_array(r["poincare_state_all"]), poincare_array(r["twin_state_all"]),
                       period, settled_from=numerics["n_transient"])
        series = poincare_array(r["poincare_tip"])[:, 0]
        try:
            lle_nolds = float(nolds_lle(series, sample_dt=period, emb_dim=emb_dim).value)
        except Exception as exc:  # nolds rejects short or constant series
            log.info("nolds: point %s: %s", p["point_id"], exc)
            lle_nolds = np.nan
        rows.append({"point_id": p["point_id"], "lle_two_trajectory": est.value,
                     "lle_two_trajectory_verdict": est.verdict, "lle_nolds": lle_nolds,
                     "lle_stefanski": np.nan})
        if (i + 1) % 25 == 0 or i + 1 == len(points):
            log.info("lyapunov: %d / %d points done", i + 1, len(points))
    return pd.DataFrame(rows)


# ----------------------------------------------------------------------------- classify
def classify_points(simulated: pd.DataFrame, lyapunov: pd.DataFrame) -> pd.DataFrame:
    """Stage 3: a label per point from its Poincare samples and its largest Lyapunov exponent.

    Non-results first: ``diverged`` (the integrator flagged the point), ``unsettled``
    (:func:`analysis.regimes.is_settled` says the transient is not over); otherwise
    :func:`analysis.regimes.classify` on the stroboscopic samples of all generalised
    coordinates and velocities, with ``lambda_1`` (two-trajectory estimate) per forcing period
    when that estimate is a proper fit (else the other indicators decide alone).
    """
    from analysis.regimes import DIVERGED, UNSETTLED, classify, is_settled

    lle = lyapunov.set_index("point_id")
    rows = []
    for _, sim in simulated.iterrows():
        pid = sim["point_id"]
        period_t = 2.0 * np.pi / sim["omega"]
        lam = lle.loc[pid, "lle_two_trajectory"] if pid in lle.index else np.nan
        # only a proper fit is evidence; a separation that saturates within a few periods
        # (a stick/slip outcome flipped by the perturbation) is not an exponent
        if pid not in lle.index or not str(lle.loc[pid, "lle_two_trajectory_verdict"]).startswith("fit over"):
            lam = np.nan
        row = {"point_id": pid, "label": None, "period": None, "reason": "", "K": np.nan,
               "spectral_growth": np.nan, "n_clusters": np.nan, "settled": False}
        x = poincare_array(sim["poincare_state"])
        if sim["diverged"] or not np.all(np.isfinite(x)):
            row.update(label=DIVERGED, reason="integration diverged")
        elif not is_settled(x):
            row.update(label=UNSETTLED, reason="transient not over: first and second half of the "
                       "Poincare record differ (is_settled)")
        else:
            res = classify(x, lle_per_period=(lam * period_t) if np.isfinite(lam) else None)
            ind = dict(res.indicators)
            row.update(label=res.label, period=res.period, reason=res.reason, settled=True,
                       K=ind.get("K", np.nan), spectral_growth=ind.get("spectral_growth", np.nan),
                       n_clusters=ind.get("n_clusters", np.nan))
        rows.append(row)
    out = pd.DataFrame(rows)
    out["period"] = out["period"].astype("Int64")
    return out


# ----------------------------------------------------------------------------- regime table
#: columns of the regime table besides the model parameters (docs/pipeline.md)
TABLE_COLUMNS = (
    "point_id", "label", "period", "lle_two_trajectory", "lle_stefanski", "lle_nolds", "K",
    "spectral_growth", "n_clusters", "slipped", "t_first_slip", "stick_fraction",
    "diss_per_cycle", "f0", "f_cr", "omega", "Omega", "lam_f", "diverged", "settled",
    "energy_residual_rel", "lle_two_trajectory_verdict", "reason",
)


def assemble_regime_table(grid_points: Sequence[dict], simulated: pd.DataFrame, lyapunov: pd.DataFrame,
                          classified: pd.DataFrame) -> pd.DataFrame:
    """Stage 4: one row per grid point in grid order (first axis slowest), parameters first."""
    by_id = (classified.set_index("point_id")
             .join(lyapunov.set_index("point_id"), rsuffix="_lle")
             .join(simulated.set_index("point_id"), rsuffix="_sim"))
    param_names = sorted({k for p in grid_points for k in p["params"]})
    rows = []
    for p in grid_points:
        r = by_id.loc[p["point_id"]]
        row = {k: p["params"].get(k) for k in param_names}
        row.update({f"index_{i}": v for i, v in enumerate(p["index"])})
        row.update({c: r[c] if c in r.index else None for c in TABLE_COLUMNS if c != "point_id"})
        row["point_id"] = p["point_id"]
        row["params_json"] = canonical_json(p["params"])
        tip = poincare_array(r["poincare_tip"])
        row["poincare_w_tip"] = tip[:, 0].tolist() if tip.size else []
        rows.append(row)
    table = pd.DataFrame(rows)
    table["period"] = table["period"].astype("Int64")
    return table


def package_versions() -> dict:
    """Versions of the packages a regime table depends on."""
    from importlib.metadata import PackageNotFoundError, version

    out = {}
    for name in ("beamsim", "numpy", "scipy", "numba", "pandas", "pyarrow", "nolds", "snakemake"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = None
    return out


def write_regime_table(table: pd.DataFrame, path: str, *, grid_name: str, grid: dict, config: dict,
                       config_hash: str) -> None:
    """Write the table to Parquet with ``beamsim.regimes`` metadata (grid, config, config hash,
    package versions); atomically, so a failed run never leaves a partial table."""
    import json
    import os

    import pyarrow as pa
    import pyarrow.parquet as pq

    tab = pa.Table.from_pandas(table, preserve_index=False)
    meta = {"grid_name": grid_name, "grid": grid, "config": config, "config_hash": config_hash,
            "versions": package_versions()}
    tab = tab.replace_schema_metadata({**(tab.schema.metadata or {}),
                                       b"beamsim.regimes": json.dumps(meta, sort_keys=True).encode()})
    tmp = f"{path}.tmp"
    pq.write_table(tab, tmp)
    os.replace(tmp, path)


def read_regime_metadata(path: str) -> dict:
    """The ``beamsim.regimes`` metadata of a regime table."""
    import json

    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[b"beamsim.regimes"])


# ----------------------------------------------------------------------------- portraits
def portrait_case(row: pd.Series, axes: list[str], numerics: dict, samples_per_period: int = 64,
                  n_show: int = 40) -> dict:
    """Dense tip history of one grid point for its phase portrait and Poincare map.

    Re-simulates the point (same parameters and numerics as the table) with a dense output of
    ``samples_per_period`` per period; the velocity is the central difference of the dense
    tip displacement.  Returns the data :func:`analysis.regime_figures.plot_portraits` draws.
    """
    import json

    from beamsim.simulate import simulate

    params = json.loads(row["params_json"])
    spp = numerics.get("steps_per_period")
    if spp is not None:
        spp = max(samples_per_period, int(np.ceil(spp / samples_per_period) * samples_per_period))
    r = simulate(n_transient=numerics["n_transient"], n_record=numerics["n_record"],
                 method=integrator(numerics["method"], params), steps_per_period=spp,
                 dense_per_period=samples_per_period, **params)
    t, w = r.dense_t, r.dense[:, 0]
    w_dot = np.gradient(w, t)
    tail = slice(len(t) - n_show * samples_per_period - 1, len(t))
    start = numerics["n_transient"] * samples_per_period
    pidx = np.arange(start, len(t), samples_per_period)
    where = ", ".join(f"{a}={row[a]:g}" for a in axes)
    title = f"{where}: {row['label']}" + (f" (period {int(row['period'])})" if pd.notna(row["period"]) else "")
    return {"title": title, "t": t[tail], "w": w[tail], "w_dot": w_dot[tail], "pw": w[pidx], "pw_dot": w_dot[pidx]}


def register_cached_modes(files: Sequence[str]) -> None:
    """Hand the workflow's cached arch modes (one Parquet file per geometry) to the model."""
    from beamsim.mode_cache import read_modes
    from beamsim.two_layer import register_modes

    for f in files:
        register_modes(read_modes(f))

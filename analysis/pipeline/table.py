"""The regime table: one row per grid point (parameters, label, exponents, indicators), and its
Parquet file with the run's metadata (grid, config, config hash, package and results versions).
Column meanings: docs/pipeline.md."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from analysis.pipeline.atomic import atomic_output
from analysis.pipeline.grid import canonical_json
from analysis.pipeline.neighbours import neighbour_support
from analysis.pipeline.stages import poincare_array

__all__ = ["TABLE_COLUMNS", "assemble_regime_table", "index_columns", "lock_ratios", "package_versions",
           "read_regime_metadata", "write_regime_table"]

#: columns of the regime table besides the model parameters (docs/pipeline.md)
TABLE_COLUMNS = (
    "point_id", "label", "period", "lle_mean", "lle_se", "lle_lo", "lle_hi", "lle_periods",
    "lle_verdict", "lle_blocks", "lle_stefanski", "lle_benettin", "lle_nolds",
    "lle_stefanski_lo", "lle_stefanski_hi", "n_transient_used", "long_run", "K", "spectral_growth",
    "n_clusters", "slipped",
    "t_first_slip", "stick_fraction", "diss_per_cycle", "f0", "f_cr", "omega", "Omega", "lam_f",
    "diverged", "settled", "energy_residual_rel", "lle_stefanski_verdict", "method", "lle_free_copy",
    "stuck_bound", "lle_expo_mean", "lle_expo_lo", "lle_expo_hi", "lle_expo_floor", "reason",
)


def index_columns(table: pd.DataFrame) -> list[str]:
    """The grid-position columns of a regime table, ``index_0``, ``index_1``, ... in axis order
    (:func:`assemble_regime_table`)."""
    return sorted((c for c in table.columns if c.startswith("index_")), key=lambda c: int(c[6:]))


def lock_ratios(params: Sequence[dict]) -> np.ndarray:
    """Per point (parameter dicts), its ``(lock_ratio, shakedown_ratio)``
    (:func:`analysis.pipeline.stages.locked_ratios`) as an ``(n, 2)`` array: below 1, a locked
    (everywhere-stuck) period-1 motion exists / every motion's total slip is finite and it
    converges to a locked orbit; NaN without an elastic stick (and the second where a stuck
    mode is undamped)."""
    from analysis.pipeline.stages import locked_ratios

    return np.array([locked_ratios(p) for p in params], dtype=float).reshape(-1, 2)


def assemble_regime_table(grid_points: Sequence[dict], simulated: pd.DataFrame, lyapunov: pd.DataFrame,
                          classified: pd.DataFrame) -> pd.DataFrame:
    """Stage 4: one row per grid point in grid order (first axis slowest), parameters first;
    then the lock-up and shakedown ratios (``lock_ratio``, ``shakedown_ratio``:
    :func:`lock_ratios`); last the neighbour support of
    each label (``n_neighbours``, ``neighbours_same``:
    :func:`analysis.pipeline.neighbours.neighbour_support`)."""
    by_id = (classified.merge(lyapunov, on="point_id", how="left", suffixes=("", "_lle"))
             .merge(simulated, on="point_id", how="left", suffixes=("", "_sim"))
             .set_index("point_id"))
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
    table[["lock_ratio", "shakedown_ratio"]] = lock_ratios([p["params"] for p in grid_points])
    # how many grid neighbours share each label (analysis.pipeline.neighbours)
    return table.join(neighbour_support(table))


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
    package versions, the results and classifier versions); atomically, so a failed run never
    leaves a partial table."""
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    from analysis.pipeline.grid import RESULTS_VERSION
    from analysis.regimes import CLASSIFIER_VERSION

    tab = pa.Table.from_pandas(table, preserve_index=False)
    meta = {"grid_name": grid_name, "grid": grid, "config": config, "config_hash": config_hash,
            "versions": package_versions(), "results_version": RESULTS_VERSION,
            "classifier_version": CLASSIFIER_VERSION}
    tab = tab.replace_schema_metadata({**(tab.schema.metadata or {}),
                                       b"beamsim.regimes": json.dumps(meta, sort_keys=True).encode()})
    with atomic_output(path) as tmp:
        pq.write_table(tab, tmp)


def read_regime_metadata(path: str) -> dict:
    """The ``beamsim.regimes`` metadata of a regime table."""
    import json

    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[b"beamsim.regimes"])

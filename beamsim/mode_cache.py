"""On-disk cache of arch modes: one Parquet file per geometry, geometry in the metadata.

The workflow names each file by :func:`cache_key`, so a file is rebuilt only when the
geometry it describes changes, and files for other geometries stay valid.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Mapping

import pyarrow as pa
import pyarrow.parquet as pq

from beamsim.modes import BOUNDARY_CONDITIONS, ArchModes

_KEY = re.compile(r"^alpha(?P<alpha>[0-9.eE+-]+)_beta(?P<beta>[0-9.eE+-]+)_(?P<bc>[a-z-]+)_n(?P<n>[0-9]+)$")
METADATA_KEY = b"beamsim.geometry"


def cache_key(alpha: float, beta: float, bc: str, n_modes: int) -> str:
    """File stem that identifies a geometry, e.g. ``alpha0.01_beta0.4_clamped-free_n6``.

    ``repr`` of the floats keeps the key exact (no rounding collisions).
    """
    if bc not in BOUNDARY_CONDITIONS:
        raise ValueError(f"bc must be one of {', '.join(BOUNDARY_CONDITIONS)}; got {bc!r}")
    return f"alpha{float(alpha)!r}_beta{float(beta)!r}_{bc}_n{int(n_modes)}"


def model_cache_key(params: Mapping, n_modes: int | None = None) -> str:
    """:func:`cache_key` of the modes a model with these parameters (``alpha1``, ``alpha2``,
    ``alpha_modes``, ``beta``, ``bc``, ``n_modes``, as in :class:`beamsim.two_layer.Geometry`)
    needs; ``n_modes`` overrides the parameter's."""
    from beamsim.two_layer import basis_thickness

    alpha = basis_thickness(params["alpha1"], params.get("alpha2", params["alpha1"]),
                            params.get("alpha_modes"))
    return cache_key(alpha, params["beta"], params.get("bc", "clamped-free"),
                     params["n_modes"] if n_modes is None else n_modes)


def parse_cache_key(key: str) -> dict:
    """Inverse of :func:`cache_key`: ``{"alpha", "beta", "bc", "n_modes"}``."""
    m = _KEY.match(key)
    if m is None or m["bc"] not in BOUNDARY_CONDITIONS:
        raise ValueError(f"not a mode cache key: {key!r}")
    alpha, beta = float(m["alpha"]), float(m["beta"])
    if not (math.isfinite(alpha) and math.isfinite(beta)):
        raise ValueError(f"not a mode cache key: {key!r}")
    return {"alpha": alpha, "beta": beta, "bc": m["bc"], "n_modes": int(m["n"])}


def write_modes(modes: ArchModes, path: str | Path, extra_metadata: dict | None = None) -> None:
    """Write ``modes`` to Parquet (one row per mode); geometry and versions go in the metadata."""
    import beamsim

    table = pa.Table.from_pandas(modes.to_table(), preserve_index=False)
    meta = {"alpha": modes.alpha, "beta": modes.beta, "bc": modes.bc, "n_modes": modes.n_modes,
            "beamsim_version": beamsim.__version__} | (extra_metadata or {})
    table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                           METADATA_KEY: json.dumps(meta).encode()})
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(path.suffix + ".tmp")
    pq.write_table(table, tmp)
    tmp.replace(path)  # atomic: a failed write never leaves a half file under the real name


def read_geometry(path: str | Path) -> dict:
    """The geometry metadata stored by :func:`write_modes`."""
    meta = pq.read_schema(path).metadata or {}
    if METADATA_KEY not in meta:
        raise ValueError(f"{path} carries no beamsim geometry metadata")
    return json.loads(meta[METADATA_KEY])


def read_modes(path: str | Path) -> ArchModes:
    """Load modes written by :func:`write_modes`."""
    geom = read_geometry(path)
    return ArchModes.from_table(pq.read_table(path).to_pandas(), geom["alpha"], geom["beta"], geom["bc"])

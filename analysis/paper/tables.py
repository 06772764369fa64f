"""The paper target's Parquet tables (measured runs, verdicts) with their metadata: the paper
config, the numerics, the config hash and the package versions."""

from __future__ import annotations

import json

import pandas as pd

from analysis.pipeline.atomic import atomic_output

__all__ = ["write_paper_table", "read_paper_metadata", "paper_config_hash"]

_KEY = b"beamsim.paper"


def paper_config_hash(table_config: dict, paper: dict) -> str:
    """16 hex digits of the workflow config (without run-only keys) and the paper config."""
    import hashlib

    from analysis.pipeline.grid import canonical_json

    return hashlib.sha256(canonical_json({"config": table_config, "paper": paper}).encode()).hexdigest()[:16]


def write_paper_table(table: pd.DataFrame, path: str, **metadata) -> None:
    """Write ``table`` to Parquet, atomically, with ``metadata`` (JSON) and the package and
    results versions under the ``beamsim.paper`` key."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from analysis.pipeline.grid import RESULTS_VERSION
    from analysis.pipeline.table import package_versions
    from analysis.regimes import CLASSIFIER_VERSION

    tab = pa.Table.from_pandas(table, preserve_index=False)
    meta = dict(metadata, versions=package_versions(), results_version=RESULTS_VERSION,
                classifier_version=CLASSIFIER_VERSION)
    tab = tab.replace_schema_metadata({**(tab.schema.metadata or {}),
                                       _KEY: json.dumps(meta, sort_keys=True, default=str).encode()})
    with atomic_output(path) as tmp:
        pq.write_table(tab, tmp)


def read_paper_metadata(path: str) -> dict:
    import pyarrow.parquet as pq

    return json.loads(pq.read_schema(path).metadata[_KEY])

"""Atomic file output: a result file is either complete or absent, never half-written.

Every file the pipeline writes goes through :func:`atomic_output`: the writer fills a temporary
file in the target's directory, which is renamed onto the target only when the writer returned
(``os.replace``, atomic on POSIX within one filesystem).  A writer that fails (a full disk, a
read-only directory) leaves no temporary file behind; one killed with SIGKILL may leave a hidden
``.<name>.<pid>.tmp`` file, which nothing reads.  A target that existed before stays untouched
until the new file is complete.
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import pandas as pd

__all__ = ["atomic_output", "write_parquet"]


@contextmanager
def atomic_output(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path next to ``path`` (same suffix) to write; rename it onto ``path``
    when the block completes, remove it when the block raises."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_parquet(table: pd.DataFrame, path: str | Path, metadata: Mapping[str, Any] | None = None) -> None:
    """``table.to_parquet(path, index=False)``, atomically; ``metadata``: extra schema metadata,
    key -> a JSON-serialisable value (stored as sorted-key JSON)."""
    if not metadata:
        with atomic_output(path) as tmp:
            table.to_parquet(tmp, index=False)
        return
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    tab = pa.Table.from_pandas(table, preserve_index=False)
    extra = {k.encode(): json.dumps(v, sort_keys=True).encode() for k, v in metadata.items()}
    tab = tab.replace_schema_metadata({**(tab.schema.metadata or {}), **extra})
    with atomic_output(path) as tmp:
        pq.write_table(tab, tmp)

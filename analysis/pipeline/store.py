"""Content-addressed store of per-point results, one file per (stage, point id).

The pipeline's chunk jobs look a point up here before computing it, so a point is computed
once whatever grid or chunk asks for it (its id is a hash of its parameters, see
:mod:`analysis.pipeline.grid`).  Files are written atomically (:mod:`analysis.pipeline.atomic`), so an
interrupted job never leaves a half-written record that a later run would trust; a record that is
damaged anyway (truncated by a full disk, edited by hand) does not load (:meth:`PointStore.find`)
and is recomputed.
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from analysis.pipeline.atomic import atomic_output


class PointStore:
    """``root/<stage>/<id[:2]>/<id>.npz`` holding arrays plus a JSON ``meta`` dict of scalars."""

    def __init__(self, root: str | Path, stage: str):
        self.dir = Path(root) / stage

    def path(self, pid: str) -> Path:
        return self.dir / pid[:2] / f"{pid}.npz"

    def has(self, pid: str) -> bool:
        return self.path(pid).is_file()

    def load(self, pid: str) -> dict:
        with np.load(self.path(pid), allow_pickle=False) as z:
            out = {k: z[k] for k in z.files if k != "__meta__"}
            out.update(json.loads(str(z["__meta__"])))
        return out

    def find(self, pid: str) -> dict | None:
        """The record of ``pid``, or None if there is none or it does not load (damaged)."""
        if not self.has(pid):
            return None
        try:
            return self.load(pid)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
            return None

    def save(self, pid: str, record: dict) -> None:
        arrays = {k: np.asarray(v) for k, v in record.items() if isinstance(v, np.ndarray)}
        meta = {k: v for k, v in record.items() if not isinstance(v, np.ndarray)}
        path = self.path(pid)
        path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_output(path) as tmp:
            np.savez(tmp, __meta__=np.array(json.dumps(meta, default=_json_default)), **arrays)


def _json_default(value):
    if isinstance(value, (np.floating, np.integer, np.bool_)):
        return value.item()
    raise TypeError(f"cannot store {type(value).__name__} in a point record")

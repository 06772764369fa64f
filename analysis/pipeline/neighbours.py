"""Neighbour support of a regime map's labels: how many of a cell's grid neighbours carry its
label.

A label that no grid neighbour shares is a feature finer than the grid: a narrow periodic
window, a locking tongue, the edge of a chaotic band, a cell whose exponent sits at the
margin.  Such a label is a property of that parameter point, but a small change of the
numerics or of the model (a stiffer stick, one more mode, 2 % more load) is as large a
perturbation as a step to the next cell, so it cannot be expected to hold there.  The
convergence evidence measures that on a sample (the controls,
:mod:`analysis.pipeline.convergence`); the neighbour support says it for every cell of the map
at no cost: it is read from the labels alone.

Neighbours are the cells one grid step away along one axis (up to 4 on a 2-D map, 2 on a line);
a label is shared when it is the same regime and, for a periodic orbit, the same period
(:func:`analysis.pipeline.convergence.same_label`), so an ``undetermined`` cell among
``undetermined`` cells is supported too: the map says the same thing there.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["neighbour_support", "supported"]


def neighbour_support(table: pd.DataFrame) -> pd.DataFrame:
    """Per row of a regime table (same order): ``n_neighbours``, the cells one step away along
    one axis that the table has, and ``neighbours_same``, those with the same label
    (:func:`~analysis.pipeline.convergence.same_label`).  The grid positions are the table's
    ``index_0``, ``index_1``, ... columns; a table without them (or a single point) has no
    neighbours (0 and 0)."""
    from analysis.pipeline.convergence import label_text
    from analysis.pipeline.table import index_columns

    cols = index_columns(table)
    n = len(table)
    n_nb = np.zeros(n, np.int64)
    n_same = np.zeros(n, np.int64)
    if cols and n:
        pos = [tuple(int(v) for v in row) for row in table[cols].to_numpy()]
        labels = [label_text(a, p) for a, p in zip(table["label"], table["period"])]
        at = dict(zip(pos, labels))
        for i, (p, lab) in enumerate(zip(pos, labels)):
            for axis in range(len(cols)):
                for step in (-1, 1):
                    q = p[:axis] + (p[axis] + step,) + p[axis + 1:]
                    if q in at:
                        n_nb[i] += 1
                        n_same[i] += at[q] == lab
    return pd.DataFrame({"n_neighbours": n_nb, "neighbours_same": n_same}, index=table.index)


def supported(table: pd.DataFrame) -> pd.Series:
    """Boolean per row: the label is shared by at least one grid neighbour; NA for a cell
    without neighbours, or a table without the columns of :func:`neighbour_support`."""
    if "neighbours_same" not in table or "n_neighbours" not in table:
        return pd.Series(pd.NA, index=table.index, dtype="boolean")
    out = pd.Series(table["neighbours_same"].astype("Int64") > 0, dtype="boolean")
    return out.mask(table["n_neighbours"].astype("Int64").fillna(0) == 0)

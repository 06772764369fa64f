"""Figure of a continuation line (:mod:`analysis.continuation`): bifurcation diagram of the up-
and down-sweep in two colours, each branch's labels, and the ``lambda_1`` curves with their
confidence bands."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch

from analysis.figures.regimes import (
    LABEL_COLOURS,
    LIMIT_STYLE,
    _axis_label,
    _edges,
    label_key,
    limit_ratios,
    lock_up_crossings,
)

#: colour of each sweep direction
BRANCH_COLOURS = {"up": "#1f77b4", "down": "#d62728"}


#: the legend of the limits on a line (:func:`analysis.figures.regimes.limit_ratios`)
LINE_LIMIT_TEXT = {"lock-up": "lock-up limit: on the side where the lock ratio is below 1 a locked "
                              "period-1 state exists",
                   "shakedown": "shakedown limit: on the side where the kinetic ratio is below 1 "
                                "every motion converges to a locked orbit"}


def plot_continuation(table: pd.DataFrame, axis: str, line: dict, name: str, path: str,
                      margin: float = 0.05, dpi: int = 130) -> None:
    """Three panels sharing the axis: the tip's Poincare samples of both branches (up: dots,
    down: rings; the same attractor on both shows as a filled ring), a strip with each branch's
    label per point, and ``lambda_1 T`` (block mean, 95 % band) per branch with the margin."""
    from analysis.continuation import hysteresis

    spec = line["axes"][axis]
    log = isinstance(spec, dict) and spec.get("scale") == "log"
    fig, (ax0, ax1, ax2) = plt.subplots(3, 1, figsize=(9, 8), sharex=True, constrained_layout=True,
                                        gridspec_kw={"height_ratios": [3.0, 0.5, 2.0]})
    for b, style in (("down", dict(marker="o", mfc="none", ms=3.5, mew=0.6)),
                     ("up", dict(marker=".", ms=2.0))):
        t = table[table["branch"] == b]
        xs = np.concatenate([np.full(len(w), x) for x, w in zip(t[axis], t["poincare_w_tip"])])
        ws = np.concatenate([np.asarray(w, dtype=float) for w in t["poincare_w_tip"]])
        ax0.plot(xs, ws, ls="", color=BRANCH_COLOURS[b], label=f"{b}-sweep", **style)
    ax0.set_ylabel(r"tip $w(\beta)/R$ at $t = kT$")
    ax0.legend(fontsize=8, loc="best")
    hy = hysteresis(table, axis)
    fixed = ", ".join(f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}"
                      for k, v in line.get("fixed", {}).items())
    ax0.set_title(f"Continuation line '{name}' ({fixed}): up- and down-sweep\n"
                  f"labels differ at {int(hy['differs'].sum())} of {len(hy)} points, attractors "
                  f"(Poincare sets) at {int((hy['same_attractor'] == False).sum())}",  # noqa: E712
                  fontsize=9)

    keys = list(LABEL_COLOURS)
    codes = {k: i for i, k in enumerate(keys)}
    xs = np.sort(table[axis].unique())
    edges = _edges(xs, log)
    z = np.full((2, xs.size), np.nan)
    for row, b in enumerate(("up", "down")):
        t = table[table["branch"] == b]
        for x, lab, per in zip(t[axis], t["label"], t["period"]):
            z[row, np.searchsorted(xs, x)] = codes[label_key(lab, per)]
    ax1.pcolormesh(edges, [0, 1, 2], z, cmap=ListedColormap(list(LABEL_COLOURS.values())),
                   vmin=-0.5, vmax=len(keys) - 0.5, edgecolors="white", linewidth=0.3)
    ax1.set_yticks([0.5, 1.5], ["up", "down"], fontsize=8)
    present = sorted({int(c) for c in z[np.isfinite(z)]})
    ax1.legend(handles=[Patch(color=LABEL_COLOURS[keys[c]], label=keys[c]) for c in present],
               fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.4))

    for b in ("up", "down"):
        t = table[table["branch"] == b].sort_values(axis)
        ax2.fill_between(t[axis], t["lle_lo_T"].clip(lower=-1.0), t["lle_hi_T"], color=BRANCH_COLOURS[b],
                         alpha=0.2, lw=0)
        ax2.plot(t[axis], t["lle_T"], "o-", ms=3, color=BRANCH_COLOURS[b],
                 label=f"{b}: block mean, 95 % band")
    ax2.axhline(0.0, color="0.5", lw=0.8)
    ax2.axhline(margin, color="k", ls=":", lw=0.8, label=f"margin {margin:g}")
    ax2.set_ylabel(r"$\lambda_1 T$ (per forcing period)")
    if "lock_ratio" in table.columns:
        one = table.drop_duplicates("k")  # the ratios are the point's, the same on both branches
        for limit, ratio in limit_ratios(one).items():
            for i, x in enumerate(lock_up_crossings(one[axis].to_numpy(float), ratio)):
                for ax in (ax0, ax1, ax2):
                    ax.axvline(x, color="black", ls=LIMIT_STYLE[limit]["ls"], lw=1.0,
                               label=LINE_LIMIT_TEXT[limit] if ax is ax2 and i == 0 else None)
    ax2.legend(fontsize=7)
    if log:
        ax2.set_xscale("log")
    ax2.set_xlabel(_axis_label(axis))
    fig.savefig(path, dpi=dpi)
    plt.close(fig)

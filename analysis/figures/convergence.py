"""Figure of a map's convergence evidence (:mod:`analysis.pipeline.convergence`): the fraction
of sampled points whose label holds under each refinement, and every sampled point's label
before and after each refinement."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch

from analysis.figures.regimes import LABEL_COLOURS, label_key
from analysis.pipeline.convergence import CONTROLS

#: the fraction of sampled points whose label must hold under every refinement (issue target)
HOLD_TARGET = 0.95


def row_labels(summary: pd.DataFrame) -> list[str]:
    """The left panel's row names: the refinement (``control: ...`` for a control) and, for a
    model row whose moved labels were followed from the map's attractor (``followed``), how
    many ended on the map's label there (``persisted``)."""
    out = []
    for _, r in summary.iterrows():
        name = f"control: {r['what']}" if r["refinement"] in CONTROLS else r["what"]
        fol = r.get("followed", pd.NA)
        if not pd.isna(fol) and fol:
            name += f"\nmoved, followed from the map:\nthe map's label {int(r['persisted'])}/{int(fol)}"
        out.append(name)
    return out


def plot_convergence(runs: pd.DataFrame, summary: pd.DataFrame, grid_name: str, axes: list[str],
                     path: str, dpi: int = 130) -> None:
    """Left: per refinement, the fraction of sampled points whose label holds (bars, with
    ``held/n`` and its exact 95 % interval; the controls in a lighter grey), the
    stratum-weighted estimate for the whole map (diamonds) and, with controls, the fraction
    among the robust points (circles: those whose label holds under every control) and, with
    the neighbour support, among the points whose label a grid neighbour shares (squares),
    against :data:`HOLD_TARGET`; a model row whose moved labels were followed from the map's
    attractor says in its tick label how many ended on the map's label (``persisted`` /
    ``followed``).  Right: one row per sampled point, the map's label and the label under each
    refinement (a changed label is crossed)."""
    refs = list(summary["refinement"])
    whats = list(summary["what"])
    points = runs.drop_duplicates("point_id")
    n_pts = len(points)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, max(4.0, 1.5 + 0.22 * n_pts)),
                                   gridspec_kw={"width_ratios": [1.0, 1.2]}, constrained_layout=True)
    y = np.arange(len(refs))
    err = np.vstack([summary["fraction"] - summary["fraction_lo"],
                     summary["fraction_hi"] - summary["fraction"]])
    control = summary["refinement"].isin(CONTROLS).to_numpy()
    ax0.barh(y, summary["fraction"], xerr=err, color=np.where(control, "0.8", "0.6"), ecolor="0.2",
             capsize=3, label="sampled points (95 % interval)")
    ax0.plot(summary["map_fraction"], y, "D", color="k", ms=5, label="map estimate (stratum weights)")
    rob = summary[summary["n_robust"].fillna(0) > 0] if "n_robust" in summary else summary.iloc[:0]
    if len(rob):
        ax0.plot(rob["held_robust"].astype(float) / rob["n_robust"].astype(float), y[rob.index], "o",
                 mfc="none", mec="C0", mew=1.5, ms=7,
                 label=f"the {int(rob['n_robust'].iloc[0])} points whose label holds under the controls")
    sup = summary[summary["n_supported"].fillna(0) > 0] if "n_supported" in summary else summary.iloc[:0]
    if len(sup):
        ax0.plot(sup["held_supported"].astype(float) / sup["n_supported"].astype(float), y[sup.index], "s",
                 mfc="none", mec="C2", mew=1.5, ms=6,
                 label=f"the {int(sup['n_supported'].iloc[0])} points whose label a grid neighbour shares")
    for yi, (_, r), c in zip(y, summary.iterrows(), control):
        ax0.text(0.02, yi, f"{r['held']}/{r['n']}", va="center", fontsize=8, color="k" if c else "white")
    ax0.axvline(HOLD_TARGET, color="C3", ls="--", lw=1, label=f"target {HOLD_TARGET:.0%}")
    ax0.set_yticks(y, row_labels(summary))
    ax0.invert_yaxis()
    ax0.set_xlim(0, 1.0)
    ax0.set_xlabel("fraction of points whose label holds")
    ax0.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)
    ax0.set_title(f"grid '{grid_name}': labels under refinement" + (" and controls" if control.any() else ""),
                  fontsize=9)

    codes = {k: i for i, k in enumerate(LABEL_COLOURS)}
    z = np.full((n_pts, len(refs) + 1), np.nan)
    changed = np.zeros_like(z, dtype=bool)
    names = []
    for i, (_, p) in enumerate(points.iterrows()):
        z[i, 0] = codes[label_key(p["label"], p["period"])]
        names.append(", ".join(f"{a}={p[a]:.3g}" for a in axes) if axes else p["point_id"][:8])
        for j, ref in enumerate(refs):
            r = runs[(runs["point_id"] == p["point_id"]) & (runs["refinement"] == ref)]
            if len(r):
                r = r.iloc[0]
                z[i, j + 1] = codes[label_key(r["refined_label"], r["refined_period"])]
                changed[i, j + 1] = not bool(r["holds"])
    cmap = ListedColormap(list(LABEL_COLOURS.values()))
    ax1.pcolormesh(np.arange(len(refs) + 2) - 0.5, np.arange(n_pts + 1) - 0.5, z, cmap=cmap,
                   vmin=-0.5, vmax=len(LABEL_COLOURS) - 0.5, edgecolors="white", linewidth=0.5)
    for i, j in zip(*np.nonzero(changed)):
        ax1.plot(j, i, "x", color="white", ms=7, mew=1.5)
    ax1.set_xticks(np.arange(len(refs) + 1), ["map"] + whats, rotation=30, ha="right", fontsize=8)
    ax1.set_yticks(np.arange(n_pts), names, fontsize=6)
    ax1.set_ylim(n_pts - 0.5, -0.5)
    present = sorted({int(v) for v in z[np.isfinite(z)]})
    keys = list(LABEL_COLOURS)
    ax1.legend(handles=[Patch(color=LABEL_COLOURS[keys[c]], label=keys[c]) for c in present]
               + [plt.Line2D([], [], marker="x", ls="", color="0.3", label="label changed")],
               loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    ax1.set_title("sampled points (stratified by label): map vs refined", fontsize=9)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)

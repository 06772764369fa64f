"""Figures of the regime pipeline: regime map and lambda_1 map (2-D grids), bifurcation
diagram and lambda_1 curve (1-D grids), phase portraits and Poincare maps of marked points."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.colors import ListedColormap, TwoSlopeNorm
from matplotlib.patches import Patch

#: colour of each label (periodic orbits of period > 1 get a darker blue)
LABEL_COLOURS = {
    "periodic": "#4c72b0",
    "periodic (m > 1)": "#1b3a6b",
    "quasi-periodic": "#55a868",
    "chaotic": "#c44e52",
    "undetermined": "#dd8452",
    "unsettled": "#bbbbbb",
    "diverged": "#000000",
}

#: axis labels with definitions and units
PARAM_LABELS = {
    "Omega": r"$\Omega = \omega / \omega_1$ (forcing / first stuck natural frequency)",
    "f0_rel": r"$f_0 / f_{cr}$ (load amplitude / static initial-slip load)",
    "f0": r"$f_0 = F_0 / (E b R)$",
    "lam_f": r"$\lambda = \omega^2 \rho R^2 / E$",
    "p": r"$p^* = p / E$ (interlayer pressure)",
    "mu_s": r"$\mu_s$ (static friction coefficient)",
    "mu_k": r"$\mu_k$ (kinetic friction coefficient)",
    "beta": r"$\beta$ [rad] (opening angle)",
    "damping": r"$\zeta$ (modal damping ratio)",
    "k_t": r"$k_t R / E$ (interface stick stiffness)",
    "alpha1": r"$\alpha_1 = h_1 / R$",
    "alpha2": r"$\alpha_2 = h_2 / R$",
    "n_modes": "number of modes N",
}


def label_key(label, period) -> str:
    """The :data:`LABEL_COLOURS` key of a label: periodic orbits of period > 1 get their own."""
    if label == "periodic" and pd.notna(period) and int(period) > 1:
        return "periodic (m > 1)"
    return str(label)


def _label_key(row) -> str:
    return label_key(row["label"], row["period"])


def _axis_label(name: str) -> str:
    return PARAM_LABELS.get(name, name)


def _fixed_title(grid_name: str, table: pd.DataFrame, axes: list[str]) -> str:
    keys = ["law", "mu_s", "mu_k", "p", "n_modes", "alpha1", "alpha2", "beta", "k_t", "damping",
            "interface_damping", "interface_viscosity",
            "f0_rel", "Omega"]
    parts = []
    for k in keys:
        if k in table.columns and k not in axes:
            vals = table[k].dropna().unique()
            if len(vals) == 1:
                v = vals[0]
                parts.append(f"{k}={v:g}" if isinstance(v, (int, float, np.floating)) else f"{k}={v}")
    import textwrap

    return textwrap.fill(f"grid '{grid_name}': " + ", ".join(parts), width=75)


def _edges(values: np.ndarray, log: bool) -> np.ndarray:
    v = np.log(values) if log else values
    if v.size == 1:
        e = np.array([v[0] - 0.5, v[0] + 0.5])
    else:
        mid = 0.5 * (v[1:] + v[:-1])
        e = np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])
    return np.exp(e) if log else e


def _is_log(grid: dict, name: str) -> bool:
    spec = grid["axes"][name]
    return isinstance(spec, dict) and spec.get("scale") == "log"


def _title(what: str, grid_name: str, table: pd.DataFrame, axes: list[str], evidence: str | None) -> str:
    """Figure title: what, the grid's fixed parameters, and the map's convergence evidence
    (:func:`analysis.pipeline.convergence.title_line`) when given."""
    import textwrap

    out = what + "\n" + _fixed_title(grid_name, table, axes)
    return out + ("\n" + textwrap.fill(evidence, width=72) if evidence else "")


def plot_regimes(table: pd.DataFrame, grid_name: str, grid: dict, path: str, dpi: int = 130,
                 evidence: str | None = None, attractors: pd.DataFrame | None = None,
                 lifetimes: pd.DataFrame | None = None) -> None:
    """2-D grid: categorical regime map; 1-D grid: bifurcation diagram coloured by regime.
    ``evidence``: a line on the labels' convergence (and multistability) for the title.
    ``attractors``: the multistability table (:func:`analysis.pipeline.cell_attractors.cell_attractors`):
    on a 2-D map the cells run from other starts are outlined, multistable ones hatched (``//``),
    those with attractors of two regimes (two different verdicts) cross-hatched (``xx``); on a
    1-D diagram the tip samples of the attractors the start from rest did not reach are drawn
    as open circles in their own label's colour.  On a 2-D map a black dot marks a cell whose
    label no grid neighbour shares (:mod:`analysis.pipeline.neighbours`), a white cross a point
    that never slipped, and a white bar one that slipped at first and then stayed stuck at
    every element over its whole record (``stick_fraction`` 1: the interface does no friction
    work there, docs/classification.md rule 3); each marker is in the legend, with its count,
    only where the map has such cells.  With a ``lock_ratio`` column, a dashed line marks the
    lock-up limit and a dotted one the shakedown limit (:func:`_draw_limits`).  ``lifetimes``: the
    lifetime table (:func:`analysis.pipeline.chaos_lifetime.chaos_lifetimes`): a triangle marks
    each cell measured, filled black where copies of its motion were proven to end locked (a
    transient), open where none was (:func:`_mark_lifetimes`)."""
    axes = list(grid["axes"])
    keys = table.apply(_label_key, axis=1)
    present = [k for k in LABEL_COLOURS if (keys == k).any()]
    handles = [Patch(color=LABEL_COLOURS[k], label=f"{k} ({int((keys == k).sum())})") for k in present]
    if len(axes) == 2:
        xa, ya = axes
        xs, ys = np.sort(table[xa].unique()), np.sort(table[ya].unique())
        codes = {k: i for i, k in enumerate(LABEL_COLOURS)}
        z = np.full((ys.size, xs.size), np.nan)
        for (_, row), key in zip(table.iterrows(), keys):
            z[np.searchsorted(ys, row[ya]), np.searchsorted(xs, row[xa])] = codes[key]
        fig, ax = plt.subplots(figsize=(9, 8), constrained_layout=True)
        cmap = ListedColormap(list(LABEL_COLOURS.values()))
        ax.pcolormesh(_edges(xs, _is_log(grid, xa)), _edges(ys, _is_log(grid, ya)), z, cmap=cmap,
                      vmin=-0.5, vmax=len(LABEL_COLOURS) - 0.5, edgecolors="white", linewidth=0.3)
        if attractors is not None and not attractors.empty:
            _hatch_multistable(ax, attractors, xs, ys, xa, ya, grid, handles)
        if "slipped" in table.columns:  # initial-slip boundary: mark points that never slipped
            never = table[~table["slipped"].astype(bool)]
            if len(never):
                ax.plot(never[xa], never[ya], "x", ms=3, color="white", mew=0.6, ls="")
                handles.append(plt.Line2D([], [], marker="x", ls="", color="0.3",
                                          label=f"never slipped ({len(never)})"))
        if "stick_fraction" in table.columns:  # slipped at first, then locked: no friction work
            slipped = table["slipped"].astype(bool) if "slipped" in table.columns else True
            locked = table[(table["stick_fraction"] >= 1.0) & slipped]
            if len(locked):
                ax.plot(locked[xa], locked[ya], "_", ms=5, color="white", mew=1.0, ls="")
                handles.append(plt.Line2D([], [], marker="_", ms=5, mew=1.0, ls="", color="0.3",
                                          label=f"every element stuck over the record ({len(locked)})"))
        if "lock_ratio" in table.columns:
            _draw_limits(ax, table, keys, xs, ys, xa, ya, handles)
        if lifetimes is not None:
            _mark_lifetimes(ax, lifetimes, xa, ya, handles)
        if "neighbours_same" in table.columns:  # labels finer than the grid
            from analysis.pipeline.neighbours import supported

            alone = table[supported(table).eq(False).fillna(False).to_numpy(bool)]
            ax.plot(alone[xa], alone[ya], "o", ms=2.5, color="black", ls="")
            handles.append(plt.Line2D([], [], marker="o", ms=2.5, ls="", color="black",
                                      label=f"label no neighbour shares ({len(alone)})"))
        for name, setter in ((xa, ax.set_xscale), (ya, ax.set_yscale)):
            if _is_log(grid, name):
                setter("log")
        ax.set_xlabel(_axis_label(xa))
        ax.set_ylabel(_axis_label(ya))
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="regime")
    else:
        xa = axes[0]
        fig, ax = plt.subplots(figsize=(9, 5), constrained_layout=True)
        for (_, row), key in zip(table.iterrows(), keys):
            w = np.asarray(row["poincare_w_tip"], dtype=float)
            ax.plot(np.full(w.size, row[xa]), w, ".", ms=1.5, color=LABEL_COLOURS[key])
        if attractors is not None and not attractors.empty:
            mine = attractors["starts"].map(lambda s: "rest" in list(s))  # the map's own run
            other = attractors[attractors["attractor"].notna() & ~mine & attractors["poincare_w_tip"].notna()]
            for _, row in other.iterrows():
                w = np.asarray(row["poincare_w_tip"], dtype=float)
                colour = LABEL_COLOURS.get(label_key(row["label"], row["period"]), "0.5")
                ax.plot(np.full(w.size, row[xa]), w, "o", ms=3, mfc="none", mew=0.5, color=colour)
            if len(other):
                handles.append(plt.Line2D([], [], marker="o", ls="", mfc="none", color="0.3",
                                          label="other attractors (other starts)"))
        if "lock_ratio" in table.columns:
            _draw_limits(ax, table, keys, None, None, xa, None, handles)
        if lifetimes is not None:
            _mark_lifetimes(ax, lifetimes, xa, None, handles)
        if _is_log(grid, xa):
            ax.set_xscale("log")
        ax.set_xlabel(_axis_label(xa))
        ax.set_ylabel(r"tip radial displacement $w(\beta)/R$ at $t = kT$ (Poincare samples)")
        ax.legend(handles=handles, fontsize=8, title="regime")
    ax.set_title(_title("Regimes", grid_name, table, axes, evidence), fontsize=9)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def lock_up_crossings(x: np.ndarray, ratio: np.ndarray) -> list[float]:
    """Where a line's ratio crosses 1 (linear interpolation between neighbouring points in
    ``x`` order; pairs with a non-finite ratio are skipped; a point at exactly 1 counts once)."""
    order = np.argsort(x, kind="stable")
    x, r = np.asarray(x, float)[order], np.asarray(ratio, float)[order]
    out: list[float] = []
    for i in np.flatnonzero(np.diff(np.sign(r - 1.0)) != 0):
        if np.isfinite(r[i]) and np.isfinite(r[i + 1]):
            at = float(x[i] + (1.0 - r[i]) * (x[i + 1] - x[i]) / (r[i + 1] - r[i]))
            if not out or at != out[-1]:
                out.append(at)
    return out


def limit_ratios(table: pd.DataFrame) -> dict[str, np.ndarray]:
    """The table's ratios to its two limits (:func:`beamsim.shakedown.locked_orbit`): ``lock-up``
    (``lock_ratio``) and ``shakedown`` (``shakedown_ratio``, the pipeline's: NaN where a stuck
    mode is undamped; only where the table has the column)."""
    out = {"lock-up": table["lock_ratio"].astype(float).to_numpy()}
    if "shakedown_ratio" in table.columns:
        out["shakedown"] = table["shakedown_ratio"].astype(float).to_numpy()
    return out


#: how each limit is drawn and what its legend says
LIMIT_STYLE = {
    "lock-up": dict(ls="--", text="lock-up limit (lock ratio 1): on its side below 1 a locked\n"
                                  "period-1 state exists ({n} cells there with another label)"),
    "shakedown": dict(ls=":", text="shakedown limit (kinetic ratio 1): on its side below 1 every\n"
                                   "motion converges to a locked orbit ({n} cells there with another label)"),
}


def _draw_limits(ax, table: pd.DataFrame, keys: pd.Series, xs: np.ndarray | None, ys: np.ndarray | None,
                   xa: str, ya: str | None, handles: list) -> None:
    """Draw where the table's ratios to the lock-up and shakedown limits
    (:func:`limit_ratios`) cross 1: a contour on a 2-D map, vertical lines on a 1-D diagram,
    dashed and dotted.  Below the lock-up limit a locked, everywhere-stuck period-1 motion
    coexists with whatever the run from rest reached; below the shakedown limit every motion's
    total slip is finite and it converges to a locked orbit.  The legend counts the cells below
    each limit whose label is not periodic-1; a limit the map lies entirely below gets its
    legend entry without a line."""
    other_label = (keys != "periodic").to_numpy()  # "periodic": period 1
    for name, ratio in limit_ratios(table).items():
        below = ratio < 1.0
        if not below.any():
            continue
        style = LIMIT_STYLE[name]
        if (ratio >= 1.0).any():
            if ys is None:
                for x in lock_up_crossings(table[xa].to_numpy(float), ratio):
                    ax.axvline(x, color="black", ls=style["ls"], lw=1.0)
            else:
                grid_r = np.full((ys.size, xs.size), np.nan)
                for (_, row), value in zip(table.iterrows(), ratio):
                    grid_r[np.searchsorted(ys, row[ya]), np.searchsorted(xs, row[xa])] = value
                ax.contour(xs, ys, grid_r, levels=[1.0], colors="black", linestyles=style["ls"],
                           linewidths=1.2)
        text = style["text"].format(n=int((below & other_label).sum()))
        if not (ratio >= 1.0).any():
            text += "; every cell is below it"
        handles.append(plt.Line2D([], [], color="black", ls=style["ls"], lw=1.2, label=text))


def _mark_lifetimes(ax, lifetimes: pd.DataFrame, xa: str, ya: str | None, handles: list) -> None:
    """A triangle on each cell of the lifetime table with a measured lifetime (at the top of a
    1-D diagram): filled black where copies were proven to end locked (the motion is a transient
    there), open where none was; the legend entries are those of
    :func:`analysis.pipeline.chaos_lifetime.group_text` (counts, mean lifetimes, lower bound)."""
    import textwrap

    from analysis.pipeline.chaos_lifetime import group_text, lifetime_groups

    groups = lifetime_groups(lifetimes)
    text = group_text(groups)
    for part, face, key in ((groups.escaped, "black", "escaped"), (groups.none, "none", "none")):
        if part.empty:
            continue
        if ya is None:
            y, kw = np.ones(len(part)), {"transform": ax.get_xaxis_transform(), "clip_on": False}
        else:
            y, kw = part[ya].to_numpy(), {}
        ax.plot(part[xa], y, "v", ms=5, mfc=face, mec="black", mew=0.6, ls="", **kw)
        handles.append(plt.Line2D([], [], marker="v", ms=5, mfc=face, mec="black", ls="",
                                  label=textwrap.fill(f"lifetime runs: {text[key]}", width=62)))


def _hatch_multistable(ax, attractors: pd.DataFrame, xs: np.ndarray, ys: np.ndarray, xa: str, ya: str,
                       grid: dict, handles: list) -> None:
    """Outline the cells run from other starts; hatch the multistable ones (module docstring of
    :func:`plot_regimes`)."""
    from matplotlib.patches import Rectangle

    from analysis.pipeline.cell_attractors import cell_summary

    xe, ye = _edges(xs, _is_log(grid, xa)), _edges(ys, _is_log(grid, ya))
    first = attractors.drop_duplicates("point_id").set_index("point_id")
    counts = {"checked": 0, "//": 0, "xx": 0}
    for _, cell in cell_summary(attractors).iterrows():
        i = int(np.searchsorted(xs, first.loc[cell["point_id"], xa]))
        j = int(np.searchsorted(ys, first.loc[cell["point_id"], ya]))
        hatch = "xx" if cell["n_regimes"] > 1 else ("//" if cell["multistable"] else None)
        counts["checked"] += 1
        if hatch:
            counts[hatch] += 1
        ax.add_patch(Rectangle((xe[i], ye[j]), xe[i + 1] - xe[i], ye[j + 1] - ye[j], fill=False,
                               edgecolor="black", linewidth=0.8, hatch=hatch))
    handles.append(Patch(fill=False, edgecolor="black", label=f"run from other starts ({counts['checked']})"))
    handles.append(Patch(fill=False, edgecolor="black", hatch="//",
                         label=f"several attractors, regimes not shown to differ ({counts['//']})"))
    handles.append(Patch(fill=False, edgecolor="black", hatch="xx",
                         label=f"attractors of two regimes ({counts['xx']})"))


#: the lambda_1 maps' colour range covers this quantile of |lambda_1 T|; larger values are
#: drawn in the end colours and written into their cells
LLE_RANGE_QUANTILE = 0.95


def lle_colour_limit(values: np.ndarray, resolution: float = 0.0) -> float:
    """Half-width of the symmetric colour scale of a ``lambda_1 T`` map: the
    :data:`LLE_RANGE_QUANTILE` quantile of ``|values|`` (non-finite ignored), at least
    ``resolution`` and ``1e-6``; 1 if nothing is finite."""
    v = np.abs(np.asarray(values, dtype=float))
    v = v[np.isfinite(v)]
    q = float(np.quantile(v, LLE_RANGE_QUANTILE)) if v.size else 1.0
    return max(q, float(resolution), 1e-6)


def plot_lle(table: pd.DataFrame, grid_name: str, grid: dict, path: str, dpi: int = 130,
             resolution: float = 0.0, evidence: str | None = None) -> None:
    """Largest Lyapunov exponent per forcing period, map (2-D grid) or curve (1-D grid).

    2-D: two panels on one colour scale, the label's exponent (``lle_mean``: the block mean of
    the long Benettin record, undetermined points marked x) and the Stefanski cross-check, so
    that points where they disagree (Stefanski's threshold is an upper bound at grazing
    breakaways, docs/lyapunov.md) are seen at a glance.  1-D: the block mean with its interval
    as a band, Stefanski and nolds.  The scale is
    symmetric about 0 and covers the :data:`LLE_RANGE_QUANTILE` quantile of ``|lambda_1 T|``
    (a few outliers would otherwise wash out the map), at least ``resolution`` (the
    ``lambda_1 T`` below which the estimators call the exponent zero,
    :func:`analysis.pipeline.stages.lle_resolution`); cells beyond it take the end colours and
    carry their value as text."""
    axes = list(grid["axes"])
    period = 2.0 * np.pi / table["omega"]
    if len(axes) == 2:
        xa, ya = axes
        xs, ys = np.sort(table[xa].unique()), np.sort(table[ya].unique())
        cols = [(c, name) for c, name in (("lle_mean", "label's exponent: block mean of the long Benettin "
                                                        "record (x: interval straddles the margin);\n"
                                                        "0 where every element stayed stuck (linear), "
                                                        "25-period value on periodic records"),
                                          ("lle_stefanski", "Stefanski synchronisation (cross-check)"))
                if c in table.columns]
        grids = []
        for col, _ in cols:
            z = np.full((ys.size, xs.size), np.nan)
            for (_, row), v in zip(table.iterrows(), table[col] * period):
                z[np.searchsorted(ys, row[ya]), np.searchsorted(xs, row[xa])] = v
            grids.append(z)
        finite = np.abs(np.concatenate([z[np.isfinite(z)] for z in grids]))
        lim = lle_colour_limit(finite, resolution)
        over = bool(finite.size and finite.max() > lim)
        fig, axs = plt.subplots(1, len(cols), figsize=(6.5 * len(cols), 7), constrained_layout=True,
                                sharey=True, squeeze=False)
        xe, ye = _edges(xs, _is_log(grid, xa)), _edges(ys, _is_log(grid, ya))
        for ax, z, (col, name) in zip(axs[0], grids, cols):
            mesh = ax.pcolormesh(xe, ye, z, cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -lim, lim))
            for iy, ix in zip(*np.nonzero(np.isfinite(z) & (np.abs(np.nan_to_num(z)) > lim))):
                ax.text(xs[ix], ys[iy], f"{z[iy, ix]:.3g}", ha="center", va="center", fontsize=6,
                        color="white")
            if col == "lle_mean" and "lle_verdict" in table.columns:
                und = table[table["lle_verdict"] == "undetermined"]
                ax.plot(und[xa], und[ya], "x", color="k", ms=4, mew=0.8)
            for nm, setter in ((xa, ax.set_xscale), (ya, ax.set_yscale)):
                if _is_log(grid, nm):
                    setter("log")
            ax.set_xlabel(_axis_label(xa))
            ax.set_title(name, fontsize=9)
        axs[0, 0].set_ylabel(_axis_label(ya))
        fig.colorbar(mesh, ax=axs[0].tolist(), extend="both" if over else "neither",
                     label=r"$\lambda_1 T$ (per forcing period; > 0: chaos)")
        axs[0, 0].text(0.0, -0.16, "blank: not determined (diverged, or no synchronisation up to "
                       "the RK4 limit); numbers: values beyond the colour range",
                       transform=axs[0, 0].transAxes, fontsize=7)
        fig.suptitle(_title("Largest Lyapunov exponent", grid_name, table, axes, evidence), fontsize=9)
    else:
        xa = axes[0]
        fig, ax = plt.subplots(figsize=(9, 4), constrained_layout=True)
        if "lle_mean" in table.columns:
            ax.fill_between(table[xa], table["lle_lo"] * period, table["lle_hi"] * period, color="C0",
                            alpha=0.25, lw=0, label="95 % interval (block statistics)")
            ax.plot(table[xa], table["lle_mean"] * period, "o-", ms=3, color="C0",
                    label="block mean (decides the label)")
        ax.plot(table[xa], table["lle_stefanski"] * period, "D:", ms=3, label="Stefanski")
        for col, style in (("lle_nolds", "s--"),):
            if col in table.columns:
                ax.plot(table[xa], table[col] * period, style, ms=3, label=col[4:])
        ax.axhline(0, color="0.5", lw=0.8)
        if _is_log(grid, xa):
            ax.set_xscale("log")
        ax.set_xlabel(_axis_label(xa))
        ax.set_ylabel(r"$\lambda_1 T$ (per forcing period)")
        ax.legend(fontsize=8)
        ax.set_title(_title("Largest Lyapunov exponent", grid_name, table, axes, evidence), fontsize=9)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def nearest_rows(table: pd.DataFrame, grid: dict) -> list[pd.Series]:
    """Grid rows nearest to each ``mark`` entry of the grid (distance in axis units scaled by
    each axis' span; log axes in log units)."""
    rows = []
    for mark in grid.get("mark", []):
        d = np.zeros(len(table))
        for a in grid["axes"]:
            if a not in mark:
                continue
            vals = table[a].to_numpy(dtype=float)
            target = float(mark[a])
            if _is_log(grid, a):
                vals, target = np.log(vals), np.log(target)
            span = np.ptp(vals) or 1.0
            d += ((vals - target) / span) ** 2
        rows.append(table.iloc[int(np.argmin(d))])
    return rows


def plot_portraits(cases: list[dict], grid_name: str, path: str, dpi: int = 130) -> None:
    """Phase portrait (tip radial displacement vs velocity) and Poincare map of marked points.

    ``cases``: dicts with ``title``, ``t``, ``w``, ``w_dot`` (dense history of the last
    periods) and ``pw``, ``pw_dot`` (Poincare samples).
    """
    n = max(1, len(cases))
    fig, axes = plt.subplots(n, 2, figsize=(11, 3.6 * n), constrained_layout=True, squeeze=False)
    for row, case in zip(axes, cases):
        row[0].plot(case["w"], case["w_dot"], lw=0.5, color="C0")
        row[0].plot(case["pw"], case["pw_dot"], ".", ms=3, color="C3", label="Poincare samples")
        row[0].set_xlabel(r"tip radial displacement $w(\beta)/R$")
        row[0].set_ylabel(r"tip radial velocity")
        row[0].set_title("phase portrait: " + case["title"], fontsize=8)
        row[0].legend(fontsize=7)
        row[1].plot(case["pw"], case["pw_dot"], ".", ms=2, color="C3")
        row[1].set_xlabel(r"$w(\beta)/R$ at $t = kT$")
        row[1].set_ylabel("tip radial velocity at $t = kT$")
        row[1].set_title("Poincare map", fontsize=8)
    if not cases:
        axes[0, 0].text(0.5, 0.5, "no points marked in config/grid.yaml", ha="center")
    fig.suptitle(f"Marked points of grid '{grid_name}'", fontsize=10)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)

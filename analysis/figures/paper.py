"""Figure kinds of the paper reproduction (docs/paper-reproduction.md).

Each function draws from plain arrays (dense histories and Poincare samples as measured by
:mod:`analysis.paper.measure`) and writes one PNG:

* :func:`plot_tip_histories` -- tip time histories (radial, circumferential of each layer) for
  several mode counts overlaid (the paper's Fig 8);
* :func:`plot_law_pairs` -- phase portraits of two or more friction laws side by side at the
  same load (Figs 9 and 13);
* :func:`plot_layer_phase_planes` -- axial phase planes of both layers with lateral and axial
  Poincare maps (Fig 11);
* :func:`plot_friction_law` -- traction against slip rate (Fig 12);
* :func:`plot_poincare_transient` -- Poincare samples from rest coloured by period index, so a
  spiral into a fixed point or a slow drift shows as what it is (Fig 10);
* :func:`plot_load_sweeps` -- 1-D bifurcation diagrams with the lambda_1 curve under each.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from analysis.figures.regimes import LABEL_COLOURS

__all__ = ["plot_tip_histories", "plot_law_pairs", "plot_layer_phase_planes", "plot_friction_law",
           "plot_poincare_transient", "plot_load_sweeps"]

_TIP = {"w": r"radial $w(\beta)/R$", "u1": r"circumferential $u_1(\beta)/R$ (upper layer)",
        "u2": r"circumferential $u_2(\beta)/R$ (lower layer)"}


def _save(fig, path: str, dpi: int) -> None:
    fig.savefig(path, dpi=dpi)
    plt.close(fig)


def plot_tip_histories(cases: list[dict], path: str, dpi: int = 130) -> None:
    """One row per case, columns w, u1, u2 against t / T.

    ``cases``: dicts with ``title`` and ``curves``, a list of dicts with ``label`` (e.g.
    ``"N = 3"``), ``t``, ``period_T``, ``w``, ``u1``, ``u2``.
    """
    n = max(1, len(cases))
    fig, axes = plt.subplots(n, 3, figsize=(14, 3.2 * n), constrained_layout=True, squeeze=False)
    for row, case in zip(axes, cases):
        for k, key in enumerate(("w", "u1", "u2")):
            ax = row[k]
            for j, c in enumerate(case["curves"]):
                t = np.asarray(c["t"]) / c["period_T"]
                ax.plot(t, c[key], lw=0.9, color=plt.cm.viridis(j / max(1, len(case["curves"]) - 1)),
                        label=c["label"])
            ax.set_xlabel("t / T (forcing periods)")
            ax.set_ylabel(_TIP[key])
            ax.set_title(case["title"], fontsize=8)
        row[0].legend(fontsize=7)
    _save(fig, path, dpi)


def _portrait(ax, c: dict, key: str = "w") -> None:
    ax.plot(c[key], c[key + "_dot"], lw=0.4, color=LABEL_COLOURS.get(c.get("label", ""), "C0"))
    T = c["period_T"]
    t = np.asarray(c["t"])
    idx = np.nonzero(np.abs((t / T) - np.round(t / T)) < 1e-6)[0]
    ax.plot(np.asarray(c[key])[idx], np.asarray(c[key + "_dot"])[idx], ".", ms=3, color="k",
            label="Poincare samples")


def plot_law_pairs(rows: list[dict], path: str, dpi: int = 130) -> None:
    """Tip radial phase portraits, one row per load and one column per friction law.

    ``rows``: dicts with ``title`` and ``panels``, a list of dicts with ``title``, ``label``
    (regime label, sets the colour), ``t``, ``period_T``, ``w``, ``w_dot``.
    """
    n = max(1, len(rows))
    m = max([len(r["panels"]) for r in rows] + [1])
    fig, axes = plt.subplots(n, m, figsize=(4.6 * m, 3.6 * n), constrained_layout=True, squeeze=False)
    for ax_row, row in zip(axes, rows):
        for ax, c in zip(ax_row, row["panels"]):
            _portrait(ax, c)
            ax.set_xlabel(r"$w(\beta)/R$")
            ax.set_ylabel(r"$\dot w(\beta)$")
            ax.set_title(f"{row['title']}\n{c['title']}", fontsize=8)
        for ax in ax_row[len(row["panels"]):]:
            ax.set_axis_off()
    _save(fig, path, dpi)


def plot_layer_phase_planes(cases: list[dict], path: str, dpi: int = 130) -> None:
    """Per case one row: axial phase planes of the upper and lower layer (tip ``u1``, ``u2``
    against their velocities), then the lateral (``w``) and axial (``u1``) Poincare maps.

    ``cases``: dicts with ``title``, ``label``, ``t``, ``period_T``, ``w``, ``u1``, ``u2`` and
    the ``_dot`` velocities.
    """
    n = max(1, len(cases))
    fig, axes = plt.subplots(n, 4, figsize=(17, 3.6 * n), constrained_layout=True, squeeze=False)
    for row, c in zip(axes, cases):
        for ax, key, name in ((row[0], "u1", "upper layer"), (row[1], "u2", "lower layer")):
            ax.plot(c[key], c[key + "_dot"], lw=0.4, color=LABEL_COLOURS.get(c["label"], "C0"))
            ax.set_xlabel(f"$u_{key[1]}(\\beta)/R$")
            ax.set_ylabel(f"$\\dot u_{key[1]}(\\beta)$")
            ax.set_title(f"axial phase plane, {name}\n{c['title']}", fontsize=8)
        t, T = np.asarray(c["t"]), c["period_T"]
        idx = np.nonzero(np.abs((t / T) - np.round(t / T)) < 1e-6)[0]
        for ax, key, name in ((row[2], "w", "lateral"), (row[3], "u1", "axial")):
            ax.plot(np.asarray(c[key])[idx], np.asarray(c[key + "_dot"])[idx], ".", ms=3, color="k")
            ax.set_xlabel(f"{key} at t = kT")
            ax.set_ylabel(f"d{key}/dt at t = kT")
            ax.set_title(f"{name} Poincare map ({idx.size} samples)", fontsize=8)
    _save(fig, path, dpi)


def plot_friction_law(curves: list[dict], path: str, dpi: int = 130) -> None:
    """Traction against slip rate (eq 34), one curve per law.  ``curves``: dicts with ``label``,
    ``v`` and ``traction`` (in units of the static traction F_s)."""
    fig, ax = plt.subplots(figsize=(6.5, 4.2), constrained_layout=True)
    for c in curves:
        ax.plot(c["v"], c["traction"], lw=1.4, label=c["label"])
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.axvline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel(r"slip rate $v$ (units $\sqrt{E/\rho}$)")
    ax.set_ylabel(r"traction / $F_s$")
    ax.set_title("Friction laws (eq 34; Fig 12)", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path, dpi)


def plot_poincare_transient(cases: list[dict], path: str, dpi: int = 130) -> None:
    """Poincare samples of the tip (``w`` against ``u1``) from the end of the first period on
    (the rest state at k = 0 is left out), coloured by period index.

    ``cases``: dicts with ``title`` and ``poincare`` ((n, >= 2) array: w, u1, ...; row k at t = kT).
    """
    n = max(1, len(cases))
    fig, axes = plt.subplots(1, n, figsize=(4.4 * n, 4.0), constrained_layout=True, squeeze=False)
    sc = None
    for ax, c in zip(axes[0], cases):
        x = np.asarray(c["poincare"], dtype=float)[1:]  # from the end of the first period on
        k = np.arange(1, len(x) + 1)
        sc = ax.scatter(x[:, 0], x[:, 1], c=k, s=6, cmap="viridis")
        ax.plot(x[-1, 0], x[-1, 1], "r+", ms=10, label="last sample")
        ax.set_xlabel(r"$w(\beta)/R$ at $t = kT$")
        ax.set_ylabel(r"$u_1(\beta)/R$ at $t = kT$")
        ax.set_title(c["title"], fontsize=8)
        ax.legend(fontsize=7)
    if sc is not None:
        fig.colorbar(sc, ax=axes[0].tolist(), label="period index k")
    _save(fig, path, dpi)


def plot_load_sweeps(sweeps: list[dict], path: str, dpi: int = 130, resolution: float | None = None) -> None:
    """One column per sweep: bifurcation diagram (Poincare tip ``w`` at every value of the swept
    parameter, coloured by label) over the lambda_1 curve (per forcing period: the block mean
    of the long Benettin record with its confidence band, and the Stefanski cross-check).

    ``sweeps``: dicts with ``title``, ``xlabel``, ``log`` and ``points``, a list of dicts with
    ``x``, ``label``, ``poincare_w``, ``lle_T``, ``lle_lo_T``, ``lle_hi_T``, ``lle_stefanski_T``.
    """
    n = max(1, len(sweeps))
    fig, axes = plt.subplots(2, n, figsize=(6.0 * n, 6.4), constrained_layout=True, squeeze=False,
                             sharex="col", gridspec_kw={"height_ratios": [2, 1]})
    for k, s in enumerate(sweeps):
        top, bottom = axes[0, k], axes[1, k]
        pts = sorted(s["points"], key=lambda p: p["x"])
        for p in pts:
            w = np.asarray(p["poincare_w"], dtype=float)
            top.plot(np.full(w.size, p["x"]), w, ".", ms=1.5, color=LABEL_COLOURS.get(p["label"], "C7"))
        for lab in sorted({p["label"] for p in pts}):
            top.plot([], [], "s", color=LABEL_COLOURS.get(lab, "C7"), label=lab)
        top.legend(fontsize=7)
        top.set_ylabel(r"$w(\beta)/R$ at $t = kT$")
        top.set_title(s["title"], fontsize=9)
        x = [p["x"] for p in pts]
        bottom.fill_between(x, [p["lle_lo_T"] for p in pts], [p["lle_hi_T"] for p in pts],
                            color="C0", alpha=0.25, lw=0, label="95 % interval")
        bottom.plot(x, [p["lle_T"] for p in pts], "o-", ms=3, label="block mean (label)")
        bottom.plot(x, [p["lle_stefanski_T"] for p in pts], "s--", ms=3, label="Stefanski")
        if resolution is not None:
            bottom.axhspan(-resolution, resolution, color="0.9", label="resolution")
        bottom.axhline(0.0, color="0.5", lw=0.6)
        bottom.set_ylabel(r"$\lambda_1 T$")
        bottom.set_xlabel(s["xlabel"])
        bottom.legend(fontsize=7)
        if s.get("log"):
            bottom.set_xscale("log")
    _save(fig, path, dpi)

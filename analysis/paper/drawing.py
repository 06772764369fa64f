"""The figures of each paper item, from its measured table (:mod:`analysis.paper.measure`);
the figure kinds themselves are in :mod:`analysis.figures.paper`."""

from __future__ import annotations

import numpy as np
import pandas as pd

from analysis.figures import paper as fig
from analysis.paper.measure import drawn
from analysis.paper.runs import FIGURES
from analysis.pipeline.stages import poincare_array

__all__ = ["FIGURES", "draw_item"]


def _label(r: pd.Series) -> str:
    if r.get("label") == "periodic" and pd.notna(r.get("period")):
        return f"period {int(r['period'])}"
    return str(r.get("label"))


def _curve(r: pd.Series, title: str) -> dict:
    return {"title": title, "label": str(r.get("label")), "t": r["t"], "period_T": r["period_T"],
            **{k: r[k] for k in ("w", "w_dot", "u1", "u1_dot", "u2", "u2_dot")}}


def _law_title(r: pd.Series) -> str:
    return f"{r['law']}: {_label(r)}, $\\lambda_1 T$ = {r['lle_T']:+.3f}"


def _sweep(rows: pd.DataFrame, x_key: str, title: str, xlabel: str) -> dict:
    pts = []
    for _, r in rows.iterrows():
        pts.append({"x": float(r[x_key]), "label": str(r["label"]),
                    "poincare_w": poincare_array(r["poincare_tip"])[:, 0],
                    "lle_T": r["lle_T"], "lle_lo_T": r["lle_lo_T"],
                    "lle_hi_T": r["lle_hi_T"], "lle_stefanski_T": r["lle_stefanski_T"]})
    return {"title": title, "xlabel": xlabel, "log": True, "points": pts}


def draw_item(item: str, measured: pd.DataFrame | None, outputs: list[str], *, dpi: int = 130,
              resolution: float | None = None, modes=None, stribeck: dict | None = None) -> None:
    """Write the figures of ``item`` (file names :data:`FIGURES`) to ``outputs`` in that order.
    ``modes``: the Table 1 arch modes (item ``modes``); ``stribeck``: ``F_s, F_c, v_s, k_v,
    eps`` of the Stribeck law (item ``fig12``)."""
    if item == "modes":
        from analysis.figures.modes import plot_determinant, plot_mode_shapes

        plot_determinant(modes, outputs[0])
        plot_mode_shapes(modes, outputs[1])
    elif item == "fig8":
        cases = []
        for case, df in measured.groupby("case", sort=False):
            curves = [dict(_curve(r, ""), label=f"N = {int(r['n_modes'])}")
                      for _, r in df.sort_values("n_modes").iterrows()]
            r0 = df.iloc[0]
            cases.append({"title": f"Fig 8, {case}, f0_rel = {r0['f0_rel']:g}, from rest", "curves": curves})
        fig.plot_tip_histories(cases, outputs[0], dpi=dpi)
    elif item in ("fig9", "fig13"):
        rows = []
        for case, df in drawn(measured).groupby("case", sort=False):
            r0 = df.iloc[0]
            title = f"{item} {case}: paper f0 = {r0['f0_paper']:g}, f0_rel = {r0['f0_rel']:.3g}"
            rows.append({"title": title, "panels": [_curve(r, _law_title(r)) for _, r in df.iterrows()]})
        fig.plot_law_pairs(rows, outputs[0], dpi=dpi)
    elif item == "fig10":
        cls = measured[measured["kind"] == "classified"]
        load = cls[cls["case"] == "load sweep"]
        freq = cls[cls["case"] == "frequency sweep"]
        fig.plot_load_sweeps([_sweep(df, "f0_rel", f"load sweep, {law}", r"$f_0 / f_{cr}$")
                              for law, df in load.groupby("law", sort=False)], outputs[0], dpi=dpi,
                             resolution=resolution)
        fig.plot_load_sweeps([_sweep(df, "Omega", f"frequency sweep at the paper's f0 = 1, {law}",
                                     r"$\Omega = \omega/\omega_1$")
                              for law, df in freq.groupby("law", sort=False)], outputs[1], dpi=dpi,
                             resolution=resolution)
        tr = measured[measured["kind"] == "transient"]
        fig.plot_poincare_transient([{"title": f"{r['case']} (f0_rel {r['f0_rel']:.3g}), from rest",
                                      "poincare": poincare_array(r["poincare_tip"])}
                                     for _, r in tr.iterrows()], outputs[2], dpi=dpi)
    elif item == "fig11":
        cases = []
        for law, df in drawn(measured).groupby("law", sort=False):
            r = df.loc[df["lle_T"].fillna(-np.inf).idxmax()]  # the most unstable of the mapped loads
            cases.append(_curve(r, f"{_law_title(r)}, f0_rel {r['f0_rel']:.3g}"))
        fig.plot_layer_phase_planes(cases, outputs[0], dpi=dpi)
    elif item == "fig12":
        from beamsim.friction import smooth_traction

        s = stribeck
        v = np.linspace(-8 * s["v_s"], 8 * s["v_s"], 2001)

        def traction(fc, kv):
            return np.array([smooth_traction(x, fc, s["F_s"], s["v_s"], kv, s["eps"]) for x in v]) / s["F_s"]

        name = f"Stribeck: F_c = {s['F_c'] / s['F_s']:g} F_s, v_s = {s['v_s']:g}, k_v = {s['k_v']:g}"
        curves = [{"label": name,
                   "v": v, "traction": traction(s["F_c"], s["k_v"])},
                  {"label": "dry (Coulomb, mu_s = mu_k)", "v": v, "traction": traction(s["F_s"], 0.0)}]
        fig.plot_friction_law(curves, outputs[0], dpi=dpi)
    else:
        raise ValueError(f"item must be one of {tuple(FIGURES)}, got {item!r}")

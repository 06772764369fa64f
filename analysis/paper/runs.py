"""The runs each paper item needs, from the paper config (``config/paper.yaml``).

The paper gives no unit for its load ``f0``, no forcing frequency for figs 9-13 and no friction
coefficients.  The mapping used here (docs/paper-reproduction.md, "Parameter mapping"):

* a paper load ``f0`` is run at ``f0_rel = f0 / anchor`` for every ``anchor`` in
  ``mapping.f0_anchors`` (the paper's slip onset lies between its f0 = 0.5 and f0 = 1);
* figs 9-13 are run at ``Omega = mapping.Omega``; fig 10 adds sweeps over the load and the
  frequency;
* the paper's friction law (eq 33) is ``mu_s = mu_k``; the chaos claims are also run at
  ``mu_s / mu_k`` in ``mapping.mu_ratios`` (item ``chaos_ratio``), and the smallest ratio with a
  chaotic point (:func:`smallest_chaotic_ratio`) is run beside the paper's law in figs 9-11.

A run is ``classified`` (reference run, lambda_1, label: the regime pipeline's stages and
store), ``history`` (dense tip history from rest, fig 8) or ``transient`` (Poincare samples
from rest, fig 10).  ``draw`` asks for the dense history of a classified run's attractor.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from analysis.pipeline.grid import axis_values

__all__ = ["PaperRun", "ITEMS", "FIGURES", "RUN_ITEMS", "NEEDS_CHAOS_RATIO", "PAPER_LAW", "item_runs",
           "smallest_chaotic_ratio",
           "model_defaults", "f0_rel_of", "paper_modes", "stribeck_constants", "TABLE1_GEOMETRY"]

#: Table 1's arch: alpha = h / R = 0.01, beta = 0.4 rad, clamped-free
TABLE1_GEOMETRY = {"alpha": 0.01, "beta": 0.4, "bc": "clamped-free"}

#: every item of the paper target, in the paper's order (``modes``: Table 1 and figs 4-5)
ITEMS = ("modes", "fig8", "fig9", "fig10", "fig11", "fig12", "fig13")
#: figure files of each item, under results/paper/<item>/ (drawn by
#: :func:`analysis.paper.drawing.draw_item`)
FIGURES = {
    "modes": ("characteristic_function.png", "mode_shapes.png"),
    "fig8": ("tip_histories.png",),
    "fig9": ("law_pairs.png",),
    "fig10": ("load_sweeps.png", "frequency_sweeps.png", "poincare_transient.png"),
    "fig11": ("layer_phase_planes.png",),
    "fig12": ("friction_law.png",),
    "fig13": ("law_pairs.png",),
}
#: items that need simulations, in the order they run (fig9-11 use chaos_ratio's result)
RUN_ITEMS = ("chaos_ratio", "fig8", "fig9", "fig10", "fig11", "fig13")
#: items whose runs use the smallest chaotic mu_s / mu_k of item chaos_ratio
NEEDS_CHAOS_RATIO = ("fig9", "fig10", "fig11")
#: legend name of the paper's own friction law
PAPER_LAW = "mu_s = mu_k (paper)"


@dataclass(frozen=True)
class PaperRun:
    """One simulation of a paper item.

    item, case : the item and what the run stands for (e.g. ``"f0=1"``, ``"load sweep"``).
    law : legend name of the friction law (:data:`PAPER_LAW`, ``"mu_s/mu_k = 2"``,
        ``"full-slip"``, ``"Stribeck"``).
    kind : ``"classified"``, ``"history"`` or ``"transient"`` (module docstring).
    params : the point's model parameters (config defaults, paper overrides, the run's own).
    draw : keep the dense history of the attractor for a figure.
    f0_paper, anchor, ratio : the paper's load, the mapping anchor and ``mu_s / mu_k`` (NaN
        where they do not apply).
    extra : what a run's kind needs besides (``n_periods`` of history and transient runs; the
        mode count, ``lam_f`` and ``p`` of fig 8), copied into its table row.
    """

    item: str
    case: str
    law: str
    kind: str
    params: dict
    draw: bool = False
    f0_paper: float = float("nan")
    anchor: float = float("nan")
    ratio: float = float("nan")
    extra: dict = field(default_factory=dict)


def model_defaults(config_model: dict, paper: dict) -> dict:
    """The config's model with the paper config's overrides."""
    return dict(config_model) | dict(paper.get("model") or {})


def f0_rel_of(f0_paper: float, anchor: float) -> float:
    """``f0_rel`` of a paper load under one anchor (rounded to 12 digits: stable point ids)."""
    return float(f"{f0_paper / anchor:.12g}")


def _law_name(ratio: float) -> str:
    return PAPER_LAW if ratio == 1.0 else f"mu_s/mu_k = {ratio:g}"


def _with_ratio(base: dict, ratio: float) -> dict:
    mu_k = float(base["mu_k"])
    return dict(base, mu_s=float(f"{ratio * mu_k:.12g}"), law="stick-slip")


def _middle(values: list) -> float:
    return sorted(values)[len(values) // 2]


def smallest_chaotic_ratio(measured: pd.DataFrame) -> tuple[float, bool]:
    """The smallest ``mu_s / mu_k`` of item ``chaos_ratio`` with a chaotic point, and True; or
    the largest ratio run, and False, when no point is chaotic."""
    chaotic = measured[measured["label"] == "chaotic"]
    if len(chaotic):
        return float(chaotic["ratio"].min()), True
    return float(measured["ratio"].max()), False


def paper_modes(n_modes: int = 4):
    """The arch modes of Table 1 and figs 4-5 (:data:`TABLE1_GEOMETRY`)."""
    from beamsim.modes import arch_modes

    g = TABLE1_GEOMETRY
    return arch_modes(g["alpha"], g["beta"], n_modes, bc=g["bc"])


def stribeck_constants(paper: dict, model: dict) -> dict:
    """The Stribeck law of fig 13 (eq 34) beside the paper's dry law (``mu = mu_k`` of
    ``model``): ``F_s = mu_k p``, ``F_c = F_c_ratio F_s``, ``v_s``, ``k_v``; ``eps`` =
    ``v_s / 100``, the tanh band used to draw it."""
    st = paper["fig13"]["stribeck"]
    F_s = float(f"{float(model['mu_k']) * float(model['p']):.12g}")
    return {"F_s": F_s, "F_c": float(f"{st['F_c_ratio'] * F_s:.12g}"), "v_s": float(st["v_s"]),
            "k_v": float(st["k_v"]), "eps": float(st["v_s"]) / 100.0}


def item_runs(item: str, paper: dict, model: dict, chaos_ratio: float | None = None) -> list[PaperRun]:
    """The runs of one item (``item`` in :data:`RUN_ITEMS`).  ``model``: the paper runs' model
    defaults (:func:`model_defaults`); ``chaos_ratio``: :func:`smallest_chaotic_ratio` of the
    ``chaos_ratio`` item (needed by fig9, fig10, fig11)."""
    mp = paper["mapping"]
    anchors = [float(a) for a in mp["f0_anchors"]]
    mid = _middle(anchors)
    Omega = float(mp["Omega"])
    # the items set the load and the frequency themselves
    base = {k: v for k, v in model.items() if k not in ("f0", "f0_rel", "omega", "lam_f", "Omega")}
    base.update(Omega=Omega, law="stick-slip")
    paper_law = _with_ratio(base, 1.0)
    if item in NEEDS_CHAOS_RATIO and chaos_ratio is None:
        raise ValueError(f"item {item} needs the chaos_ratio item's smallest chaotic ratio")
    runs: list[PaperRun] = []

    def classified(case, law, params, f0=np.nan, anchor=np.nan, ratio=np.nan, draw=False, **extra):
        runs.append(PaperRun(item, case, law, "classified", params, draw, f0, anchor, ratio, extra))

    if item == "chaos_ratio":
        for ratio in mp["mu_ratios"]:
            for a in anchors:
                classified("f0=1", _law_name(ratio), dict(_with_ratio(base, ratio), f0_rel=f0_rel_of(1.0, a)),
                           1.0, a, ratio)
    elif item == "fig8":
        f8 = paper["fig8"]
        for lam, p in zip(f8["lam_f"], f8["p"]):
            for n in f8["n_modes"]:
                params = dict(paper_law, n_modes=int(n), p=float(p), lam_f=float(lam),
                              f0_rel=float(f8["f0_rel"]))
                params.pop("Omega")
                runs.append(PaperRun(item, f"lambda={lam:g}, p*={p:g}", PAPER_LAW, "history", params,
                                     extra={"n_modes": int(n), "lam_f": float(lam), "p": float(p),
                                            "n_periods": int(f8["n_periods"])}))
    elif item == "fig9":
        for f0 in (5.0, 1.0):
            case = "(a, b)" if f0 == 5.0 else "(c, d)"
            for a in anchors:
                rel = f0_rel_of(f0, a)
                classified(case, PAPER_LAW, dict(paper_law, f0_rel=rel), f0, a, 1.0, draw=a == mid)
                if a == mid:  # a regularised law is far dearer (RK4, stiff band; docs/paper-reproduction.md)
                    classified(case, "full-slip", dict(paper_law, law="full-slip", f0_rel=rel), f0, a,
                               draw=True)
                if f0 == 1.0 and chaos_ratio != 1.0:
                    classified(case, _law_name(chaos_ratio), dict(_with_ratio(base, chaos_ratio), f0_rel=rel),
                               f0, a, chaos_ratio, draw=a == mid)
    elif item == "fig10":
        f10 = paper["fig10"]
        ratios = [1.0] if chaos_ratio == 1.0 else [1.0, chaos_ratio]
        for f0 in f10["f0"]:
            for a in anchors:
                classified(f"f0={f0:g}", PAPER_LAW, dict(paper_law, f0_rel=f0_rel_of(f0, a)), f0, a, 1.0)
        for ratio in ratios:
            law = dict(_with_ratio(base, ratio))
            for rel in axis_values("fig10.load_sweep", f10["load_sweep"]):
                classified("load sweep", _law_name(ratio), dict(law, f0_rel=rel), ratio=ratio)
            for Om in axis_values("fig10.frequency_sweep", f10["frequency_sweep"]):
                classified("frequency sweep", _law_name(ratio),
                           dict(law, Omega=Om, f0_rel=f0_rel_of(1.0, mid)), 1.0, mid, ratio)
        for f0 in f10["f0"]:
            runs.append(PaperRun(item, f"f0={f0:g}", PAPER_LAW, "transient",
                                 dict(paper_law, f0_rel=f0_rel_of(f0, mid)), False, f0, mid, 1.0,
                                 {"n_periods": int(f10["transient_periods"])}))
    elif item == "fig11":
        for ratio in ([1.0] if chaos_ratio == 1.0 else [1.0, chaos_ratio]):
            for a in anchors:
                classified("f0=1", _law_name(ratio), dict(_with_ratio(base, ratio), f0_rel=f0_rel_of(1.0, a)),
                           1.0, a, ratio, draw=True)
    elif item == "fig13":
        st = stribeck_constants(paper, paper_law)
        stribeck = dict(paper_law, law="stribeck", F_s=st["F_s"], F_c=st["F_c"], v_s=st["v_s"], k_v=st["k_v"])
        for f0 in paper["fig13"]["f0"]:
            for a in anchors:
                rel = f0_rel_of(f0, a)
                classified(f"f0={f0:g}", "dry (stick-slip)", dict(paper_law, f0_rel=rel), f0, a, 1.0,
                           draw=a == mid)
                if a == mid:  # as fig9's full-slip runs
                    classified(f"f0={f0:g}", "Stribeck", dict(stribeck, f0_rel=rel), f0, a, draw=True)
    else:
        raise ValueError(f"item must be one of {RUN_ITEMS}, got {item!r}")
    return runs

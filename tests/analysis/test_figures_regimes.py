"""Regime figures: the lambda_1 colour scale and that every figure kind is drawn (2-D maps,
1-D diagrams) from a regime table."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.figures.regimes import LLE_RANGE_QUANTILE, lle_colour_limit, plot_lle, plot_regimes


def test_lle_colour_limit_ignores_outliers_but_not_the_resolution() -> None:
    v = np.r_[np.linspace(-1.0, 1.0, 98), 460.0, np.nan]  # one Stefanski outlier, one undetermined
    lim = lle_colour_limit(v)
    assert lim == pytest.approx(np.quantile(np.abs(v[np.isfinite(v)]), LLE_RANGE_QUANTILE))
    assert 0.9 < lim < 1.0  # the outlier does not set the scale
    assert lle_colour_limit(v * 1e-3, resolution=0.2) == 0.2  # all within the resolution
    assert lle_colour_limit(np.array([np.nan])) == 1.0


def _table(axes: dict) -> pd.DataFrame:
    names = list(axes)
    grid = np.meshgrid(*axes.values(), indexing="ij")
    n = grid[0].size
    rng = np.random.default_rng(0)
    t = pd.DataFrame({k: g.ravel() for k, g in zip(names, grid)})
    t = t.assign(law="stick-slip", mu_k=0.3, n_modes=1, omega=0.1,
                 label=np.array(["periodic", "quasi-periodic", "chaotic", "unsettled"])[np.arange(n) % 4],
                 period=pd.array([1 if i % 4 == 0 else None for i in range(n)], dtype="Int64"),
                 lle_stefanski=rng.normal(0.0, 0.01, n), lle_benettin=rng.normal(0.0, 0.01, n),
                 lle_nolds=rng.normal(0.0, 0.01, n), slipped=np.arange(n) % 5 != 0)
    t.loc[0, "lle_stefanski"] = 7.0  # an outlier
    t["poincare_w_tip"] = [rng.normal(size=8) for _ in range(n)]
    return t


@pytest.mark.parametrize("axes", [{"Omega": [1.0, 2.0, 4.0], "f0_rel": [1.0, 1.5, 2.0, 3.0]},
                                  {"f0_rel": [1.0, 1.5, 2.0, 3.0, 4.0]}])
def test_regime_and_lle_figures_are_drawn(tmp_path, axes) -> None:
    table = _table(axes)
    grid = {"axes": {k: ({"range": [v[0], v[-1]], "num": len(v), "scale": "log"} if k == "Omega" else v)
                     for k, v in axes.items()}}
    for plot, name in ((plot_regimes, "regimes.png"), (plot_lle, "lle.png")):
        plot(table, "g", grid, str(tmp_path / name), dpi=40)
        assert (tmp_path / name).stat().st_size > 1000


@pytest.mark.parametrize("axes", [{"Omega": [1.0, 2.0, 4.0], "f0_rel": [1.0, 1.5, 2.0, 3.0]},
                                  {"f0_rel": [1.0, 1.5, 2.0, 3.0, 4.0]}])
def test_multistable_cells_are_marked(tmp_path, axes) -> None:
    """With a multistability table the map outlines the checked cells and hatches the
    multistable ones (its legend counts them); the 1-D diagram adds the other attractors."""
    table = _table(axes)
    table["point_id"] = [f"p{i}" for i in range(len(table))]
    grid = {"axes": {k: v for k, v in axes.items()}}
    rows = []
    for i in (0, 3):  # cell 0: one attractor; cell 3: two of two regimes
        r = table.iloc[i]
        n = 1 if i == 0 else 2
        for a in range(n):
            rows.append({"point_id": r["point_id"], **{k: r[k] for k in axes}, "weight": 1.0, "attractor": a,
                         "starts": [["rest"], ["perturbed0"]][a], "label": ["periodic", "chaotic"][a],
                         "period": [1, None][a],
                         "label_text": ["periodic-1", "chaotic"][a], "poincare_w_tip": [0.1, 0.2],
                         "n_starts": 3, "n_attractors": n, "n_regimes": n, "multistable": n > 1})
    att = pd.DataFrame(rows)
    att["attractor"] = att["attractor"].astype("Int64")
    legend = _legend_of(plot_regimes, table, "g", grid, str(tmp_path / "r.png"), dpi=40, attractors=att)
    assert (tmp_path / "r.png").stat().st_size > 1000
    if len(axes) == 2:
        assert "run from other starts (2)" in legend
        assert "attractors of two regimes (1)" in legend
        assert "several attractors, regimes not shown to differ (0)" in legend
    else:
        assert "other attractors (other starts)" in legend


def _legend_of(plot, *args, **kw) -> list[str]:
    """The legend texts of the figure ``plot(*args, **kw)`` saves."""
    import matplotlib.pyplot as plt

    saved = {}
    real_savefig = plt.Figure.savefig

    def keep(fig, path, **k):
        saved["legend"] = [t.get_text() for ax in fig.axes for t in (ax.get_legend().get_texts()
                                                                      if ax.get_legend() else [])]
        return real_savefig(fig, path, **k)

    plt.Figure.savefig = keep
    try:
        plot(*args, **kw)
    finally:
        plt.Figure.savefig = real_savefig
    return saved["legend"]


def test_stuck_and_never_slipped_markers_are_counted_and_only_shown_when_present(tmp_path) -> None:
    """The never-slipped and the stuck-over-the-record markers appear in the legend with their
    counts, and not at all on a map without such cells (a legend entry for nothing drawn would
    read as a claim about the map)."""
    axes = {"Omega": [1.0, 2.0, 4.0], "f0_rel": [1.0, 1.5, 2.0, 3.0]}
    table = _table(axes)  # every fifth point never slipped
    table["stick_fraction"] = 0.4
    table.loc[[1, 2, 5], "stick_fraction"] = 1.0  # 1, 2: slipped then stuck; 5: never slipped
    assert not table.loc[5, "slipped"] and table.loc[[1, 2], "slipped"].all()
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "a.png"), dpi=40)
    assert f"never slipped ({int((~table['slipped']).sum())})" in legend
    assert "every element stuck over the record (2)" in legend
    table["slipped"] = True
    table["stick_fraction"] = 0.4
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "b.png"), dpi=40)
    assert not [t for t in legend if "never slipped" in t or "stuck over the record" in t]


@pytest.mark.parametrize("axes", [{"Omega": [1.0, 2.0, 4.0], "f0_rel": [1.0, 1.5, 2.0, 3.0]},
                                  {"f0_rel": [1.0, 1.5, 2.0, 3.0, 4.0]}])
def test_the_limits_are_drawn_where_their_ratios_cross_one_and_count_the_other_labels(tmp_path,
                                                                                      axes) -> None:
    """The lock ratio is proportional to the load: with ``lock_ratio = f0_rel / 1.8`` the
    lock-up limit lies at ``f0_rel`` 1.8 (interpolated exactly, the ratio being linear), and
    with ``shakedown_ratio`` 1.5 times it (``mu_s / mu_k``) the shakedown limit at 1.2; a map
    without a shakedown ratio (undamped) has no dotted line.  Each legend entry counts the cells
    below its limit whose label is not periodic-1 (a period-2 orbit counts: another label); a
    map entirely below a limit keeps its count and says so; one entirely above has no entry."""
    from analysis.figures.regimes import lock_up_crossings

    table = _table(axes)
    table.loc[table.index[::3], ["label", "period"]] = ["periodic", 2]
    table["lock_ratio"] = table["f0_rel"] / 1.8
    table["shakedown_ratio"] = table["lock_ratio"] * 1.5  # mu_s / mu_k
    x = np.array([1.0, 1.5, 2.0, 3.0])
    assert lock_up_crossings(x[::-1], x[::-1] / 1.8) == pytest.approx([1.8], rel=1e-12)
    assert lock_up_crossings(x, np.array([0.5, np.nan, 2.0, 3.0])) == []
    assert lock_up_crossings(x, x / 2.0) == [2.0]  # a point exactly at 1: one crossing
    p1 = ((table["label"] == "periodic") & (table["period"] == 1)).to_numpy()
    assert (~p1 & (table["period"] == 2)).any()
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "a.png"), dpi=40)
    for name, at in (("lock-up", 1.8), ("shakedown", 1.2)):
        n = int(((table["f0_rel"] < at).to_numpy() & ~p1).sum())
        entry = [t for t in legend if t.startswith(f"{name} limit")]
        assert len(entry) == 1 and f"({n} cells there with another label)" in entry[0], legend
        assert "every cell is below it" not in entry[0]
    table["lock_ratio"], table["shakedown_ratio"] = 0.5, np.nan  # an undamped map: no shakedown limit
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "b.png"), dpi=40)
    assert not [t for t in legend if t.startswith("shakedown limit")]
    entry = [t for t in legend if t.startswith("lock-up limit")]
    assert len(entry) == 1 and f"({int((~p1).sum())} cells there" in entry[0]
    assert "every cell is below" in entry[0]
    table["lock_ratio"], table["shakedown_ratio"] = 2.0, 3.0
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "c.png"), dpi=40)
    assert not [t for t in legend if "limit" in t]


@pytest.mark.parametrize("axes", [{"Omega": [1.0, 2.0, 4.0], "f0_rel": [1.0, 1.5, 2.0, 3.0]},
                                  {"f0_rel": [1.0, 1.5, 2.0, 3.0, 4.0]}])
def test_lifetime_cells_are_marked_with_their_counts_and_lifetimes(tmp_path, axes) -> None:
    """With a lifetime table the map marks the cells measured: the legend counts those whose
    copies were proven to end locked with the range of their mean lifetimes, and the others
    with the least lower bound; a cell without observed time is not marked; an empty table adds
    nothing."""
    table = _table(axes)
    cells = table.iloc[[1, 2, 4, 0]][list(axes)].assign(
        n_escaped=[2, 0, 1, 0], n_unproven=[0, 0, 0, 0], exposure=[1600.0, 16000.0, 3100.0, 0.0],
        lifetime=[812.4, np.inf, 3100.0, np.nan], lifetime_lo=[300.0, 4337.4, 900.0, np.nan])
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "a.png"), dpi=40,
                        lifetimes=cells)
    legend = [" ".join(t.split()) for t in legend]  # entries are wrapped
    assert ("lifetime runs: 2 with copies proven to end locked (a transient, mean lifetimes 812-3100 "
            "periods)") in legend
    assert "lifetime runs: 1 without (mean lifetime > 4337 periods)" in legend
    assert not [t for t in legend if "not measured" in t]
    legend = _legend_of(plot_regimes, table, "g", {"axes": axes}, str(tmp_path / "b.png"), dpi=40,
                        lifetimes=cells.iloc[:0])
    assert not [t for t in legend if "locked" in t]

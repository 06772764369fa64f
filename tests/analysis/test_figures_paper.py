"""The paper reproduction's figure kinds (analysis.figures.paper), each drawn from a small
simulation: the file is written, every panel has data, and the panel count is the documented
one."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest
from matplotlib.image import imread

from analysis.figures import paper as fig
from analysis.paper.measure import dense_history
from analysis.pipeline.config import Numerics
from beamsim.simulate import simulate

POINT = dict(n_modes=1, Omega=1.5, f0_rel=3.0, mu_s=0.3, mu_k=0.3)
NUMERICS = Numerics(method="expo")


@pytest.fixture(scope="module")
def history():
    return dense_history(POINT, NUMERICS, 2, 3, 32)


@pytest.fixture
def drawn(monkeypatch):
    """The figures each function closes, captured before they are closed."""
    figures = []
    close = matplotlib.pyplot.close
    monkeypatch.setattr(fig.plt, "close", lambda f: (figures.append(f), close(f)))
    return figures


def _check(path, figures, n_panels):
    assert imread(str(path)).shape[0] > 100
    (f,) = figures
    axes = [ax for ax in f.axes if ax.get_label() != "<colorbar>"]
    assert len(axes) == n_panels
    for ax in axes:
        if ax.axison:
            assert ax.lines or ax.collections, ax.get_title()
            for line in ax.lines:
                assert np.all(np.isfinite(np.asarray(line.get_xydata(), dtype=float)))


def test_dense_history_continues_a_run_exactly():
    """A history started from a run's final state is that run continued: it starts where the
    run ended and, two periods on, is where one longer run is (the whole state -- velocities,
    slips, stick states -- was handed over; a dropped velocity or slip is off by O(1) of the
    amplitude).  Not bitwise: the restart runs its clock from 0, and expo locates its switches
    to a tolerance (2e-7 of the amplitude measured here)."""
    r = simulate(n_transient=0, n_record=4, method="expo", **POINT)
    longer = simulate(n_transient=0, n_record=6, method="expo", **POINT)
    h = dense_history(POINT, NUMERICS, 0, 2, 32, start=r.final_state)
    scale = np.max(np.abs(longer.poincare_tip[:, :3]))
    assert h["w"][0] == pytest.approx(r.poincare_tip[-1, 0], abs=1e-12 * scale)
    for j, key in enumerate(("w", "u1", "u2")):
        assert h[key][-1] == pytest.approx(longer.poincare_tip[-1, j], abs=1e-5 * scale)


def test_tip_histories_one_row_per_case_three_columns(history, drawn, tmp_path):
    curves = [dict(history, label=f"N = {n}") for n in (1, 2)]
    fig.plot_tip_histories([{"title": "a", "curves": curves}, {"title": "b", "curves": curves}],
                           tmp_path / "h.png")
    _check(tmp_path / "h.png", drawn, 6)
    assert all(len(ax.lines) == 2 for ax in drawn[0].axes)  # one curve per mode count


def test_law_pairs_one_panel_per_law(history, drawn, tmp_path):
    panel = dict(history, title="law", label="periodic")
    fig.plot_law_pairs([{"title": "f0=1", "panels": [panel, panel, panel]},
                        {"title": "f0=5", "panels": [panel, panel]}], tmp_path / "p.png")
    _check(tmp_path / "p.png", drawn, 6)
    assert not drawn[0].axes[5].axison  # the second row has two laws: its third panel is empty


def test_layer_phase_planes_four_panels_per_case(history, drawn, tmp_path):
    fig.plot_layer_phase_planes([dict(history, title="c", label="chaotic")] * 2, tmp_path / "l.png")
    _check(tmp_path / "l.png", drawn, 8)
    # the Poincare panels hold one sample per period of the history
    n_periods = round((history["t"][-1] - history["t"][0]) / history["period_T"]) + 1
    assert len(drawn[0].axes[2].lines[0].get_xdata()) == n_periods


def test_friction_law_curve(drawn, tmp_path):
    v = np.linspace(-1e-3, 1e-3, 101)
    fig.plot_friction_law([{"label": "s", "v": v, "traction": np.tanh(v / 1e-5)}], tmp_path / "f.png")
    _check(tmp_path / "f.png", drawn, 1)


def test_poincare_transient_coloured_by_period(drawn, tmp_path):
    r = simulate(n_transient=0, n_record=12, method="expo", **POINT)
    fig.plot_poincare_transient([{"title": "a", "poincare": r.poincare_tip}] * 3, tmp_path / "t.png")
    _check(tmp_path / "t.png", drawn, 3)
    colours = drawn[0].axes[0].collections[0].get_array()
    np.testing.assert_array_equal(colours, np.arange(1, 13))  # period index 1 .. 12 (0 is rest)


def test_load_sweeps_diagram_over_lle_curve(drawn, tmp_path):
    pts = [{"x": x, "label": "periodic", "poincare_w": np.full(5, x), "lle_T": -0.1,
            "lle_lo_T": -0.15, "lle_hi_T": -0.05, "lle_stefanski_T": -0.05}
           for x in (1.0, 2.0, 4.0)]
    fig.plot_load_sweeps([{"title": "a", "xlabel": "x", "log": True, "points": pts}] * 2, tmp_path / "s.png",
                         resolution=0.2)
    _check(tmp_path / "s.png", drawn, 4)
    assert drawn[0].axes[1].get_xscale() == "log"

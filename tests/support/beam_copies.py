"""Shared pieces of the beam's Lyapunov tests (tests/analysis/test_lyapunov_beam.py,
tests/beamsim/test_expo_copies.py, tests/analysis/test_pipeline_stages.py,
tests/analysis/test_second_opinion.py, tests/analysis/test_noise_floor.py): the two-mode
chaotic point, the one-mode and grazing points, stretches of the chaotic attractor, and the
closed-form check of a coupled copy."""

from __future__ import annotations

import math

import numpy as np

from analysis.lyapunov.beam import attractor_scale, initial_offset, response_scale
from beamsim.coupled_copies import run_copies
from beamsim.simulate import prepare_point, restart_params, simulate_batch

#: a chaotic point of the default grid's axes with two modes (row 89 of the two-mode run,
#: docs/lyapunov.md s.7): weaker static/kinetic drop, and a tight Stefanski threshold
CHAOTIC_2MODES = dict(n_modes=2, mu_s=0.45, mu_k=0.3, interface_damping=0.5, Omega=1.84770278237,
                      f0_rel=1.4962340536)
#: one-mode points of the default friction: a period-1 orbit with slip, and a stuck torus below
#: the slip onset (undamped)
ONE_MODE = dict(n_modes=1, mu_k=0.3, interface_damping=0.5)
SLIPPING = dict(ONE_MODE, Omega=2.5, f0_rel=2.5, mu_s=0.6)
STUCK = dict(ONE_MODE, Omega=2.5, f0_rel=0.5, mu_s=0.45)
#: the default map's period-1 cell (three modes, mu_s 0.45 > mu_k 0.3) at Omega 1.25, f0_rel
#: 1.057, just above the static slip onset, where the expo pair read chaos (docs/lyapunov.md
#: sections 15 and 16), and the transient its table used (map of 2026-11-28)
GRAZING = dict(n_modes=3, mu_s=0.45, mu_k=0.3, interface_viscosity=0.0939, Omega=1.25,
               f0_rel=1.05666829058)
GRAZING_TRANSIENT = 1424


def stretches(point: dict, gaps: tuple[int, ...]):
    """Start states of stretches of ``point``'s attractor: where the pipeline starts (RK4 at
    step factor 1.0, 60 + 128 periods) and ``gaps[0]``, ``gaps[0] + gaps[1]``, ... periods
    later; returns the prepared point, the ``(1 + len(gaps), ...)`` start states and the
    attractor scale of the first record."""
    pp = prepare_point(**point)
    runs = [simulate_batch([point], n_transient=60, n_record=128, method="rk4", step_factor=1.0,
                           n_threads=2)[0]]
    for n in gaps:
        runs.append(simulate_batch([point | restart_params(runs[-1])], n_transient=0, n_record=n,
                                   method="rk4", step_factor=1.0, n_threads=1)[0])
    scale = attractor_scale(runs[0].poincare_state, response_scale(pp), pp.omega)
    return pp, np.stack([r.final_state for r in runs]), scale


def check_coupling_closed_form(pp, start: np.ndarray, scale: np.ndarray, e0: float, **run_kw) -> None:
    """``e_d(t) = exp(-d t) e_0(t)`` for the linearised dynamics (the coupling adds ``-d I`` to
    the variational equation): copies with ``d T`` = 0, 0.1, 0.3 from one offset, 8 periods
    without rescaling, ``ln(e_d / e_0)`` against ``-d t`` within 2 % and 0.01."""
    T = 2 * math.pi / pp.omega
    d = np.array([[0.0, 0.1 / T, 0.3 / T]])
    off = np.stack([initial_offset(pp, scale, e0)] * 3)[None]
    le = run_copies([pp], start[None], off, d, 1 / scale[None], n_periods=8, e0=e0,
                    band=(1e-30, 1e30), **run_kw)
    t = np.arange(9) * T
    for m in (1, 2):
        measured = le[0, m, 1:] - le[0, 0, 1:]
        expected = -d[0, m] * t[1:]
        print(f"\ncoupling d T = {d[0, m] * T:.1f}: ln(e_d / e_0) per period", measured)
        assert np.allclose(measured, expected, rtol=0.02, atol=0.01), (m, measured, expected)

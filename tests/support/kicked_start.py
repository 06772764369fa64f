"""A start far off a point's locked orbit, shared by the shakedown tests of the kernels, the
simulate stage and the lifetime runs."""

from __future__ import annotations

import numpy as np


def kicked_locked_orbit(pp, factor: float = 30.0) -> np.ndarray:
    """The state of ``pp``'s locked orbit (:func:`beamsim.shakedown.locked_orbit`, kernels'
    layout ``(q, v, z, mode)``) with a velocity kick of ``factor`` times the orbit's scale
    (``omega`` times its largest coordinate) along the slowest stuck mode: every element stuck,
    so it slips at once and, below the shakedown limit, for many periods."""
    from beamsim.shakedown import locked_orbit

    x = locked_orbit(pp).state.copy()
    n = pp.model.n
    _, phi = pp.model.eig_stuck
    x[n:2 * n] += factor * pp.omega * np.abs(x[:n]).max() * phi[:, 0] / np.abs(phi[:, 0]).max()
    return x

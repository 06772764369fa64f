r"""``expo``'s noise floor at a beam point: the separation that rounding alone opens in one period.

The ``expo`` pair (:mod:`beamsim.kernels.expo_copies`) measures ``lambda_1`` from a copy kept at
the scaled separation ``e0`` from its drive (:mod:`analysis.lyapunov.beam`).  A copy whose
separation is not far above the rounding that the drive itself accumulates in a period measures
that rounding: its record grows by about ``ln(N / e0)`` per period whatever the dynamics.  Up to
results version 21 ``expo`` left a rounding error in the slow modes at every switch (the
interface loads' modal projection through the ill-conditioned mass matrix), and near the slip
onset, where stuck tractions reach their limit slowly, it grew within one forcing period to a
sizeable fraction of ``e0`` (docs/lyapunov.md, section 16).  Version 22 removed that source
(section 17); the guard stays for noise of other origins.

:func:`expo_noise_floor` measures ``N`` directly: from the same state, the drive is run over
one forcing period on two output grids (:data:`FLOOR_GRIDS` steps per period: the same
trajectory, split at different times, so the two runs differ by rounding only), and the scaled
RMS of the two end states' difference (the pairs' own metric) is the floor of that period; the
largest over ``n_periods`` periods (each restarted from the first grid's end state) is the
point's.  Where it exceeds a fraction of ``e0`` the pipeline runs the point on the RK4 pair
(:func:`analysis.lyapunov.beam.beam_lle`, ``floor_ratio``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["FLOOR_GRIDS", "FLOOR_PERIODS", "expo_noise_floor"]

#: the two output grids (steps per forcing period) whose runs are compared: the ``expo``
#: copies' default grid (:data:`beamsim.coupled_copies.EXPO_COPY_STEPS_PER_PERIOD`) and one that
#: shares none of its inner step ends.  ``beam_lle`` uses them whatever its copies' grid (the
#: convergence evidence's ``step / 2`` doubles that): the floor is the drive's rounding, not a
#: property of one grid
FLOOR_GRIDS = (16, 23)
#: forcing periods measured (each from the state the first grid's run ended in)
FLOOR_PERIODS = 3


def expo_noise_floor(prepared: list, x_start: np.ndarray, scales: np.ndarray, *,
                     n_periods: int = FLOOR_PERIODS, grids: tuple[int, int] = FLOOR_GRIDS,
                     n_threads: int | None = None, pattern_store=None) -> np.ndarray:
    """The largest one-period rounding separation of ``expo``'s drive at each point, ``(P,)``.

    prepared : points from :func:`beamsim.simulate.prepare_point` (their ``params`` are run).
    x_start : ``(P, 2 n + 2 n_quad)`` restart states (``SimResult.final_state``; each run
        restarts the forcing phase at ``t = 0``).
    scales : ``(P, 2 n)`` attractor sizes (:func:`analysis.lyapunov.beam.attractor_scale`): the
        separation is the RMS over ``(q, v)`` of the difference divided by them, as the pairs'.
    grids : two ``expo`` output grids, steps per forcing period.
    pattern_store : stick-pattern decompositions shared with other ``expo`` calls (a cost).

    A point whose run diverges, ends non-finite or meets ``expo``'s Zeno guard gets ``inf`` (it
    then runs on the RK4 pair, where the Zeno fallback would have sent it too).  Deterministic:
    the runs are the simulator's, whose results do not depend on threads or batch."""
    from beamsim.simulate import simulate_batch, state_params

    P = len(prepared)
    x = np.array(x_start, dtype=float, copy=True)
    scales = np.asarray(scales, dtype=float)
    floor = np.zeros(P)
    for _ in range(int(n_periods)):
        pts = [state_params(pp.params, x[i], pp.model.n) for i, pp in enumerate(prepared)]
        runs = [simulate_batch(pts, n_transient=0, n_record=1, method="expo", steps_per_period=g,
                               n_threads=n_threads, pattern_store=pattern_store) for g in grids]
        for i, (a, b) in enumerate(zip(*runs)):
            d = (a.poincare_state[-1] - b.poincare_state[-1]) / scales[i]
            sep = float(np.sqrt(np.mean(d * d)))
            # a diverged run, or one that met expo's Zeno guard (a jump in time), is no measure
            trusted = np.isfinite(sep) and not (a.diverged or b.diverged or a.n_zeno or b.n_zeno)
            floor[i] = max(floor[i], sep if trusted else np.inf)
            if trusted:
                x[i] = a.final_state
    return floor

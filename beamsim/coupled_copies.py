r"""A drive trajectory of the beam and perturbed copies of it, integrated together (RK4).

This is the integrator behind the beam's Lyapunov estimates (:mod:`analysis.lyapunov.beam`).
One *drive* ``x = (q, v, z)`` (generalised coordinates, velocities, Jenkins slips) with its
stick/slip state, started from a full restart state (``SimResult.final_state``), and ``M``
*copies* ``y_m`` started at ``x + offset_m``, each with its own stick/slip state, obey

.. math::  \dot x = f(t, x), \qquad \dot y_m = f(t, y_m) + d_m\,(x - y_m)

on every continuous state variable (``q``, ``v`` and ``z``): ``d_m = 0`` is a free copy
(two-trajectory / Benettin estimate), ``d_m > 0`` is the one-way coupling of the Stefanski
synchronisation method.  With ``method="rk4"`` (described here) all of them use the RK4
reference scheme of :mod:`beamsim.kernels.rk4` with the same step; ``method="expo"`` runs them
on ``expo`` (:mod:`beamsim.kernels.expo_copies`, which describes its coupling).  The drive
is stepped exactly as the reference run steps it (split only at its own stick/slip
switches), so its trajectory does not depend on the copies: every copy of a point, in
whatever task or batch, follows the same drive.  A copy follows the drive's substeps and
splits them further at its own switches; a coupled copy integrates the drive's substep
alongside (from the drive's state at the substep start) and the coupling enters every RK4
stage with the drive's stage state, so the coupled pair is integrated as one system.  Each
copy's Jenkins elements are return-mapped after every step exactly as the drive's.

The scaled error of copy ``m`` is the RMS over the ``2 n`` components of ``(q, v)``:

.. math::  \varepsilon_m = \sqrt{\tfrac{1}{2n}\sum_i ((y_{m,i} - x_i)\,/\,s_i)^2}

(``s_i``: the attractor's size in component ``i``).  To keep the copies in the linear regime
and off the round-off floor, a copy whose error leaves ``[band_lo, band_hi]`` is moved back
along its current direction to ``e0`` (about the drive, on ``q``, ``v`` and ``z``), and the
factor is carried in the recorded ``ln eps`` (so the record is the error of the linearised,
unbounded dynamics).  Copies flagged ``renorm_period`` are moved back to ``e0`` at every
period end as well (the classic Benettin renormalisation).  ``ln eps`` is recorded at every
forcing period boundary.

The stick/slip state of a Jenkins element is memory (hysteresis), not a function of the
continuous state, so a copy can stay stuck inside the band ``mu_k p < |tau| < mu_s p`` while the
drive's element slides: a mismatch that no coupling of the continuous variables removes (the
error settles at ``~ s'/d``) and that a rescaling would make inconsistent.  A copy within
``10 e0`` of the drive (after any rescaling) therefore takes the drive's stick/slip state
(:func:`beamsim.kernels.copies.adopt_modes`): in the linear regime the two switch within the
same step, so this only acts on persistent mismatches, moving the copy's switch by less than
the time its own would have taken (an error of the order of the separation).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from beamsim.friction import RIGID_STICK
from beamsim.kernels import copies, expo_copies
from beamsim.kernels.thread_pool import run_items
from beamsim.pattern_store import PatternStore, cache_slots, model_keys
from beamsim.point import check_method_law, period_steps, stack_points
from beamsim.two_layer import check_int, check_positive

#: the ``expo`` copies' output grid, steps per forcing period (where they are measured,
#: coupled and rescaled) when none is given: 16 since results version 16, the reference runs'
#: ``expo`` grid (:data:`beamsim.point.DEFAULT_STEPS_PER_PERIOD`); 64 before, where the
#: method's checks had been made (docs/lyapunov.md, section 12, repeats them at 16)
EXPO_COPY_STEPS_PER_PERIOD = 16

__all__ = ["run_copies"]


def run_copies(prepared: list, x_start: np.ndarray, offsets: np.ndarray, d: np.ndarray,
               inv_scale: np.ndarray, *, n_periods: int, e0: float,
               renorm_period: np.ndarray | None = None, band: tuple[float, float] = (1e-4, 1e4),
               steps_per_period: int | None = None, step_factor: float = 0.5,
               n_threads: int | None = None, split: int | None = None,
               div_limit: float = 1e6, return_final: bool = False, method: str = "rk4",
               event_checks: int = 4, pattern_cache: int = 2048, adoption: str = "window",
               zeno_out: np.ndarray | None = None, pattern_store: PatternStore | None = None):
    """Integrate the drive and its copies for ``n_periods`` forcing periods (see the module
    docstring) and return ``ln eps`` of shape ``(P, M, n_periods + 1)`` at the period
    boundaries (``nan``: the drive diverged; ``+inf``: the copy did).

    With ``return_final`` also the end states, ``(P, M + 1, 2 n + 2 n_quad)`` (row 0 the drive,
    row ``1 + m`` copy ``m``; layout of ``x_start``): a run restarted from the drive's end
    state with the offsets ``final[:, 1:, :2 n + n_quad] - final[:, :1, :2 n + n_quad]``
    continues this one step for step (the drive bitwise: the forcing phase restarts at
    ``t = 0`` on a period boundary), with the ``ln eps`` record starting afresh.

    prepared : ``P`` points (:func:`beamsim.simulate.prepare_point`, same ``n`` and ``n_quad``).
    x_start : ``(P, 2 n + 2 n_quad)`` drive restart states ``(q, v, z, mode)``
        (``SimResult.final_state``; the run restarts the forcing phase at ``t = 0``).
    offsets : ``(P, M, 2 n + n_quad)`` initial ``y_m - x`` on ``(q, v, z)``.
    d : ``(P, M)`` couplings (1 / time unit); ``0`` = free copy.
    inv_scale : ``(P, 2 n)`` inverse attractor size per component of ``(q, v)``.
    e0, band : rescaling target and band ``[e0 band[0], e0 band[1]]`` of the scaled error.
    renorm_period : ``(P, M)`` bool, copies also rescaled to ``e0`` at every period end.
    split : tasks per point (for threads), each integrating the drive with its share of the
        copies.  The drive does not depend on the copies, so results do not depend on
        ``split``, on which other copies run, or on the number of threads (bitwise).  Default:
        enough tasks to occupy the threads (``ceil(threads / P)``).
    method : ``"rk4"`` (the reference: every copy on the drive's RK4 steps, couplings allowed)
        or ``"expo"`` (:mod:`beamsim.kernels.expo_copies`: drive and copies each propagated
        exactly between their own located switches; stick-slip law only; a coupling acts as
        its own flow at the output grid's step ends, exact in the linearised dynamics).  With
        ``expo`` the copies are measured, coupled and rescaled at the ``expo`` output grid's
        step ends (``steps_per_period``, default 16 per period) and ``step_factor`` only sets
        the adoption window; ``event_checks``, ``pattern_cache`` and ``pattern_store`` are ``expo``'s
        (:func:`beamsim.simulate.simulate_batch`; a thread's drives and copies share its
        cache).
    adoption : ``expo`` only: how a copy takes the drive's stick/slip state where the two
        differ (:mod:`beamsim.kernels.expo_copies`): ``"window"`` once the mismatch has lasted
        ``tau_a = step_factor / (2 omega_max)``, half the RK4 pair's step (the mean delay with
        which the RK4 copies adopt it at their step ends); ``"grid"`` at every output step end.
    zeno_out : optional ``(P, M + 1)`` integer array (rows as ``final``'s) that receives the
        number of output steps ended by ``expo``'s Zeno guard (zero with RK4; more than
        ``10 n_quad + 10`` switches within one step: the trajectory is accepted there and put
        on the step's end, so a copy with a count above zero is behind its drive in time and
        its error is not a separation; docs/lyapunov.md s.12).
    """
    P = len(prepared)
    x_start = np.ascontiguousarray(x_start, dtype=float)
    offsets = np.ascontiguousarray(offsets, dtype=float)
    d = np.ascontiguousarray(d, dtype=float)
    inv_scale = np.ascontiguousarray(inv_scale, dtype=float)
    n_periods = check_int("n_periods", n_periods, 1)
    e0 = check_positive("e0", e0)
    if P == 0:
        raise ValueError("prepared must not be empty")
    n, nq = prepared[0].model.n, prepared[0].model.n_quad
    M = offsets.shape[1] if offsets.ndim == 3 else -1
    if offsets.shape != (P, M, 2 * n + nq) or d.shape != (P, M):
        raise ValueError(f"offsets must be (P, M, {2 * n + nq}) and d (P, M); got "
                         f"{offsets.shape} and {d.shape}")
    if x_start.shape != (P, 2 * n + 2 * nq) or inv_scale.shape != (P, 2 * n):
        raise ValueError("x_start must be (P, 2 n + 2 n_quad) and inv_scale (P, 2 n)")
    if not (np.all(np.isfinite(x_start)) and np.all(np.isfinite(offsets)) and np.all(d >= 0)):
        raise ValueError("x_start and offsets must be finite and d >= 0")
    if renorm_period is None:
        renorm_period = np.zeros((P, M), np.bool_)
    renorm_period = np.ascontiguousarray(renorm_period, dtype=np.bool_)
    if method not in ("rk4", "expo"):
        raise ValueError(f"method must be 'rk4' or 'expo', got {method!r}")
    if zeno_out is not None and np.shape(zeno_out) != (P, M + 1):
        raise ValueError(f"zeno_out must be (P, M + 1) = {(P, M + 1)}, got {np.shape(zeno_out)}")
    if method == "expo":
        for pp in prepared:
            check_method_law("expo", pp.friction.law)
        if adoption not in ("window", "grid"):
            raise ValueError(f"adoption must be 'window' or 'grid', got {adoption!r}")
        event_checks = check_int("event_checks", event_checks, 1)
        pattern_cache = cache_slots(check_int("pattern_cache", pattern_cache, 1), n)
    stk = stack_points(prepared, div_limit)
    h = np.empty(P)
    n_per = np.empty(P, np.int64)
    for i, pp in enumerate(prepared):
        n_per[i] = period_steps(pp, method, steps_per_period or (
            EXPO_COPY_STEPS_PER_PERIOD if method == "expo" else None), step_factor)
        h[i] = 2 * math.pi / pp.omega / n_per[i]
    threads = numba.get_num_threads() if n_threads is None else check_int("n_threads", n_threads, 1)
    split = -(-threads // P) if split is None else int(split)
    split = max(1, min(M, split))
    tasks = [(p, int(chunk[0]), int(chunk[-1]) + 1) for p in range(P)
             for chunk in np.array_split(np.arange(M), split) if chunk.size]
    log_err = np.full((P, M, n_periods + 1), np.nan)
    final = np.full((P, M + 1, 2 * n + 2 * nq), np.nan)
    all_tasks = np.array(tasks, np.int64).reshape(-1, 3)
    rigid = stk.law[all_tasks[:, 0]] == RIGID_STICK
    bundles = (all_tasks, stk, copies.CopySchedule(h, n_per, n_periods, stk.divl), x_start,
               copies.CopySpec(offsets, d, renorm_period, inv_scale),
               copies.Band(e0, e0 * band[0], e0 * band[1]))
    if method == "expo":
        tau_a = np.array([0.5 * step_factor / pp.omega_max if adoption == "window" else 0.0
                          for pp in prepared])
        opts = expo_copies.ExpoCopyOptions(event_checks, tau_a, model_keys(stk))
        out = expo_copies.ExpoCopyOutputs(log_err, final, np.zeros((P, M + 1), np.int64))
        (pattern_store or PatternStore()).run(expo_copies.run_task, bundles + (opts, out),
                                              opts.model[all_tasks[:, 0]], stk, pattern_cache,
                                              threads)
        if zeno_out is not None:
            zeno_out[...] = out.zeno
        return (log_err, final) if return_final else log_err
    if zeno_out is not None:
        zeno_out[...] = 0  # RK4 locates every switch within its steps: no guard
    args = bundles + (log_err, final)
    # the rigid stick's kernel is its own (compiled only when a rigid point is run)
    for kernel, sel in ((copies.run_task, ~rigid), (copies.run_task_rigid, rigid)):
        run_items(kernel, args, np.flatnonzero(sel), threads)
    return (log_err, final) if return_final else log_err

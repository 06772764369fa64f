"""Result types of the simulator and the named columns of the kernels' bookkeeping arrays.

The compiled kernels (:mod:`beamsim.kernels`) write a point's scalar outcomes into a row of a
``flags`` array and keep running sums in a ``stats`` vector; the integer names below are the
only place their columns are defined (numba treats module-level integers as compile-time
constants).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SimResult", "BatchResult", "TIP_COLUMNS", "ENERGY_COLUMNS", "INTEGRATORS", "N_FLAGS",
           "N_STATS", "ZENO_FALLBACK"]

#: columns of ``SimResult.poincare_tip`` / the dense history
TIP_COLUMNS = ("w_tip", "u1_tip", "u2_tip", "load_point")
#: columns of ``SimResult.energy``
ENERGY_COLUMNS = ("W_in", "D_friction", "D_damping", "E_mech", "E_interface")

# ----------------------------------------------------------------- flags row of a point (P, N_FLAGS)
FLAG_DIVERGED = 0          #: 1.0 if the point diverged (then stopped)
FLAG_T_DIVERGED = 1        #: time of divergence
FLAG_SLIPPED = 2           #: 1.0 if any Jenkins element ever slipped (after t = 0)
FLAG_T_FIRST_SLIP = 3      #: time of the first slip (nan if none)
FLAG_STICK_FRACTION = 4    #: stuck fraction of the interface over the recorded periods
FLAG_E_MECH0 = 5           #: mechanical energy at t = 0
FLAG_STICK_FRACTION_ALL = 6  #: stuck fraction over the whole run
FLAG_N_PATTERNS = 7        #: expo: stick patterns eigen-decomposed
FLAG_N_EVENTS = 8          #: located stick/slip switches (RK4, expo)
FLAG_N_CHECKS = 9          #: expo: event-function checks
FLAG_N_ZENO = 10           #: expo: steps ended by the Zeno guard (the state taken to the step end)
N_FLAGS = 11

#: the simulator's integrators, the keys of :data:`beamsim.simulate.METHODS` in its order (here,
#: without the kernels, for modules that only check a name: the pipeline's config, which every
#: ``snakemake`` call parses)
INTEGRATORS = ("rk4", "expo", "newmark")

#: the integrator recorded for a run that asked for ``expo`` and was run on RK4 because an
#: ``expo`` trajectory met the Zeno guard (``n_zeno > 0``; the pipeline's stages do this)
ZENO_FALLBACK = "rk4 (expo met its Zeno guard)"

# ------------------------------------------------------------------------ running sums (N_STATS,)
STAT_SLIPPED = 0           #: 1.0 once any element slipped
STAT_T_FIRST_SLIP = 1      #: time of the first slip
STAT_STUCK_W_RECORD = 2    #: sum of stuck quadrature weights at step ends (recorded periods)
STAT_W_RECORD = 3          #: sum of all quadrature weights at step ends (recorded periods)
STAT_STUCK_W_ALL = 4       #: as STAT_STUCK_W_RECORD over the whole run
STAT_W_ALL = 5             #: as STAT_W_RECORD over the whole run
N_STATS = 6


def flag_fields(flags: np.ndarray) -> dict:
    """The :class:`SimResult` fields held in a point's ``flags`` row."""
    div = bool(flags[FLAG_DIVERGED])
    return dict(E_mech0=float(flags[FLAG_E_MECH0]), diverged=div,
                t_diverged=float(flags[FLAG_T_DIVERGED]) if div else np.nan,
                slipped=bool(flags[FLAG_SLIPPED]), t_first_slip=float(flags[FLAG_T_FIRST_SLIP]),
                stick_fraction=float(flags[FLAG_STICK_FRACTION]),
                stick_fraction_all=float(flags[FLAG_STICK_FRACTION_ALL]),
                n_patterns=int(flags[FLAG_N_PATTERNS]), n_events=int(flags[FLAG_N_EVENTS]),
                n_checks=int(flags[FLAG_N_CHECKS]), n_zeno=int(flags[FLAG_N_ZENO]))


@dataclass
class SimResult:
    """Result of one parameter point (all times and quantities dimensionless, docs/model.md).

    poincare_state : (n_record + 1, 2 n) generalised coordinates q and velocities v at
        ``t = (n_transient + k) T``, k = 0..n_record (T = 2 pi / omega).
    poincare_tip : (n_record + 1, 4) tip w, u1, u2 and the load-point displacement
        (``cos(beta) w - sin(beta) u1``, work-conjugate to F).
    energy : (n_record + 1, 5) W_in, D_friction, D_damping, E_mech (incl. interface elastic
        energy), E_interface -- cumulative since t = 0 (E_mech: current value).
    diss_per_cycle : (n_record,) friction dissipation in each recorded forcing period.
    dense_t, dense : optional dense history (columns TIP_COLUMNS [+ q, v]).
    final_state : (2 n + 2 n_quad,) state at the end of the run: q, v, Jenkins slips z, and the
        stick/slip state of each element (0 stuck, +-1 slipping); see
        :func:`beamsim.simulate.restart_params`.
    n_patterns, n_events, n_checks, n_zeno : integrator counters (see the ``FLAG_N_*``
        columns); ``n_zeno > 0``: ``expo`` met its Zeno guard, the trajectory is not to be
        trusted there (docs/lyapunov.md s.12).
    """

    params: dict
    coord_names: list
    f0: float
    f_cr: float
    omega: float
    Omega: float
    lam_f: float
    h: float
    steps_per_period: int
    method: str
    t_poincare: np.ndarray
    poincare_state: np.ndarray
    poincare_tip: np.ndarray
    energy: np.ndarray
    E_mech0: float
    diverged: bool
    t_diverged: float
    slipped: bool
    t_first_slip: float
    stick_fraction: float
    stick_fraction_all: float
    n_patterns: int = 0
    n_events: int = 0
    n_checks: int = 0
    n_zeno: int = 0
    dense_t: np.ndarray | None = None
    dense: np.ndarray | None = None
    final_state: np.ndarray | None = None

    @property
    def diss_per_cycle(self) -> np.ndarray:
        return np.diff(self.energy[:, 1])

    @property
    def energy_residual(self) -> np.ndarray:
        """``E_mech - E_mech0 - (W_in - D_friction - D_damping)`` at the Poincare samples."""
        e = self.energy
        return e[:, 3] - self.E_mech0 - (e[:, 0] - e[:, 1] - e[:, 2])


@dataclass
class BatchResult:
    """Arrays with a leading point axis (see :class:`SimResult` for their meaning)."""

    points: list
    results: list
    wall_time: float

    def __len__(self):
        return len(self.results)

    def __getitem__(self, i) -> SimResult:
        return self.results[i]

    def summary(self):
        """One row per point (pandas DataFrame): the point's scalar parameters, the load and
        frequency in every unit, slip indicators, mean friction dissipation per recorded period
        and the last Poincare sample of the tip."""
        import pandas as pd

        rows = []
        for pt, r in zip(self.points, self.results):
            row = {k: v for k, v in pt.items() if np.isscalar(v) or v is None}
            last = r.poincare_tip[-1] if len(r.poincare_tip) else np.full(4, np.nan)
            row.update(f0=r.f0, f_cr=r.f_cr, f0_rel=(r.f0 / r.f_cr if r.f_cr > 0 else np.nan),
                       omega=r.omega, Omega=r.Omega, lam_f=r.lam_f, h=r.h,
                       steps_per_period=r.steps_per_period, method=r.method,
                       diverged=r.diverged, t_diverged=r.t_diverged, slipped=r.slipped,
                       t_first_slip=r.t_first_slip, stick_fraction=r.stick_fraction,
                       stick_fraction_all=r.stick_fraction_all,
                       diss_per_cycle=(float(np.nanmean(r.diss_per_cycle))
                                       if np.isfinite(r.diss_per_cycle).any() else np.nan),
                       W_in=r.energy[-1, 0], D_friction=r.energy[-1, 1],
                       energy_residual=r.energy_residual[-1],
                       **{f"{c}_last": last[i] for i, c in enumerate(TIP_COLUMNS)})
            rows.append(row)
        return pd.DataFrame(rows)

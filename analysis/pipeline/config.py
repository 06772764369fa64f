"""The pipeline's numerical settings: one typed bundle, the defaults in one place.

``config/config.yaml`` (section ``numerics``) and :class:`Numerics` hold the same defaults (a
test checks it); a key left out of the config takes the default here, and every stage reads its
settings from a :class:`Numerics`, never from a ``dict.get(key, default)`` of its own.  The
settings that change results (:meth:`Numerics.result_dict`: everything but ``chunk_size``)
enter every point's id (:func:`analysis.pipeline.grid.point_id`) fully resolved, so a
computation has one id whether a setting was written out or left to its default.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from typing import Any, Mapping

from analysis.lyapunov.block_statistics import BOUNDARIES, BlockPlan
from beamsim.results import INTEGRATORS

__all__ = ["CONFIRM_METHODS", "LYAPUNOV_METHODS", "LyapunovNumerics", "Numerics", "as_numerics", "check_keys"]

#: reference-run integrators the pipeline accepts: the simulator's, and ``auto``
#: (:func:`analysis.pipeline.stages.integrator`)
METHODS = ("auto", *INTEGRATORS)

#: integrators of the Lyapunov stage's free copy (:func:`analysis.pipeline.stages.free_copy_integrator`)
LYAPUNOV_METHODS = ("auto", "rk4", "expo")
#: second opinions on an ``expo`` pair's long record (:attr:`LyapunovNumerics.confirm`)
CONFIRM_METHODS = ("contradicted", "all", "none")


def check_keys(section: str, given: Mapping[str, Any], allowed) -> None:
    """Refuse the keys of the config section ``section`` that are not in ``allowed``: one line
    naming them and the allowed ones (sorted), e.g. ``lifetimes: unknown key(s) ['sample'];
    allowed: ['copies', ...]``."""
    allowed = sorted(allowed)
    unknown = set(given) - set(allowed)
    if unknown:
        raise ValueError(f"{section}: unknown key(s) {sorted(unknown)}; allowed: {allowed}")


@dataclass(frozen=True)
class LyapunovNumerics:
    """Settings of the Lyapunov stage.

    n_periods : length of every synchronisation test (Stefanski, the cross-check) and of the
        window Benettin value that seeds its ladder, in forcing periods.
    step_factor : RK4 step of the Lyapunov runs, ``h = step_factor / omega_max``.
    method : integrator of the free copy (the Benettin record, its block statistics and
        Stefanski's ``d = 0`` test), one of :data:`LYAPUNOV_METHODS`: ``rk4`` (drive and copy
        on the RK4 step ``step_factor``; the default until results version 8), ``expo`` (drive
        and copy each exact between their own located switches, a stick/slip mismatch adopted
        after half the RK4 step of ``step_factor``; stick-slip law only; 6-8x cheaper per
        period: docs/lyapunov.md, section 12) or ``auto`` (the default: ``expo`` for the
        stick-slip law with ``mu_s > mu_k``, ``rk4`` otherwise:
        :func:`analysis.pipeline.stages.free_copy_integrator`).
    ladder : integrator of the Stefanski ladder's coupled copies (the cross-check column):
        ``expo`` (the default since results version 13; used where the free copy is ``expo``'s,
        else RK4's: the coupling applied as its own flow at the output grid's step ends, exact
        in the linearised dynamics, :mod:`beamsim.kernels.expo_copies`; 5-10x cheaper, and
        within 5 % of both integrators' Benettin values at three chaotic points where the RK4
        ladder reads 10 %, 38 % and, at one three-mode point, a factor 200 above them (a step
        artefact there): docs/lyapunov.md, section 13) or ``rk4`` (the RK4 pair on
        ``step_factor`` everywhere; the default until results version 12).  Labels do not
        read it.  Not part of a point's id when ``expo``.
    expo_e0 : initial (and renormalised) scaled separation of an ``expo`` free copy, chosen
        when ``expo``'s rounding (up to results version 21) opened separations in one period
        that the RK4 pair's ``1e-6`` would have measured at many points (docs/lyapunov.md,
        sections 12 and 16; version 22 removed that source, section 17, and the choice was
        not revisited; where the floor approaches ``expo_e0``, ``expo_floor`` applies; the
        convergence evidence's ``separation`` row divides it by 10).  Not part of a point's
        id when the free copy is RK4's (:meth:`Numerics.result_dict`).
    rk4_e0 : initial (and renormalised) scaled separation of the RK4 pair's copies: the free
        copy where it is RK4's, the RK4 ladder's coupled copies and the second opinion's record
        (:func:`analysis.lyapunov.beam.beam_lle`'s ``e0``).  Part of a point's id only when it
        differs from the default ``1e-6``, the separation of every results version before it
        was a setting (whose ids stay as they were).
    confirm : second opinion on the ``expo`` pair's long record whose interval is not at or
        below ``margin``, one of :data:`CONFIRM_METHODS`: ``contradicted`` (the default since
        2026-11-28) measures such a record again on the RK4 pair (``step_factor``;
        :func:`analysis.lyapunov.beam.rk4_long_record`), whose statistics then decide, where
        the Poincare record does not say chaos on its own
        (:func:`analysis.regimes.poincare_says_chaotic`); ``all`` does so at every such record
        (on the default map about 4 minutes more); ``none`` keeps the ``expo`` pair's (at
        period-1 orbits near the slip onset, which the period test labels, its long record
        reads chaos the RK4 pair does not: docs/lyapunov.md, section 15).  Not part of a
        point's id when ``method`` is ``rk4`` (as ``expo_e0``).
    expo_floor : where the free copy is ``expo``'s, ``expo``'s noise floor ``N`` is measured
        first at every point (:func:`analysis.lyapunov.noise_floor.expo_noise_floor`: the scaled
        separation that rounding alone opens in one forcing period) and a point with ``N >
        expo_floor * expo_e0`` runs on the RK4 pair throughout (window, Stefanski, long record),
        because there the ``expo`` copy would measure the noise (docs/lyapunov.md, section 16);
        ``null`` measures no floor (the behaviour before this guard).  Not part
        of a point's id when ``method`` is ``rk4`` (as ``expo_e0``).
    nolds_emb_dim : embedding dimension of the Rosenstein (nolds) estimate.
    block_periods, burn_in, min_blocks, max_blocks, confidence, margin, boundary : the long
        Benettin record whose block statistics decide the label
        (:class:`analysis.lyapunov.block_statistics.BlockPlan`): ``burn_in + min_blocks *
        block_periods`` periods first, extended one block at a time while the
        ``confidence`` interval of ``lambda_1 T`` straddles ``margin`` (per forcing period),
        up to ``max_blocks`` blocks; each look's interval widened to the group-sequential
        ``boundary`` (one of :data:`analysis.lyapunov.block_statistics.BOUNDARIES`), so that
        ``confidence`` is the level of the sequential test, not of each look.
    """

    n_periods: int = 25
    step_factor: float = 0.5
    method: str = "auto"
    expo_e0: float = 1e-4
    rk4_e0: float = 1e-6
    ladder: str = "expo"
    confirm: str = "contradicted"
    expo_floor: float | None = 0.1
    nolds_emb_dim: int = 6
    # the long record's defaults are BlockPlan's (one place)
    block_periods: int = BlockPlan.block
    burn_in: int = BlockPlan.burn_in
    min_blocks: int = BlockPlan.min_blocks
    max_blocks: int = BlockPlan.max_blocks
    confidence: float = BlockPlan.confidence
    margin: float = BlockPlan.margin
    boundary: str = BlockPlan.boundary

    def block_plan(self) -> BlockPlan:
        """The :class:`analysis.lyapunov.block_statistics.BlockPlan` of these settings."""
        return BlockPlan(block=self.block_periods, burn_in=self.burn_in, min_blocks=self.min_blocks,
                         max_blocks=self.max_blocks, confidence=self.confidence, margin=self.margin,
                         boundary=self.boundary)


@dataclass(frozen=True)
class Numerics:
    """Settings of the reference runs (and, in ``lyapunov``, of the Lyapunov stage).

    method : integrator of the reference runs, one of :data:`METHODS`.
    step_factor : RK4 step ``h = step_factor / omega_max`` (ignored with ``steps_per_period``).
    steps_per_period : fixed RK4 steps per forcing period, or ``None``.
    n_transient, n_record : forcing periods discarded / recorded (Poincare samples).
    n_transient_max : cap of the adaptive transient: a point whose record is still a transient
        (:func:`analysis.regimes.transient_reason`) is continued from its end state by another
        ``n_transient`` periods and a new record, the old record joining the transient, while
        the transient stays within ``n_transient_max`` periods.
    continuation_check : a record that passes the transient tests is continued once by
        ``n_record`` periods from its end state and the later record is kept; when the two
        records differ (:func:`analysis.regimes.continuation_reason`: another
        :func:`~analysis.regimes.poincare_signature`, period ``m`` or aperiodic, or a period-``m``
        pattern whose size changes by over 5 %), the later record is checked in turn while it
        starts within ``n_transient_max`` periods (so a record can start up to ``n_record``
        periods after the cap, and a check runs even when ``n_transient_max == n_transient``);
        a point whose last check failed is ``unsettled``; a check run that diverges makes the
        point ``diverged``.
    n_long_transient : the long run (0: none): a record that leaves those tests aperiodic (no
        period in its Poincare samples, :func:`analysis.regimes.poincare_signature`), unsettled
        (still a transient at the cap, or its last continuation check failed) or of a period
        ``m > 1`` near a shorter one (:func:`analysis.transients.near_shorter_period`) while its
        elements slip (not every one stuck), not below the shakedown limit, is run on once from its
        end state by ``n_long_transient`` periods and a fresh record of ``n_record``, which
        goes through the adaptive transient (with the budget of a run from rest,
        ``n_transient_max - n_transient`` periods more) and the continuation check again; the
        later record is kept (the slip locked into the stuck elements creeps for thousands of
        periods: docs/pipeline.md, "Long runs from the map's end states").
    chunk_size : grid points per job (not part of a point's id).
    """

    method: str = "auto"
    step_factor: float = 1.0
    steps_per_period: int | None = None
    n_transient: int = 200
    n_record: int = 256
    n_transient_max: int = 2400
    continuation_check: bool = True
    n_long_transient: int = 4000
    chunk_size: int = 100
    lyapunov: LyapunovNumerics = field(default_factory=LyapunovNumerics)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Numerics:
        """From the config's ``numerics`` section (missing keys take the defaults)."""
        check_keys("numerics", d, [f.name for f in fields(cls)])
        kw = dict(d)
        lyap = dict(kw.pop("lyapunov", None) or {})
        check_keys("numerics.lyapunov", lyap, [f.name for f in fields(LyapunovNumerics)])
        if kw.get("method", cls.method) not in METHODS:
            raise ValueError(f"numerics.method = {kw['method']!r}; allowed: {', '.join(METHODS)}")
        if lyap.get("method", LyapunovNumerics.method) not in LYAPUNOV_METHODS:
            raise ValueError(f"numerics.lyapunov.method = {lyap['method']!r}; allowed: "
                             f"{', '.join(LYAPUNOV_METHODS)}")
        if lyap.get("confirm", LyapunovNumerics.confirm) not in CONFIRM_METHODS:
            raise ValueError(f"numerics.lyapunov.confirm = {lyap['confirm']!r}; allowed: "
                             f"{', '.join(CONFIRM_METHODS)}")
        if lyap.get("boundary", LyapunovNumerics.boundary) not in BOUNDARIES:
            raise ValueError(f"numerics.lyapunov.boundary = {lyap['boundary']!r}; allowed: "
                             f"{', '.join(BOUNDARIES)}")
        floor = lyap.get("expo_floor", LyapunovNumerics.expo_floor)
        if floor is not None and (isinstance(floor, bool) or not isinstance(floor, (int, float))
                                  or not 0.0 < floor <= 1.0):
            raise ValueError(f"numerics.lyapunov.expo_floor = {floor!r}; allowed: a number in "
                             f"(0, 1], or null (no noise floor measured)")
        out = cls(**kw, lyapunov=LyapunovNumerics(**lyap))
        if out.n_transient_max < out.n_transient:
            raise ValueError(f"numerics.n_transient_max = {out.n_transient_max} must be >= "
                             f"numerics.n_transient = {out.n_transient}")
        ly = out.lyapunov
        if not 2 <= ly.min_blocks <= ly.max_blocks:
            raise ValueError(f"numerics.lyapunov: need 2 <= min_blocks <= max_blocks, got "
                             f"min_blocks = {ly.min_blocks}, max_blocks = {ly.max_blocks}")
        return out

    def result_dict(self) -> dict:
        """The settings that change results, resolved, as they enter point ids and the rules'
        parameters (``steps_per_period`` only when set; ``lyapunov.rk4_e0`` only when not
        ``1e-6``; ``lyapunov.expo_e0``,
        ``lyapunov.confirm`` and ``lyapunov.expo_floor`` only when ``lyapunov.method`` is not
        ``rk4``, i.e. the free copy can be ``expo``'s)."""
        out = asdict(self)
        del out["chunk_size"]
        if out["steps_per_period"] is None:
            del out["steps_per_period"]
        if out["lyapunov"]["method"] == "rk4":
            # the RK4 pair of results version 8 and before: the separation of an expo copy does
            # not enter its results, so it does not enter its ids
            del out["lyapunov"]["expo_e0"]
            del out["lyapunov"]["confirm"]
            del out["lyapunov"]["expo_floor"]
        if out["lyapunov"]["rk4_e0"] == LyapunovNumerics.rk4_e0:
            # the RK4 pair's separation before it was a setting: ids as they were
            del out["lyapunov"]["rk4_e0"]
        if out["lyapunov"]["ladder"] == "expo":
            # the default ladder (results version 13): ids of points that keep it as before
            del out["lyapunov"]["ladder"]
        return out


def as_numerics(numerics: Numerics | Mapping[str, Any]) -> Numerics:
    """A :class:`Numerics` from itself or from a config-style mapping."""
    return numerics if isinstance(numerics, Numerics) else Numerics.from_dict(numerics)
